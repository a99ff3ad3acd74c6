// Placement plans against synthetic topologies, and pinning on this machine.
#include "platform/placement.hpp"

#include <chrono>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

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
  EXPECT_EQ(lockstep::platform::placements().size(), 4U);
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
    EXPECT_NE(message.find("none, compact, scatter, migrate"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
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

}  // namespace
