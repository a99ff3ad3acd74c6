// Per-thread context switches and migrations from getrusage and /proc.
#include "platform/thread_accounting.hpp"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include <fmt/core.h>

namespace lockstep::platform {

namespace {

// The value of "key : value" in a /proc/.../sched file, or "key:\tvalue" in
// /proc/.../status: the first integer after the key's separator.
std::optional<std::int64_t> field(const std::string& text, std::string_view key) {
  std::size_t at = 0;
  while ((at = text.find(key, at)) != std::string::npos) {
    const bool line_start = at == 0 || text[at - 1] == '\n';
    const std::size_t after = at + key.size();
    if (line_start && after < text.size() && (text[after] == ' ' || text[after] == ':' || text[after] == '\t')) {
      std::size_t digits = text.find_first_of("-0123456789", after);
      const std::size_t line_end = text.find('\n', after);
      if (digits == std::string::npos || (line_end != std::string::npos && digits > line_end)) return std::nullopt;
      std::int64_t value = 0;
      const auto [end, error] = std::from_chars(text.data() + digits, text.data() + text.size(), value);
      (void)end;
      if (error != std::errc{}) return std::nullopt;
      return value;
    }
    at = after;
  }
  return std::nullopt;
}

std::optional<std::string> read_small_file(const std::string& path) {
  std::ifstream file(path);
  if (!file) return std::nullopt;
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

std::optional<std::int64_t> migrations_of(pid_t thread_id) {
  const auto text = read_small_file(fmt::format("/proc/self/task/{}/sched", thread_id));
  if (!text) return std::nullopt;
  return field(*text, "se.nr_migrations");
}

}  // namespace

thread_counters operator-(const thread_counters& after, const thread_counters& before) noexcept {
  thread_counters delta;
  delta.voluntary_switches = after.voluntary_switches - before.voluntary_switches;
  delta.involuntary_switches = after.involuntary_switches - before.involuntary_switches;
  if (after.migrations && before.migrations) delta.migrations = *after.migrations - *before.migrations;
  return delta;
}

thread_counters& operator+=(thread_counters& sum, const thread_counters& more) noexcept {
  sum.voluntary_switches += more.voluntary_switches;
  sum.involuntary_switches += more.involuntary_switches;
  if (sum.migrations && more.migrations) {
    *sum.migrations += *more.migrations;
  } else {
    sum.migrations.reset();
  }
  return sum;
}

pid_t current_thread_id() noexcept { return static_cast<pid_t>(::syscall(SYS_gettid)); }

thread_counters snapshot_current_thread() {
  thread_counters counters;
  rusage usage{};
  if (::getrusage(RUSAGE_THREAD, &usage) != 0) {
    throw std::runtime_error(fmt::format("getrusage(RUSAGE_THREAD) failed: {}", std::strerror(errno)));
  }
  counters.voluntary_switches = usage.ru_nvcsw;
  counters.involuntary_switches = usage.ru_nivcsw;
  counters.migrations = migrations_of(current_thread_id());
  return counters;
}

thread_counters snapshot_thread(pid_t thread_id) {
  const auto status = read_small_file(fmt::format("/proc/self/task/{}/status", thread_id));
  if (!status) throw std::runtime_error(fmt::format("thread {} is not a live thread of this process", thread_id));
  const auto voluntary = field(*status, "voluntary_ctxt_switches");
  const auto involuntary = field(*status, "nonvoluntary_ctxt_switches");
  if (!voluntary || !involuntary) {
    throw std::runtime_error(fmt::format("/proc/self/task/{}/status has no context switch counts", thread_id));
  }
  thread_counters counters;
  counters.voluntary_switches = *voluntary;
  counters.involuntary_switches = *involuntary;
  counters.migrations = migrations_of(thread_id);
  return counters;
}

bool migrations_available() { return migrations_of(current_thread_id()).has_value(); }

std::optional<double> cross_core_switch_percent(const thread_counters& delta) noexcept {
  if (!delta.migrations) return std::nullopt;
  const std::int64_t total = delta.total_switches();
  if (total <= 0) return 0.0;
  const std::int64_t crossed = std::clamp<std::int64_t>(*delta.migrations, 0, total);
  return 100.0 * static_cast<double>(crossed) / static_cast<double>(total);
}

figure5_row figure5_row::from_counters(std::string thread, std::string role, const thread_counters& delta) {
  figure5_row row;
  row.thread = std::move(thread);
  row.role = std::move(role);
  row.total_csw = delta.total_switches();
  if (delta.migrations) row.cross_core_csw = std::clamp<std::int64_t>(*delta.migrations, 0, row.total_csw);
  row.pct = cross_core_switch_percent(delta);
  return row;
}

void figure5_table::add(std::string thread, std::string role, const thread_counters& delta) {
  rows_.push_back(figure5_row::from_counters(std::move(thread), std::move(role), delta));
}

void figure5_table::add(figure5_row row) { rows_.push_back(std::move(row)); }

figure5_row figure5_table::totals() const {
  figure5_row sum;
  sum.thread = "total";
  sum.role = "all";
  sum.cross_core_csw = 0;
  for (const figure5_row& row : rows_) {
    sum.total_csw += row.total_csw;
    if (sum.cross_core_csw && row.cross_core_csw) {
      *sum.cross_core_csw += *row.cross_core_csw;
    } else {
      sum.cross_core_csw.reset();
    }
  }
  if (sum.cross_core_csw) {
    sum.pct = sum.total_csw > 0 ? 100.0 * static_cast<double>(*sum.cross_core_csw) / static_cast<double>(sum.total_csw)
                                : 0.0;
  }
  return sum;
}

std::string figure5_table::render() const {
  std::size_t thread_width = 6;  // "thread"
  std::size_t role_width = 4;    // "role"
  for (const figure5_row& row : rows_) {
    thread_width = std::max(thread_width, row.thread.size());
    role_width = std::max(role_width, row.role.size());
  }
  const auto line = [&](const figure5_row& row) {
    const std::string crossed = row.cross_core_csw ? std::to_string(*row.cross_core_csw) : "unavailable";
    const std::string pct = row.pct ? fmt::format("{:.2f} %", *row.pct) : "unavailable";
    return fmt::format("{:<{}}  {:<{}}  {:>15}  {:>12}  {:>11}\n", row.thread, thread_width, row.role, role_width,
                       crossed, row.total_csw, pct);
  };
  std::string text = fmt::format("{:<{}}  {:<{}}  {:>15}  {:>12}  {:>11}\n", "thread", thread_width, "role",
                                 role_width, "cross-core csw", "total csw", "percent");
  for (const figure5_row& row : rows_) text += line(row);
  text += line(totals());
  return text;
}

}  // namespace lockstep::platform
