// The c2c probe over a plan of pairs (core_to_core.hpp).
#include "bench/probes/core_to_core.hpp"

#include <algorithm>

namespace lockstep::bench::c2c {

std::vector<pair_latency> measure_pairs(const c2c_settings& settings) {
  std::vector<pair_latency> measured;
  const std::size_t total = settings.pairs.size() * settings.methods.size();
  for (const auto& [a, b] : settings.pairs) {
    for (method how : settings.methods) {
      if (settings.on_pair) settings.on_pair(measured.size(), total, a, b, how);
      pair_request request;
      request.cpu_a = a;
      request.cpu_b = b;
      request.how = how;
      request.samples = settings.samples;
      request.rounds_per_sample = settings.rounds_per_sample;
      // Ten samples' worth of round trips first (at least 100): caches and
      // the core's frequency settle before the first sample.
      request.warmup_rounds = std::max(100, settings.rounds_per_sample * 10);
      measured.push_back({a, b, how, measure_pair(request)});
    }
  }
  return measured;
}

}  // namespace lockstep::bench::c2c
