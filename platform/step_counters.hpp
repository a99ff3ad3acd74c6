#pragma once
// Cheap per-thread and per-CPU counters for a per-step record: what the
// kernel says happened to the calling thread between two snapshots, and the
// interrupts each CPU took. platform/thread_accounting.hpp counts a whole run
// (a snapshot there opens a /proc file each time); this file is for one
// snapshot per period, so it keeps its files open and rereads them.
//
// Sources (Linux), each "unavailable" where the machine lacks it:
//   /proc/thread-self/schedstat   three numbers: time on the CPU (ns), time
//       waiting on a run queue (ns), timeslices run (sched_info: needs
//       CONFIG_SCHED_INFO; the file is absent without it). Opened by the
//       thread it describes: /proc/thread-self resolves to the opener.
//   getrusage(RUSAGE_THREAD)      voluntary and involuntary context switches,
//       minor and major page faults of the calling thread.
//   sched_getcpu                  the CPU the thread runs on at the snapshot.
//   /proc/interrupts, /proc/softirqs   per-CPU counts, summed over every
//       interrupt line (hardware, local timer, IPIs) and every softirq kind.
//       Read by one thread for all CPUs.
//
// Cost (measured by snapshot_cost_ns and interrupt_read_cost_ns on the
// machine that runs; lockstep delay prints both): a thread snapshot is a
// pread of a small file plus a getrusage call, about 1-3 us in a VM; the
// per-CPU interrupt totals parse two tables, tens of microseconds. Take the
// thread snapshot once per period, outside the step; read the interrupts
// from one thread, once per period or every N periods.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lockstep::platform {

// One thread's counters at one moment (absolute values since the thread
// started). Fields a source could not give are nullopt.
struct thread_step_counters {
  std::optional<std::int64_t> on_cpu_ns;          // schedstat 1
  std::optional<std::int64_t> run_queue_wait_ns;  // schedstat 2
  std::optional<std::int64_t> timeslices;         // schedstat 3
  std::int64_t voluntary_switches = 0;
  std::int64_t involuntary_switches = 0;
  std::int64_t minor_faults = 0;
  std::int64_t major_faults = 0;
  std::optional<unsigned> cpu;  // where the snapshot ran
};

// after - before, field by field (a field is unavailable if it is in either;
// cpu is after's).
thread_step_counters operator-(const thread_step_counters& after, const thread_step_counters& before) noexcept;

// "a b c\n" from /proc/thread-self/schedstat: on-CPU ns, run-queue wait ns,
// timeslices; nullopt when the text is not three integers.
struct schedstat_fields {
  std::int64_t on_cpu_ns = 0;
  std::int64_t run_queue_wait_ns = 0;
  std::int64_t timeslices = 0;
};
std::optional<schedstat_fields> parse_schedstat(std::string_view text) noexcept;

// Snapshots of the thread that constructed it. Construct it on the thread it
// reads (it opens /proc/thread-self/schedstat there) and call read() only on
// that thread. Not copyable: it owns a file descriptor.
class thread_counter_reader {
 public:
  thread_counter_reader();
  ~thread_counter_reader();
  thread_counter_reader(const thread_counter_reader&) = delete;
  thread_counter_reader& operator=(const thread_counter_reader&) = delete;

  // Whether schedstat could be opened (run-queue wait and on-CPU time).
  [[nodiscard]] bool schedstat_available() const noexcept { return schedstat_fd_ >= 0; }
  // The counters now. Never throws; a failing source leaves its fields empty.
  thread_step_counters read() noexcept;

 private:
  int schedstat_fd_ = -1;
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

// The median cost in nanoseconds of one thread_counter_reader::read() on
// the calling thread, and of one interrupt_reader::read(), over `rounds`.
double snapshot_cost_ns(int rounds = 201);
double interrupt_read_cost_ns(int rounds = 51);

}  // namespace lockstep::platform
