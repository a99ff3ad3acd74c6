#pragma once
// wait_policy: how the dataflow channels (seqlock, spsc_queue, mailbox) wait
// for a condition another participant will make true, and how they choose the
// regime to wait in. One piece for the three of them.
//
// Regimes (decided once per channel, from the participants' affinity sets):
//  * dedicated: every participant has a CPU (participants <= CPUs in the union
//    of their affinity sets). The participant we wait for is running: poll
//    with the CPU's pause for about one futex round trip (kDedicatedSpins),
//    the price of sleeping instead (competitive spinning: never worse than
//    twice the better of the two).
//  * oversubscribed: more participants than CPUs. The participant we wait for
//    is most likely queued behind us on our own CPU, and every pause we spin
//    is taken from it: do not spin (kOversubscribedSpins), hand the CPU over
//    with sched_yield a bounded number of times (kOversubscribedYields), then
//    block.
// "Block" is the primitive's: mailbox sleeps on a futex (its epoch word);
// seqlock and spsc_queue have no word to sleep on and keep yielding (each
// yield lets a queued participant run, so they still make progress with every
// participant on one CPU).
//
// Until every participant has enrolled (its first publish or wait), a
// participant waits in the dedicated regime: the safe guess while threads are
// still starting (a spin that runs out still ends in the block step).
//
// Contract: one regime_census per channel, built with the number of
// participants; each participant keeps its own regime_view (on a line only its
// thread writes) and passes it to enrol()/budget() from its own thread.
// Progress: wait_until polls, yields, then calls the caller's block step,
// which must return only once the condition holds.
// Memory ordering: the census orders each participant's affinity bits before
// its enrolment ((E1) release, (E2) acquire). wait_until adds no ordering of
// its own: `ready` performs the acquire that the caller needs.
// Counters: yields per sched_yield; spins_exhausted once per wait whose spin
// and yield budget ran out before the condition held (it then blocks).
#include <sched.h>

#include <atomic>
#include <cstdint>

#include "platform/cpu_relax.hpp"
#include "sync/affinity.hpp"
#include "sync/concepts.hpp"

namespace lockstep::sync {

// Measured on the development VM (2-vCPU KVM guest, Intel Xeon) with a
// two-thread probe, one thread pinned per vCPU, in its usual (slow) pace:
//  * PAUSE: 14-19 ns per instruction over a loop of a million (an earlier
//    probe saw about 25 ns). kPauseNs takes the fast end, so that the spin below never
//    lasts less than the round trip it is meant to cover.
//  * a futex round trip: FUTEX_WAKE to a sleeper on an idle vCPU keeps the
//    waker in the syscall 14-15 us (the IPI exits to the hypervisor) and the
//    sleeper runs 40-42 us after the call began (p50; p10 32-35, p90 45-50);
//    an earlier probe saw 20-25 us in a quieter pace. kFutexRoundTripNs is the slow
//    pace's p50 and p90 rounded up.
// Why the whole round trip: with two participants, once one sleeps, its
// partner pays the wake-up syscall and then waits for it; if its own spin is
// shorter than the sleeper's wake-up it runs out and sleeps too, and the two
// take turns sleeping every stage (seen with a 20-25 us spin: 2-3x slower
// steps, a futex wait every few hundred steps). A spin that covers the round
// trip ends the cascade at the first wake-up.
inline constexpr std::uint32_t kPauseNs = 15;
inline constexpr std::uint32_t kFutexRoundTripNs = 50'000;
// About 3300 pauses (50-80 us): far longer than a stage of RK4 work (~0.2-0.5
// us), so a participant whose producer has its own CPU never sleeps in
// steady state, only when that producer is descheduled.
inline constexpr std::uint32_t kDedicatedSpins = kFutexRoundTripNs / kPauseNs;
// Oversubscribed: no spin (every pause is stolen from the producer queued on
// this CPU), then yields. A yield hands the CPU to a queued participant for
// the price of a syscall and a context switch (~0.3-1 us here) where a sleep
// costs a futex round trip, and the producer's FUTEX_WAKE alone keeps it in
// the kernel 14-15 us; after kOversubscribedYields (tens of microseconds) the
// producer is evidently not runnable soon (preempted on the other CPU, or
// blocked), and sleeping frees the CPU for whoever is. Why 64 and not fewer:
// with 8, mailbox's RK4 step at 4 threads on 2 CPUs slept 0.017-0.035 times
// per step (the producer was preempted on the other CPU for longer than 8
// yields) and took 3.4 us; with 64 it slept 0.000 times per step and took
// 3.0-3.8 us, 0.92-1.06x seqlock's (which never sleeps) in the same run
// (release build, interleaved, one run each). futex_spin yields
// as many times before it sleeps.
inline constexpr std::uint32_t kOversubscribedSpins = 0;
inline constexpr std::uint32_t kOversubscribedYields = 64;

enum class wait_regime : std::uint8_t { dedicated, oversubscribed };

// How long to poll before the block step.
struct wait_budget {
  std::uint32_t spins;   // pause iterations
  std::uint32_t yields;  // sched_yield calls after the spins
};

constexpr wait_budget budget_of(wait_regime regime) noexcept {
  return regime == wait_regime::dedicated ? wait_budget{kDedicatedSpins, 0}
                                          : wait_budget{kOversubscribedSpins, kOversubscribedYields};
}

// One participant's view of the census: touched only by its own thread, kept
// in the channel's per-participant line (so checking it costs no extra line).
struct regime_view {
  bool enrolled = false;
  bool settled = false;
  wait_regime regime = wait_regime::dedicated;
  wait_budget budget = budget_of(wait_regime::dedicated);
};

// Which regime a team of participants runs in.
class regime_census {
 public:
  explicit regime_census(unsigned participants) noexcept : participants_(participants) {}
  regime_census(const regime_census&) = delete;  // participants hold its address
  regime_census& operator=(const regime_census&) = delete;

  // Adds the calling thread's CPUs, once per participant (a branch after that).
  void enrol(regime_view& view) noexcept {
    if (!view.enrolled) [[unlikely]] {
      cpus_.add_calling_thread();
      // (E1) release: our CPU bits (relaxed fetch_or in add_calling_thread)
      // before the count; the enrolments form one release sequence, so (E2)
      // seeing the full count sees every participant's bits.
      enrolled_.fetch_add(1, std::memory_order_release);
      view.enrolled = true;
    }
  }

  // The budget to wait with: the dedicated one until every participant has
  // enrolled, then the team's regime, fixed from then on.
  const wait_budget& budget(regime_view& view) noexcept {
    enrol(view);
    if (!view.settled) [[unlikely]] settle(view);
    return view.budget;
  }

  unsigned participants() const noexcept { return participants_; }

 private:
  void settle(regime_view& view) noexcept {
    // (E2) acquire: pairs with every participant's (E1).
    if (enrolled_.load(std::memory_order_acquire) < participants_) return;
    const unsigned cpus = cpus_.count();
    // An empty union means the kernel would not say: assume a CPU each.
    view.regime = (cpus != 0 && participants_ > cpus) ? wait_regime::oversubscribed : wait_regime::dedicated;
    view.budget = budget_of(view.regime);
    view.settled = true;
  }

  unsigned participants_;
  cpu_union cpus_;
  alignas(platform::kCacheLine) std::atomic<unsigned> enrolled_{0};
};

// Polls ready() with the budget, then calls block() (which returns only once
// ready() holds). ready() must be cheap and perform the caller's acquire.
template <class Ready, class Block>
inline void wait_until(Ready&& ready, const wait_budget& budget, sync_counters& counters, Block&& block) {
  for (std::uint32_t spin = 0; spin < budget.spins; ++spin) {
    if (ready()) return;
    platform::cpu_relax();
  }
  for (std::uint32_t yield = 0; yield < budget.yields; ++yield) {
    if (ready()) return;
    sched_yield();
    ++counters.yields;
  }
  if (ready()) return;
  ++counters.spins_exhausted;
  block();
}

// The block step of a primitive that has nothing to sleep on: keep yielding.
template <class Ready>
inline void yield_until(Ready&& ready, sync_counters& counters) {
  while (!ready()) {
    sched_yield();
    ++counters.yields;
  }
}

}  // namespace lockstep::sync
