#pragma once
// pthread_barrier: glibc's pthread_barrier_wait.
//
// What it is: an adapter from phase_barrier to pthread_barrier_t (process
// private, default attributes). glibc 2.36 counts arrivals in a shared word
// and puts waiters straight to sleep on a futex: blocking, no spinning.
// Contract: construct with the number of participants (>= 1; throws
// std::system_error if glibc refuses); each calls arrive_and_wait(self) once
// per phase; destroy after every participant has returned from its last call.
// Not copyable or movable (pthread_barrier_t must not be copied).
// Progress: blocking.
// Memory ordering: POSIX lists pthread_barrier_wait among the functions that
// synchronise memory: writes before the call are visible to every participant
// after its call returns.
// Counters: none (glibc's futex calls are not observable from outside), so
// kCountsFutexWaits is false: the harness omits its futex-wait counters
// (unavailable) rather than report the 0 it never counted.
#include <cerrno>
#include <string_view>
#include <system_error>

#include <pthread.h>

#include "sync/concepts.hpp"

namespace lockstep::sync {

class pthread_barrier {
 public:
  static constexpr std::string_view kName = "pthread_barrier";
  static constexpr std::string_view kDescription = "glibc pthread_barrier_wait: counter, waiters sleep on a futex";
  static constexpr primitive_kind kKind = primitive_kind::barrier;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = false;
  static constexpr bool kSpinsLong = false;  // glibc sleeps at once
  static constexpr bool kVisibleToTsan = true;  // TSan intercepts pthread_barrier_wait

  explicit pthread_barrier(unsigned participants) {
    if (const int status = pthread_barrier_init(&barrier_, nullptr, participants); status != 0)
      throw std::system_error(status, std::generic_category(), "pthread_barrier_init");
  }
  pthread_barrier(const pthread_barrier&) = delete;  // pthread_barrier_t must not be copied
  pthread_barrier& operator=(const pthread_barrier&) = delete;
  ~pthread_barrier() { pthread_barrier_destroy(&barrier_); }

  void arrive_and_wait(participant& /*self*/) noexcept {
    // Returns PTHREAD_BARRIER_SERIAL_THREAD in one participant, 0 in the
    // others; there is no error case for a valid, initialised barrier.
    (void)pthread_barrier_wait(&barrier_);
  }

 private:
  pthread_barrier_t barrier_;
};

static_assert(phase_barrier<pthread_barrier>);

}  // namespace lockstep::sync
