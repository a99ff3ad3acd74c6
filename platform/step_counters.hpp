#pragma once
// Cheap per-thread and per-CPU counters for a per-step record: what the
// kernel says happened to a thread between two snapshots, and the
// interrupts each CPU took. platform/thread_accounting.hpp counts a whole run
// (a snapshot there opens a /proc file each time); this file is for one
// snapshot per period, so it keeps its files open and rereads them.
//
// Sources (Linux), each "unavailable" where the machine lacks it:
//   the thread's CPU clock (pthread_getcpuclockid)   its time on the CPU,
//       up to date when it is running (the kernel brings the running
//       thread's account up to date for the clock; schedstat's first field
//       lags by the slice in progress, so it is not used).
//   /proc/thread-self/schedstat   time waiting on a run queue (ns, field 2),
//       and how many times the thread was scheduled in (field 3: one per
//       context switch, voluntary or not; sched_info: needs
//       CONFIG_SCHED_INFO, the file is absent without it).
//   /proc/thread-self/stat        minor and major page faults (fields 10
//       and 12).
//   Both are opened by the thread they describe (/proc/thread-self
//   resolves to the opener) and the open files keep naming it, so any
//   thread can reread them: the thread itself does not have to stop for its
//   snapshot.
//   /proc/interrupts, /proc/softirqs   per-CPU counts, summed over every
//       interrupt line (hardware, local timer, IPIs) and every softirq kind.
//       Read by one thread for all CPUs.
//
// Cost (measured by snapshot_cost_ns and interrupt_read_cost_ns on the
// machine that runs; lockstep delay prints both): a thread's snapshot is
// two preads of small procfs files, a few microseconds in a VM; the per-CPU
// interrupt totals parse two tables, tens of microseconds. Take them once
// per period, outside the step, from one thread once everyone has ended,
// so that nobody still stepping waits behind them.
#include <time.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lockstep::platform {

// "a b c\n" from /proc/thread-self/schedstat: on-CPU ns, run-queue wait ns,
// timeslices; nullopt when the text is not three integers.
struct schedstat_fields {
  std::int64_t on_cpu_ns = 0;
  std::int64_t run_queue_wait_ns = 0;
  std::int64_t timeslices = 0;
};
std::optional<schedstat_fields> parse_schedstat(std::string_view text) noexcept;

// "... (comm) S ppid ... minflt cminflt majflt ..." from /proc/<tid>/stat:
// the thread's own minor and major faults (fields 10 and 12, counted after
// the command name's closing parenthesis, which the name itself may
// contain); nullopt when the text does not have them.
struct fault_fields {
  std::int64_t minor = 0;
  std::int64_t major = 0;
};
std::optional<fault_fields> parse_stat_faults(std::string_view text) noexcept;

// One thread's counters at one moment (absolute values since the thread
// started). Fields a source could not give are nullopt.
struct thread_step_counters {
  std::optional<std::int64_t> on_cpu_ns;          // the thread's CPU clock
  std::optional<std::int64_t> run_queue_wait_ns;  // schedstat 2
  std::optional<std::int64_t> switches;           // schedstat 3: times scheduled in
  std::optional<std::int64_t> minor_faults;       // stat 10
  std::optional<std::int64_t> major_faults;       // stat 12
};

// after - before, field by field (a field is unavailable if it is in either).
thread_step_counters operator-(const thread_step_counters& after, const thread_step_counters& before) noexcept;

// Snapshots of the thread that constructed it (its owner). Construct it on
// the thread it reads: it opens /proc/thread-self/schedstat and stat there.
// read() may then be called from any thread, at any time (the open files
// keep naming the owner). Not copyable: it owns file descriptors.
class thread_counter_reader {
 public:
  thread_counter_reader();
  ~thread_counter_reader();
  thread_counter_reader(const thread_counter_reader&) = delete;
  thread_counter_reader& operator=(const thread_counter_reader&) = delete;

  // Whether schedstat could be opened (run-queue wait and switches).
  [[nodiscard]] bool schedstat_available() const noexcept { return schedstat_fd_ >= 0; }
  // The owner's counters now. Never throws; a failing source leaves its
  // fields empty.
  [[nodiscard]] thread_step_counters read() const noexcept;

 private:
  int schedstat_fd_ = -1;
  int stat_fd_ = -1;
  std::optional<clockid_t> cpu_clock_;
};

// Per-CPU totals: cpus[i] is the CPU number of column i; interrupts[i] the
// sum of every /proc/interrupts line's count on it, softirqs[i] the same for
// /proc/softirqs. A table that could not be read is empty.
struct cpu_interrupt_totals {
  std::vector<unsigned> cpus;
  std::vector<std::int64_t> interrupts;
  std::vector<std::int64_t> softirqs;
};

// The per-CPU sums of a /proc/interrupts or /proc/softirqs text: the header
// names the columns ("CPU0 CPU1 ..."); every later line is "NAME: n n ..."
// followed by words (a line with fewer numbers, such as ERR, adds nothing to
// the CPUs it lacks). Returns the CPU numbers and the sums; empty when the
// header is missing.
struct per_cpu_sums {
  std::vector<unsigned> cpus;
  std::vector<std::int64_t> sums;
};
per_cpu_sums parse_per_cpu_table(std::string_view text);

// Reads both tables for every CPU (one reader, any thread; keeps the files
// open and rereads them).
class interrupt_reader {
 public:
  interrupt_reader();
  ~interrupt_reader();
  interrupt_reader(const interrupt_reader&) = delete;
  interrupt_reader& operator=(const interrupt_reader&) = delete;

  [[nodiscard]] bool available() const noexcept { return interrupts_fd_ >= 0 || softirqs_fd_ >= 0; }
  // The totals now; the vectors of a table that cannot be read are empty.
  cpu_interrupt_totals read();

 private:
  int interrupts_fd_ = -1;
  int softirqs_fd_ = -1;
  std::string buffer_;
};

// The median cost in nanoseconds, over `rounds`, of one
// thread_counter_reader::read() and of one interrupt_reader::read().
double snapshot_cost_ns(int rounds = 201);
double interrupt_read_cost_ns(int rounds = 51);

}  // namespace lockstep::platform
