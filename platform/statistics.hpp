#pragma once
// The statistics lockstep states its figures with, each defined once, here.
// reports/lockstep_reports/common/statistics.py is the Python twin; the golden file
// tests/fixtures/statistics/golden.json holds both to the same answers
// (tests/platform/statistics_golden_test.cpp and
// reports/tests/test_statistics.py read it).
//
// Quantile (Hyndman and Fan's definition 7, linear interpolation between
// closest ranks: numpy.quantile's default and R's quantile's). For n sorted
// values x[0] <= ... <= x[n-1] and q in [0, 1]:
//     h = (n - 1) q,   Q(q) = x[floor h] + (h - floor h) (x[floor h + 1] - x[floor h])
// Q(0) is the minimum, Q(1) the maximum; a single value is every quantile.
//
// Median: the middle value of an odd count, the mean of the two middle values
// of an even count (numpy.median; Q(0.5) up to rounding).
//
// Bootstrap interval of a median (percentile bootstrap): B resamples, each n
// indices into the n values drawn with replacement; the median of each
// resample; the interval at confidence c is [Q((1 - c) / 2), Q(1 - (1 - c) / 2)]
// of those B medians. bootstrap_interval takes the resamples' indices;
// bootstrap_median draws them. One value: the interval is that value; no
// resamples: the interval is the median.
//
// The draws (bootstrap_draws), portable so that any language can recompute a
// result file's interval from its values and seed: the generator is
// splitmix64 started at the seed,
//     state += 0x9e3779b97f4a7c15
//     z = state;  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9
//                 z = (z ^ (z >> 27)) * 0x94d049bb133111eb
//     output z ^ (z >> 31)                         (all arithmetic mod 2^64)
// and an output x becomes the index floor(x n / 2^64) in [0, n) (Lemire's
// multiply-shift, without his rejection step: an index's probability is off
// by at most n / 2^64). Resample after resample, index after index: resample
// r's index i is output number r n + i. std::uniform_int_distribution is not
// used: its mapping is each standard library's own.
//
// Agreement with reports/lockstep_reports/common/statistics.py: the draws are
// integers and identical; the medians and quantiles are the same IEEE
// expressions in the same order, so on this build the two agree to the last
// bit (the golden file's seeded cases agree exactly on x86-64, and so do a
// run file's intervals: tests/run/run_fixture_test.cpp and
// reports/tests/test_run_fixture.py). The golden tests allow 1 ulp: a
// compiler that fuses x[floor h] + w (x[floor h + 1] - x[floor h]) into one
// multiply-add (an FMA target, -ffp-contract=fast) may move an interpolated
// end by that much; a changed draw moves it by far more.
//
// Verdict of a ratio's interval [low, high] against a noise band of half-width
// `noise` (a fraction: 0.05 is 5 %), the band being [1 / (1 + noise), 1 + noise]:
//     penalty       low > 1 + noise            (the whole interval above the band)
//     gain          high < 1 / (1 + noise)     (the whole interval below the band)
//     within noise  1 / (1 + noise) <= low and high <= 1 + noise
//                                              (the whole interval inside the band)
//     unsure        anything else: the interval straddles an edge of the band
// An interval end exactly on an edge lies inside the band.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string_view>
#include <vector>

namespace lockstep::platform {

// Q(q) of sorted values (ascending) by the rule above. Throws
// std::invalid_argument on no values or q outside [0, 1].
template <class Sample>
double quantile_of_sorted(std::span<const Sample> sorted, double q) {
  if (sorted.empty()) throw std::invalid_argument("quantile of no values");
  if (!(q >= 0.0 && q <= 1.0)) throw std::invalid_argument("quantile fraction outside [0, 1]");
  const double rank = q * static_cast<double>(sorted.size() - 1);
  const auto below = static_cast<std::size_t>(std::floor(rank));
  const std::size_t above = std::min(below + 1, sorted.size() - 1);
  const double weight = rank - static_cast<double>(below);
  const auto low = static_cast<double>(sorted[below]);
  const auto high = static_cast<double>(sorted[above]);
  return low + weight * (high - low);
}

// Q(q) of values in any order. Throws as quantile_of_sorted.
double quantile(std::vector<double> values, double q);

// The median of values in any order. Throws std::invalid_argument on no values.
double median(std::span<const double> values);

struct interval {
  double low = 0.0;
  double high = 0.0;
};

// The percentile bootstrap interval of the median of `values` at `confidence`
// (in (0, 1)) over the given resamples, each a list of values.size() indices
// into `values`. Throws std::invalid_argument on no values, an index out of
// range or a resample of the wrong length; no resamples: [median, median].
interval bootstrap_interval(std::span<const double> values, const std::vector<std::vector<std::size_t>>& resamples,
                            double confidence);

// The seeded draws of the contract above: splitmix64 from `seed`, each output
// mapped to an index in [0, n).
class bootstrap_draws {
 public:
  explicit bootstrap_draws(std::uint64_t seed) noexcept : state_(seed) {}

  // The generator's next output.
  std::uint64_t next() noexcept;
  // The next output as an index in [0, n): floor(x n / 2^64). n >= 1.
  std::size_t next_index(std::size_t n) noexcept;

 private:
  std::uint64_t state_;
};

struct median_estimate {
  double median = 0.0;
  double low = 0.0;  // the interval's ends
  double high = 0.0;
};

// The median of `values` and its bootstrap interval over `resamples`
// resamples drawn by bootstrap_draws(seed), resample after resample, index
// after index. No values: all zero; one value or no resamples: the interval
// is the median.
median_estimate bootstrap_median(std::span<const double> values, double confidence, unsigned resamples,
                                 std::uint64_t seed);

enum class verdict { penalty, gain, within_noise, unsure };

// "penalty", "gain", "within noise", "unsure": the words of result files and
// of reports/lockstep_reports/common/statistics.py.
std::string_view to_string(verdict outcome) noexcept;

// The rule of the contract above.
verdict verdict_of(double low, double high, double noise) noexcept;

}  // namespace lockstep::platform
