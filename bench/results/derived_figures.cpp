// The derived figures (derived_figures.hpp).
#include "bench/results/derived_figures.hpp"

#include <fmt/core.h>

namespace lockstep::bench {

namespace {

// What each derived ratio divides, and by which calibration.
struct ratio_rule {
  const char* ratio;
  const char* counter;
  std::optional<double> calibrations::*base;
};
constexpr ratio_rule kRatios[] = {
    {"vs_serial", "ns_per_step", &calibrations::serial_step_ns},
    {"vs_c2c", "sync_ns_per_stage", &calibrations::c2c_one_way_ns},
};

}  // namespace

std::vector<derived_ratio> derived_ratios(const std::map<std::string, double>& counters, const calibrations& run) {
  std::vector<derived_ratio> ratios;
  for (const ratio_rule& rule : kRatios) {
    const std::optional<double>& base = run.*rule.base;
    const auto value = counters.find(rule.counter);
    if (value == counters.end() || !base || !(*base > 0.0)) continue;
    ratios.push_back({rule.ratio, rule.counter, value->second / *base});
  }
  return ratios;
}

}  // namespace lockstep::bench
