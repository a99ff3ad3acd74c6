// Per-thread and per-CPU counters for a per-step record (step_counters.hpp).
#include "platform/step_counters.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cctype>

#include "platform/clock.hpp"

namespace lockstep::platform {

namespace {

std::optional<std::int64_t> difference(const std::optional<std::int64_t>& after,
                                       const std::optional<std::int64_t>& before) noexcept {
  if (!after || !before) return std::nullopt;
  return *after - *before;
}

// The whole file at `fd` from its start into `buffer` (procfs files are
// regenerated on every read from offset 0). False on an error.
bool reread(int fd, std::string& buffer) {
  if (fd < 0) return false;
  if (::lseek(fd, 0, SEEK_SET) != 0) return false;
  buffer.clear();
  char chunk[4096];
  for (;;) {
    const ssize_t got = ::read(fd, chunk, sizeof chunk);
    if (got < 0) return false;
    if (got == 0) return true;
    buffer.append(chunk, static_cast<std::size_t>(got));
  }
}

std::size_t skip_spaces(std::string_view text, std::size_t at) {
  while (at < text.size() && (text[at] == ' ' || text[at] == '\t')) ++at;
  return at;
}

}  // namespace

thread_step_counters operator-(const thread_step_counters& after, const thread_step_counters& before) noexcept {
  thread_step_counters delta;
  delta.on_cpu_ns = difference(after.on_cpu_ns, before.on_cpu_ns);
  delta.run_queue_wait_ns = difference(after.run_queue_wait_ns, before.run_queue_wait_ns);
  delta.switches = difference(after.switches, before.switches);
  delta.minor_faults = difference(after.minor_faults, before.minor_faults);
  delta.major_faults = difference(after.major_faults, before.major_faults);
  return delta;
}

std::optional<schedstat_fields> parse_schedstat(std::string_view text) noexcept {
  std::int64_t values[3] = {};
  std::size_t at = 0;
  for (std::int64_t& value : values) {
    at = skip_spaces(text, at);
    const auto [end, error] = std::from_chars(text.data() + at, text.data() + text.size(), value);
    if (error != std::errc{}) return std::nullopt;
    at = static_cast<std::size_t>(end - text.data());
  }
  return schedstat_fields{values[0], values[1], values[2]};
}

std::optional<fault_fields> parse_stat_faults(std::string_view text) noexcept {
  // The command name is in parentheses and may hold spaces and ')': the
  // fields resume after the last ')'. Then state (3), ppid (4), pgrp (5),
  // session (6), tty_nr (7), tpgid (8), flags (9), minflt (10), cminflt (11),
  // majflt (12).
  const std::size_t close = text.rfind(')');
  if (close == std::string_view::npos) return std::nullopt;
  std::size_t at = close + 1;
  std::int64_t fields[10] = {};  // 3..12; the state (3) is a letter, skipped
  for (int field = 3; field <= 12; ++field) {
    at = skip_spaces(text, at);
    if (at >= text.size()) return std::nullopt;
    if (field == 3) {
      while (at < text.size() && text[at] != ' ') ++at;
      continue;
    }
    const auto [end, error] = std::from_chars(text.data() + at, text.data() + text.size(), fields[field - 3]);
    if (error != std::errc{}) return std::nullopt;
    at = static_cast<std::size_t>(end - text.data());
  }
  return fault_fields{fields[10 - 3], fields[12 - 3]};
}

thread_counter_reader::thread_counter_reader()
    : schedstat_fd_(::open("/proc/thread-self/schedstat", O_RDONLY | O_CLOEXEC)),
      stat_fd_(::open("/proc/thread-self/stat", O_RDONLY | O_CLOEXEC)) {
  clockid_t clock{};
  if (::pthread_getcpuclockid(::pthread_self(), &clock) == 0) cpu_clock_ = clock;
}

thread_counter_reader::~thread_counter_reader() {
  if (schedstat_fd_ >= 0) ::close(schedstat_fd_);
  if (stat_fd_ >= 0) ::close(stat_fd_);
}

namespace {

// The short procfs file at `fd` read whole with one pread at offset 0 (it is
// regenerated per read) and parsed by `parse`; nullopt when either fails.
template <std::size_t Capacity, class Parse>
auto parse_small_file(int fd, Parse&& parse) noexcept -> decltype(parse(std::string_view())) {
  if (fd < 0) return std::nullopt;
  char text[Capacity];
  const ssize_t got = ::pread(fd, text, sizeof text - 1, 0);
  if (got <= 0) return std::nullopt;
  return parse(std::string_view(text, static_cast<std::size_t>(got)));
}

}  // namespace

thread_step_counters thread_counter_reader::read() const noexcept {
  thread_step_counters counters;
  if (const auto fields = parse_small_file<96>(schedstat_fd_, parse_schedstat)) {
    counters.run_queue_wait_ns = fields->run_queue_wait_ns;
    counters.switches = fields->timeslices;
  }
  timespec on_cpu{};
  if (cpu_clock_ && ::clock_gettime(*cpu_clock_, &on_cpu) == 0)
    counters.on_cpu_ns = static_cast<std::int64_t>(on_cpu.tv_sec) * 1'000'000'000 + on_cpu.tv_nsec;
  if (const auto faults = parse_small_file<1024>(stat_fd_, parse_stat_faults)) {
    counters.minor_faults = faults->minor;
    counters.major_faults = faults->major;
  }
  return counters;
}

per_cpu_sums parse_per_cpu_table(std::string_view text) {
  per_cpu_sums result;
  std::size_t line_start = 0;
  bool header = true;
  while (line_start < text.size()) {
    std::size_t line_end = text.find('\n', line_start);
    if (line_end == std::string_view::npos) line_end = text.size();
    const std::string_view line = text.substr(line_start, line_end - line_start);
    line_start = line_end + 1;
    if (header) {
      // "           CPU0       CPU1 ..."
      std::size_t at = 0;
      while ((at = line.find("CPU", at)) != std::string_view::npos) {
        at += 3;
        unsigned cpu = 0;
        const auto [end, error] = std::from_chars(line.data() + at, line.data() + line.size(), cpu);
        if (error != std::errc{}) break;
        result.cpus.push_back(cpu);
        at = static_cast<std::size_t>(end - line.data());
      }
      if (result.cpus.empty()) return result;
      result.sums.assign(result.cpus.size(), 0);
      header = false;
      continue;
    }
    const std::size_t colon = line.find(':');
    if (colon == std::string_view::npos) continue;
    std::size_t at = colon + 1;
    for (std::size_t column = 0; column < result.cpus.size(); ++column) {
      at = skip_spaces(line, at);
      std::int64_t count = 0;
      const auto [end, error] = std::from_chars(line.data() + at, line.data() + line.size(), count);
      if (error != std::errc{}) break;  // the words after the counts, or a short line (ERR, MIS)
      result.sums[column] += count;
      at = static_cast<std::size_t>(end - line.data());
    }
  }
  return result;
}

interrupt_reader::interrupt_reader()
    : interrupts_fd_(::open("/proc/interrupts", O_RDONLY | O_CLOEXEC)),
      softirqs_fd_(::open("/proc/softirqs", O_RDONLY | O_CLOEXEC)) {
  buffer_.reserve(16384);
}

interrupt_reader::~interrupt_reader() {
  if (interrupts_fd_ >= 0) ::close(interrupts_fd_);
  if (softirqs_fd_ >= 0) ::close(softirqs_fd_);
}

cpu_interrupt_totals interrupt_reader::read() {
  cpu_interrupt_totals totals;
  if (reread(interrupts_fd_, buffer_)) {
    per_cpu_sums sums = parse_per_cpu_table(buffer_);
    totals.cpus = std::move(sums.cpus);
    totals.interrupts = std::move(sums.sums);
  }
  if (reread(softirqs_fd_, buffer_)) {
    per_cpu_sums sums = parse_per_cpu_table(buffer_);
    if (totals.cpus.empty()) totals.cpus = sums.cpus;
    // The two tables list the same online CPUs; a CPU that went on or off
    // line between the reads leaves softirqs unavailable for this read.
    if (sums.cpus == totals.cpus) totals.softirqs = std::move(sums.sums);
  }
  return totals;
}

namespace {

// The median in nanoseconds of `rounds` calls of `read`.
template <class Read>
double median_cost_ns(int rounds, Read&& read) {
  std::vector<double> costs;
  costs.reserve(static_cast<std::size_t>(rounds));
  for (int round = 0; round < rounds; ++round) {
    const std::int64_t start = now_ns();
    read();
    costs.push_back(static_cast<double>(now_ns() - start));
  }
  std::nth_element(costs.begin(), costs.begin() + static_cast<std::ptrdiff_t>(costs.size() / 2), costs.end());
  return costs[costs.size() / 2];
}

}  // namespace

double snapshot_cost_ns(int rounds) {
  const thread_counter_reader reader;
  return median_cost_ns(rounds, [&] { (void)reader.read(); });
}

double interrupt_read_cost_ns(int rounds) {
  interrupt_reader reader;
  return median_cost_ns(rounds, [&] { (void)reader.read(); });
}

}  // namespace lockstep::platform
