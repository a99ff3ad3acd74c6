#pragma once
// Waiting for a condition another thread will make true, for the dataflow
// primitives (seqlock, spsc_queue): spin with the CPU's pause for a bounded
// budget, then sched_yield until it holds.
//
// Progress: the condition's owner always gets the CPU back: a waiter spins at
// most kSpinBeforeYield pauses, then yields on every check, so with 4 threads
// on 2 CPUs (or all on 1) the producer it waits for is scheduled.
// Memory ordering: none of its own; `ready` performs the acquire.
// Counters: spins_exhausted once per wait whose spin ran out, yields per
// sched_yield.
#include <sched.h>

#include "platform/cpu_relax.hpp"
#include "sync/concepts.hpp"

namespace lockstep::sync {

// About 2-10 us of pause instructions (Zen 2 .. Skylake): longer than a
// producer's stage of RK4 work (~0.5 us), so a waiter whose producer has its
// own CPU never yields; short enough that a waiter sharing a CPU with its
// producer gives the CPU up quickly.
inline constexpr unsigned kSpinBeforeYield = 256;

template <class Ready>
inline void spin_then_yield(Ready&& ready, sync_counters& counters) noexcept(noexcept(ready())) {
  for (unsigned spin = 0; spin < kSpinBeforeYield; ++spin) {
    if (ready()) return;
    platform::cpu_relax();
  }
  ++counters.spins_exhausted;
  while (!ready()) {
    sched_yield();
    ++counters.yields;
  }
}

}  // namespace lockstep::sync
