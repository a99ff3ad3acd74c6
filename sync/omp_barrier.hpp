#pragma once
// omp_barrier: OpenMP's `#pragma omp barrier` (libgomp) inside one persistent
// parallel region: the paper's OpenMP model.
//
// What it is: arrive_and_wait() executes an orphaned `omp barrier`, which binds
// to the parallel region that omp_team::run opened (team_of<omp_barrier> is
// omp_team). libgomp's barrier spins for GOMP_SPINCOUNT (reduced
// automatically when threads outnumber CPUs), then sleeps on a futex.
// Contract: construct with the number of participants; call arrive_and_wait
// only from bodies run by omp_team::run with that many participants (every
// thread of the region must call it the same number of times). Outside a
// parallel region it would be a no-op: a debug assertion catches that misuse.
// Progress: blocking.
// Memory ordering: an OpenMP barrier implies a flush: writes before it are
// visible to every thread of the region after it.
// Counters: none (libgomp's spins and futex calls are not observable), so
// kCountsFutexWaits is false: the harness omits its futex-wait counters
// (unavailable) rather than report the 0 it never counted.
#include <cassert>
#include <string_view>

#include "sync/concepts.hpp"
#include "sync/team.hpp"

namespace lockstep::sync {

class omp_barrier {
 public:
  static constexpr std::string_view kName = "omp_barrier";
  static constexpr std::string_view kDescription =
      "OpenMP (libgomp) #pragma omp barrier in a persistent parallel region: the paper's OpenMP model";
  static constexpr primitive_kind kKind = primitive_kind::barrier;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = false;
  static constexpr bool kSpinsLong = true;  // libgomp spins GOMP_SPINCOUNT (300000 by default) before sleeping
  static constexpr bool kVisibleToTsan = false;  // libgomp is not built with TSan instrumentation

  explicit omp_barrier(unsigned participants) : participants_(participants) {}
  omp_barrier(const omp_barrier&) = delete;  // one per region, by address
  omp_barrier& operator=(const omp_barrier&) = delete;

  unsigned participants() const noexcept { return participants_; }

  void arrive_and_wait(participant& /*self*/) noexcept {
    assert(in_parallel_region() && "omp_barrier used outside omp_team::run");
    wait_in_region();
  }

 private:
  // Defined in omp_team.cpp (compiled with OpenMP flags).
  static void wait_in_region() noexcept;
  static bool in_parallel_region() noexcept;
  unsigned participants_;
};

template <>
struct team_of<omp_barrier> {
  using type = omp_team;
};

static_assert(phase_barrier<omp_barrier>);

}  // namespace lockstep::sync
