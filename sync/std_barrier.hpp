#pragma once
// std_barrier: std::barrier<> from libstdc++, the C++20 baseline.
//
// What it is: a thin adapter from phase_barrier to std::barrier<> with the
// default (empty) completion function. libstdc++ 12 implements it as a tree of
// arrival counters whose waiters use std::atomic wait (a short spin, a few
// sched_yield calls, then a futex): blocking, not pure-spin.
// Contract: construct with the number of participants (>= 1); each calls
// arrive_and_wait(self) once per phase; destroy after every participant has
// returned from its last call. Not copyable or movable (std::barrier is not).
// Progress: blocking (no participant leaves before all arrived).
// Memory ordering: as [thread.barrier]: every arrival strongly happens before
// the completion of the phase, which happens before every return from that
// phase's wait: writes before arriving are visible to everyone after leaving.
// Counters: none. What the library does inside (spins, yields, futex calls) is
// not observable from outside, so every counter stays 0 rather than guessed,
// and kCountsFutexWaits is false: the harness reports its futex waits as
// unavailable (omits the counter) instead of that 0.
#include <barrier>
#include <string_view>

#include "sync/concepts.hpp"

namespace lockstep::sync {

class std_barrier {
 public:
  static constexpr std::string_view kName = "std_barrier";
  static constexpr std::string_view kDescription =
      "std::barrier<> (libstdc++), the C++20 baseline: tree of counters, spin then futex";
  static constexpr primitive_kind kKind = primitive_kind::barrier;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = false;
  static constexpr bool kSpinsLong = false;  // a short spin, then yields and a futex
  static constexpr bool kVisibleToTsan = true;  // libstdc++ templates, instrumented in the caller

  explicit std_barrier(unsigned participants) : barrier_(static_cast<std::ptrdiff_t>(participants)) {}

  void arrive_and_wait(participant& /*self*/) { barrier_.arrive_and_wait(); }

 private:
  std::barrier<> barrier_;
};

static_assert(phase_barrier<std_barrier>);

}  // namespace lockstep::sync
