#pragma once
// The migrate probe: the cost of one forced migration, split into
//   move    the time from asking the kernel to move the calling thread to
//           another CPU (sched_setaffinity to that CPU alone) until the thread
//           runs there (sched_getcpu says so): system call, stopper thread,
//           context switch;
//   refill  the extra time of the first pass over a working set of `bytes` on
//           the new CPU, against a pass whose lines are already local:
//           first pass after the move - the pass right after it.
// A baseline prices what the move includes but is not a migration: the same
// sched_setaffinity call naming the CPU the thread is already on.
//
// Contract: measure_migration runs on a thread of its own (the caller's
// affinity stays untouched) and throws std::runtime_error when a CPU cannot
// be used or the working set cannot be mapped.
#include <cstdint>
#include <functional>
#include <vector>

namespace lockstep::bench::probes {

struct migrate_settings {
  unsigned from = 0;  // the two ends of the move; each repeat moves once, alternating direction
  unsigned to = 1;
  std::uint64_t bytes = 256 * 1024;  // working set (>= one cache line)
  int repeats = 200;
  // Called every 100 migrations (done so far, total).
  std::function<void(int, int)> on_progress;
};

struct migrate_result {
  std::vector<double> move_ns;        // setaffinity to the other CPU until running there
  std::vector<double> stay_ns;        // baseline: setaffinity naming the current CPU
  std::vector<double> refill_ns;      // first pass after the move - the next pass
  std::vector<double> first_pass_ns;  // the first pass after the move
  std::vector<double> next_pass_ns;   // the pass right after it (lines local)
};

migrate_result measure_migration(const migrate_settings& settings);

}  // namespace lockstep::bench::probes
