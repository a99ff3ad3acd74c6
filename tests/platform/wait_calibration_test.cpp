// The waiting primitives' calibration (platform/spin_budget.hpp,
// platform/wait_calibration.hpp): the poll's cost measured on a fake clock,
// the conversion of a time into polls at its edges, and the futex round
// trip's measurement and its fallback. Nothing here asserts a time this
// machine took: only what the measurement reports and how it says it.
#include "platform/spin_budget.hpp"
#include "platform/wait_calibration.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

namespace {

namespace platform = lockstep::platform;

// A clock that only the fake hint moves: each hint costs `hint_ns`.
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

TEST(WaitCalibration, ThePollCostIsWhatTheHintCosts) {
  for (const double cost : {0.4, 13.2, 40.0, 140.0}) {
    fake_core core{0.0, cost};
    const double measured = platform::measure_poll_ns(core.clock(), core.hint());
    EXPECT_NEAR(measured, cost, cost * 0.01) << "a hint of " << cost << " ns";
  }
}

TEST(WaitCalibration, PollsLastingATime) {
  EXPECT_EQ(platform::polls_lasting(50'000, 15.0), 3334U);   // rounded up
  EXPECT_EQ(platform::polls_lasting(50'000, 0.4), 125'000U);
  EXPECT_EQ(platform::polls_lasting(0, 15.0), 0U);           // no budget, no poll
  EXPECT_EQ(platform::polls_lasting(1, 40.0), 1U);           // a budget above 0 polls once
  // A poll cost below the fastest credible one (or not a number) counts as that one.
  EXPECT_EQ(platform::polls_lasting(1'000, 0.0), 10'000U);
  EXPECT_EQ(platform::polls_lasting(1'000, std::nan("")), 10'000U);
  EXPECT_EQ(platform::polls_lasting(1e300, 1.0), std::numeric_limits<std::uint32_t>::max());
}

TEST(WaitCalibration, ASpinMeantToCoverARoundTripIsCapped) {
  platform::wait_calibration machine;
  machine.poll_ns = 10.0;
  machine.futex.ns = 20'000;
  machine.futex.p90_ns = 40'000;  // the spin outlasts nine wake-ups in ten, not one in two
  EXPECT_EQ(machine.round_trip_spin_ns(), 40'000);
  EXPECT_EQ(machine.round_trip_spin_polls(), 4'000U);
  machine.futex.p90_ns = 30'000'000;  // a loaded machine's scheduling delay, not a futex's price
  EXPECT_EQ(machine.round_trip_spin_ns(), platform::kLongestRoundTripSpinNs);
}

// No time to measure in: the assumed figure, and the reason in words.
TEST(WaitCalibration, AFutexRoundTripWithNoTimeFallsBackAndSaysSo) {
  const platform::futex_round_trip trip = platform::measure_futex_round_trip(0);
  EXPECT_FALSE(trip.measured);
  EXPECT_EQ(trip.ns, platform::kAssumedFutexRoundTripNs);
  EXPECT_EQ(trip.p90_ns, platform::kAssumedFutexRoundTripNs);
  EXPECT_EQ(trip.hand_overs, 0U);
  EXPECT_NE(trip.how.find("not measured"), std::string::npos) << trip.how;
  EXPECT_NE(trip.how.find("assumed"), std::string::npos) << trip.how;
}

// On this machine (two CPUs shared with whatever else runs): measured, or
// the fallback with its reason; either way a figure and words for it.
TEST(WaitCalibration, AFutexRoundTripIsMeasuredOrSaysWhyNot) {
  const platform::futex_round_trip trip = platform::measure_futex_round_trip();
  EXPECT_GT(trip.ns, 0.0);
  if (trip.measured) {
    EXPECT_GE(trip.hand_overs, platform::kFutexMinimumHandOvers);
    EXPECT_LE(trip.hand_overs, static_cast<std::size_t>(platform::kFutexRounds));
    EXPECT_GE(trip.p90_ns, trip.ns);
    EXPECT_NE(trip.how.find("median and 90th percentile of"), std::string::npos) << trip.how;
  } else {
    EXPECT_EQ(trip.ns, platform::kAssumedFutexRoundTripNs);
    EXPECT_NE(trip.how.find("not measured"), std::string::npos) << trip.how;
  }
}

TEST(WaitCalibration, TheProcessMeasuresOnce) {
  const platform::wait_calibration& first = platform::machine_wait_calibration();
  const platform::wait_calibration& again = platform::machine_wait_calibration();
  EXPECT_EQ(&first, &again);
  EXPECT_EQ(first.hint, platform::kSpinHintName);
  EXPECT_GE(first.poll_ns, platform::kFastestPollNs);
  EXPECT_GE(first.round_trip_spin_polls(), 1U);
  EXPECT_FALSE(first.futex.how.empty());
}

}  // namespace
