#pragma once
// wait_policy: how the dataflow channels (seqlock, spsc_queue, mailbox) wait
// for a condition another participant will make true, and how they choose the
// regime to wait in. One piece for the three of them.
//
// Regimes (decided once per channel, from the participants' affinity sets):
//  * dedicated: every participant has a CPU (participants <= CPUs in the union
//    of their affinity sets). The participant we wait for is running: poll
//    with the CPU's spin hint for about one futex round trip, the price of
//    sleeping instead (competitive spinning: never worse than twice the better
//    of the two); precisely, for the 90th percentile of the futex hand-overs
//    measured at start-up, so that the spin outlasts a sleeping partner's
//    wake-up nine times in ten (platform/wait_calibration.hpp says why not
//    the median).
//  * oversubscribed: more participants than CPUs. The participant we wait for
//    is most likely queued behind us on our own CPU, and every poll we spin
//    is taken from it: do not spin (kOversubscribedSpins), hand the CPU over
//    with sched_yield a bounded number of times (kOversubscribedYields), then
//    block.
// "Block" is the primitive's: mailbox sleeps on a futex (its epoch word);
// seqlock and spsc_queue have no word to sleep on and keep yielding (each
// yield lets a queued participant run, so they still make progress with every
// participant on one CPU).
//
// The spin is a time, not a count: the futex round trip is measured on this
// machine at start-up and the spin lasts that long, in polls calibrated to
// this CPU's cost of one poll (platform/wait_calibration.hpp,
// platform/spin_budget.hpp: why a calibrated count rather than a deadline).
// A count fixed in the source lasted whatever it lasted on the core it was
// tuned on: 3300 polls were 50 us with this project's VM's 15 ns PAUSE and
// would be 1.3 us on an AArch64 core whose hint costs 0.4 ns, where the
// participants then sleep in the cascade described below.
//
// Until every participant has enrolled (its first publish or wait), a
// participant waits in the dedicated regime: the safe guess while threads are
// still starting (a spin that runs out still ends in the block step).
//
// Contract: one regime_census per channel, built with the number of
// participants (and, by default, this machine's calibrated budgets); each
// participant keeps its own regime_view (on a line only its thread writes)
// and passes it to enrol()/budget() from its own thread.
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
#include "platform/spin_budget.hpp"
#include "platform/wait_calibration.hpp"
#include "sync/affinity.hpp"
#include "sync/concepts.hpp"

namespace lockstep::sync {

// Why the whole futex round trip (measured on the development VM, a 2-vCPU
// KVM guest, Intel Xeon: FUTEX_WAKE to a sleeper on an idle vCPU keeps the
// waker in the syscall 14-15 us, and the sleeper runs 40-42 us after the call
// began): with two participants, once one sleeps, its partner pays the
// wake-up syscall and then waits for it; if its own spin is shorter than the
// sleeper's wake-up it runs out and sleeps too, and the two take turns
// sleeping every stage (seen with a 20-25 us spin: 2-3x slower steps, a futex
// wait every few hundred steps). A spin that covers the round trip ends the
// cascade at the first wake-up. It is far longer than a stage of RK4 work
// (~0.2-0.5 us), so a participant whose producer has its own CPU never sleeps
// in steady state, only when that producer is descheduled.
//
// Oversubscribed: no spin (every poll is stolen from the producer queued on
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
// as many times before it sleeps. Yields are counted, not timed: each is a
// system call whose cost is the kernel's, not the CPU's hint.
inline constexpr std::uint32_t kOversubscribedSpins = 0;
inline constexpr std::uint32_t kOversubscribedYields = 64;

enum class wait_regime : std::uint8_t { dedicated, oversubscribed };

// How long to poll before the block step.
struct wait_budget {
  std::uint32_t spins = 0;   // polls (spin_until: an acquire check and the CPU's hint)
  std::uint32_t yields = 0;  // sched_yield calls after the spins
};

// The budget of each regime.
struct wait_budgets {
  wait_budget dedicated;
  wait_budget oversubscribed;
};

// The channels' budgets on a machine so calibrated: dedicated, polls lasting
// one futex round trip (round_trip_spin_ns: the 90th percentile hand-over);
// oversubscribed, kOversubscribedSpins then kOversubscribedYields.
inline wait_budgets channel_budgets(const platform::wait_calibration& machine) noexcept {
  return {wait_budget{machine.round_trip_spin_polls(), 0},
          wait_budget{kOversubscribedSpins, kOversubscribedYields}};
}

// One participant's view of the census: touched only by its own thread, kept
// in the channel's per-participant line (so checking it costs no extra line).
struct regime_view {
  bool enrolled = false;
  bool settled = false;
  wait_regime regime = wait_regime::dedicated;
  wait_budget budget;  // the census's dedicated budget from enrolment, the regime's once settled
};

// Which regime a team of participants runs in.
class regime_census {
 public:
  // `budgets`: this machine's calibrated ones unless a test passes others.
  explicit regime_census(unsigned participants,
                         const wait_budgets& budgets = channel_budgets(platform::machine_wait_calibration())) noexcept
      : participants_(participants), budgets_(budgets) {}
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
      view.budget = budgets_.dedicated;
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
  const wait_budgets& budgets() const noexcept { return budgets_; }

 private:
  void settle(regime_view& view) noexcept {
    // (E2) acquire: pairs with every participant's (E1).
    if (enrolled_.load(std::memory_order_acquire) < participants_) return;
    const unsigned cpus = cpus_.count();
    // An empty union means the kernel would not say: assume a CPU each.
    view.regime = (cpus != 0 && participants_ > cpus) ? wait_regime::oversubscribed : wait_regime::dedicated;
    view.budget = view.regime == wait_regime::dedicated ? budgets_.dedicated : budgets_.oversubscribed;
    view.settled = true;
  }

  unsigned participants_;
  wait_budgets budgets_;  // written by the constructor only
  cpu_union cpus_;
  alignas(platform::kCacheLine) std::atomic<unsigned> enrolled_{0};
};

// Polls ready() with the budget, then calls block() (which returns only once
// ready() holds). ready() must be cheap and perform the caller's acquire.
// hint() is the CPU's spin hint; a test passes a fake one.
template <class Ready, class Block, class Hint = platform::cpu_hint>
inline void wait_until(Ready&& ready, const wait_budget& budget, sync_counters& counters, Block&& block,
                       Hint&& hint = Hint{}) {
  if (platform::spin_until(ready, budget.spins, hint)) return;
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
