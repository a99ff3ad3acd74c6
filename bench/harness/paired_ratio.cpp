// Paired ratios: the bootstrap and the verdict (paired_ratio.hpp).
#include "bench/harness/paired_ratio.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace lockstep::bench {

namespace {

double median_in_place(std::vector<double>& values) {
  const std::size_t middle = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle), values.end());
  const double upper = values[middle];
  if (values.size() % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle));
  return (lower + upper) / 2.0;
}

// The value at quantile q of sorted values (linear between neighbours).
double quantile_sorted(const std::vector<double>& sorted, double q) {
  const double position = q * static_cast<double>(sorted.size() - 1);
  const auto below = static_cast<std::size_t>(std::floor(position));
  const std::size_t above = std::min(below + 1, sorted.size() - 1);
  const double fraction = position - static_cast<double>(below);
  return sorted[below] + fraction * (sorted[above] - sorted[below]);
}

}  // namespace

std::string_view to_string(ratio_verdict verdict) noexcept {
  switch (verdict) {
    case ratio_verdict::penalty:
      return "penalty";
    case ratio_verdict::gain:
      return "gain";
    case ratio_verdict::within_noise:
      return "within noise";
  }
  return "within noise";
}

std::string_view to_string(comparison_kind kind) noexcept {
  switch (kind) {
    case comparison_kind::false_sharing:
      return "false_sharing";
    case comparison_kind::migration:
      return "migration";
    case comparison_kind::against_best_other:
      return "against_best_other";
  }
  return "false_sharing";
}

ratio_estimate bootstrap_median(const std::vector<double>& ratios, double confidence, unsigned resamples,
                                std::uint64_t seed) {
  if (ratios.empty()) return {};
  std::vector<double> scratch = ratios;
  ratio_estimate estimate;
  estimate.median = median_in_place(scratch);
  if (ratios.size() == 1 || resamples == 0) {
    estimate.low = estimate.high = estimate.median;
    return estimate;
  }
  std::mt19937_64 generator(seed);
  std::uniform_int_distribution<std::size_t> pick(0, ratios.size() - 1);
  std::vector<double> medians;
  medians.reserve(resamples);
  for (unsigned resample = 0; resample < resamples; ++resample) {
    for (double& value : scratch) value = ratios[pick(generator)];
    medians.push_back(median_in_place(scratch));
  }
  std::sort(medians.begin(), medians.end());
  const double tail = (1.0 - confidence) / 2.0;
  estimate.low = quantile_sorted(medians, tail);
  estimate.high = quantile_sorted(medians, 1.0 - tail);
  return estimate;
}

ratio_verdict verdict_of(const ratio_estimate& estimate, double noise) {
  if (estimate.low > 1.0 + noise) return ratio_verdict::penalty;
  if (estimate.high < 1.0 / (1.0 + noise)) return ratio_verdict::gain;
  return ratio_verdict::within_noise;
}

}  // namespace lockstep::bench
