// The shared result JSON shapes (result_json.hpp).
#include "bench/harness/result_json.hpp"

#include <span>

namespace lockstep::bench {

nlohmann::json distribution_json(const std::vector<double>& samples) {
  if (samples.empty())
    return {{"min", nullptr}, {"p50", nullptr},  {"p99", nullptr}, {"p999", nullptr},
            {"max", nullptr}, {"mean", nullptr}, {"count", 0}};
  return distribution_json(platform::summarize(samples));
}

nlohmann::json distribution_json(const platform::distribution& summary) {
  return {{"min", summary.min}, {"p50", summary.p50},   {"p99", summary.p99},    {"p999", summary.p999},
          {"max", summary.max}, {"mean", summary.mean}, {"count", summary.count}};
}

platform::histogram histogram_of(const std::vector<double>& samples, std::size_t max_buckets) {
  platform::histogram h = platform::histogram::covering(std::span<const double>(samples), max_buckets);
  for (double sample : samples) h.add(sample);
  return h;
}

nlohmann::json histogram_json(const platform::histogram& histogram) {
  return {{"bucket_ns", histogram.bucket_ns()}, {"first_ns", histogram.first_ns()}, {"counts", histogram.counts()},
          {"below", histogram.below()},         {"above", histogram.above()}};
}

}  // namespace lockstep::bench
