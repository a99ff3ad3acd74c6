// c2c pair labels against synthetic hwloc topologies: every relation appears
// exactly as often as the machine's shape says.
#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <string>

#include "bench/delay_topology.hpp"

namespace {

using lockstep::bench::delay::topology_view;

std::map<std::string, int> count_relations(const topology_view& topology) {
  std::map<std::string, int> counts;
  const auto cpus = topology.cpus(true);
  for (std::size_t i = 0; i < cpus.size(); ++i)
    for (std::size_t j = i + 1; j < cpus.size(); ++j) ++counts[topology.relation(cpus[i], cpus[j])];
  return counts;
}

TEST(PairLabels, TwoSocketsWithEveryLevel) {
  // 2 packages x 2 L3 x 2 L2 x 2 cores x 2 PUs = 32 PUs.
  const auto topology = topology_view::from_synthetic("pack:2 l3:2 l2:2 core:2 pu:2");
  const auto counts = count_relations(topology);
  EXPECT_EQ(counts.at("SMT siblings"), 16);        // one pair per core
  EXPECT_EQ(counts.at("shared L2"), 32);           // 8 L2s x (2 x 2) cross-core pairs
  EXPECT_EQ(counts.at("shared L3"), 64);           // 4 L3s x (4 x 4 across its two L2s)
  EXPECT_EQ(counts.at("different L3"), 128);       // 2 packages x (8 x 8 across its two L3s)
  EXPECT_EQ(counts.at("different package"), 256);  // 16 x 16
  EXPECT_EQ(counts.size(), 5u);
}

TEST(PairLabels, NeighboursInLogicalOrder) {
  const auto topology = topology_view::from_synthetic("pack:2 l3:2 l2:2 core:2 pu:2");
  EXPECT_EQ(topology.relation(0, 1), "SMT siblings");
  EXPECT_EQ(topology.relation(0, 2), "shared L2");
  EXPECT_EQ(topology.relation(0, 4), "shared L3");
  EXPECT_EQ(topology.relation(0, 8), "different L3");
  EXPECT_EQ(topology.relation(0, 16), "different package");
  EXPECT_EQ(topology.relation(31, 0), "different package");
}

TEST(PairLabels, SharedL3WithoutL2Level) {
  // One package, one L3, private L2 per core (the common desktop shape).
  const auto topology = topology_view::from_synthetic("pack:1 l3:1 l2:4 core:1 pu:1");
  const auto counts = count_relations(topology);
  EXPECT_EQ(counts.at("shared L3"), 6);
  EXPECT_EQ(counts.size(), 1u);
}

TEST(PairLabels, SmtSiblingsAreSkippedUnlessAsked) {
  const auto topology = topology_view::from_synthetic("pack:1 l3:1 core:4 pu:2");
  EXPECT_EQ(topology.cpus(true).size(), 8u);
  const auto one_per_core = topology.cpus(false);
  ASSERT_EQ(one_per_core.size(), 4u);
  EXPECT_EQ(one_per_core[1], 2);
  const auto shape = topology.summary();
  EXPECT_EQ(shape.text(), "packages=1 l3=1 cores=4 pus=8");
}

TEST(PairLabels, BadInputIsRejected) {
  EXPECT_THROW(topology_view::from_synthetic("pack:two"), std::invalid_argument);
  const auto topology = topology_view::from_synthetic("pack:1 core:2 pu:1");
  EXPECT_THROW(topology.relation(0, 0), std::invalid_argument);
  EXPECT_THROW(topology.relation(0, 9), std::invalid_argument);
  EXPECT_THROW(topology.relation(-1, 0), std::invalid_argument);
}

}  // namespace
