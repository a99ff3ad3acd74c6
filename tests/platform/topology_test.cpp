// Topology tables from synthetic descriptions, XML files and this machine.
#include "platform/topology.hpp"

#include <hwloc.h>
#include <unistd.h>

#include <cstdio>
#include <iterator>
#include <regex>
#include <set>
#include <string>
#include <string_view>

#include <gtest/gtest.h>

namespace {

using lockstep::platform::pu_relation;
using lockstep::platform::topology;
using lockstep::platform::topology_error;

TEST(Topology, TwoSocketSyntheticCountsEveryLevel) {
  const topology machine = topology::from_synthetic("package:2 l3:2 core:4 pu:2");
  EXPECT_EQ(machine.packages(), 2U);
  EXPECT_EQ(machine.l3_domains(), 4U);
  EXPECT_EQ(machine.core_count(), 16U);
  EXPECT_EQ(machine.pu_count(), 32U);
  EXPECT_EQ(machine.summary(), "packages=2 l3=4 cores=16 pus=32");
  EXPECT_FALSE(machine.is_this_system());
  EXPECT_EQ(machine.affinity().size(), 32U) << "every PU of a synthetic machine is usable";
  for (const auto& core : machine.cores()) EXPECT_EQ(core.pus.size(), 2U);
}

TEST(Topology, ThisVmShapeHasOneL3AndTwoCores) {
  const topology machine = topology::from_synthetic("package:1 l3:1 core:2 pu:1");
  EXPECT_EQ(machine.summary(), "packages=1 l3=1 cores=2 pus=2");
  EXPECT_EQ(machine.relation(0, 1), pu_relation::shared_l3);
}

TEST(Topology, PairRelationsFollowTheTree) {
  const topology machine = topology::from_synthetic("package:2 l3:2 core:4 pu:2");
  // OS indices follow the tree: PU 2k and 2k+1 share core k; 8 PUs per L3; 16 per package.
  EXPECT_EQ(machine.relation(0, 0), pu_relation::same_pu);
  EXPECT_EQ(machine.relation(0, 1), pu_relation::smt_siblings);
  EXPECT_EQ(machine.relation(0, 2), pu_relation::shared_l3);
  EXPECT_EQ(machine.relation(0, 8), pu_relation::different_l3);
  EXPECT_EQ(machine.relation(0, 16), pu_relation::different_package);
  EXPECT_EQ(machine.relation(31, 17), pu_relation::different_l3);
  EXPECT_EQ(machine.relation(5, 4), pu_relation::smt_siblings) << "the relation is symmetric";
}

TEST(Topology, SharedL2AndSamePackageWithoutL3) {
  const topology clustered = topology::from_synthetic("package:1 l3:1 l2:2 core:2 pu:1");
  EXPECT_EQ(clustered.relation(0, 1), pu_relation::shared_l2);
  EXPECT_EQ(clustered.relation(0, 2), pu_relation::shared_l3);
  EXPECT_EQ(clustered.l2_domains(), 2U);

  const topology no_l3 = topology::from_synthetic("package:2 core:2 pu:1");
  EXPECT_EQ(no_l3.l3_domains(), 0U);
  EXPECT_EQ(no_l3.relation(0, 1), pu_relation::same_package);
  EXPECT_EQ(no_l3.relation(0, 2), pu_relation::different_package);
}

TEST(Topology, RelationLabelsAreTheAgreedWords) {
  EXPECT_EQ(to_string(pu_relation::smt_siblings), "SMT siblings");
  EXPECT_EQ(to_string(pu_relation::shared_l2), "shared L2");
  EXPECT_EQ(to_string(pu_relation::shared_l3), "shared L3");
  EXPECT_EQ(to_string(pu_relation::different_l3), "different L3");
  EXPECT_EQ(to_string(pu_relation::other_numa_node), "other NUMA node");
  EXPECT_EQ(to_string(pu_relation::different_package), "different package");
  std::set<std::string_view> labels;
  for (pu_relation relation : lockstep::platform::kRelationsClosestFirst) labels.insert(to_string(relation));
  EXPECT_EQ(labels.size(), std::size(lockstep::platform::kRelationsClosestFirst)) << "one label per relation";
}

// NUMA nodes: each PU's node by the kernel's number, and the relation of two
// PUs of one package on two nodes.
TEST(TopologyNuma, TwoPackagesOfTwoNodesEach) {
  // 2 packages x 2 nodes x one L3 each x 4 cores x 2 PUs: node N holds PUs 8N .. 8N+7.
  const topology machine = topology::from_synthetic("pack:2 numa:2 l3:1 core:4 pu:2");
  EXPECT_EQ(machine.numa_nodes(), 4U);
  EXPECT_EQ(machine.summary(), "packages=2 l3=4 cores=16 pus=32 numa=4");
  for (const auto& pu : machine.pus()) EXPECT_EQ(pu.numa, static_cast<int>(pu.os_index / 8)) << pu.os_index;
  for (const auto& core : machine.cores()) EXPECT_EQ(core.numa, machine.pu(core.pus.front()).numa);
  EXPECT_EQ(machine.relation(0, 2), pu_relation::shared_l3);
  EXPECT_EQ(machine.relation(0, 8), pu_relation::other_numa_node) << "one package, two nodes (NPS2)";
  EXPECT_EQ(machine.relation(0, 16), pu_relation::different_package);
}

TEST(TopologyNuma, SubNumaClustersUnderOneL3AreOtherNodes) {
  // Intel's sub-NUMA clustering: one L3 over the package, two nodes inside it.
  const topology machine = topology::from_synthetic("pack:2 l3:1 group:2 numa:1 core:4 pu:2");
  EXPECT_EQ(machine.numa_nodes(), 4U);
  EXPECT_EQ(machine.pu(0).l3, machine.pu(8).l3) << "hwloc shows them one L3";
  EXPECT_EQ(machine.relation(0, 8), pu_relation::other_numa_node);
  EXPECT_EQ(machine.relation(0, 6), pu_relation::shared_l3);
}

TEST(TopologyNuma, OneNodePerPackageAndOneNodeMachines) {
  const topology two = topology::from_synthetic("pack:2 [numa] l3:2 core:4 pu:2");
  EXPECT_EQ(two.numa_nodes(), 2U);
  EXPECT_EQ(two.relation(0, 8), pu_relation::different_l3) << "one package, one node, two L3 domains";
  EXPECT_EQ(two.relation(0, 16), pu_relation::different_package);
  EXPECT_EQ(two.pu(16).numa, 1);
  const topology one = topology::from_synthetic("package:2 l3:2 core:4 pu:2");
  EXPECT_EQ(one.numa_nodes(), 1U);
  for (const auto& pu : one.pus()) EXPECT_EQ(pu.numa, 0);
  EXPECT_EQ(one.summary(), "packages=2 l3=4 cores=16 pus=32") << "one node: the summary reads as before";
}

TEST(TopologyNuma, PerCpuTableIsIndexedByTheKernelsNumbers) {
  const topology machine = topology::from_synthetic("pack:2 [numa] l3:1 core:2 pu:2");
  const auto table = machine.cpu_table();
  EXPECT_EQ(table.package, "0,0,0,0,1,1,1,1");
  EXPECT_EQ(table.numa_node, "0,0,0,0,1,1,1,1");
  EXPECT_EQ(table.l3, "0,0,0,0,1,1,1,1");
  EXPECT_EQ(table.core, "0,0,1,1,2,2,3,3");
  EXPECT_EQ(table.kind, "-,-,-,-,-,-,-,-") << "no CPU kinds in a synthetic topology";
  EXPECT_EQ(table.kinds, "");
}

// CPU kinds, from the hybrid XML fixtures (tests/fixtures/topology/README.md).
std::string fixture(const std::string& name) {
  return std::string(LOCKSTEP_SOURCE_DIR) + "/tests/fixtures/topology/" + name;
}

TEST(TopologyKinds, HybridXmlHasTwoKindsRankedByPerformance) {
  const topology machine = topology::from_xml_file(fixture("hybrid-8p-8e.xml"));
  EXPECT_EQ(machine.summary(), "packages=1 l3=1 cores=16 pus=24 kinds=2");
  ASSERT_TRUE(machine.hybrid());
  ASSERT_EQ(machine.kinds().size(), 2U);
  const auto& efficient = machine.kinds()[0];
  const auto& performant = machine.kinds()[1];
  EXPECT_EQ(efficient.name(), "IntelAtom");
  EXPECT_EQ(efficient.max_mhz, 3900U);
  EXPECT_EQ(efficient.pus, (std::vector<unsigned>{16, 17, 18, 19, 20, 21, 22, 23}));
  EXPECT_EQ(performant.name(), "IntelCore");
  EXPECT_EQ(performant.max_mhz, 5200U);
  EXPECT_EQ(performant.pus.size(), 16U);
  EXPECT_GT(performant.efficiency, efficient.efficiency) << "hwloc ranks the P cores above the E cores";
  EXPECT_GT(machine.performance_rank(0), machine.performance_rank(16));
  EXPECT_EQ(machine.kind_name(1), "IntelCore");
  EXPECT_EQ(machine.kind_name(23), "IntelAtom");
  for (const auto& core : machine.cores()) EXPECT_EQ(core.kind, machine.pu(core.pus.front()).kind);
  const auto table = machine.cpu_table();
  EXPECT_EQ(table.kinds, "IntelAtom,IntelCore");
  EXPECT_EQ(table.kind, "1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,0,0,0,0,0,0,0,0");
  EXPECT_EQ(machine.relation(0, 1), pu_relation::smt_siblings);
  EXPECT_EQ(machine.relation(16, 17), pu_relation::shared_l2) << "E cores share an L2 by four";
  EXPECT_EQ(machine.relation(0, 16), pu_relation::shared_l3);
}

TEST(TopologyKinds, HomogeneousMachinesHaveOneRank) {
  const topology machine = topology::from_synthetic("package:1 l3:2 core:4 pu:2");
  EXPECT_FALSE(machine.hybrid());
  for (const auto& pu : machine.pus()) EXPECT_EQ(machine.performance_rank(pu.os_index), 0U);
  EXPECT_EQ(machine.kind_name(0), "");
}

TEST(Topology, UnknownPuAndBadDescriptionsAreErrors) {
  const topology machine = topology::from_synthetic("package:1 core:2 pu:1");
  EXPECT_THROW((void)machine.relation(0, 7), topology_error);
  EXPECT_THROW(topology::from_synthetic("bogus:3"), topology_error);
  EXPECT_THROW(topology::from_synthetic(""), topology_error);
  EXPECT_THROW(topology::from_xml_file("/nonexistent/lockstep.xml"), topology_error);
}

TEST(Topology, XmlFileRoundTripsASyntheticMachine) {
  char path[] = "/tmp/lockstep-topology-XXXXXX";
  const int fd = ::mkstemp(path);
  ASSERT_GE(fd, 0);
  ::close(fd);
  hwloc_topology_t exported = nullptr;
  ASSERT_EQ(hwloc_topology_init(&exported), 0);
  ASSERT_EQ(hwloc_topology_set_synthetic(exported, "package:1 l3:2 core:4 pu:2"), 0);
  ASSERT_EQ(hwloc_topology_load(exported), 0);
  ASSERT_EQ(hwloc_topology_export_xml(exported, path, 0), 0);
  hwloc_topology_destroy(exported);

  const topology machine = topology::from_xml_file(path);
  EXPECT_EQ(machine.summary(), "packages=1 l3=2 cores=8 pus=16");
  EXPECT_EQ(machine.relation(0, 8), pu_relation::different_l3);
  EXPECT_FALSE(machine.is_this_system());
  std::remove(path);

  char garbage[] = "/tmp/lockstep-garbage-XXXXXX";
  const int garbage_fd = ::mkstemp(garbage);
  ASSERT_GE(garbage_fd, 0);
  ASSERT_EQ(::write(garbage_fd, "not xml\n", 8), 8);
  ::close(garbage_fd);
  EXPECT_THROW(topology::from_xml_file(garbage), topology_error);
  std::remove(garbage);
}

TEST(Topology, RestrictAffinityKeepsKnownPus) {
  topology machine = topology::from_synthetic("package:1 core:4 pu:1");
  machine.restrict_affinity({3, 1, 1});
  EXPECT_EQ(machine.affinity(), (std::vector<unsigned>{1, 3}));
  EXPECT_THROW(machine.restrict_affinity({9}), topology_error);
  EXPECT_THROW(machine.restrict_affinity({}), topology_error);
}

TEST(Topology, ThisMachineLoadsWithASummaryAndAffinity) {
  const topology machine = topology::this_machine();
  EXPECT_TRUE(std::regex_match(machine.summary(), std::regex("packages=[0-9]+ l3=[0-9]+ cores=[0-9]+ pus=[0-9]+")))
      << machine.summary();
  EXPECT_GE(machine.core_count(), 1U);
  EXPECT_GE(machine.pu_count(), machine.core_count());
  EXPECT_FALSE(machine.affinity().empty());
  for (unsigned cpu : machine.affinity()) EXPECT_TRUE(machine.has_pu(cpu));
  EXPECT_FALSE(machine.hwloc_version().empty());
  EXPECT_EQ(machine.hwloc_version().substr(0, 2), "2.");
}

}  // namespace
