#pragma once
// Linux futex calls on a std::atomic<std::uint32_t>, for the blocking
// primitives in sync/ (futex_spin, mailbox, the Win32 event emulation) and
// for the start-up measurement of a futex round trip
// (platform/wait_calibration.hpp).
//
// What it is: thin wrappers over syscall(SYS_futex, ...). By default with the
// PRIVATE flag (futex_scope::process_private: the word is never shared across
// processes, so the kernel may key the wait queue by address without taking
// the mm-wide lock); futex_scope::process_shared for a word in memory that
// several processes map (an MPI-3 shared window, distributed/shm_window): the
// kernel then keys the queue by the page, so a wake in one process reaches a
// waiter in another. A private wait and a shared wake on the same word miss
// each other: every caller on one word must use one scope.
// Progress: futex_wait blocks; futex_wake never blocks.
// Who may call: any thread, on a word that lives as long as every caller.
// Memory ordering: none. The kernel compares the word with `expected`
// atomically with respect to FUTEX_WAKE on the same word, which is what
// prevents a lost wake-up; every ordering a caller relies on must come from its
// own atomic operations on the word (or elsewhere), never from these calls.
// Spurious returns (EINTR, EAGAIN, a wake meant for an earlier phase) are
// normal: callers re-check their condition in a loop.
// Failures: any other error (EFAULT: the word is not readable; EINVAL: a
// misaligned word or a bad operation; ENOSYS, EPERM) would come back on
// every call, so a caller's wait loop would spin on it hot and for ever.
// Both calls end the process instead, with one line naming the error.
#include <atomic>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace lockstep::platform {

static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t),
              "the futex word must be exactly a 32-bit integer");
static_assert(std::atomic<std::uint32_t>::is_always_lock_free,
              "the futex word must be a lock-free atomic (no hidden lock beside it)");

enum class futex_result { woken, value_changed, timed_out, interrupted };

// Who may wait on and wake a word: threads of one process, or processes that
// map the same memory (see the header).
enum class futex_scope { process_private, process_shared };

namespace detail {
// A futex call failed in a way no retry can cure: one line, then abort.
[[noreturn]] inline void futex_failed(const char* call, int error) noexcept {
  char text[160];
  const int length = std::snprintf(text, sizeof text, "lockstep: %s failed: %s (errno %d); a wait loop cannot go on\n",
                                   call, std::strerror(error), error);
  if (length > 0) {
    const ssize_t ignored = ::write(STDERR_FILENO, text, static_cast<std::size_t>(length) < sizeof text
                                                             ? static_cast<std::size_t>(length)
                                                             : sizeof text - 1);
    (void)ignored;
  }
  std::abort();
}
inline std::uint32_t* futex_address(std::atomic<std::uint32_t>& word) noexcept {
  // The atomic holds nothing but the integer (asserted above); the kernel reads
  // and compares it atomically.
  return reinterpret_cast<std::uint32_t*>(&word);
}
constexpr int futex_operation(int operation, futex_scope scope) noexcept {
  return scope == futex_scope::process_private ? (operation | FUTEX_PRIVATE_FLAG) : operation;
}
}  // namespace detail

// Sleeps while `word` still holds `expected`, until a futex_wake on `word`, a
// signal, or `timeout` (relative; negative means no timeout) elapses.
template <futex_scope Scope = futex_scope::process_private>
inline futex_result futex_wait(std::atomic<std::uint32_t>& word, std::uint32_t expected,
                               std::chrono::nanoseconds timeout = std::chrono::nanoseconds(-1)) noexcept {
  timespec relative{};
  timespec* relative_pointer = nullptr;
  if (timeout.count() >= 0) {
    relative.tv_sec = static_cast<time_t>(timeout.count() / 1'000'000'000);
    relative.tv_nsec = static_cast<long>(timeout.count() % 1'000'000'000);
    relative_pointer = &relative;
  }
  const long status = syscall(SYS_futex, detail::futex_address(word), detail::futex_operation(FUTEX_WAIT, Scope), expected,
                              relative_pointer, nullptr, 0);
  if (status == 0) return futex_result::woken;
  const int error = errno;
  switch (error) {
    case EAGAIN: return futex_result::value_changed;
    case ETIMEDOUT: return futex_result::timed_out;
    case EINTR: return futex_result::interrupted;  // a signal: the caller re-checks and waits again
    default: detail::futex_failed("FUTEX_WAIT", error);
  }
}

// Wakes up to `count` threads sleeping on `word`; returns how many it woke.
template <futex_scope Scope = futex_scope::process_private>
inline int futex_wake(std::atomic<std::uint32_t>& word, int count = INT_MAX) noexcept {
  const long woken = syscall(SYS_futex, detail::futex_address(word), detail::futex_operation(FUTEX_WAKE, Scope), count, nullptr,
                             nullptr, 0);
  if (woken < 0) detail::futex_failed("FUTEX_WAKE", errno);
  return static_cast<int>(woken);
}

}  // namespace lockstep::platform
