#pragma once
// A distribution (platform/stats.hpp) as every result file writes it:
// {min, p50, p99, p999, max, mean, count}; no samples: every statistic null
// and count 0 (a missing number is said, never faked). Low in the layering
// so that bench/ and distributed/ write it the one way.
#include <nlohmann/json.hpp>

#include <vector>

#include "platform/stats.hpp"

namespace lockstep::platform {

inline nlohmann::json distribution_json(const distribution& summary) {
  return {{"min", summary.min}, {"p50", summary.p50},   {"p99", summary.p99},    {"p999", summary.p999},
          {"max", summary.max}, {"mean", summary.mean}, {"count", summary.count}};
}

inline nlohmann::json distribution_json(const std::vector<double>& samples) {
  if (samples.empty())
    return {{"min", nullptr}, {"p50", nullptr},  {"p99", nullptr}, {"p999", nullptr},
            {"max", nullptr}, {"mean", nullptr}, {"count", 0}};
  return distribution_json(summarize(samples));
}

}  // namespace lockstep::platform
