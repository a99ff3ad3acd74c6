// The measured-path clock: monotonic, nanoseconds, round-trips to timespec.
#include "platform/clock.hpp"

#include <gtest/gtest.h>

namespace {

TEST(Clock, NeverGoesBackwards) {
  std::int64_t previous = lockstep::platform::now_ns();
  for (int reading = 0; reading < 10000; ++reading) {
    const std::int64_t now = lockstep::platform::now_ns();
    ASSERT_GE(now, previous);
    previous = now;
  }
}

TEST(Clock, TimespecRoundTrip) {
  const timespec when = lockstep::platform::to_timespec(12'345'678'901);
  EXPECT_EQ(when.tv_sec, 12);
  EXPECT_EQ(when.tv_nsec, 345'678'901);
}

TEST(Clock, ReadCostAndSourceAreReported) {
  EXPECT_GT(lockstep::platform::clock_read_cost_ns(101), 0.0);
  EXPECT_FALSE(lockstep::platform::clocksource().empty());
}

}  // namespace
