// Thread counts and the run's cost estimate (run_plan.hpp).
#include "bench/harness/run_plan.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>

#include "bench/harness/paired_blocks.hpp"
#include "kernels/model_choice.hpp"

namespace lockstep::bench {

namespace {

// A repetition lasts a fixed part (the team's start, the pace readings
// around its call, the first call's batch-size probe) and a part that grows
// with its minimum time (Google Benchmark's trial to size the iteration
// count, the warm-up batch): on the development VM the default mode's
// repetitions (40 ms) took about 95 ms and the quick mode's (5 ms) about
// 22 ms, once collapsing entries were measured briefly.
constexpr double kRepetitionFixedNs = 12'000'000.0;
constexpr double kRepetitionOverMinTime = 2.1;
// A pair of blocks costs this many times its two timed blocks (building the
// two teams once, the pace readings around each pair): 0.10 s for 10 pairs of
// 1 ms blocks on the development VM.
constexpr double kPairOverBlocks = 5.0;
// Points between the paper's 4 and the core count in the default list.
constexpr int kPointsBetween = 3;

void sort_unique(std::vector<unsigned>& counts) {
  std::sort(counts.begin(), counts.end());
  counts.erase(std::unique(counts.begin(), counts.end()), counts.end());
}

}  // namespace

std::vector<unsigned> default_thread_counts(unsigned cores) {
  const unsigned paper = kernels::kPaperThreadsMax;
  cores = std::max(1u, cores);
  std::vector<unsigned> counts{paper, cores};
  if (cores > paper) {
    const double span = std::log(static_cast<double>(cores) / paper);
    for (int point = 1; point <= kPointsBetween; ++point) {
      const double between = paper * std::exp(span * point / (kPointsBetween + 1));
      const auto even = static_cast<unsigned>(2.0 * std::round(between / 2.0));
      if (even > paper && even < cores) counts.push_back(even);
    }
  }
  sort_unique(counts);
  return counts;
}

std::vector<unsigned> scaling_thread_counts(unsigned cpus) {
  constexpr unsigned kAtLeastUpTo = 8;
  std::vector<unsigned> counts{kernels::kPaperThreadsMax};
  const unsigned top = std::max(cpus, kAtLeastUpTo);
  for (unsigned threads = 2; threads <= top; threads *= 2) counts.push_back(threads);
  counts.push_back(std::max(cpus, 2u));
  sort_unique(counts);
  return counts;
}

run_estimate estimate_run(std::size_t entries, std::size_t comparisons, const run_cost& cost) {
  run_estimate estimate;
  estimate.matrix_s = static_cast<double>(entries) * cost.repetitions *
                      (kRepetitionFixedNs + kRepetitionOverMinTime * static_cast<double>(cost.min_time_ns)) / 1e9;
  const double per_comparison_ns = std::min<double>(
      kPairOverBlocks * 2.0 * static_cast<double>(cost.block_ns) * cost.pairs,
      static_cast<double>(cost.pair_budget_ns) + kPairOverBlocks * 2.0 * static_cast<double>(cost.block_ns) * kMinPairs);
  estimate.pairs_s = cost.pairs == 0 ? 0.0 : static_cast<double>(comparisons) * per_comparison_ns / 1e9;
  return estimate;
}

std::string format_seconds(double seconds) {
  const auto whole = static_cast<long>(std::lround(seconds));
  if (whole < 60) return fmt::format("{} s", whole);
  return fmt::format("{} min {:02} s", whole / 60, whole % 60);
}

}  // namespace lockstep::bench
