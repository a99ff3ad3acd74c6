#pragma once
// A ratio that survives a machine changing pace: the two sides of a comparison
// run in alternating short blocks (A B, then B A, ...), a ratio is taken per
// adjacent pair, and the figure is the median ratio with a bootstrap
// confidence interval, judged against a noise band.
//
// Why pairs: the development VM keeps a pace (core-to-core latency 25, 55 or
// 120-270 ns, and every primitive's cost with it) for seconds to tens of
// seconds, so two entries measured a minute apart can differ 3x for no reason
// of their own. Two blocks a few milliseconds apart almost always share a
// pace; their ratio keeps the effect and drops the pace.
//
// Why the median and a percentile bootstrap: a pair that straddles a change
// of pace, or a block that was preempted, gives one wild ratio; the median
// ignores it, and the bootstrap needs no assumption about the ratios'
// distribution. The resampling is seeded, so a file's intervals can be
// recomputed from its ratios.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "platform/statistics.hpp"

namespace lockstep::bench {

// The median ratio and its interval, and the verdict: platform/statistics.hpp
// defines both (the verdict's four outcomes, penalty, gain, within noise and
// unsure, are written down there).
using ratio_estimate = platform::median_estimate;
using ratio_verdict = platform::verdict;
using platform::to_string;

// The default half-width of the noise band: a ratio within 5 % of 1 is no
// effect (the harness's own cost and a quiet machine's repeatability are a
// few percent).
inline constexpr double kDefaultNoise = 0.05;
inline constexpr double kConfidence = 0.95;
inline constexpr unsigned kBootstrapResamples = 4000;
inline constexpr std::uint64_t kBootstrapSeed = 0x5eed'1234;

// The median of `ratios` and its percentile-bootstrap interval at
// `confidence` (platform::bootstrap_median: deterministic for a given seed).
// One ratio: the interval is that ratio. Empty input: all zero.
inline ratio_estimate bootstrap_median(const std::vector<double>& ratios, double confidence = kConfidence,
                                       unsigned resamples = kBootstrapResamples, std::uint64_t seed = kBootstrapSeed) {
  return platform::bootstrap_median(ratios, confidence, resamples, seed);
}

// The estimate's interval against the noise band (platform::verdict_of).
inline ratio_verdict verdict_of(const ratio_estimate& estimate, double noise = kDefaultNoise) {
  return platform::verdict_of(estimate.low, estimate.high, noise);
}

// The same comparison read the other way round (b / a): the median and the
// interval's ends inverted, the verdict mirrored. The band is symmetric on a
// log scale ([1 / (1 + noise), 1 + noise]), so the mirrored verdict is the
// one the inverted interval would get; it is mirrored, not recomputed, so
// that rounding at a band edge cannot make the two directions disagree.
inline ratio_estimate inverse(const ratio_estimate& estimate) {
  const auto invert = [](double value) { return value > 0.0 ? 1.0 / value : 0.0; };
  return {invert(estimate.median), invert(estimate.high), invert(estimate.low)};
}
inline ratio_verdict inverse(ratio_verdict verdict) {
  switch (verdict) {
    case ratio_verdict::penalty: return ratio_verdict::gain;
    case ratio_verdict::gain: return ratio_verdict::penalty;
    default: return verdict;
  }
}

// What a comparison sets side by side (the summary's sections).
// against_best_other compares RK4 steps (rk4/...) or bare episodes (barrier/...): the names say which.
// crossover: the serial step of a chain against a parallel step of the same
// chain (a speedup; bench/run/crossover_sweep.hpp), kept out of the run's
// lockstep_pairs.
enum class comparison_kind { false_sharing, migration, against_best_other, crossover };
std::string_view to_string(comparison_kind kind) noexcept;

struct comparison {
  comparison_kind kind = comparison_kind::false_sharing;
  std::string group;  // "sync:futex_spin pin:compact threads:4", for people
  std::string a;      // the numerator entry
  std::string b;      // the denominator entry
};

// One comparison as measured: the per-pair ratios a/b and the pace readings
// around them (readings[2 i] before pair i, readings[2 i + 1] after it).
struct paired_result {
  comparison what;
  std::vector<double> ratios;
  std::vector<std::size_t> readings;
  std::vector<int> modes;  // per pair: the pace mode both readings agree on, or -1 (set after the run)
  ratio_estimate estimate;
  ratio_verdict verdict = ratio_verdict::unsure;
  double block_ms = 0.0;   // the median timed block, both sides
  bool budget_cut = false; // fewer pairs than asked: the comparison's time budget ran out
  std::string failure;     // non-empty: not measured, and why
  // Where a side says what its blocks saw (block_runner::last_facts,
  // accounting on): the ratios of pairs in which another thread held a CPU of
  // a side (its threads waited on a run queue for more than 1 % of its block;
  // without schedstat, any involuntary context switch) are set aside here,
  // never in `ratios`.
  // Per pair kept: each side's time per unit and the CPUs the side kept busy
  // (0 where the side says nothing or its clock could not be read).
  std::vector<double> set_aside;
  std::vector<double> unit_ns_a;
  std::vector<double> unit_ns_b;
  std::vector<double> cpus_busy_a;
  std::vector<double> cpus_busy_b;
};

}  // namespace lockstep::bench
