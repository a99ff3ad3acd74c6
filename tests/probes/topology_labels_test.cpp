// c2c pair choice and labels against synthetic hwloc topologies: every
// relation appears exactly as often as the machine's shape says, SMT siblings
// are skipped unless asked, and sampling is bounded and deterministic.
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "bench/probes/c2c_pairs.hpp"
#include "bench/cli/options.hpp"
#include "platform/topology.hpp"

namespace {

namespace probes = lockstep::bench::probes;
namespace cli = lockstep::cli;
using lockstep::platform::topology;

std::map<std::string, int> count_relations(const probes::c2c_plan& plan) {
  std::map<std::string, int> counts;
  for (const auto& pair : plan.pairs) ++counts[pair.relation];
  return counts;
}

TEST(C2cPairLabels, TwoSocketsWithEveryLevel) {
  // 2 packages x 2 L3 x 2 L2 x 2 cores x 2 PUs = 32 PUs, 496 pairs.
  const auto machine = topology::from_synthetic("pack:2 l3:2 l2:2 core:2 pu:2");
  const auto plan = probes::plan_c2c_pairs(machine, cli::usable_cpus(machine, true), 1000, 1);
  EXPECT_FALSE(plan.sampled);
  EXPECT_EQ(plan.all_pairs, 496u);
  const auto counts = count_relations(plan);
  EXPECT_EQ(counts.at("SMT siblings"), 16);        // one pair per core
  EXPECT_EQ(counts.at("shared L2"), 32);           // 8 L2s x (2 x 2) cross-core pairs
  EXPECT_EQ(counts.at("shared L3"), 64);           // 4 L3s x (4 x 4 across its two L2s)
  EXPECT_EQ(counts.at("different L3"), 128);       // 2 packages x (8 x 8 across its two L3s)
  EXPECT_EQ(counts.at("different package"), 256);  // 16 x 16
  EXPECT_EQ(counts.size(), 5u);
}

TEST(C2cPairLabels, NodesInsideAndAcrossPackages) {
  // 2 packages x 2 NUMA nodes x 2 cores (an L3 a node): 8 CPUs, 28 pairs; node N holds CPUs 2N, 2N+1.
  const auto machine = topology::from_synthetic("pack:2 numa:2 l3:1 core:2 pu:1");
  const auto plan = probes::plan_c2c_pairs(machine, cli::usable_cpus(machine, false), 1000, 1);
  const auto counts = count_relations(plan);
  EXPECT_EQ(counts.at("shared L3"), 4);           // one pair per node
  EXPECT_EQ(counts.at("other NUMA node"), 8);     // 2 packages x (2 x 2) across its two nodes
  EXPECT_EQ(counts.at("different package"), 16);  // 4 x 4
  EXPECT_EQ(counts.size(), 3u);
  for (const auto& pair : plan.pairs) {
    EXPECT_EQ(pair.node_a, pair.a / 2);
    EXPECT_EQ(pair.node_b, pair.b / 2);
  }
  EXPECT_EQ(probes::pair_words("different package", 0, 2), "different package (nodes 0 and 2)");
  EXPECT_EQ(probes::pair_words("other NUMA node", 0, 1), "other NUMA node (nodes 0 and 1)");
  EXPECT_EQ(probes::pair_words("shared L3", 1, 1), "shared L3") << "one node: nothing to add";
}

TEST(C2cPairLabels, WithoutSmtOnePuPerCore) {
  const auto machine = topology::from_synthetic("pack:2 l3:2 l2:2 core:2 pu:2");
  const auto cpus = cli::usable_cpus(machine, false);
  ASSERT_EQ(cpus.size(), 16u);
  const auto plan = probes::plan_c2c_pairs(machine, cpus, 1000, 1);
  const auto counts = count_relations(plan);
  EXPECT_EQ(counts.count("SMT siblings"), 0u);
  EXPECT_EQ(counts.at("shared L2"), 8);
  EXPECT_EQ(counts.at("different package"), 64);
}

TEST(C2cPairLabels, DesktopShapeIsAllSharedL3) {
  const auto machine = topology::from_synthetic("pack:1 l3:1 l2:4 core:1 pu:1");
  const auto plan = probes::plan_c2c_pairs(machine, cli::usable_cpus(machine, false), 100, 1);
  const auto counts = count_relations(plan);
  EXPECT_EQ(counts.at("shared L3"), 6);
  EXPECT_EQ(counts.size(), 1u);
}

TEST(C2cPairLabels, SamplingIsBoundedDeterministicAndSaid) {
  const auto machine = topology::from_synthetic("pack:2 core:16 pu:2");
  const auto cpus = cli::usable_cpus(machine, true);
  const auto first = probes::plan_c2c_pairs(machine, cpus, 50, 7);
  const auto again = probes::plan_c2c_pairs(machine, cpus, 50, 7);
  EXPECT_TRUE(first.sampled);
  EXPECT_EQ(first.all_pairs, 64u * 63u / 2u);
  ASSERT_EQ(first.pairs.size(), 50u);
  for (std::size_t i = 0; i < first.pairs.size(); ++i) {
    EXPECT_EQ(first.pairs[i].a, again.pairs[i].a);
    EXPECT_EQ(first.pairs[i].b, again.pairs[i].b);
    EXPECT_LT(first.pairs[i].a, first.pairs[i].b);
  }
}

TEST(C2cPairLabels, RequestedCoresMustBeUsable) {
  const auto machine = topology::from_synthetic("pack:1 core:4 pu:2");
  const auto without_smt = cli::usable_cpus(machine, false);
  EXPECT_EQ(cli::restrict_to(without_smt, {0, 2}, "--cores"), (std::vector<int>{0, 2}));
  EXPECT_THROW(cli::restrict_to(without_smt, {0, 1}, "--cores"), lockstep::cli::usage_error);  // 1: SMT sibling
  EXPECT_THROW(cli::restrict_to(without_smt, {0, 99}, "--cores"), lockstep::cli::usage_error);
}

}  // namespace
