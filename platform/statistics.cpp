// The statistics (statistics.hpp).
#include "platform/statistics.hpp"

namespace lockstep::platform {

namespace {

// The median of values, reordering them (nth_element: a resample's median
// costs O(n), not a sort).
double median_in_place(std::vector<double>& values) {
  const std::size_t middle = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle), values.end());
  const double upper = values[middle];
  if (values.size() % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle));
  return (lower + upper) / 2.0;
}

interval percentile_interval(std::vector<double>& resample_medians, double confidence) {
  std::sort(resample_medians.begin(), resample_medians.end());
  const double tail = (1.0 - confidence) / 2.0;
  const std::span<const double> sorted(resample_medians);
  return {quantile_of_sorted(sorted, tail), quantile_of_sorted(sorted, 1.0 - tail)};
}

// The high 64 bits of the 128-bit product x n, from 32-bit halves (no
// compiler's 128-bit integer needed): floor(x n / 2^64).
std::uint64_t multiply_high(std::uint64_t x, std::uint64_t n) noexcept {
  constexpr std::uint64_t kLow = 0xffff'ffffu;
  const std::uint64_t x_high = x >> 32, x_low = x & kLow;
  const std::uint64_t n_high = n >> 32, n_low = n & kLow;
  const std::uint64_t low_low = x_low * n_low;
  const std::uint64_t high_low = x_high * n_low;
  const std::uint64_t low_high = x_low * n_high;
  const std::uint64_t middle = (low_low >> 32) + (high_low & kLow) + low_high;
  return x_high * n_high + (high_low >> 32) + (middle >> 32);
}

void check_confidence(double confidence) {
  if (!(confidence > 0.0 && confidence < 1.0)) throw std::invalid_argument("confidence outside (0, 1)");
}

}  // namespace

double quantile(std::vector<double> values, double q) {
  std::sort(values.begin(), values.end());
  return quantile_of_sorted(std::span<const double>(values), q);
}

double median(std::span<const double> values) {
  if (values.empty()) throw std::invalid_argument("median of no values");
  std::vector<double> scratch(values.begin(), values.end());
  return median_in_place(scratch);
}

interval bootstrap_interval(std::span<const double> values, const std::vector<std::vector<std::size_t>>& resamples,
                            double confidence) {
  check_confidence(confidence);
  const double whole = median(values);
  if (resamples.empty()) return {whole, whole};
  std::vector<double> medians;
  medians.reserve(resamples.size());
  std::vector<double> scratch(values.size());
  for (const auto& indices : resamples) {
    if (indices.size() != values.size()) throw std::invalid_argument("a resample of another length than the values");
    for (std::size_t slot = 0; slot < indices.size(); ++slot) {
      if (indices[slot] >= values.size()) throw std::invalid_argument("a resample index beyond the values");
      scratch[slot] = values[indices[slot]];
    }
    medians.push_back(median_in_place(scratch));
  }
  return percentile_interval(medians, confidence);
}

median_estimate bootstrap_median(std::span<const double> values, double confidence, unsigned resamples,
                                 std::uint64_t seed) {
  if (values.empty()) return {};
  check_confidence(confidence);
  median_estimate estimate;
  estimate.median = median(values);
  if (values.size() == 1 || resamples == 0) {
    estimate.low = estimate.high = estimate.median;
    return estimate;
  }
  bootstrap_draws draws(seed);
  std::vector<double> medians;
  medians.reserve(resamples);
  std::vector<double> scratch(values.size());
  for (unsigned resample = 0; resample < resamples; ++resample) {
    for (double& value : scratch) value = values[draws.next_index(values.size())];
    medians.push_back(median_in_place(scratch));
  }
  const interval ends = percentile_interval(medians, confidence);
  estimate.low = ends.low;
  estimate.high = ends.high;
  return estimate;
}

std::uint64_t bootstrap_draws::next() noexcept {
  state_ += 0x9e37'79b9'7f4a'7c15u;
  std::uint64_t z = state_;
  z = (z ^ (z >> 30)) * 0xbf58'476d'1ce4'e5b9u;
  z = (z ^ (z >> 27)) * 0x94d0'49bb'1331'11ebu;
  return z ^ (z >> 31);
}

std::size_t bootstrap_draws::next_index(std::size_t n) noexcept {
  return static_cast<std::size_t>(multiply_high(next(), static_cast<std::uint64_t>(n)));
}

std::string_view to_string(verdict outcome) noexcept {
  switch (outcome) {
    case verdict::penalty:
      return "penalty";
    case verdict::gain:
      return "gain";
    case verdict::within_noise:
      return "within noise";
    case verdict::unsure:
      return "unsure";
  }
  return "unsure";
}

verdict verdict_of(double low, double high, double noise) noexcept {
  const double upper_edge = 1.0 + noise;
  const double lower_edge = 1.0 / upper_edge;
  if (low > upper_edge) return verdict::penalty;
  if (high < lower_edge) return verdict::gain;
  if (low >= lower_edge && high <= upper_edge) return verdict::within_noise;
  return verdict::unsure;
}

}  // namespace lockstep::platform
