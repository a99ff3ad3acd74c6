#pragma once
// Per-thread scheduler accounting without hardware counters: context switches
// (voluntary, involuntary) and migrations between CPUs, and the paper's
// Figure 5 metric, the share of context switches that crossed cores.
//
// Sources (Linux):
//   voluntary / involuntary switches  getrusage(RUSAGE_THREAD) for the calling
//       thread (ru_nvcsw / ru_nivcsw); /proc/self/task/TID/status
//       (voluntary_ctxt_switches / nonvoluntary_ctxt_switches) for another.
//   migrations  se.nr_migrations in /proc/self/task/TID/sched. That file
//       exists only with CONFIG_SCHED_DEBUG (Debian enables it) and may be
//       hidden; then migrations are "unavailable" (std::nullopt), never 0.
//
// Cost: a snapshot is a getrusage call plus one open/read/close of a small
// /proc file, a few microseconds. Take snapshots outside measured loops: at
// the start and the end of a run, or every few thousand steps.
//
// Figure 5 metric. The paper's table (Concurrency Visualizer) lists, per
// thread, the context switches after which the thread resumed on a different
// core than it left ("cross-core"), and all its context switches. Linux
// counts a migration (se.nr_migrations) each time the scheduler moves a task
// to another CPU's run queue (set_task_cpu). A task that is running cannot be
// moved, so every migration follows a switch-out (voluntary: it slept and
// woke on another CPU; involuntary: it was preempted and then pulled by load
// balancing), and the next switch-in happens on the new CPU: one migration is
// one context switch that crossed cores. The count can exceed that only when a
// waiting task is moved twice before it runs again, which the kernel rarely
// does; the share is therefore migrations / (voluntary + involuntary), capped
// at 100 %.
#include <sys/types.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace lockstep::platform {

struct thread_counters {
  std::int64_t voluntary_switches = 0;    // the thread blocked (sleep, futex wait, I/O)
  std::int64_t involuntary_switches = 0;  // the thread was preempted
  std::optional<std::int64_t> migrations; // moves to another CPU; nullopt: unavailable

  std::int64_t total_switches() const noexcept { return voluntary_switches + involuntary_switches; }
};

// after - before, field by field (migrations unavailable if either is).
thread_counters operator-(const thread_counters& after, const thread_counters& before) noexcept;
thread_counters& operator+=(thread_counters& sum, const thread_counters& more) noexcept;

// The kernel's id of the calling thread (gettid).
pid_t current_thread_id() noexcept;

// The calling thread's counters now.
thread_counters snapshot_current_thread();
// Another thread of this process, by kernel id (from its current_thread_id()).
// Throws std::runtime_error when /proc/self/task/TID/status cannot be read
// (the thread has exited).
thread_counters snapshot_thread(pid_t thread_id);

// True when se.nr_migrations can be read on this machine.
bool migrations_available();

// The share of context switches that crossed cores, in percent (see above),
// or nullopt when migrations are unavailable. 0 when there were no switches.
std::optional<double> cross_core_switch_percent(const thread_counters& delta) noexcept;

// The paper's Figure 5 table: one row per thread, plus sums.
struct figure5_row {
  std::string thread;                       // "main", "worker 0", ...
  std::string role;                         // "main", "worker", "pacer", ...
  std::optional<std::int64_t> cross_core_csw;  // nullopt: unavailable
  std::int64_t total_csw = 0;
  std::optional<double> pct;                // nullopt: unavailable

  static figure5_row from_counters(std::string thread, std::string role, const thread_counters& delta);
};

class figure5_table {
 public:
  void add(std::string thread, std::string role, const thread_counters& delta);
  void add(figure5_row row);
  const std::vector<figure5_row>& rows() const noexcept { return rows_; }
  // Thread "total", role "all": the sums of the rows, its percentage computed
  // from the sums (not averaged); cross-core unavailable if any row's is.
  figure5_row totals() const;
  // A text rendering: header, one line per row, the totals line.
  std::string render() const;

 private:
  std::vector<figure5_row> rows_;
};

}  // namespace lockstep::platform
