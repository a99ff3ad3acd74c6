#pragma once
// Which pairs `lockstep c2c` measures, and how each is labelled: a pure
// function of (topology, CPUs, bound on pairs, seed), so tests check it on
// synthetic two-socket machines. A pair's label is its relation in hwloc's
// tree (platform/topology.hpp: "shared L3", "other NUMA node", "different
// package", ...); beside it every pair carries both CPUs' NUMA nodes, which
// the text states where they differ ("different package (nodes 0 and 1)").
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
  int node_a = platform::kNoObject;  // a's NUMA node (the kernel's number)
  int node_b = platform::kNoObject;  // b's
};

// The relation, and the two nodes where they differ: "shared L3",
// "other NUMA node (nodes 0 and 1)", "different package (nodes 0 and 2)".
inline std::string pair_words(const std::string& relation, int node_a, int node_b) {
  if (node_a == node_b || node_a == platform::kNoObject || node_b == platform::kNoObject) return relation;
  return relation + " (nodes " + std::to_string(node_a) + " and " + std::to_string(node_b) + ")";
}

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
  for (const auto& [a, b] : pairs) {
    const auto cpu_a = static_cast<unsigned>(a);
    const auto cpu_b = static_cast<unsigned>(b);
    plan.pairs.push_back({a, b, std::string(platform::to_string(machine.relation(cpu_a, cpu_b))),
                          machine.pu(cpu_a).numa, machine.pu(cpu_b).numa});
  }
  return plan;
}

}  // namespace lockstep::bench::probes
