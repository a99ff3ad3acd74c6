#pragma once
// Spin budgets as times: the one spin loop of lockstep's waiting primitives
// (spin_until), what one of its polls costs on this CPU (measure_poll_ns),
// and how many polls last a given time (polls_lasting).
//
// Why a calibrated count and not a deadline: a budget could also be a
// deadline read from the clock. Read at every poll it would add a clock
// reading (20-30 ns through the vDSO, 0.5-1 us where the clocksource is hpet
// or acpi_pm: platform/clock.hpp) to a poll that costs 0.4-50 ns; read every N
// polls it still adds a branch and a counter, and N must itself be chosen
// from the hint's cost. A count calibrated once at start-up costs what the
// fixed counts cost before (a compare and a decrement a poll, no clock), and
// lasts the time it was computed for. Its error: the poll's cost in ns follows
// the core's clock (a core at half its start-up frequency spins twice as long)
// and the polled line's state (a poll that misses pays a line transfer), so
// the budget's time is approximate, within about 2x; the policies it serves
// are competitive bounds (sync/wait_policy.hpp) that tolerate as much.
//
// The calibration times the loop the primitives run, not the bare hint: one
// poll is an acquire load of a word this core holds plus one hint, over
// kCalibrationPolls polls, kCalibrationTries times; the median try is the
// figure (an interrupt or a preemption inflates one try, not the median).
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "platform/cpu_relax.hpp"
#include "platform/statistics.hpp"

namespace lockstep::platform {

// Polls per try and tries of the calibration: 4096 polls last 1.6 us at
// 0.4 ns a poll (an AArch64 YIELD), 190 us at 47 ns (a Skylake PAUSE at 3 GHz),
// so the nine tries take 15 us to 1.7 ms, and a clock reading (about 20 ns) is
// at most about 1 % of the shortest try.
inline constexpr unsigned kCalibrationPolls = 4096;
inline constexpr unsigned kCalibrationTries = 9;
// No loop polls faster than one cycle of a 10 GHz clock: a cheaper figure is
// a broken clock, and would turn a budget into billions of polls.
inline constexpr double kFastestPollNs = 0.1;

// Polls ready() up to `polls` times with hint() between polls; true as soon
// as ready() holds, false when the budget ran out. ready() performs the
// caller's acquire.
template <class Ready, class Hint = cpu_hint>
inline bool spin_until(Ready&& ready, std::uint32_t polls, Hint&& hint = Hint{}) {
  for (std::uint32_t poll = 0; poll < polls; ++poll) {
    if (ready()) return true;
    hint();
  }
  return false;
}

// The median cost in ns of one poll of spin_until: now_ns() is a clock in
// nanoseconds (platform::now_ns, or a test's fake), hint() the spin hint.
// Each try polls a word nobody sets (the loop runs its whole budget).
template <class Clock, class Hint = cpu_hint>
double measure_poll_ns(Clock&& now_ns, Hint&& hint = Hint{}, unsigned polls = kCalibrationPolls,
                       unsigned tries = kCalibrationTries) {
  // Relaxed would do for a word nobody writes; acquire is what the waits do.
  std::atomic<std::uint32_t> never_set{0};
  const auto ready = [&never_set] { return never_set.load(std::memory_order_acquire) != 0; };
  std::vector<double> per_poll;
  per_poll.reserve(tries);
  for (unsigned attempt = 0; attempt < tries; ++attempt) {
    const auto start = now_ns();
    spin_until(ready, polls, hint);
    const auto end = now_ns();
    per_poll.push_back(static_cast<double>(end - start) / static_cast<double>(polls));
  }
  const double typical = median(per_poll);
  return typical > kFastestPollNs ? typical : kFastestPollNs;
}

// How many polls at `poll_ns` each last `budget_ns`: rounded up, at least 1
// for a budget above 0, and at most what a std::uint32_t holds. A poll cost
// below kFastestPollNs (or not a number) counts as kFastestPollNs.
inline std::uint32_t polls_lasting(double budget_ns, double poll_ns) noexcept {
  if (!(budget_ns > 0.0)) return 0;
  const double cost = poll_ns > kFastestPollNs ? poll_ns : kFastestPollNs;
  const double polls = std::ceil(budget_ns / cost);
  constexpr double kMost = static_cast<double>(std::numeric_limits<std::uint32_t>::max());
  return polls >= kMost ? std::numeric_limits<std::uint32_t>::max() : static_cast<std::uint32_t>(polls);
}

}  // namespace lockstep::platform
