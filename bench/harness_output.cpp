// Progress, the run book's feed, and the atomic result file (harness_output.hpp).
#include "bench/harness_output.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <fmt/core.h>

#include <array>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <stdexcept>

namespace lockstep::bench {

namespace {

std::string format_duration(double seconds) {
  if (seconds < 90.0) return fmt::format("{:.0f} s", seconds);
  return fmt::format("{:.0f} min {:02.0f} s", std::floor(seconds / 60.0), std::fmod(seconds, 60.0));
}

std::string format_ns(double ns) {
  if (ns >= 1e6) return fmt::format("{:.2f} ms", ns / 1e6);
  if (ns >= 1e3) return fmt::format("{:.2f} us", ns / 1e3);
  return fmt::format("{:.1f} ns", ns);
}

// The counter a user reads first for each kind of entry.
const char* headline_counter(const std::string& kind) {
  if (kind == "c2c") return "one_way_ns";
  if (kind == "barrier") return "ns_per_episode";
  return "ns_per_step";
}

}  // namespace

std::map<std::string, std::string> parse_entry_name(const std::string& name) {
  std::map<std::string, std::string> fields;
  std::size_t start = 0;
  bool first = true;
  while (start <= name.size()) {
    std::size_t end = name.find('/', start);
    if (end == std::string::npos) end = name.size();
    const std::string segment = name.substr(start, end - start);
    const std::size_t colon = segment.find(':');
    if (first) {
      fields["kind"] = segment;
      first = false;
    } else if (colon == std::string::npos) {
      fields["variant"] = segment;
    } else {
      fields[segment.substr(0, colon)] = segment.substr(colon + 1);
    }
    start = end + 1;
  }
  return fields;
}

std::string plain_name(const benchmark::BenchmarkReporter::Run& run) {
  benchmark::BenchmarkName name = run.run_name;
  name.iterations.clear();
  name.repetitions.clear();  // "/repeats:N", on an entry with its own repetition count
  name.time_type.clear();
  return name.str();
}

void result_json_reporter::ReportRuns(const std::vector<Run>& runs) {
  std::vector<Run> renamed = runs;
  for (Run& run : renamed) {
    run.run_name.iterations.clear();
    run.run_name.repetitions.clear();
    run.run_name.time_type.clear();
    // The "cv" aggregate of a counter that is 0 in every repetition is 0/0;
    // Google Benchmark would write it as NaN, which is not JSON. Omitted.
    for (auto counter = run.counters.begin(); counter != run.counters.end();) {
      if (std::isfinite(counter->second.value)) {
        ++counter;
      } else {
        counter = run.counters.erase(counter);
      }
    }
  }
  JSONReporter::ReportRuns(renamed);
}

progress_reporter::progress_reporter(run_book& book, std::size_t expected_entries)
    : book_(book), expected_(expected_entries), start_(std::chrono::steady_clock::now()) {}

void derive_ratios(nlohmann::json& result, std::optional<double> c2c_one_way_ns,
                   std::optional<double> serial_step_ns) {
  if (!result.contains("benchmarks") || !result["benchmarks"].is_array()) return;
  const auto derive = [](nlohmann::json& row, const char* counter, const char* ratio, std::optional<double> base) {
    if (!base || !(*base > 0.0) || !row.contains(counter) || !row[counter].is_number()) return;
    const bool coefficient_of_variation = row.value("aggregate_unit", "") == "percentage";
    const double value = row[counter].get<double>();
    row[ratio] = coefficient_of_variation ? value : value / *base;
  };
  for (nlohmann::json& row : result["benchmarks"]) {
    if (!row.is_object() || !row.contains("run_name") || !row["run_name"].is_string()) continue;
    if (!has_derived_ratios(parse_entry_name(row["run_name"].get<std::string>()))) continue;
    derive(row, "ns_per_step", "vs_serial", serial_step_ns);
    derive(row, "sync_ns_per_stage", "vs_c2c", c2c_one_way_ns);
  }
}

bool progress_reporter::ReportContext(const Context& /*context*/) { return true; }

void progress_reporter::ReportRuns(const std::vector<Run>& runs) {
  // Google Benchmark reports an entry's repetitions, then (separately) its
  // aggregates; the book recomputes aggregates, so only the first call counts.
  const bool any_repetition = std::any_of(runs.begin(), runs.end(), [](const Run& run) {
    return run.run_type == Run::RT_Iteration;
  });
  if (!any_repetition) return;
  captured_entry entry;
  // Repetitions carry their own name; aggregates are recomputed from them.
  for (const Run& run : runs) {
    if (run.run_type != Run::RT_Iteration) continue;
    entry.name = plain_name(run);
    if (run.error_occurred) {
      entry.error = run.error_message;
      continue;
    }
    std::map<std::string, double> counters;
    for (const auto& [key, counter] : run.counters) counters[key] = counter.value;
    entry.repetitions.push_back(std::move(counters));
  }
  entry.fields = parse_entry_name(entry.name);
  // Some repetitions measured, some stopped: the entry counts as measured
  // (its medians come from the measured ones) and the stop becomes a note.
  if (!entry.error.empty() && !entry.repetitions.empty()) {
    book_.notes.push_back(entry.name + ": some repetitions were flagged and left out: " + entry.error);
    entry.error.clear();
  }
  ++finished_;

  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::string what;
  if (!entry.error.empty()) {
    what = entry.error;
  } else if (const auto median = entry.median(headline_counter(entry.field("kind")))) {
    what = format_ns(*median) + (entry.field("kind") == "barrier" ? "/episode" : entry.field("kind") == "c2c" ? " one-way" : "/step");
  }
  const std::size_t total = std::max(expected_, finished_);
  const double left = elapsed / static_cast<double>(finished_) * static_cast<double>(total - finished_);
  fmt::print(stderr, "[{}/{}] {}  {}  ({} elapsed, about {} left)\n", finished_, total, entry.name, what,
             format_duration(elapsed), format_duration(left));
  std::fflush(stderr);
  book_.record(std::move(entry));
}

// ---------------------------------------------------------------------------
// The atomic result file.

namespace {

// The temporary path, for the signal handler (which may only use
// async-signal-safe calls: unlink, write, _exit).
std::array<char, 4096> g_temporary_path{};
struct sigaction g_previous_int {};
struct sigaction g_previous_term {};

extern "C" void remove_partial_result(int signal_number) {
  if (g_temporary_path[0] != '\0') ::unlink(g_temporary_path.data());
  static const char message[] = "\nlockstep: interrupted; no result file was written\n";
  const ssize_t ignored = ::write(STDERR_FILENO, message, sizeof message - 1);
  (void)ignored;
  ::_exit(128 + signal_number);
}

}  // namespace

atomic_result_file::atomic_result_file(std::string destination) : destination_(std::move(destination)) {
  namespace fs = std::filesystem;
  const fs::path target(destination_);
  std::error_code error;
  if (target.has_parent_path()) {
    fs::create_directories(target.parent_path(), error);
    if (error)
      throw std::runtime_error("cannot create the directory " + target.parent_path().string() + ": " +
                               error.message());
  }
  temporary_ = destination_ + ".partial-" + std::to_string(::getpid());
  const int fd = ::open(temporary_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot write " + temporary_ + ": " + std::strerror(errno));
  ::close(fd);
  if (temporary_.size() >= g_temporary_path.size()) throw std::runtime_error("result path too long: " + temporary_);
  std::memcpy(g_temporary_path.data(), temporary_.c_str(), temporary_.size() + 1);

  struct sigaction action {};
  action.sa_handler = remove_partial_result;
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGINT, &action, &g_previous_int);
  ::sigaction(SIGTERM, &action, &g_previous_term);
}

atomic_result_file::~atomic_result_file() {
  ::sigaction(SIGINT, &g_previous_int, nullptr);
  ::sigaction(SIGTERM, &g_previous_term, nullptr);
  if (!committed_) ::unlink(temporary_.c_str());
  g_temporary_path[0] = '\0';
}

void atomic_result_file::commit() {
  const int fd = ::open(temporary_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
  // Block the signals across the rename so the handler never unlinks a file
  // that is already the destination.
  sigset_t block;
  sigset_t previous;
  sigemptyset(&block);
  sigaddset(&block, SIGINT);
  sigaddset(&block, SIGTERM);
  ::pthread_sigmask(SIG_BLOCK, &block, &previous);
  const int renamed = std::rename(temporary_.c_str(), destination_.c_str());
  const int rename_errno = errno;
  if (renamed == 0) {
    committed_ = true;
    g_temporary_path[0] = '\0';
  }
  ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  if (renamed != 0)
    throw std::runtime_error("cannot rename " + temporary_ + " to " + destination_ + ": " +
                             std::strerror(rename_errno));
}

std::string default_result_path() {
  std::array<char, 256> host{};
  if (::gethostname(host.data(), host.size() - 1) != 0) std::strcpy(host.data(), "unknown-host");
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  ::gmtime_r(&now, &utc);
  std::array<char, 32> stamp{};
  std::strftime(stamp.data(), stamp.size(), "%Y%m%dT%H%M%SZ", &utc);
  return fmt::format("results/{}-{}.json", host.data(), stamp.data());
}

}  // namespace lockstep::bench
