// Thread counts and the run's cost estimate (run_plan.hpp).
#include "bench/run/run_plan.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>

#include "bench/run/paired_blocks.hpp"
#include "kernels/model_choice.hpp"

namespace lockstep::bench {

namespace {

// A repetition lasts a fixed part (the team's start, the pace readings
// around its call, the entry's batch-size probe spread over its
// repetitions) and a part that grows with its minimum time (the timed
// batches, the warm-up batch, batches longer than the target): on the
// development VM, quiet, the default mode's repetitions (40 ms) took 60 and
// 70 ms in two runs back to back and the quick mode's (5 ms) 21 ms, once
// each repetition ran a fixed number of batches (run_book.hpp: timed_batches).
constexpr double kRepetitionFixedNs = 14'000'000.0;
constexpr double kRepetitionOverMinTime = 1.25;
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
