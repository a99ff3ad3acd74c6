// Topology tables from synthetic descriptions, XML files and this machine.
#include "platform/topology.hpp"

#include <hwloc.h>
#include <unistd.h>

#include <cstdio>
#include <regex>
#include <string>

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
  EXPECT_EQ(to_string(pu_relation::different_package), "different package");
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
