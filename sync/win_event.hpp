#pragma once
// win_event: the paper's ThreadWaiter idea (an interlocked counter and
// manual-reset events, on the same Win32 emulation), corrected so that no
// wake-up is lost: two events, alternating by phase parity.
//
// Phase p's waiters wait on events[p % 2]. Its last arriver stores the count
// back, resets events[(p + 1) % 2] (nobody waits on it: every participant has
// arrived at p, so every one has left phase p - 1), then sets events[p % 2].
// That event stays set until the last arriver of phase p + 1 resets it, which
// cannot happen before every participant has arrived at p + 1, i.e. left
// phase p. So a participant that decremented but had not yet begun to wait
// finds the event still set and passes: the paper's lost wake-up cannot
// occur, and no participant resets an event someone may still need.
//
// Contract: as win_event_faithful (construct with the participants and an
// optional timeout; one call per phase per participant; destroy after the
// last call returns; not copyable or movable).
// Progress: blocking. A wait that times out (a phase longer than the timeout)
// is counted and waits again: it never leaves a phase early.
// Memory ordering: seq_cst Win32 emulation. The reset of events[(p+1)%2] is
// sequenced before the set of events[p%2]; a participant released by that set
// therefore sees the reset when it waits on events[(p+1)%2] at phase p + 1.
// Counters: futex_wakes (one per set), futex_waits (per sleep), timeouts (per
// expired wait; 0 unless a phase outlasts the timeout). Every futex wait is
// counted (kCountsFutexWaits).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string_view>

#include "platform/cache_line.hpp"
#include "sync/concepts.hpp"
#include "sync/win32_emulation.hpp"
#include "sync/win_event_hooks.hpp"

namespace lockstep::sync {

template <thread_waiter_hooks Hooks = no_hooks>
class basic_win_event {
 public:
  static constexpr std::string_view kName = "win_event";
  static constexpr std::string_view kDescription =
      "ThreadWaiter corrected: interlocked counter + two manual-reset events alternating by phase parity; "
      "no lost wake-up";
  static constexpr primitive_kind kKind = primitive_kind::barrier;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = true;
  static constexpr bool kSpinsLong = false;  // sleeps on the event (futex)
  static constexpr bool kVisibleToTsan = true;  // C++ atomics and futex
  static constexpr std::chrono::milliseconds kDefaultTimeout{1000};

  explicit basic_win_event(unsigned participants, std::chrono::milliseconds timeout = kDefaultTimeout)
      : participants_(static_cast<long>(participants)),
        count_(static_cast<long>(participants)),
        timeout_(timeout),
        parity_(std::make_unique<parity_slot[]>(participants)) {}
  basic_win_event(const basic_win_event&) = delete;  // participants hold its address
  basic_win_event& operator=(const basic_win_event&) = delete;

  void arrive_and_wait(participant& self) noexcept {
    parity_slot& mine = parity_[self.id];
    const unsigned parity = mine.parity;
    mine.parity ^= 1u;
    if (win32::interlocked_decrement(count_) == 0) {
      win32::interlocked_exchange(count_, participants_);
      events_[parity ^ 1u].event.reset();
      events_[parity].event.set(self.counters);
      return;
    }
    hooks_.after_decrement(self);
    while (events_[parity].event.wait(timeout_, self.counters) == win32::wait_result::timed_out) {
      // Counted by wait(); the phase is not over, so wait again.
    }
  }

  Hooks& hooks() noexcept { return hooks_; }

 private:
  struct alignas(platform::kCacheLine) padded_event {
    win32::manual_reset_event event;
  };
  struct alignas(platform::kCacheLine) parity_slot {
    unsigned parity = 0;  // touched only by its participant
  };
  static_assert(sizeof(padded_event) == platform::kCacheLine, "each event has a line of its own");

  const long participants_;
  alignas(platform::kCacheLine) std::atomic<long> count_;
  std::chrono::milliseconds timeout_;
  padded_event events_[2];
  std::unique_ptr<parity_slot[]> parity_;
  [[no_unique_address]] Hooks hooks_;
};

using win_event = basic_win_event<>;
static_assert(phase_barrier<win_event>);

}  // namespace lockstep::sync
