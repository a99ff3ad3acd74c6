// Per-thread and per-CPU counters for a per-step record (step_counters.hpp).
#include "platform/step_counters.hpp"

#include <fcntl.h>
#include <sched.h>
#include <sys/resource.h>
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
  delta.timeslices = difference(after.timeslices, before.timeslices);
  delta.voluntary_switches = after.voluntary_switches - before.voluntary_switches;
  delta.involuntary_switches = after.involuntary_switches - before.involuntary_switches;
  delta.minor_faults = after.minor_faults - before.minor_faults;
  delta.major_faults = after.major_faults - before.major_faults;
  delta.cpu = after.cpu;
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

thread_counter_reader::thread_counter_reader()
    : schedstat_fd_(::open("/proc/thread-self/schedstat", O_RDONLY | O_CLOEXEC)) {}

thread_counter_reader::~thread_counter_reader() {
  if (schedstat_fd_ >= 0) ::close(schedstat_fd_);
}

thread_step_counters thread_counter_reader::read() noexcept {
  thread_step_counters counters;
  if (schedstat_fd_ >= 0) {
    // One pread at offset 0: the file is one short line, regenerated per read.
    char text[96];
    const ssize_t got = ::pread(schedstat_fd_, text, sizeof text - 1, 0);
    if (got > 0) {
      if (const auto fields = parse_schedstat(std::string_view(text, static_cast<std::size_t>(got)))) {
        counters.on_cpu_ns = fields->on_cpu_ns;
        counters.run_queue_wait_ns = fields->run_queue_wait_ns;
        counters.timeslices = fields->timeslices;
      }
    }
  }
  rusage usage{};
  if (::getrusage(RUSAGE_THREAD, &usage) == 0) {
    counters.voluntary_switches = usage.ru_nvcsw;
    counters.involuntary_switches = usage.ru_nivcsw;
    counters.minor_faults = usage.ru_minflt;
    counters.major_faults = usage.ru_majflt;
  }
  if (const int cpu = ::sched_getcpu(); cpu >= 0) counters.cpu = static_cast<unsigned>(cpu);
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

double snapshot_cost_ns(int rounds) {
  thread_counter_reader reader;
  std::vector<double> costs;
  costs.reserve(static_cast<std::size_t>(rounds));
  for (int round = 0; round < rounds; ++round) {
    const std::int64_t start = now_ns();
    const thread_step_counters counters = reader.read();
    costs.push_back(static_cast<double>(now_ns() - start));
    (void)counters;
  }
  std::nth_element(costs.begin(), costs.begin() + static_cast<std::ptrdiff_t>(costs.size() / 2), costs.end());
  return costs[costs.size() / 2];
}

double interrupt_read_cost_ns(int rounds) {
  interrupt_reader reader;
  std::vector<double> costs;
  costs.reserve(static_cast<std::size_t>(rounds));
  for (int round = 0; round < rounds; ++round) {
    const std::int64_t start = now_ns();
    const cpu_interrupt_totals totals = reader.read();
    costs.push_back(static_cast<double>(now_ns() - start));
    (void)totals;
  }
  std::nth_element(costs.begin(), costs.begin() + static_cast<std::ptrdiff_t>(costs.size() / 2), costs.end());
  return costs[costs.size() / 2];
}

}  // namespace lockstep::platform
