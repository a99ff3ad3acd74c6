#pragma once
// Which thread counts a run measures, and what a run would cost before it
// runs (`lockstep run --plan`).
//
// Default thread counts on a machine of N usable cores: the paper's 4, N,
// and up to three points between, spaced evenly on a log scale and rounded to
// even counts (a chain of one equation per thread then has whole masses):
//   N = 2: 2, 4      N = 8: 4, 6, 8      N = 64: 4, 8, 16, 32, 64
//   N = 96: 4, 8, 20, 44, 96
// So the default matrix grows with the machine's log, not its size: on 64
// cores it is about 700 entries, which the estimate below puts near 7
// minutes.
//
// The scaling sweep (--scaling): 2, 4, 8, ... up to the CPUs of the affinity
// set, the CPU count itself when it is not a power of two, and never fewer
// points than 2, 4, 8: a machine with fewer than 8 CPUs still shows the
// oversubscribed end of the curve (the summary says which points oversubscribe).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lockstep::bench {

std::vector<unsigned> default_thread_counts(unsigned cores);
std::vector<unsigned> scaling_thread_counts(unsigned cpus);

// What one run costs, from its settings. The constants are calibrated on the
// 2-vCPU development VM, whose default run measured 268 entries in 127 s
// (0.47 s each: 5 repetitions of at least 40 ms, about 95 ms each with Google
// Benchmark's sizing of the iteration count and the team's start) and 198
// paired comparisons in 20 s (0.10 s each: 10 pairs of two 1 ms blocks, and
// the two teams' start). A machine with more threads per entry starts bigger
// teams; the estimate does not know that, and says it is an estimate.
struct run_cost {
  int repetitions = 5;
  std::int64_t min_time_ns = 40'000'000;
  unsigned pairs = 10;
  std::int64_t block_ns = 1'000'000;
  std::int64_t pair_budget_ns = 150'000'000;
};

struct run_estimate {
  double matrix_s = 0.0;  // every entry's repetitions
  double pairs_s = 0.0;   // the paired comparisons after the matrix
  [[nodiscard]] double total_s() const noexcept { return matrix_s + pairs_s; }
};

run_estimate estimate_run(std::size_t entries, std::size_t comparisons, const run_cost& cost);

// "6 min 40 s", "47 s".
std::string format_seconds(double seconds);

}  // namespace lockstep::bench
