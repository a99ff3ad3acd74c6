// The shared result JSON shapes (result_json.hpp).
#include "bench/results/result_json.hpp"

#include <span>

namespace lockstep::bench {

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
