#pragma once
// The C++ side of Concurrency Kit's barriers: one adapter template over the C
// shim (ck_shim.h), instantiated once per ck barrier in ck_centralized.hpp,
// ck_dissemination.hpp, ck_tournament.hpp, ck_mcs.hpp, ck_combining.hpp.
//
// Contract: construct with the number of participants (>= 1; throws
// std::bad_alloc if the shim cannot allocate); participant self.id in
// [0, participants) calls arrive_and_wait(self) once per phase from one
// thread; destroy after every participant has returned from its last call.
// Not copyable or movable (participants spin on its memory).
// Progress: pure spin (ck_pr_stall in a loop; never yields, never sleeps).
// With more participants than CPUs a phase completes only when the scheduler
// preempts spinners, typically a timeslice (milliseconds) per phase: bounded
// by the scheduler, not by the primitive. kPureSpin says so to the harness.
// Memory ordering: writes before arrive_and_wait are visible to every
// participant after it: on x86-64 by ck alone (TSO); on AArch64 because the
// shim adds a release fence before dispatching into ck and an acquire fence
// after (ck issues neither). ck_shim.h states the promise per architecture.
// Counters: none. Spinning is all they do, and the shim does not count loop
// turns (that would change what is measured): every counter stays 0. That 0
// is exact for futex waits (kCountsFutexWaits): a ck barrier never sleeps.
// ThreadSanitizer: ck synchronises with inline assembly and plain volatile
// accesses that TSan cannot see, so the ck barriers are left out of the TSan
// run (tests/sync/CMakeLists.txt); asan-ubsan runs them.
#include <new>
#include <string_view>

#include "sync/ck_shim.h"
#include "sync/concepts.hpp"

namespace lockstep::sync {

template <lockstep_ck_kind Kind>
class ck_barrier {
 public:
  static constexpr primitive_kind kKind = primitive_kind::barrier;
  static constexpr bool kPureSpin = true;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = true;
  static constexpr bool kSpinsLong = true;  // pure spin: a waiter keeps its CPU until the phase ends
  static constexpr bool kVisibleToTsan = false;  // inline assembly (ck_pr) and volatile accesses

  explicit ck_barrier(unsigned participants) : barrier_(lockstep_ck_barrier_create(Kind, participants)) {
    if (barrier_ == nullptr) throw std::bad_alloc();
  }
  ck_barrier(const ck_barrier&) = delete;  // participants spin on its memory
  ck_barrier& operator=(const ck_barrier&) = delete;
  ~ck_barrier() { lockstep_ck_barrier_destroy(barrier_); }

  void arrive_and_wait(participant& self) noexcept { lockstep_ck_barrier_wait(barrier_, self.id); }

 private:
  lockstep_ck_barrier* barrier_;
};

}  // namespace lockstep::sync
