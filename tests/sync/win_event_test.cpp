// The Win32 emulation's semantics, and the paper's lost wake-up forced
// deterministically: win_event_faithful loses it (a timeout, counted),
// win_event does not.
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "sync/phase_run.hpp"
#include "sync/win32_emulation.hpp"
#include "sync/win_event.hpp"
#include "sync/win_event_faithful.hpp"
#include "tests/support/watchdog.hpp"
#include "tests/sync/conformance.hpp"

namespace lockstep::sync {
namespace {

using namespace std::chrono_literals;
using lockstep::testing::kSlowdown;
using lockstep::testing::watchdog;

// The scheduler state of thread `tid` ('S' = sleeping), from /proc.
char thread_state(pid_t tid) {
  std::ifstream stat("/proc/self/task/" + std::to_string(tid) + "/stat");
  std::string line;
  std::getline(stat, line);
  const auto close = line.rfind(')');
  return close == std::string::npos || close + 2 >= line.size() ? '?' : line[close + 2];
}

TEST(ManualResetEvent, WaitOnASetEventReturnsAtOnce) {
  win32::manual_reset_event event;
  sync_counters counters;
  event.set(counters);
  EXPECT_EQ(event.wait(1000ms, counters), win32::wait_result::object_0);
  EXPECT_EQ(event.wait(1000ms, counters), win32::wait_result::object_0) << "stays set until reset";
  EXPECT_EQ(counters.futex_waits, 0u);
  EXPECT_EQ(counters.futex_wakes, 1u);
}

TEST(ManualResetEvent, TimeoutIsReportedAndCounted) {
  win32::manual_reset_event event;
  sync_counters counters;
  EXPECT_EQ(event.wait(5ms, counters), win32::wait_result::timed_out);
  EXPECT_EQ(counters.timeouts, 1u);
  sync_counters set_counters;
  event.set(set_counters);
  event.reset();
  EXPECT_EQ(event.wait(5ms, counters), win32::wait_result::timed_out) << "a reset event does not release";
  EXPECT_EQ(counters.timeouts, 2u);
}

// Windows: SetEvent releases every thread waiting at that moment, even if
// ResetEvent follows before the waiter runs again.
TEST(ManualResetEvent, SetReleasesSleepingWaitersEvenIfResetFollows) {
  watchdog guard(30s * kSlowdown, "a waiter released by set() + reset() never returned");
  win32::manual_reset_event event;
  constexpr int kWaiters = 3;
  std::atomic<pid_t> tids[kWaiters] = {};
  std::atomic<int> released{0};
  std::atomic<int> timed_out{0};
  std::vector<std::jthread> waiters;
  for (int index = 0; index < kWaiters; ++index)
    waiters.emplace_back([&, index] {
      tids[index].store(static_cast<pid_t>(syscall(SYS_gettid)));
      sync_counters counters;
      if (event.wait(20s, counters) == win32::wait_result::object_0) ++released;
      else ++timed_out;
    });
  // Wait until every waiter sleeps in the kernel (inside wait()).
  for (int index = 0; index < kWaiters; ++index) {
    while (tids[index].load() == 0) std::this_thread::yield();
    while (thread_state(tids[index].load()) != 'S') std::this_thread::sleep_for(1ms);
  }
  sync_counters counters;
  event.set(counters);
  event.reset();
  waiters.clear();  // join
  EXPECT_EQ(released.load(), kWaiters);
  EXPECT_EQ(timed_out.load(), 0);
  EXPECT_FALSE(event.signalled());
}

TEST(WaitForMultipleObjects, WaitAllReturnsWhenEverySetAndTimesOutOtherwise) {
  watchdog guard(30s * kSlowdown);
  win32::manual_reset_event first, second, never;
  sync_counters counters;
  std::jthread setter([&] {
    sync_counters mine;
    first.set(mine);
    second.set(mine);
  });
  win32::manual_reset_event* both[] = {&first, &second};
  EXPECT_EQ(win32::wait_for_multiple_objects(both, win32::kInfinite, counters), win32::wait_result::object_0);
  win32::manual_reset_event* with_unset[] = {&first, &never};
  EXPECT_EQ(win32::wait_for_multiple_objects(with_unset, 5ms, counters), win32::wait_result::timed_out);
  EXPECT_EQ(counters.timeouts, 1u);
}

// A hook that parks participant 0 right after its decrement, at phase 0 only,
// until participant 1 has returned from the same phase.
struct parking_hooks {
  std::atomic<bool> decremented{false};
  std::atomic<bool> other_returned{false};
  bool armed = true;  // read and written by participant 0 only
  void after_decrement(participant& self) noexcept {
    if (self.id != 0 || !armed) return;
    armed = false;
    decremented.store(true);
    decremented.notify_all();
    other_returned.wait(false);
  }
};

// The paper's lost wake-up: participant 0 has decremented but not yet waited;
// participant 1 arrives last, sets the event, resets it (every thread resets
// after its wait) and leaves. Participant 0 then waits on a reset event that
// nobody will set for this phase.
template <class Barrier>
struct forced_interleaving {
  participant parked{0, {}};
  participant last{1, {}};
  std::chrono::nanoseconds parked_wait{};

  void run(Barrier& barrier) {
    std::jthread first([&] {
      const auto start = std::chrono::steady_clock::now();
      barrier.arrive_and_wait(parked);  // parks in the hook
      parked_wait = std::chrono::steady_clock::now() - start;
    });
    std::jthread second([&] {
      barrier.hooks().decremented.wait(false);
      barrier.arrive_and_wait(last);
      barrier.hooks().other_returned.store(true);
      barrier.hooks().other_returned.notify_all();
    });
  }
};

// After the forced phase, both keep going for 200 phases under the phase
// invariant of the conformance suite: whether the barrier still orders them,
// and how many of their waits timed out meanwhile.
struct later_phases {
  std::uint64_t violations = 0;
  std::string first_violation;
  std::uint64_t timeouts = 0;  // during these phases only
};

template <class Barrier>
later_phases more_phases(Barrier& barrier, forced_interleaving<Barrier>& forced) {
  constexpr std::uint64_t kPhases = 200;
  const std::uint64_t timeouts_before = forced.parked.counters.timeouts + forced.last.counters.timeouts;
  testing::phase_invariant invariant(2);
  {
    std::jthread first([&] {
      for (std::uint64_t phase = 0; phase < kPhases; ++phase) {
        invariant.before_arrival(forced.parked, phase);
        barrier.arrive_and_wait(forced.parked);
      }
    });
    for (std::uint64_t phase = 0; phase < kPhases; ++phase) {
      invariant.before_arrival(forced.last, phase);
      barrier.arrive_and_wait(forced.last);
    }
  }  // joined: the counters and the invariant are read after
  return {invariant.violations(), invariant.first_violation(),
          forced.parked.counters.timeouts + forced.last.counters.timeouts - timeouts_before};
}

TEST(WinEventFaithful, LosesTheWakeUpOfALateWaiterAndCountsTheTimeout) {
  watchdog guard(60s * kSlowdown, "win_event_faithful: the lost wake-up did not end in a timeout");
  basic_win_event_faithful<parking_hooks> barrier(2, 50ms);  // a short timeout keeps the test quick
  forced_interleaving<basic_win_event_faithful<parking_hooks>> forced;
  forced.run(barrier);
  EXPECT_EQ(forced.parked.counters.timeouts, 1u) << "the parked participant's wake-up was lost: one timeout";
  EXPECT_GE(forced.parked_wait, 50ms) << "it waited for the whole timeout";
  EXPECT_EQ(forced.last.counters.timeouts, 0u);
  EXPECT_EQ(forced.last.counters.futex_wakes, 1u) << "the last arriver set the event once";
  // The loss left the counter intact (the phase was over when the wait timed
  // out): the barrier orders the next phases. Checkable only while it loses
  // no further wake-up, which with this primitive is up to the scheduler (a
  // wait that times out leaves its phase early: the paper's design).
#if defined(__SANITIZE_THREAD__)
  // Under ThreadSanitizer a later wait that outlasts the 50 ms timeout (on a
  // loaded machine it does) leaves its phase early, and the invariant's plain
  // records are then a data race that ends the process before the timeouts
  // can be counted (seen: 1 tsan ctest round in 3 beside two busy loops).
  GTEST_SKIP() << "under ThreadSanitizer a later lost wake-up is a reported race on the invariant's records: "
                  "the counter after the loss is checked in the other builds";
#endif
  const later_phases after = more_phases(barrier, forced);
  if (after.timeouts > 0)
    GTEST_SKIP() << "a later phase lost a wake-up too (" << after.timeouts
                 << " timeouts): whether the counter stayed intact cannot be told";
  EXPECT_EQ(after.violations, 0u) << "the counter is off after the loss: " << after.first_violation;
}

TEST(WinEvent, TheSameInterleavingLosesNothing) {
  watchdog guard(60s * kSlowdown, "win_event lost the wake-up (it waits again after each timeout)");
  basic_win_event<parking_hooks> barrier(2, 2000ms);
  forced_interleaving<basic_win_event<parking_hooks>> forced;
  forced.run(barrier);
  EXPECT_EQ(forced.parked.counters.timeouts, 0u) << "the late waiter found its phase's event still set";
  EXPECT_EQ(forced.parked.counters.futex_waits, 0u) << "it did not even need to sleep";
  EXPECT_EQ(forced.last.counters.timeouts, 0u);
  // And the barrier goes on ordering its phases. (A later wait may still time
  // out if a phase outlasts the 2 s on a stalled machine: win_event then
  // waits again and never leaves early, so the invariant holds regardless.)
  const later_phases after = more_phases(barrier, forced);
  EXPECT_EQ(after.violations, 0u) << after.first_violation;
}

// Participant 1 is late to wait in every fifth phase: win_event_faithful loses
// wake-ups over and over, its counter goes off by one and the participants
// drift a phase apart (the paper's design, see its header). A run bounded by
// run_phases must still end for every participant: one that runs a phase
// ahead of the leader stops too (phase_stop asks "at or before mine?"), where
// it used to wait out timeouts for ever (a CI run's 90 s watchdog).
struct late_waiter_hooks {
  unsigned calls = 0;  // participant 1's alone
  void after_decrement(participant& self) noexcept {
    if (self.id == 1 && ++calls % 5 == 0) std::this_thread::sleep_for(2ms);
  }
};

TEST(WinEventFaithful, ARunThatLosesWakeUpsStillEndsEveryParticipant) {
  watchdog guard(60s * kSlowdown, "run_phases did not end a win_event_faithful run that lost wake-ups");
  constexpr unsigned kParticipants = 4;
  basic_win_event_faithful<late_waiter_hooks> barrier(kParticipants, 5ms);  // short: losses are cheap
  const phase_run_result result =
      run_phases(barrier, kParticipants, {400, std::chrono::hours(1)}, [](participant&, std::uint64_t) {});
  EXPECT_EQ(result.phases, 400u);
  if (result.total().timeouts == 0)
    GTEST_SKIP() << "the late waiter lost no wake-up: the scenario this test is about did not happen";
}

}  // namespace
}  // namespace lockstep::sync
