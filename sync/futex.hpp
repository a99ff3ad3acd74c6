#pragma once
// Linux futex calls on a std::atomic<std::uint32_t>, for the blocking
// primitives in sync/ (futex_spin, the Win32 event emulation).
//
// What it is: thin wrappers over syscall(SYS_futex, ...) with the PRIVATE
// flag (the word is never shared across processes, so the kernel may key the
// wait queue by address without taking the mm-wide lock).
// Progress: futex_wait blocks; futex_wake never blocks.
// Who may call: any thread, on a word that lives as long as every caller.
// Memory ordering: none. The kernel compares the word with `expected`
// atomically with respect to FUTEX_WAKE on the same word, which is what
// prevents a lost wake-up; every ordering a caller relies on must come from its
// own atomic operations on the word (or elsewhere), never from these calls.
// Spurious returns (EINTR, EAGAIN, a wake meant for an earlier phase) are
// normal: callers re-check their condition in a loop.
#include <atomic>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cstdint>
#include <ctime>

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace lockstep::sync {

static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t),
              "the futex word must be exactly a 32-bit integer");
static_assert(std::atomic<std::uint32_t>::is_always_lock_free,
              "the futex word must be a lock-free atomic (no hidden lock beside it)");

enum class futex_result { woken, value_changed, timed_out, interrupted };

namespace detail {
inline std::uint32_t* futex_address(std::atomic<std::uint32_t>& word) noexcept {
  // The atomic holds nothing but the integer (asserted above); the kernel reads
  // and compares it atomically.
  return reinterpret_cast<std::uint32_t*>(&word);
}
}  // namespace detail

// Sleeps while `word` still holds `expected`, until a futex_wake on `word`, a
// signal, or `timeout` (relative; negative means no timeout) elapses.
inline futex_result futex_wait(std::atomic<std::uint32_t>& word, std::uint32_t expected,
                               std::chrono::nanoseconds timeout = std::chrono::nanoseconds(-1)) noexcept {
  timespec relative{};
  timespec* relative_pointer = nullptr;
  if (timeout.count() >= 0) {
    relative.tv_sec = static_cast<time_t>(timeout.count() / 1'000'000'000);
    relative.tv_nsec = static_cast<long>(timeout.count() % 1'000'000'000);
    relative_pointer = &relative;
  }
  const long status = syscall(SYS_futex, detail::futex_address(word), FUTEX_WAIT_PRIVATE, expected,
                              relative_pointer, nullptr, 0);
  if (status == 0) return futex_result::woken;
  switch (errno) {
    case EAGAIN: return futex_result::value_changed;
    case ETIMEDOUT: return futex_result::timed_out;
    default: return futex_result::interrupted;  // EINTR: the caller re-checks and waits again
  }
}

// Wakes up to `count` threads sleeping on `word`; returns how many it woke.
inline int futex_wake(std::atomic<std::uint32_t>& word, int count = INT_MAX) noexcept {
  return static_cast<int>(syscall(SYS_futex, detail::futex_address(word), FUTEX_WAKE_PRIVATE, count, nullptr,
                                  nullptr, 0));
}

}  // namespace lockstep::sync
