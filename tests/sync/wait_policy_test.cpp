// Spin budgets are times (sync/wait_policy.hpp, sync/futex_spin.hpp,
// platform/spin_budget.hpp): on a fake core whose clock only the fake spin
// hint moves, a budget calibrated at "start-up" lasts its time whether one
// hint costs 0.4 ns (an AArch64 YIELD on Neoverse N1) or 40 ns (a Skylake
// PAUSE), where a count fixed in the source lasted 100 times longer on one
// than on the other. The waits run the primitives' own loop (wait_until and
// spin_until) with the fake hint; nothing here reads a real clock.
#include "sync/futex_spin.hpp"
#include "sync/wait_policy.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <thread>
#include <vector>

#include "platform/spin_budget.hpp"
#include "platform/wait_calibration.hpp"
#include "tests/support/watchdog.hpp"

namespace {

namespace platform = lockstep::platform;
namespace sync = lockstep::sync;

constexpr double kRoundTripNs = 50'000;  // the futex round trip a spin covers on the fake machine (its p90)

// A core whose clock only its spin hint moves: each hint costs `hint_ns`.
struct fake_core {
  double now = 0.0;
  double hint_ns;
  auto clock() {
    return [this] { return static_cast<std::int64_t>(std::floor(now)); };
  }
  auto hint() {
    return [this] { now += hint_ns; };
  }
};

// What start-up measures on that core: the poll's cost on its clock.
platform::wait_calibration calibrated(fake_core& core) {
  platform::wait_calibration machine;
  machine.poll_ns = platform::measure_poll_ns(core.clock(), core.hint());
  machine.futex.ns = kRoundTripNs / 2;
  machine.futex.p90_ns = kRoundTripNs;  // what the spin covers
  machine.futex.measured = true;
  return machine;
}

// How long a wait that never succeeds spins before its block step, on the fake clock.
double spin_time(fake_core& core, const sync::wait_budget& budget, sync::sync_counters& counters) {
  const double start = core.now;
  double blocked_at = -1.0;
  sync::wait_until([] { return false; }, budget, counters, [&] { blocked_at = core.now; }, core.hint());
  return blocked_at - start;
}

TEST(WaitPolicy, ADedicatedSpinLastsOneFutexRoundTripWhateverAHintCosts) {
  for (const double hint_ns : {0.4, 40.0}) {
    SCOPED_TRACE(testing::Message() << "one hint costs " << hint_ns << " ns");
    fake_core core{0.0, hint_ns};
    const sync::wait_budgets budgets = sync::channel_budgets(calibrated(core));
    sync::sync_counters counters;
    EXPECT_NEAR(spin_time(core, budgets.dedicated, counters), kRoundTripNs, kRoundTripNs * 0.01);
    EXPECT_EQ(counters.spins_exhausted, 1U);
    EXPECT_EQ(counters.yields, 0U);
  }
}

// What the budgets were before: 50 us / 15 ns = 3333 pauses, right on the
// core they were tuned on and 1.3 us on a 0.4 ns hint (the participants then
// fall asleep in turn: the cascade wait_policy.hpp describes).
TEST(WaitPolicy, ACountFixedInTheSourceLastedWhatTheHintCost) {
  const sync::wait_budget fixed{3333, 0};
  sync::sync_counters counters;
  fake_core yield_like{0.0, 0.4};
  fake_core pause_like{0.0, 15.0};
  EXPECT_LT(spin_time(yield_like, fixed, counters), 1'400.0);
  EXPECT_NEAR(spin_time(pause_like, fixed, counters), kRoundTripNs, kRoundTripNs * 0.01);
}

TEST(WaitPolicy, FutexSpinsBudgetsAreTimesToo) {
  for (const double hint_ns : {0.4, 40.0}) {
    SCOPED_TRACE(testing::Message() << "one hint costs " << hint_ns << " ns");
    fake_core core{0.0, hint_ns};
    const sync::wait_budgets budgets = sync::futex_spin_budgets(calibrated(core));
    // futex_spin's spin is spin_until, as here, with its budget's polls.
    const auto spun = [&](std::uint32_t polls) {
      const double start = core.now;
      EXPECT_FALSE(platform::spin_until([] { return false; }, polls, core.hint()));
      return core.now - start;
    };
    EXPECT_NEAR(spun(budgets.dedicated.spins), kRoundTripNs, kRoundTripNs * 0.01);
    // Oversubscribed: a short spin of its own time, then the yields.
    EXPECT_NEAR(spun(budgets.oversubscribed.spins), sync::kOversubscribedSpinNs,
                sync::kOversubscribedSpinNs * 0.01 + hint_ns);
    EXPECT_EQ(budgets.oversubscribed.yields, sync::kOversubscribedYields);
  }
}

// The census hands out the dedicated budget from enrolment, the team's
// regime's once every participant has enrolled: here far more participants
// than this machine's CPUs (every enrolment from this thread), so
// oversubscribed.
TEST(WaitPolicy, TheCensusHandsOutTheBudgetOfItsRegime) {
  constexpr unsigned kParticipants = 4096;
  const sync::wait_budgets budgets{{1234, 0}, {0, 56}};
  sync::regime_census census(kParticipants, budgets);
  std::vector<sync::regime_view> views(kParticipants);
  EXPECT_EQ(census.budget(views[0]).spins, 1234U);  // not every participant has enrolled
  for (auto& view : views) census.enrol(view);
  const sync::wait_budget& settled = census.budget(views[0]);
  EXPECT_EQ(views[0].regime, sync::wait_regime::oversubscribed);
  EXPECT_EQ(settled.spins, 0U);
  EXPECT_EQ(settled.yields, 56U);
}

// A futex_spin given a budget of no spin and no yield sleeps at every wait
// and still releases every phase.
TEST(WaitPolicy, AFutexSpinWithNoSpinBudgetStillCompletesEveryPhase) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown),
                                    "futex_spin with no spin budget did not finish its phases");
  constexpr unsigned kParticipants = 2;
  constexpr int kPhases = 200;
  sync::futex_spin barrier(kParticipants, sync::wait_budgets{{0, 0}, {0, 0}});
  std::vector<sync::participant> selves(kParticipants);
  std::vector<std::thread> threads;
  for (unsigned id = 0; id < kParticipants; ++id) {
    selves[id].id = id;
    threads.emplace_back([&, id] {
      for (int phase = 0; phase < kPhases; ++phase) barrier.arrive_and_wait(selves[id]);
    });
  }
  for (auto& thread : threads) thread.join();
  std::uint64_t exhausted = 0;
  for (const auto& self : selves) exhausted += self.counters.spins_exhausted;
  EXPECT_GT(exhausted, 0U);  // every non-last arriver ran out of its (empty) budget
}

}  // namespace
