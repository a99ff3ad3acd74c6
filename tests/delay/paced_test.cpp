// The paced engine on a stand-in step: it records one wake-up per participant
// per period and one completion per period, counts deadline misses against
// the period, and its Figure 5 table has one row per thread whose sums are
// the totals. No latency is asserted.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>

#include "bench/probes/paced.hpp"
#include "sync/team.hpp"
#include "tests/support/watchdog.hpp"

namespace {

namespace probes = lockstep::bench::probes;

TEST(PacedRun, RecordsEveryPeriodAndThread) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced run");
  constexpr unsigned kParticipants = 3;
  probes::paced_settings settings;
  settings.period_ns = 2'000'000;
  settings.periods = 10;
  settings.lead_ns = 1'000'000;
  lockstep::sync::std_thread_team team(kParticipants);
  std::atomic<int> prepared{0};
  std::atomic<int> steps{0};
  const auto run = probes::run_paced(
      team, kParticipants, settings, [&](unsigned) { prepared.fetch_add(1); },
      [&](unsigned, std::uint64_t) { steps.fetch_add(1); });
  EXPECT_EQ(prepared.load(), 3);
  EXPECT_EQ(steps.load(), 30);
  EXPECT_EQ(run.wakeup_ns.size(), 30u);
  EXPECT_EQ(run.completion_ns.size(), 10u);
  EXPECT_LE(run.deadline_misses, 10u);
  EXPECT_TRUE(run.errors.empty());
  for (double wake : run.wakeup_ns) EXPECT_GE(wake, 0.0);  // an absolute sleep never returns early
  ASSERT_EQ(run.figure5.rows().size(), 4u);
  EXPECT_EQ(run.figure5.rows()[0].thread, "main");
  EXPECT_EQ(run.figure5.rows()[1].thread, "worker 0");
  EXPECT_EQ(run.figure5.rows()[3].role, "worker");
}

TEST(PacedRun, EveryOverrunIsADeadlineMiss) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced overrun");
  probes::paced_settings settings;
  settings.period_ns = 100'000;  // 0.1 ms
  settings.periods = 5;
  settings.lead_ns = 1'000'000;
  lockstep::sync::std_thread_team team(1);
  // A step that sleeps 0.5 ms cannot finish inside a 0.1 ms period.
  const auto run = probes::run_paced(
      team, 1, settings, [](unsigned) {},
      [](unsigned, std::uint64_t) { std::this_thread::sleep_for(std::chrono::microseconds(500)); });
  EXPECT_EQ(run.deadline_misses, 5u);
  for (double completion : run.completion_ns) EXPECT_GT(completion, 100'000.0);
}

TEST(PacedRun, AFailedPinIsReportedAndTheRunCompletes) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced pin failure");
  probes::paced_settings settings;
  settings.period_ns = 1'000'000;
  settings.periods = 3;
  settings.lead_ns = 1'000'000;
  lockstep::sync::std_thread_team team(2);
  const auto run = probes::run_paced(
      team, 2, settings,
      [](unsigned id) {
        if (id == 1) throw std::runtime_error("cannot pin");
      },
      [](unsigned, std::uint64_t) {});
  ASSERT_EQ(run.errors.size(), 1u);
  EXPECT_EQ(run.errors[0], "worker 1: cannot pin");
  EXPECT_EQ(run.completion_ns.size(), 3u);
}

TEST(Figure5Table, TotalsAreTheSumsOfTheRows) {
  lockstep::platform::figure5_table table;
  lockstep::platform::thread_counters main_thread{1, 1, 1};
  lockstep::platform::thread_counters worker_a{100, 20, 6};
  lockstep::platform::thread_counters worker_b{30, 0, 0};
  table.add("main", "main", main_thread);
  table.add("worker 0", "worker", worker_a);
  table.add("worker 1", "worker", worker_b);
  const auto totals = table.totals();
  EXPECT_EQ(totals.total_csw, 2 + 120 + 30);
  ASSERT_TRUE(totals.cross_core_csw.has_value());
  EXPECT_EQ(*totals.cross_core_csw, 1 + 6 + 0);
  ASSERT_TRUE(totals.pct.has_value());
  EXPECT_DOUBLE_EQ(*totals.pct, 100.0 * 7.0 / 152.0);  // from the sums, not the mean of the rows
  EXPECT_DOUBLE_EQ(*table.rows()[1].pct, 5.0);
}

}  // namespace
