#pragma once
// An emulation of the Win32 calls the paper's ThreadWaiter (and its join) use,
// with Windows' semantics, on C++ atomics and Linux futexes:
//   InterlockedDecrement, InterlockedExchange     -> interlocked_decrement, interlocked_exchange
//   CreateEvent(manual reset, initially reset)    -> manual_reset_event
//   SetEvent, ResetEvent                          -> manual_reset_event::set, reset
//   WaitForSingleObject(event, timeout)           -> manual_reset_event::wait
//   WaitForMultipleObjects(n, events, TRUE, t)    -> wait_for_multiple_objects
// win_event_faithful.hpp builds the paper's ThreadWaiter on these;
// win_event.hpp builds the corrected design on the same calls.
//
// Semantics reproduced (Win32 documentation of SetEvent / ResetEvent /
// WaitForSingleObject for a manual-reset event):
//  * set() makes the event signalled and releases every thread waiting on it
//    at that moment; it stays signalled (later waits return at once) until
//    reset(). A waiter released by set() returns WAIT_OBJECT_0 even if reset()
//    follows before it runs again ("pulse" behaviour is not needed: the
//    generation count below remembers the set).
//  * reset() makes it non-signalled; it wakes nobody.
//  * wait(timeout) returns object_0 at once if signalled; otherwise it sleeps
//    until a set() or the timeout (timed_out). kInfinite never times out.
// Windows makes each of these a kernel call; so does the emulation for set()
// (always one FUTEX_WAKE, as SetEvent always enters the kernel) and for a
// wait that has to sleep.
//
// Progress: set/reset never block; wait blocks.
// Memory ordering: the Interlocked functions are full barriers on Windows and
// the wait functions synchronise with the set that released them; the
// emulation is seq_cst throughout (no weaker order is claimed or used), so a
// write before set() is visible after a wait() that set() released.
// Counters: set() counts a futex wake; wait() counts each futex wait it
// makes and a timeout when it returns timed_out.
//
// Limits: the generation count is 31 bits: a waiter that sleeps through
// exactly 2^31 set() calls would not notice them (harmless here: a phase
// cannot pass 2^31 times while one of its participants sleeps).
// wait_for_multiple_objects emulates only bWaitAll = TRUE, by waiting for each
// object in turn: exact for objects that stay signalled once set (thread
// handles, as in the paper's join), not for events that are reset meanwhile.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <span>

#include "sync/concepts.hpp"
#include "platform/futex.hpp"

namespace lockstep::sync::win32 {

inline constexpr std::chrono::milliseconds kInfinite{-1};

enum class wait_result { object_0, timed_out };

// InterlockedDecrement: returns the decremented value; a full barrier.
inline long interlocked_decrement(std::atomic<long>& addend) noexcept {
  return addend.fetch_sub(1, std::memory_order_seq_cst) - 1;
}

// InterlockedExchange: returns the previous value; a full barrier.
inline long interlocked_exchange(std::atomic<long>& target, long value) noexcept {
  return target.exchange(value, std::memory_order_seq_cst);
}

class manual_reset_event {
 public:
  manual_reset_event() = default;  // CreateEvent(NULL, TRUE, FALSE, NULL)
  manual_reset_event(const manual_reset_event&) = delete;  // waiters sleep on its address
  manual_reset_event& operator=(const manual_reset_event&) = delete;

  // SetEvent.
  void set(sync_counters& counters) noexcept {
    std::uint32_t state = state_.load(std::memory_order_seq_cst);
    // One more set, and signalled: the generation lets a waiter that sleeps
    // through set() + reset() still see that it was released.
    while (!state_.compare_exchange_weak(state, ((state >> 1) + 1) << 1 | kSignalled, std::memory_order_seq_cst))
      ;
    platform::futex_wake(state_);
    ++counters.futex_wakes;
  }

  // ResetEvent.
  void reset() noexcept { state_.fetch_and(~kSignalled, std::memory_order_seq_cst); }

  bool signalled() const noexcept { return (state_.load(std::memory_order_seq_cst) & kSignalled) != 0; }

  // WaitForSingleObject.
  wait_result wait(std::chrono::milliseconds timeout, sync_counters& counters) noexcept {
    std::uint32_t seen = state_.load(std::memory_order_seq_cst);
    if ((seen & kSignalled) != 0) return wait_result::object_0;
    const std::uint32_t generation = seen >> 1;
    const bool infinite = timeout.count() < 0;
    const auto deadline = std::chrono::steady_clock::now() + (infinite ? std::chrono::milliseconds(0) : timeout);
    for (;;) {
      std::chrono::nanoseconds remaining(-1);
      if (!infinite) {
        remaining = deadline - std::chrono::steady_clock::now();
        if (remaining.count() <= 0) break;
      }
      platform::futex_wait(state_, seen, remaining);
      ++counters.futex_waits;
      seen = state_.load(std::memory_order_seq_cst);
      // Released by a set() since we began waiting, even if reset() followed.
      if ((seen & kSignalled) != 0 || (seen >> 1) != generation) return wait_result::object_0;
    }
    ++counters.timeouts;
    return wait_result::timed_out;
  }

 private:
  static constexpr std::uint32_t kSignalled = 1;
  std::atomic<std::uint32_t> state_{0};  // bit 0: signalled; bits 1..31: number of set() calls
};

// WaitForMultipleObjects(count, events, TRUE, timeout): see the header's limits.
inline wait_result wait_for_multiple_objects(std::span<manual_reset_event* const> events,
                                             std::chrono::milliseconds timeout, sync_counters& counters) noexcept {
  const bool infinite = timeout.count() < 0;
  const auto deadline = std::chrono::steady_clock::now() + (infinite ? std::chrono::milliseconds(0) : timeout);
  for (manual_reset_event* event : events) {
    std::chrono::milliseconds remaining = kInfinite;
    if (!infinite) {
      remaining = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (remaining.count() < 0) remaining = std::chrono::milliseconds(0);
    }
    if (event->wait(remaining, counters) == wait_result::timed_out) return wait_result::timed_out;
  }
  return wait_result::object_0;
}

}  // namespace lockstep::sync::win32
