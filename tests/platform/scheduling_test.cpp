// SCHED_FIFO and mlockall: the failure messages for every errno path, and a
// real FIFO attempt that must either work or fail with that message.
#include "platform/scheduling.hpp"

#include <cerrno>
#include <chrono>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "tests/support/watchdog.hpp"

namespace {

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(Scheduling, FifoPermissionMessageSaysWhatIsMissingAndHowToRunWithout) {
  const std::string message = lockstep::platform::describe_fifo_failure(EPERM, 50);
  EXPECT_TRUE(contains(message, "SCHED_FIFO priority 50")) << message;
  EXPECT_TRUE(contains(message, "EPERM")) << message;
  EXPECT_TRUE(contains(message, "CAP_SYS_NICE")) << message;
  EXPECT_TRUE(contains(message, "RLIMIT_RTPRIO")) << message;
  EXPECT_TRUE(contains(message, "ulimit -r 50")) << message;
  EXPECT_TRUE(contains(message, "without --fifo")) << message;
  EXPECT_FALSE(contains(message, "\n")) << "one line";
}

TEST(Scheduling, FifoRangeMessageGivesTheRange) {
  const std::string message = lockstep::platform::describe_fifo_failure(EINVAL, 500);
  EXPECT_TRUE(contains(message, "1..99")) << message;
  EXPECT_TRUE(contains(message, "without --fifo")) << message;
}

TEST(Scheduling, OutOfRangePriorityThrowsEinval) {
  try {
    lockstep::platform::set_current_thread_fifo(1000);
    FAIL() << "priority 1000 must be refused";
  } catch (const lockstep::platform::scheduling_error& error) {
    EXPECT_EQ(error.error_number(), EINVAL);
    EXPECT_TRUE(contains(error.what(), "1..99")) << error.what();
  }
}

TEST(Scheduling, FifoEitherWorksOrSaysWhy) {
  lockstep::testing::watchdog guard(std::chrono::seconds(10 * lockstep::testing::kSlowdown), "fifo attempt");
  std::string outcome;
  std::thread attempt([&] {
    try {
      lockstep::platform::set_current_thread_fifo(1);
      outcome = lockstep::platform::current_thread_policy();
      lockstep::platform::set_current_thread_normal();
    } catch (const lockstep::platform::scheduling_error& error) {
      outcome = error.what();
      EXPECT_EQ(error.error_number(), EPERM);
    }
  });
  attempt.join();
  EXPECT_TRUE(outcome == "SCHED_FIFO 1" || contains(outcome, "without --fifo")) << outcome;
}

TEST(Scheduling, MlockMessagesNameTheLimit) {
  const std::string permission = lockstep::platform::describe_mlock_failure(EPERM);
  EXPECT_TRUE(contains(permission, "CAP_IPC_LOCK")) << permission;
  EXPECT_TRUE(contains(permission, "without --mlock")) << permission;
  const std::string memory = lockstep::platform::describe_mlock_failure(ENOMEM);
  EXPECT_TRUE(contains(memory, "RLIMIT_MEMLOCK")) << memory;
  EXPECT_FALSE(contains(memory, "\n"));
}

}  // namespace
