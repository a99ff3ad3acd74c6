// Placement plans against synthetic topologies, and pinning on this machine.
#include "platform/placement.hpp"

#include <chrono>
#include <cstdlib>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "platform/placement_memory.hpp"
#include "tests/support/watchdog.hpp"

namespace {

using lockstep::platform::placement;
using lockstep::platform::placement_plan;
using lockstep::platform::plan_placement;
using lockstep::platform::pu_relation;
using lockstep::platform::topology;

constexpr const char* kTwoSockets = "package:2 l3:2 core:4 pu:2";
constexpr const char* kThisVm = "package:1 l3:1 core:2 pu:1";
constexpr const char* kTwoL3Smt = "package:1 l3:2 core:4 pu:2";

std::vector<unsigned> pus_of(const placement_plan& plan) {
  std::vector<unsigned> pus;
  for (const auto& entry : plan.entries) pus.push_back(entry.pu.value());
  return pus;
}

TEST(Placement, CompactFillsOneL3BeforeTheNext) {
  const topology machine = topology::from_synthetic(kTwoSockets);
  const placement_plan plan = plan_placement(machine, placement::compact, 4);
  EXPECT_EQ(pus_of(plan), (std::vector<unsigned>{0, 2, 4, 6})) << "one PU per core, neighbouring cores";
  for (unsigned thread = 1; thread < 4; ++thread) {
    EXPECT_EQ(machine.relation(plan.entries[0].pu.value(), plan.entries[thread].pu.value()), pu_relation::shared_l3);
  }
  EXPECT_FALSE(plan.wrapped);
  EXPECT_FALSE(plan.oversubscribed);
}

TEST(Placement, ScatterSpreadsPackagesThenL3) {
  const topology machine = topology::from_synthetic(kTwoSockets);
  const placement_plan two = plan_placement(machine, placement::scatter, 2);
  EXPECT_EQ(machine.relation(two.entries[0].pu.value(), two.entries[1].pu.value()), pu_relation::different_package);
  const placement_plan four = plan_placement(machine, placement::scatter, 4);
  std::set<int> l3s;
  for (const auto& entry : four.entries) l3s.insert(machine.pu(entry.pu.value()).l3);
  EXPECT_EQ(l3s.size(), 4U) << "four threads land in four different L3 domains";
  EXPECT_EQ(pus_of(four), (std::vector<unsigned>{0, 16, 8, 24}));
  const placement_plan sixteen = plan_placement(machine, placement::scatter, 16);
  std::set<unsigned> cores;
  for (const auto& entry : sixteen.entries) cores.insert(entry.core.value());
  EXPECT_EQ(cores.size(), 16U) << "one thread per core until the cores run out";
}

TEST(Placement, ScatterAndCompactDifferOnTwoL3Domains) {
  const topology machine = topology::from_synthetic(kTwoL3Smt);
  const placement_plan compact = plan_placement(machine, placement::compact, 2);
  const placement_plan scatter = plan_placement(machine, placement::scatter, 2);
  EXPECT_EQ(machine.relation(compact.entries[0].pu.value(), compact.entries[1].pu.value()), pu_relation::shared_l3);
  EXPECT_EQ(machine.relation(scatter.entries[0].pu.value(), scatter.entries[1].pu.value()), pu_relation::different_l3);
}

TEST(Placement, WrapsOntoSmtSiblingsWithoutOversubscribing) {
  const topology machine = topology::from_synthetic(kTwoL3Smt);  // 8 cores, 16 PUs
  const placement_plan plan = plan_placement(machine, placement::compact, 9);
  EXPECT_TRUE(plan.wrapped);
  EXPECT_FALSE(plan.oversubscribed) << "9 threads fit on 16 PUs";
  EXPECT_EQ(plan.entries[8].core, plan.entries[0].core);
  EXPECT_EQ(machine.relation(plan.entries[0].pu.value(), plan.entries[8].pu.value()), pu_relation::smt_siblings);
  EXPECT_NE(plan.note.find("wrapped"), std::string::npos);
}

TEST(Placement, FourThreadsOnThisVmShapeWrapAndOversubscribe) {
  const topology machine = topology::from_synthetic(kThisVm);
  for (placement kind : {placement::compact, placement::scatter, placement::migrate}) {
    const placement_plan plan = plan_placement(machine, kind, 4);
    EXPECT_EQ(pus_of(plan), (std::vector<unsigned>{0, 1, 0, 1})) << to_string(kind);
    EXPECT_TRUE(plan.wrapped);
    EXPECT_TRUE(plan.oversubscribed);
  }
  const placement_plan two = plan_placement(machine, placement::compact, 2);
  EXPECT_FALSE(two.wrapped);
  EXPECT_FALSE(two.oversubscribed);
}

// Placement at scale: the shapes of the servers lockstep's users characterise.
constexpr const char* kTwoSockets64Pus = "package:2 l3:2 core:8 pu:2";    // 32 cores, 64 PUs
constexpr const char* kTwoSockets192Pus = "package:2 l3:4 core:12 pu:2";  // 96 cores, 192 PUs

// Every thread on a PU of its own, and which of them share a core.
void expect_distinct_pus(const placement_plan& plan) {
  const std::vector<unsigned> pus = pus_of(plan);
  EXPECT_EQ(std::set<unsigned>(pus.begin(), pus.end()).size(), pus.size()) << plan.note;
}

std::size_t distinct_cores(const placement_plan& plan) {
  std::set<unsigned> cores;
  for (const auto& entry : plan.entries) cores.insert(entry.core.value());
  return cores.size();
}

TEST(PlacementAtScale, CompactUsesEveryCoreBeforeAnySmtSibling) {
  for (const char* shape : {kTwoSockets64Pus, kTwoSockets192Pus}) {
    const topology machine = topology::from_synthetic(shape);
    const unsigned cores = machine.core_count();
    for (placement kind : {placement::compact, placement::scatter}) {
      const placement_plan full = plan_placement(machine, kind, cores);
      EXPECT_EQ(distinct_cores(full), cores) << shape << " " << to_string(kind);
      EXPECT_FALSE(full.wrapped) << "no SMT sibling while a core is free";
      expect_distinct_pus(full);
      const placement_plan past = plan_placement(machine, kind, cores + 1);
      EXPECT_TRUE(past.wrapped) << shape << " " << to_string(kind);
      EXPECT_FALSE(past.oversubscribed);
      EXPECT_NE(past.note.find("wrapped"), std::string::npos) << "the plan says it used SMT siblings";
      EXPECT_EQ(machine.relation(past.entries[0].pu.value(), past.entries[cores].pu.value()),
                pu_relation::smt_siblings);
      expect_distinct_pus(plan_placement(machine, kind, machine.pu_count()));
      EXPECT_TRUE(plan_placement(machine, kind, machine.pu_count() + 1).oversubscribed);
    }
  }
}

TEST(PlacementAtScale, CompactFillsAnL3ThenAPackage) {
  const topology machine = topology::from_synthetic(kTwoSockets192Pus);  // 12 cores per L3, 48 per package
  const placement_plan plan = plan_placement(machine, placement::compact, 64);
  for (unsigned thread = 0; thread < 64; ++thread) {
    const auto& pu = machine.pu(plan.entries[thread].pu.value());
    EXPECT_EQ(pu.l3, static_cast<int>(thread / 12)) << "thread " << thread;
    EXPECT_EQ(pu.package, thread / 48) << "thread " << thread;
  }
}

TEST(PlacementAtScale, ScatterVisitsEveryL3BeforeRepeatingOne) {
  const topology machine = topology::from_synthetic(kTwoSockets192Pus);  // 8 L3 domains
  const placement_plan plan = plan_placement(machine, placement::scatter, 16);
  std::vector<int> first_round;
  std::vector<int> second_round;
  for (unsigned thread = 0; thread < 16; ++thread)
    (thread < 8 ? first_round : second_round).push_back(machine.pu(plan.entries[thread].pu.value()).l3);
  EXPECT_EQ(std::set<int>(first_round.begin(), first_round.end()).size(), 8U);
  EXPECT_EQ(std::set<int>(second_round.begin(), second_round.end()).size(), 8U);
  EXPECT_EQ(machine.relation(plan.entries[0].pu.value(), plan.entries[1].pu.value()), pu_relation::different_package);
  EXPECT_EQ(distinct_cores(plan), 16U);
}

TEST(Placement, NoneHasNoPinsButStillDetectsOversubscription) {
  const topology machine = topology::from_synthetic(kThisVm);
  const placement_plan two = plan_placement(machine, placement::none, 2);
  for (const auto& entry : two.entries) EXPECT_FALSE(entry.pu.has_value());
  EXPECT_FALSE(two.oversubscribed);
  EXPECT_TRUE(plan_placement(machine, placement::none, 3).oversubscribed);
  EXPECT_EQ(two.pu_at(1, 5000), std::nullopt);
}

TEST(Placement, RestrictedAffinityLimitsTheCores) {
  topology machine = topology::from_synthetic("package:1 core:4 pu:1");
  machine.restrict_affinity({1, 3});
  const placement_plan plan = plan_placement(machine, placement::compact, 3);
  EXPECT_EQ(pus_of(plan), (std::vector<unsigned>{1, 3, 1}));
  EXPECT_TRUE(plan.oversubscribed);
  EXPECT_EQ(lockstep::platform::compact_core_order(machine), (std::vector<unsigned>{1, 3}));
}

TEST(Placement, MigrateMovesEveryThreadEachPeriodWithoutCollisions) {
  const topology machine = topology::from_synthetic("package:1 core:4 pu:1");
  const placement_plan plan = plan_placement(machine, placement::migrate, 2, 10);
  EXPECT_EQ(plan.migrate_every_steps, 10U);
  EXPECT_FALSE(plan.moves_at(0));
  EXPECT_TRUE(plan.moves_at(10));
  EXPECT_FALSE(plan.moves_at(15));
  EXPECT_TRUE(plan.moves_at(40));
  EXPECT_EQ(plan.pu_at(0, 0), 0U);
  EXPECT_EQ(plan.pu_at(1, 9), 1U);
  EXPECT_EQ(plan.pu_at(0, 10), 1U);
  EXPECT_EQ(plan.pu_at(1, 10), 2U);
  EXPECT_EQ(plan.pu_at(0, 30), 3U);
  EXPECT_EQ(plan.pu_at(1, 30), 0U) << "the schedule wraps around the cores";
  for (std::uint64_t step = 10; step < 200; step += 10) {
    EXPECT_NE(plan.pu_at(0, step), plan.pu_at(1, step)) << "step " << step;
    EXPECT_NE(plan.pu_at(0, step), plan.pu_at(0, step - 10)) << "thread 0 moved at step " << step;
  }
}

TEST(Placement, MigrateWithMoreThreadsThanCoresStillMovesEachThread) {
  const topology machine = topology::from_synthetic(kThisVm);
  const placement_plan plan = plan_placement(machine, placement::migrate, 4, 100);
  for (unsigned thread = 0; thread < 4; ++thread) {
    EXPECT_NE(plan.pu_at(thread, 0), plan.pu_at(thread, 100)) << "thread " << thread;
  }
}

TEST(Placement, MigrateOnOneCoreSaysItCannotMove) {
  const topology machine = topology::from_synthetic("package:1 core:1 pu:1");
  const placement_plan plan = plan_placement(machine, placement::migrate, 1, 10);
  EXPECT_NE(plan.note.find("cannot move"), std::string::npos) << plan.note;
}

TEST(Placement, NamesParseAndUnknownNamesListTheValidOnes) {
  EXPECT_EQ(lockstep::platform::placements().size(), 5U);
  for (const auto& description : lockstep::platform::placements()) {
    EXPECT_EQ(lockstep::platform::parse_placement(description.name), description.kind);
    EXPECT_FALSE(description.description.empty());
  }
  try {
    (void)lockstep::platform::parse_placement("spread");
    FAIL() << "an unknown name must throw";
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("'spread'"), std::string::npos) << message;
    EXPECT_NE(message.find("none, compact, compact_smt, scatter, migrate"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
}

TEST(Placement, TraitsSayWhoPinsForGoodAndWhoTakesSiblings) {
  using lockstep::platform::describe;
  EXPECT_FALSE(describe(placement::none).fixed_cpus);
  EXPECT_TRUE(describe(placement::compact).fixed_cpus);
  EXPECT_TRUE(describe(placement::compact_smt).fixed_cpus);
  EXPECT_TRUE(describe(placement::scatter).fixed_cpus);
  EXPECT_FALSE(describe(placement::migrate).fixed_cpus) << "it moves on purpose";
  for (const auto& description : lockstep::platform::placements())
    EXPECT_EQ(description.smt_siblings_first, description.kind == placement::compact_smt) << description.name;
}

TEST(Placement, BadArgumentsAreRejected) {
  const topology machine = topology::from_synthetic(kThisVm);
  EXPECT_THROW(plan_placement(machine, placement::compact, 0), std::invalid_argument);
  EXPECT_THROW(plan_placement(machine, placement::migrate, 2, 0), std::invalid_argument);
  EXPECT_THROW((void)plan_placement(machine, placement::compact, 2).pu_at(5), std::out_of_range);
}

TEST(Placement, DescribeIsOneLine) {
  const topology machine = topology::from_synthetic(kThisVm);
  EXPECT_EQ(plan_placement(machine, placement::compact, 4).describe(),
            "compact threads=4: 0->pu0 1->pu1 2->pu0 3->pu1 (wrapped, oversubscribed)");
}

TEST(Placement, OversubscriptionIsThreadsAgainstCpus) {
  EXPECT_FALSE(lockstep::platform::is_oversubscribed(2, 2));
  EXPECT_TRUE(lockstep::platform::is_oversubscribed(4, 2));
  EXPECT_GE(lockstep::platform::affinity_cpu_count(), 1U);
}

TEST(Placement, SyntheticPlansCannotPinThisMachine) {
  const topology machine = topology::from_synthetic(kTwoSockets);
  const placement_plan plan = plan_placement(machine, placement::compact, 1);
  EXPECT_THROW(lockstep::platform::pin_current_thread(plan, 0), lockstep::platform::placement_error);
}

TEST(Placement, PinningMovesAThreadToItsEntryOnThisMachine) {
  lockstep::testing::watchdog guard(std::chrono::seconds(10 * lockstep::testing::kSlowdown), "pinning test");
  const topology machine = topology::this_machine();
  const unsigned cores = static_cast<unsigned>(lockstep::platform::compact_core_order(machine).size());
  const placement_plan plan = plan_placement(machine, placement::migrate, 1, 1);
  std::vector<std::optional<unsigned>> seen;
  std::thread worker([&] {
    for (std::uint64_t step = 0; step < 2 * cores; ++step) {
      lockstep::platform::pin_current_thread(plan, 0, step);
      seen.push_back(lockstep::platform::current_cpu());
    }
    const placement_plan unpinned = plan_placement(machine, placement::none, 1);
    lockstep::platform::pin_current_thread(unpinned, 0);
  });
  worker.join();
  ASSERT_EQ(seen.size(), 2U * cores);
  for (std::uint64_t step = 0; step < seen.size(); ++step) {
    EXPECT_EQ(seen[step], plan.pu_at(0, step)) << "step " << step;
  }
}

// ---------------------------------------------------------------- NUMA nodes
// Shapes: "pack:2 numa:2 l3:2 core:4 pu:2" is 2 packages x 2 nodes x 2 L3 x 4
// cores x 2 PUs (64 PUs; node N holds PUs 16N .. 16N+15, L3 domain D PUs
// 8D .. 8D+7); the emulated 64-CPU machine is 2 packages of one node and two
// L3 dies of 8 cores with SMT; the AMD CCD shape one package of 2 L3 dies x 4
// cores x 2 threads.
constexpr const char* kNodesInPackages = "pack:2 numa:2 l3:2 core:4 pu:2";
constexpr const char* kEmulated64 = "pack:2 [numa] l3:2 core:8 pu:2";
constexpr const char* kAmdCcds = "pack:1 l3:2 core:4 pu:2";

const lockstep::platform::pu_info& pu_of(const topology& machine, const placement_plan& plan, unsigned thread) {
  return machine.pu(plan.entries.at(thread).pu.value());
}

TEST(PlacementNuma, CompactFillsAnL3ThenANodeThenAPackage) {
  const topology machine = topology::from_synthetic(kNodesInPackages);
  const placement_plan plan = plan_placement(machine, placement::compact, machine.core_count());
  for (unsigned thread = 0; thread < machine.core_count(); ++thread) {
    const auto& pu = pu_of(machine, plan, thread);
    EXPECT_EQ(pu.l3, static_cast<int>(thread / 4)) << "thread " << thread;
    EXPECT_EQ(pu.numa, static_cast<int>(thread / 8)) << "thread " << thread;
    EXPECT_EQ(pu.package, thread / 16) << "thread " << thread;
    EXPECT_EQ(plan.entries[thread].numa, pu.numa) << "the entry names its node";
  }
  EXPECT_EQ(plan_placement(machine, placement::compact, 8).numa_nodes, (std::vector<int>{0}))
      << "a team that fits one node stays on it";
  EXPECT_EQ(plan_placement(machine, placement::compact, 9).numa_nodes, (std::vector<int>{0, 1}));
}

TEST(PlacementNuma, ScatterAlternatesPackagesThenNodesThenL3) {
  const topology machine = topology::from_synthetic(kNodesInPackages);
  const placement_plan plan = plan_placement(machine, placement::scatter, 8);
  std::vector<unsigned> packages;
  std::vector<int> nodes;
  std::set<int> l3s;
  for (unsigned thread = 0; thread < 8; ++thread) {
    packages.push_back(pu_of(machine, plan, thread).package);
    nodes.push_back(pu_of(machine, plan, thread).numa);
    l3s.insert(pu_of(machine, plan, thread).l3);
  }
  EXPECT_EQ(packages, (std::vector<unsigned>{0, 1, 0, 1, 0, 1, 0, 1}));
  EXPECT_EQ(nodes, (std::vector<int>{0, 2, 1, 3, 0, 2, 1, 3})) << "each package's nodes in turn";
  EXPECT_EQ(l3s.size(), 8U) << "8 threads, 8 L3 domains";
  EXPECT_EQ(distinct_cores(plan_placement(machine, placement::scatter, 32)), 32U);
}

TEST(PlacementNuma, Emulated64CpuMachinePlans) {
  const topology machine = topology::from_synthetic(kEmulated64);
  ASSERT_EQ(machine.summary(), "packages=2 l3=4 cores=32 pus=64 numa=2");
  const placement_plan compact = plan_placement(machine, placement::compact, 16);
  EXPECT_EQ(compact.numa_nodes, (std::vector<int>{0})) << "16 threads fit node 0's 16 cores";
  EXPECT_EQ(distinct_cores(compact), 16U) << "no SMT sibling";
  EXPECT_EQ(pu_of(machine, compact, 7).l3, pu_of(machine, compact, 0).l3);
  EXPECT_NE(pu_of(machine, compact, 8).l3, pu_of(machine, compact, 0).l3) << "the first die filled, then the next";
  const placement_plan scatter = plan_placement(machine, placement::scatter, 16);
  for (unsigned thread = 1; thread < 16; ++thread)
    EXPECT_NE(pu_of(machine, scatter, thread).numa, pu_of(machine, scatter, thread - 1).numa) << thread;
  const placement_plan smt = plan_placement(machine, placement::compact_smt, 16);
  EXPECT_EQ(distinct_cores(smt), 8U) << "compact_smt: both siblings of 8 cores";
  EXPECT_EQ(machine.relation(smt.entries[0].pu.value(), smt.entries[1].pu.value()), pu_relation::smt_siblings);
  EXPECT_FALSE(smt.wrapped);
  EXPECT_EQ(smt.numa_nodes, (std::vector<int>{0}));
  for (placement kind : {placement::compact, placement::scatter}) {
    EXPECT_FALSE(plan_placement(machine, kind, 32).wrapped) << to_string(kind);
    EXPECT_TRUE(plan_placement(machine, kind, 33).wrapped) << to_string(kind);
  }
}

TEST(PlacementNuma, AmdCcdShape) {
  const topology machine = topology::from_synthetic(kAmdCcds);
  const placement_plan compact = plan_placement(machine, placement::compact, 5);
  for (unsigned thread = 0; thread < 4; ++thread) EXPECT_EQ(pu_of(machine, compact, thread).l3, 0) << thread;
  EXPECT_EQ(pu_of(machine, compact, 4).l3, 1) << "one CCD's L3 filled before the next";
  const placement_plan scatter = plan_placement(machine, placement::scatter, 2);
  EXPECT_EQ(machine.relation(scatter.entries[0].pu.value(), scatter.entries[1].pu.value()), pu_relation::different_l3);
  const placement_plan smt = plan_placement(machine, placement::compact_smt, 2);
  EXPECT_EQ(machine.relation(smt.entries[0].pu.value(), smt.entries[1].pu.value()), pu_relation::smt_siblings);
  EXPECT_EQ(pus_of(plan_placement(machine, placement::compact_smt, 8)), (std::vector<unsigned>{0, 1, 2, 3, 4, 5, 6, 7}));
}

TEST(PlacementNuma, TheMemoryNodeIsParticipantZerosAndDescribeNamesTheNodes) {
  const topology machine = topology::from_synthetic("pack:2 [numa] l3:1 core:2 pu:1");
  const placement_plan scatter = plan_placement(machine, placement::scatter, 2);
  EXPECT_EQ(scatter.memory_node, 0);
  EXPECT_EQ(scatter.describe(), "scatter threads=2: 0->pu0 1->pu2 on nodes 0,1");
  EXPECT_EQ(plan_placement(machine, placement::compact, 2).describe(), "compact threads=2: 0->pu0 1->pu1 on node 0");
  const placement_plan none = plan_placement(machine, placement::none, 2);
  EXPECT_EQ(none.memory_node, lockstep::platform::kNoObject) << "no pin: no node can be promised";
  EXPECT_EQ(none.numa_nodes, (std::vector<int>{0, 1})) << "none may run on the whole affinity set";
  topology second_node = machine;
  second_node.restrict_affinity({2, 3});
  EXPECT_EQ(plan_placement(second_node, placement::compact, 2).memory_node, 1);
}

// ---------------------------------------------------------------- SMT on purpose
TEST(PlacementSmt, CompactSmtFillsACoreBeforeTheNext) {
  const topology machine = topology::from_synthetic(kTwoL3Smt);  // 8 cores, 16 PUs
  const placement_plan plan = plan_placement(machine, placement::compact_smt, 4);
  EXPECT_EQ(pus_of(plan), (std::vector<unsigned>{0, 1, 2, 3}));
  EXPECT_FALSE(plan.wrapped) << "SMT siblings are what compact_smt asks for";
  EXPECT_TRUE(plan.note.empty()) << plan.note;
  const placement_plan full = plan_placement(machine, placement::compact_smt, 16);
  expect_distinct_pus(full);
  EXPECT_FALSE(full.wrapped);
  const placement_plan past = plan_placement(machine, placement::compact_smt, 17);
  EXPECT_TRUE(past.wrapped);
  EXPECT_TRUE(past.oversubscribed);
}

TEST(PlacementSmt, WithoutSmtCompactSmtIsCompact) {
  const topology machine = topology::from_synthetic("package:1 l3:2 core:4 pu:1");
  for (unsigned threads : {1U, 3U, 8U, 9U})
    EXPECT_EQ(pus_of(plan_placement(machine, placement::compact_smt, threads)),
              pus_of(plan_placement(machine, placement::compact, threads)))
        << threads;
}

TEST(PlacementSmt, OneThreadPerCorePlacementsTakeSiblingsOnlyWhenCoresRunOut) {
  const topology machine = topology::from_synthetic(kTwoSockets);  // 16 cores, 32 PUs
  for (placement kind : {placement::compact, placement::scatter, placement::migrate}) {
    for (unsigned threads = 1; threads <= 16; ++threads) {
      const placement_plan plan = plan_placement(machine, kind, threads);
      EXPECT_EQ(distinct_cores(plan), threads) << to_string(kind) << " " << threads;
      EXPECT_FALSE(plan.wrapped);
    }
    const placement_plan past = plan_placement(machine, kind, 20);
    EXPECT_TRUE(past.wrapped);
    for (unsigned thread = 16; thread < 20; ++thread)
      EXPECT_EQ(machine.relation(past.entries[thread].pu.value(), past.entries[thread - 16].pu.value()),
                pu_relation::smt_siblings)
          << "the second round takes the first round's siblings, in the same order";
  }
}

TEST(PlacementSmt, RoundsSkipCoresWithoutAnotherPu) {
  topology machine = topology::from_synthetic("package:1 core:3 pu:2");  // PUs 0-1, 2-3, 4-5
  machine.restrict_affinity({0, 1, 2, 4});  // core 0 has both PUs, cores 1 and 2 one each
  const placement_plan plan = plan_placement(machine, placement::compact, 5);
  EXPECT_EQ(pus_of(plan), (std::vector<unsigned>{0, 2, 4, 1, 0})) << "round two: core 0's sibling; then round one again";
  EXPECT_TRUE(plan.wrapped);
  EXPECT_TRUE(plan.oversubscribed);
}

// ---------------------------------------------------------------- CPU kinds
std::string fixture(const std::string& name) {
  return std::string(LOCKSTEP_SOURCE_DIR) + "/tests/fixtures/topology/" + name;
}

std::set<int> kinds_of(const placement_plan& plan) {
  std::set<int> kinds;
  for (const auto& entry : plan.entries) kinds.insert(entry.kind);
  return kinds;
}

TEST(PlacementKinds, CompactAndScatterNeverMixKindsUnlessTheTeamFitsNoKind) {
  const topology machine = topology::from_xml_file(fixture("hybrid-8p-8e.xml"));  // 8 P cores (SMT), 8 E cores
  const int performant = 1;  // IntelCore: hwloc's second kind
  for (placement kind : {placement::compact, placement::scatter, placement::migrate, placement::compact_smt}) {
    const unsigned one_kind_room = kind == placement::compact_smt ? 16U : 8U;
    for (unsigned threads = 1; threads <= machine.pu_count(); ++threads) {
      const placement_plan plan = plan_placement(machine, kind, threads);
      const std::set<int> kinds = kinds_of(plan);
      EXPECT_EQ(plan.mixed_kinds, kinds.size() > 1) << to_string(kind) << " " << threads;
      EXPECT_EQ(kinds.size() > 1, threads > one_kind_room) << to_string(kind) << " " << threads;
      if (threads <= one_kind_room) {
        EXPECT_EQ(kinds, std::set<int>{performant}) << "the most performant kind first: " << threads;
        EXPECT_EQ(plan.kinds, std::vector<std::string>{"IntelCore"});
        EXPECT_EQ(plan.note.find("mixed"), std::string::npos) << plan.note;
      } else {
        EXPECT_NE(plan.note.find("mixed kinds"), std::string::npos) << "the plan says so: " << plan.note;
        EXPECT_EQ(plan.kinds, (std::vector<std::string>{"IntelCore", "IntelAtom"}));
        for (unsigned thread = 0; thread < one_kind_room; ++thread)
          EXPECT_EQ(plan.entries[thread].kind, performant) << "the P cores fill first";
      }
    }
  }
}

TEST(PlacementKinds, MixingComesBeforeSiblingsAndSiblingsAfterEveryCore) {
  const topology machine = topology::from_xml_file(fixture("hybrid-8p-8e.xml"));
  const placement_plan nine = plan_placement(machine, placement::compact, 9);
  EXPECT_EQ(distinct_cores(nine), 9U) << "nine cores of two kinds rather than a P core's sibling";
  EXPECT_FALSE(nine.wrapped);
  EXPECT_EQ(nine.entries[8].pu, 16U) << "the first E core";
  EXPECT_EQ(nine.describe(),
            "compact threads=9: 0->pu0 1->pu2 2->pu4 3->pu6 4->pu8 5->pu10 6->pu12 7->pu14 8->pu16 on IntelCore and "
            "IntelAtom (mixed kinds)");
  const placement_plan seventeen = plan_placement(machine, placement::compact, 17);
  EXPECT_TRUE(seventeen.wrapped);
  EXPECT_EQ(machine.relation(seventeen.entries[16].pu.value(), 0), pu_relation::smt_siblings)
      << "past every core, the P cores' siblings";
  EXPECT_EQ(plan_placement(machine, placement::compact, 4).describe(),
            "compact threads=4: 0->pu0 1->pu2 2->pu4 3->pu6 on IntelCore");
}

TEST(PlacementKinds, ATeamThatFitsOnlyTheSmallerKindStaysOnIt) {
  const topology machine = topology::from_xml_file(fixture("hybrid-4p-8e.xml"));  // 4 P cores (SMT), 8 E cores
  const placement_plan six = plan_placement(machine, placement::compact, 6);
  EXPECT_EQ(six.kinds, std::vector<std::string>{"IntelAtom"}) << "6 threads fit 8 E cores, not 4 P cores";
  EXPECT_FALSE(six.mixed_kinds);
  const placement_plan four = plan_placement(machine, placement::compact, 4);
  EXPECT_EQ(four.kinds, std::vector<std::string>{"IntelCore"});
  const placement_plan smt = plan_placement(machine, placement::compact_smt, 6);
  EXPECT_EQ(smt.kinds, std::vector<std::string>{"IntelCore"}) << "compact_smt: 6 threads fit 8 P PUs";
  EXPECT_TRUE(plan_placement(machine, placement::compact, 9).mixed_kinds);
}

TEST(PlacementKinds, AnAffinitySetOfOneKindChoosesTheKind) {
  topology machine = topology::from_xml_file(fixture("hybrid-8p-8e.xml"));
  machine.restrict_affinity({16, 17, 18, 19, 20, 21, 22, 23});  // taskset -c 16-23: the E cores
  const placement_plan plan = plan_placement(machine, placement::compact, 4);
  EXPECT_EQ(pus_of(plan), (std::vector<unsigned>{16, 17, 18, 19}));
  EXPECT_EQ(plan.kinds, std::vector<std::string>{"IntelAtom"});
  EXPECT_FALSE(plan.mixed_kinds);
}

// ---------------------------------------------------------------- where participants ran
TEST(ParticipantCpus, OnPlanOnlyWhenEveryReadingIsThePlannedCpu) {
  using lockstep::platform::off_plan;
  using lockstep::platform::team_cpus;
  const topology machine = topology::from_synthetic(kTwoL3Smt);
  const placement_plan plan = plan_placement(machine, placement::compact, 2);  // PUs 0 and 2
  EXPECT_EQ(off_plan(plan, team_cpus{{0, 0}, {2, 2}}), "");
  EXPECT_EQ(off_plan(plan, team_cpus{{0, 0}, {2, 3}}), "participant 1, planned on CPU 2, read CPU 3 at the end");
  EXPECT_EQ(off_plan(plan, team_cpus{{0, 0}, {std::nullopt, 2}}),
            "participant 1, planned on CPU 2, read no CPU at the start");
  EXPECT_THROW((void)off_plan(plan, team_cpus{{0, 0}}), std::invalid_argument);
  EXPECT_EQ(lockstep::platform::team_cpus_json(team_cpus{{0, 0}, {2, std::nullopt}}).dump(), "[[0,0],[2,null]]");

  topology restricted = machine;
  restricted.restrict_affinity({4, 5});
  const placement_plan none = plan_placement(restricted, placement::none, 2);
  EXPECT_EQ(off_plan(none, team_cpus{{4, 5}, {5, 5}}), "");
  EXPECT_EQ(off_plan(none, team_cpus{{4, 5}, {5, 6}}),
            "participant 1, free to run on its affinity set, read CPU 6 at the end");

  const placement_plan migrate = plan_placement(machine, placement::migrate, 1, 10);
  EXPECT_EQ(off_plan(migrate, team_cpus{{migrate.pu_at(0, 10), migrate.pu_at(0, 25)}}, 10, 25), "");
  EXPECT_NE(off_plan(migrate, team_cpus{{migrate.pu_at(0, 0), migrate.pu_at(0, 0)}}, 10, 25), "");
}

TEST(ParticipantCpus, EveryParticipantReadsItsPlannedCpuOnThisMachine) {
  lockstep::testing::watchdog guard(std::chrono::seconds(10 * lockstep::testing::kSlowdown), "participant CPUs");
  const topology machine = topology::this_machine();
  const placement_plan plan = plan_placement(machine, placement::compact, 2);
  lockstep::platform::team_cpus seen(2);
  for (unsigned thread = 0; thread < 2; ++thread) {
    std::thread participant([&, thread] {
      lockstep::platform::pin_current_thread(plan, thread);
      seen[thread].start = lockstep::platform::current_cpu();
      seen[thread].end = lockstep::platform::current_cpu();
    });
    participant.join();
  }
  EXPECT_EQ(lockstep::platform::off_plan(plan, seen), "");
}

// ---------------------------------------------------------------- first touch
TEST(FirstTouch, TheScopePinsToParticipantZeroAndGivesTheCpusBack) {
  lockstep::testing::watchdog guard(std::chrono::seconds(10 * lockstep::testing::kSlowdown), "first touch scope");
  const topology machine = topology::this_machine();
  const placement_plan plan = plan_placement(machine, placement::compact, 2);
  std::thread builder([&] {
    const std::vector<unsigned> before = lockstep::platform::current_thread_affinity();
    {
      lockstep::platform::first_touch_scope scope(plan);
      EXPECT_EQ(scope.cpu(), plan.entries[0].pu);
      EXPECT_EQ(lockstep::platform::current_cpu(), plan.entries[0].pu);
      EXPECT_EQ(lockstep::platform::current_thread_affinity(), std::vector<unsigned>{plan.entries[0].pu.value()});
      scope.end();
      EXPECT_EQ(lockstep::platform::current_thread_affinity(), before) << "end() gives the CPUs back";
    }
    EXPECT_EQ(lockstep::platform::current_thread_affinity(), before);
    const lockstep::platform::first_touch_scope unpinned(plan_placement(machine, placement::none, 2));
    EXPECT_FALSE(unpinned.cpu().has_value());
    const lockstep::platform::first_touch_scope other(plan_placement(topology::from_synthetic(kTwoSockets),
                                                                     placement::compact, 2));
    EXPECT_FALSE(other.cpu().has_value()) << "a plan of another machine pins nothing";
  });
  builder.join();
}

TEST(FirstTouch, TouchedPagesReadTheNodeOfTheCpuThatTouchedThem) {
  const topology machine = topology::this_machine();
  const std::size_t page = lockstep::platform::page_bytes();
  void* raw = std::aligned_alloc(page, 4 * page);
  ASSERT_NE(raw, nullptr);
  const std::unique_ptr<void, decltype(&std::free)> buffer(raw, &std::free);
  auto* bytes = static_cast<unsigned char*>(raw);
  std::vector<int> nodes;
  std::thread toucher([&] {
    lockstep::platform::pin_current_thread_to_pu(machine.affinity().front());
    for (std::size_t at = 0; at < 4 * page; at += page) bytes[at] = 1;
    nodes = lockstep::platform::memory_nodes_of(raw, 4 * page);
  });
  toucher.join();
  if (nodes.empty()) GTEST_SKIP() << "this kernel does not say where pages are (move_pages refused)";
  ASSERT_EQ(nodes.size(), 4U);
  // Default policy: a page lives on the node of the CPU that touched it
  // first, unless that node had no room (then another node).
  const int home = machine.pu(machine.affinity().front()).numa;
  for (int node : nodes) EXPECT_TRUE(node == home || machine.numa_nodes() > 1) << node;
  EXPECT_EQ(lockstep::platform::memory_nodes_of(raw, 1).size(), 1U) << "one byte: one page";
  EXPECT_TRUE(lockstep::platform::memory_nodes_of(nullptr, 8).empty());
}

}  // namespace
