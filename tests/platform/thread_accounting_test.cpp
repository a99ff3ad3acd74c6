// Per-thread context-switch and migration accounting on this machine, and the
// Figure 5 table's arithmetic.
#include "platform/thread_accounting.hpp"

#include <sched.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "tests/support/watchdog.hpp"

namespace {

using lockstep::platform::figure5_table;
using lockstep::platform::thread_counters;

TEST(ThreadAccounting, ASleepingThreadHasVoluntarySwitches) {
  lockstep::testing::watchdog guard(std::chrono::seconds(10 * lockstep::testing::kSlowdown), "sleeping thread");
  thread_counters delta;
  std::thread sleeper([&] {
    const thread_counters before = lockstep::platform::snapshot_current_thread();
    for (int nap = 0; nap < 10; ++nap) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    delta = lockstep::platform::snapshot_current_thread() - before;
  });
  sleeper.join();
  EXPECT_GE(delta.voluntary_switches, 10) << "each sleep blocks the thread once";
}

TEST(ThreadAccounting, AnotherThreadIsReadThroughProc) {
  lockstep::testing::watchdog guard(std::chrono::seconds(10 * lockstep::testing::kSlowdown), "proc reader");
  std::atomic<pid_t> id{0};
  std::atomic<bool> done{false};
  std::thread sleeper([&] {
    id.store(lockstep::platform::current_thread_id());
    while (!done.load()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  });
  while (id.load() == 0) std::this_thread::yield();
  const thread_counters first = lockstep::platform::snapshot_thread(id.load());
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const thread_counters second = lockstep::platform::snapshot_thread(id.load());
  done.store(true);
  sleeper.join();
  EXPECT_GT((second - first).voluntary_switches, 0);
  EXPECT_THROW(lockstep::platform::snapshot_thread(999999999), std::runtime_error);
}

TEST(ThreadAccounting, MigrationsAreReadWhenTheKernelShowsThem) {
  const bool readable = std::ifstream("/proc/self/sched").good();
  const thread_counters now = lockstep::platform::snapshot_current_thread();
  EXPECT_EQ(lockstep::platform::migrations_available(), now.migrations.has_value());
  EXPECT_EQ(now.migrations.has_value(), readable) << "unreadable must be unavailable, not 0";
}

// A thread that the kernel must move (its affinity no longer holds the CPU it
// runs on) counts a migration: an event, not a time.
TEST(ThreadAccounting, AThreadMovedToAnotherCpuCountsAMigration) {
  if (!lockstep::platform::migrations_available()) GTEST_SKIP() << "se.nr_migrations is not readable here";
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  ASSERT_EQ(sched_getaffinity(0, sizeof(allowed), &allowed), 0);
  if (CPU_COUNT(&allowed) < 2) GTEST_SKIP() << "needs two CPUs to move between";
  lockstep::testing::watchdog guard(std::chrono::seconds(10 * lockstep::testing::kSlowdown), "migrating thread");
  thread_counters delta;
  std::optional<int> refused;
  std::thread mover([&] {
    const thread_counters before = lockstep::platform::snapshot_current_thread();
    // Each move goes to an allowed CPU other than the one the thread is on.
    for (int move = 0; move < 3 && !refused; ++move) {
      const int here = sched_getcpu();
      cpu_set_t elsewhere;
      CPU_ZERO(&elsewhere);
      for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu)
        if (CPU_ISSET(cpu, &allowed) && cpu != here) {
          CPU_SET(cpu, &elsewhere);
          break;
        }
      if (sched_setaffinity(0, sizeof(elsewhere), &elsewhere) != 0) refused = errno;
    }
    delta = lockstep::platform::snapshot_current_thread() - before;
  });
  mover.join();
  ASSERT_FALSE(refused) << "sched_setaffinity: " << std::strerror(*refused);
  ASSERT_TRUE(delta.migrations.has_value());
  EXPECT_GE(*delta.migrations, 3) << "three moves to another CPU";
}

TEST(ThreadAccounting, DifferencesPropagateUnavailable) {
  thread_counters known{10, 5, 3};
  thread_counters unknown{20, 6, std::nullopt};
  const thread_counters delta = unknown - known;
  EXPECT_EQ(delta.voluntary_switches, 10);
  EXPECT_EQ(delta.involuntary_switches, 1);
  EXPECT_FALSE(delta.migrations.has_value());
  EXPECT_FALSE(lockstep::platform::cross_core_switch_percent(delta).has_value());
}

TEST(ThreadAccounting, CrossCoreShareIsMigrationsOverSwitchesCapped) {
  EXPECT_DOUBLE_EQ(*lockstep::platform::cross_core_switch_percent({40, 7, 23}), 100.0 * 23 / 47);
  EXPECT_DOUBLE_EQ(*lockstep::platform::cross_core_switch_percent({0, 0, 0}), 0.0);
  EXPECT_DOUBLE_EQ(*lockstep::platform::cross_core_switch_percent({1, 1, 5}), 100.0);
}

TEST(Figure5Table, ThePapersRowsSumAndThePercentComesFromTheSums) {
  figure5_table table;
  table.add("main", "main", thread_counters{40, 7, 23});  // the paper: 23 / 47 = 48.94 %
  table.add("worker 0", "worker", thread_counters{30000, 691, 0});
  table.add("worker 1", "worker", thread_counters{29000, 225, 0});
  ASSERT_EQ(table.rows().size(), 3U);
  EXPECT_EQ(table.rows()[0].cross_core_csw, 23);
  EXPECT_EQ(table.rows()[0].total_csw, 47);
  EXPECT_NEAR(*table.rows()[0].pct, 48.94, 0.005);
  EXPECT_DOUBLE_EQ(*table.rows()[1].pct, 0.0);
  const auto totals = table.totals();
  EXPECT_EQ(totals.thread, "total");
  EXPECT_EQ(totals.total_csw, 47 + 30691 + 29225);
  EXPECT_EQ(totals.cross_core_csw, 23);
  EXPECT_DOUBLE_EQ(*totals.pct, 100.0 * 23 / (47 + 30691 + 29225));
  const std::string text = table.render();
  EXPECT_NE(text.find("48.94 %"), std::string::npos) << text;
  EXPECT_NE(text.find("total"), std::string::npos) << text;
}

TEST(Figure5Table, OneUnavailableRowMakesTheSumUnavailable) {
  figure5_table table;
  table.add("main", "main", thread_counters{4, 1, 1});
  table.add("worker 0", "worker", thread_counters{4, 1, std::nullopt});
  EXPECT_FALSE(table.totals().cross_core_csw.has_value());
  EXPECT_FALSE(table.totals().pct.has_value());
  EXPECT_EQ(table.totals().total_csw, 10);
  EXPECT_NE(table.render().find("unavailable"), std::string::npos);
}

}  // namespace
