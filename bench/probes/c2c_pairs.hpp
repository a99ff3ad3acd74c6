#pragma once
// Which pairs `lockstep c2c` measures, and how each is labelled: a pure
// function of (topology, CPUs, bound on pairs, seed), so tests check it on
// synthetic two-socket machines.
#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "platform/topology.hpp"

namespace lockstep::bench::probes {

struct c2c_pair {
  int a = 0;  // the initiator (the smaller CPU number)
  int b = 0;
  std::string relation;  // platform::to_string(pu_relation): "shared L3", ...
};

struct c2c_plan {
  std::vector<c2c_pair> pairs;  // ascending by (a, b)
  std::size_t all_pairs = 0;    // how many unordered pairs the CPUs make
  bool sampled = false;         // pairs is a random subset of them
};

// Every unordered pair of `cpus`, or, when there are more than max_pairs, a
// random subset of max_pairs drawn with a fixed seed (hundreds of CPUs make
// tens of thousands of pairs; the output says that it sampled).
inline c2c_plan plan_c2c_pairs(const platform::topology& machine, const std::vector<int>& cpus,
                               std::size_t max_pairs, unsigned seed) {
  c2c_plan plan;
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t i = 0; i < cpus.size(); ++i)
    for (std::size_t j = i + 1; j < cpus.size(); ++j)
      pairs.emplace_back(std::min(cpus[i], cpus[j]), std::max(cpus[i], cpus[j]));
  plan.all_pairs = pairs.size();
  plan.sampled = pairs.size() > max_pairs;
  if (plan.sampled) {
    std::mt19937 random(seed);
    std::shuffle(pairs.begin(), pairs.end(), random);
    pairs.resize(max_pairs);
  }
  std::sort(pairs.begin(), pairs.end());
  for (const auto& [a, b] : pairs)
    plan.pairs.push_back({a, b,
                          std::string(platform::to_string(
                              machine.relation(static_cast<unsigned>(a), static_cast<unsigned>(b))))});
  return plan;
}

}  // namespace lockstep::bench::probes
