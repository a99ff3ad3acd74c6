#pragma once
// futex_spin: the suite's own barrier. Sense-reversing, spins with the CPU's
// spin hint for a bounded time, then sleeps on a futex; the last arriver calls
// FUTEX_WAKE only when someone sleeps; the spin budget adapts to
// oversubscription. One primitive for both regimes: spin like the pure-spin
// barriers when every participant has a CPU, block like the blocking ones when
// they do not.
//
// Contract
//  * Construct with the number of participants (>= 1). Each participant calls
//    arrive_and_wait(self) once per phase with its own participant record
//    (self.id in [0, participants), distinct per thread, the same every phase).
//  * No participant returns from phase p before every participant has arrived
//    at phase p. The barrier rearms itself: phase p + 1 may start at once.
//  * Destroy it only after every participant has returned from its last call
//    (the last arriver still touches the barrier after the others are free).
//  * Not copyable or movable: participants hold its address.
// Progress: blocking. A waiter spins (and, oversubscribed, yields) for at most
// its budget, then sleeps until the last arriver wakes it, so it never takes a
// CPU from the thread it waits for for longer than the budget: with 4
// participants on 2 CPUs (or on 1) it still makes progress.
// Memory ordering: everything a participant wrote before arrive_and_wait
// happens-before everything any participant does after its arrive_and_wait of
// the same phase returns (edges (1), (3), (4)/(6) below).
// Counters (self.counters): spins_exhausted when the spin and yield budget ran
// out, futex_waits per FUTEX_WAIT that slept or found the phase already over,
// futex_wakes per FUTEX_WAKE issued, yields per sched_yield. timeouts stay 0
// (it never times out). Every futex wait is counted (kCountsFutexWaits).
//
// Budget: a waiter spins for a time, in polls calibrated to this CPU at
// start-up (futex_spin_budgets below; platform/wait_calibration.hpp): about
// one futex round trip, itself measured at start-up, when the participants
// fit in the union of their affinity sets (learned during phase 0; see
// cpu_union), as the channels do (sync/wait_policy.hpp says why the whole
// round trip); about kOversubscribedSpinNs when they do not. Oversubscribed, it
// then yields its CPU up to kOversubscribedYields times before it sleeps: the
// participant it waits for is most likely runnable on this very CPU, and
// sched_yield hands the CPU over for the price of a syscall, where a futex
// sleep plus wake-up costs an IPI and two scheduler passes (on the 2-vCPU VM
// this was tuned on, bare pthread_barrier and win_event episodes, which sleep
// every phase, took 25-31 us; with sleeping only, futex_spin's RK4 step at 4
// threads on 2 CPUs was 10x std::barrier's, which yields in libstdc++'s
// atomic wait). The budget does not also shrink phase by phase: a first
// version halved the budget whenever it ran out, and one late wake-up then
// fed itself (the woken thread arrives late, so its partner's short spin runs
// out and it sleeps too), settling into sleeping every phase even with a core
// per participant.
//
// Across processes (template parameter futex_scope, platform/futex.hpp): with
// futex_scope::process_shared the barrier lives in memory that several
// processes map (distributed/shm_window.hpp places it in an MPI-3 shared
// window); it then holds everything inline (no heap pointer another process
// could not follow: at most kSharedParticipantsMax participant slots) and its
// futexes are the shared kind. The protocol is the same; the registry's
// entries are the process-private ones.
//
// Phase-word layout (template parameter, phase_lines): the arrival counter,
// the sense word and the sleepers count on one line (one_line, as in ck's
// centralized barrier), or the counter on a prefetch pair of its own and the
// sense word with the sleepers count on another (split_lines). Both are
// registered: `futex_spin` is basic_futex_spin<kDefaultPhaseLines> =
// split_lines, `futex_spin_one_line` the other. Why split: measured side by
// side inside the RK4 step (release preset, `lockstep run --interleave
// --threads 2,4 --repetitions 6` with both in the --sync list, 2-vCPU KVM VM,
// c2c one-way 60-74 ns; five runs; best layout of each, median step time):
// split / one_line was 0.78 (0.76..0.86) at 2 threads unpinned, 0.77
// (0.74..0.90) at 2 threads pinned one per core, 0.91 (0.87..0.92) at 4
// threads on 2 CPUs pinned and 0.95 (0.87..1.21) unpinned. With one line,
// every arrival's fetch_sub takes the line the others spin on, so each
// arrival costs the spinners a miss; split, the spinners' line changes once
// per phase. Bare episodes (no work between phases) tell them apart less:
// 0.84 (0.81..0.86) at 2 threads unpinned, 0.93 (0.83..0.98) pinned, about
// 1.0 at 4 threads (three of those runs). An earlier version kept one line
// from bare episodes alone; the step is what the suite measures.
#include <sched.h>

#include <array>
#include <atomic>
#include <cassert>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string_view>
#include <type_traits>

#include "platform/cache_line.hpp"
#include "platform/futex.hpp"
#include "platform/spin_budget.hpp"
#include "platform/wait_calibration.hpp"
#include "sync/affinity.hpp"
#include "sync/concepts.hpp"
#include "sync/wait_policy.hpp"

namespace lockstep::sync {

// With more participants than CPUs, the thread a waiter waits for is likely
// queued behind it on its own CPU: spin only long enough to catch a phase
// that is completing on another CPU right now, then get out of its way.
// 500 ns is what the earlier fixed count (32 pauses) lasted on the
// development VM (15 ns a PAUSE).
inline constexpr double kOversubscribedSpinNs = 500;
// futex_spin's budgets on a machine so calibrated: dedicated, polls lasting one
// futex round trip (the channels' figure: channel_budgets); oversubscribed,
// polls lasting kOversubscribedSpinNs, then the channels' kOversubscribedYields
// yields (each hands the CPU to a runnable participant, ~1 us when one is
// queued here, ~0.3 us when not: 64 bound the wait at about two futex round
// trips).
inline wait_budgets futex_spin_budgets(const platform::wait_calibration& machine) noexcept {
  return {channel_budgets(machine).dedicated,
          wait_budget{machine.polls_lasting(kOversubscribedSpinNs), kOversubscribedYields}};
}

// Where the phase's words live (the template parameter of basic_futex_spin).
//  * one_line: the arrival counter, the sense word every spinner reads and
//    the sleepers count share one line, as in ck's centralized barrier.
//  * split_lines: the arrival counter on a prefetch pair of its own; the
//    sense word and the sleepers count on another (the releaser reads
//    sleepers right after writing the sense: a hit on the line it owns).
enum class phase_lines { one_line, split_lines };
// The layout `futex_spin` (the registry's name) uses; the other is registered
// too, under its own name. Why this one: see the header.
inline constexpr phase_lines kDefaultPhaseLines = phase_lines::split_lines;

namespace detail {
template <phase_lines Lines>
struct futex_spin_phase;

template <>
struct alignas(platform::kCacheLine) futex_spin_phase<phase_lines::one_line> {
  static constexpr std::string_view kAlternativeName = "futex_spin_one_line";
  std::atomic<std::uint32_t> remaining{0};  // arrivals still missing in this phase
  std::atomic<std::uint32_t> sense{0};      // the futex word: 0/1, flips every phase
  std::atomic<std::uint32_t> sleepers{0};
};
static_assert(sizeof(futex_spin_phase<phase_lines::one_line>) == platform::kCacheLine,
              "one_line: the whole phase is exactly one line");

template <>
struct futex_spin_phase<phase_lines::split_lines> {
  static constexpr std::string_view kAlternativeName = "futex_spin_split";
  alignas(platform::kPrefetchPair) std::atomic<std::uint32_t> remaining{0};
  alignas(platform::kPrefetchPair) std::atomic<std::uint32_t> sense{0};
  std::atomic<std::uint32_t> sleepers{0};
};
static_assert(offsetof(futex_spin_phase<phase_lines::split_lines>, sense) -
                      offsetof(futex_spin_phase<phase_lines::split_lines>, remaining) >=
                  platform::kPrefetchPair,
              "split_lines: the counter and the sense word are a prefetch pair apart (not even adjacent lines)");
static_assert(offsetof(futex_spin_phase<phase_lines::split_lines>, sleepers) / platform::kCacheLine ==
                  offsetof(futex_spin_phase<phase_lines::split_lines>, sense) / platform::kCacheLine,
              "split_lines: the sleepers count shares the sense word's line");
}  // namespace detail

template <phase_lines Lines, platform::futex_scope Scope = platform::futex_scope::process_private>
class basic_futex_spin {
  using phase_word = detail::futex_spin_phase<Lines>;
  static constexpr bool kInline = Scope == platform::futex_scope::process_shared;

 public:
  static constexpr std::string_view kName = Lines == kDefaultPhaseLines ? "futex_spin" : phase_word::kAlternativeName;
  static constexpr std::string_view kDescription =
      Lines == phase_lines::one_line
          ? "sense-reversing barrier: bounded spin (a time), then FUTEX_WAIT; wakes only when someone sleeps; "
            "spin budget adapts to oversubscription; counter and sense on one line"
          : "sense-reversing barrier: bounded spin (a time), then FUTEX_WAIT; wakes only when someone sleeps; "
            "spin budget adapts to oversubscription; counter and sense on separate lines";
  static constexpr phase_lines kPhaseLines = Lines;
  static constexpr primitive_kind kKind = primitive_kind::barrier;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = true;
  // At most one futex round trip of spinning (measured at start-up, capped at
  // platform::kLongestRoundTripSpinNs), then yield or sleep.
  static constexpr bool kSpinsLong = false;
  static constexpr bool kVisibleToTsan = true;  // C++ atomics

  // The most participants a process-shared barrier holds (its slots are inline).
  static constexpr unsigned kSharedParticipantsMax = 256;

  // `budgets`: this machine's calibrated ones (futex_spin_budgets) unless a
  // test passes others.
  explicit basic_futex_spin(unsigned participants,
                            const wait_budgets& budgets = futex_spin_budgets(platform::machine_wait_calibration()))
      : participants_(participants), budgets_(budgets), slots_(make_slots(participants)) {
    assert(participants >= 1);
    assert(!kInline || participants <= kSharedParticipantsMax);
    phase_.remaining.store(participants, std::memory_order_relaxed);  // published by the thread start
  }
  basic_futex_spin(const basic_futex_spin&) = delete;  // participants hold its address
  basic_futex_spin& operator=(const basic_futex_spin&) = delete;

  unsigned participants() const noexcept { return participants_; }

  void arrive_and_wait(participant& self) noexcept {
    assert(self.id < participants_);
    slot& mine = slots_[self.id];
    if (mine.arrivals == 0) {
      // Phase 0: add our CPUs to the union; (1) publishes it with our arrival.
      // Until the union is known, wait as if every participant had a CPU.
      cpus_.add_calling_thread();
      mine.budget = budgets_.dedicated;
    } else if (mine.arrivals == 1) {
      // Phase 0 is over, so every participant's add is visible ((1) then (3)/(4)).
      const unsigned cpus = cpus_.count();
      const bool oversubscribed = cpus != 0 && participants_ > cpus;
      mine.budget = oversubscribed ? budgets_.oversubscribed : budgets_.dedicated;
    }
    ++mine.arrivals;
    const std::uint32_t sense = mine.sense ^ 1u;  // the value the sense word takes when this phase ends
    mine.sense = sense;

    // (1) acq_rel: release publishes this participant's writes to the last
    // arriver; acquire (in the last arriver) takes every earlier arriver's
    // release, since all the decrements form one release sequence on remaining.
    if (phase_.remaining.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      // (2) relaxed: rearm for the next phase. Ordered before (3), and nobody
      // decrements again before acquiring (3), so they all see the reset.
      phase_.remaining.store(participants_, std::memory_order_relaxed);
      // (3) seq_cst: the release half pairs with the acquire loads (4) and (6)
      // of the waiters (this publishes (1)'s gathered writes and (2)); the
      // seq_cst half pairs with (5) in a store-buffering pair: either we see a
      // sleeper at (7) or the sleeper sees this store at (6).
      phase_.sense.store(sense, std::memory_order_seq_cst);
      // (7) seq_cst: see (3) and (5).
      if (phase_.sleepers.load(std::memory_order_seq_cst) != 0) {
        platform::futex_wake<Scope>(phase_.sense);
        ++self.counters.futex_wakes;
      }
      return;
    }

    // Spin. (4) acquire: pairs with the release half of (3).
    if (platform::spin_until([&] { return phase_.sense.load(std::memory_order_acquire) == sense; },
                             mine.budget.spins))
      return;
    // Yield (oversubscribed only). (4') acquire: as (4), pairs with the
    // release half of (3).
    for (std::uint32_t yield = 0; yield < mine.budget.yields; ++yield) {
      sched_yield();
      ++self.counters.yields;
      if (phase_.sense.load(std::memory_order_acquire) == sense) return;
    }
    ++self.counters.spins_exhausted;

    // Sleep. (5) seq_cst: announce the sleeper before the check (6); pairs
    // with (3)/(7) as explained there.
    phase_.sleepers.fetch_add(1, std::memory_order_seq_cst);
    // (6) seq_cst (so also acquire, pairing with (3)): the check that the
    // kernel repeats atomically inside FUTEX_WAIT. A spurious or early return
    // (EINTR, EAGAIN, a wake-up for another word value) just loops here.
    while (phase_.sense.load(std::memory_order_seq_cst) != sense) {
      platform::futex_wait<Scope>(phase_.sense, sense ^ 1u);
      ++self.counters.futex_waits;
    }
    // (8) relaxed: the count only steers (7); a late decrement costs at most
    // one FUTEX_WAKE nobody needed. Each decrement follows its own increment in
    // the modification order of sleepers, so (7) never misses a real sleeper.
    phase_.sleepers.fetch_sub(1, std::memory_order_relaxed);
  }

 private:
  // Per participant, touched only by its own thread.
  struct alignas(platform::kCacheLine) slot {
    std::uint32_t sense = 0;
    wait_budget budget;  // set at phase 0 (dedicated), fixed at phase 1 (by regime)
    std::uint64_t arrivals = 0;
  };
  static_assert(alignof(phase_word) >= platform::kCacheLine, "the phase words must not share a line with anything else");
  static_assert(sizeof(slot) % platform::kCacheLine == 0, "participant slots must not share a line");
  // Private: one heap array of exactly the participants. Shared: inline, so
  // that the whole barrier is one block another process can map.
  using slot_storage = std::conditional_t<kInline, std::array<slot, kSharedParticipantsMax>, std::unique_ptr<slot[]>>;
  static slot_storage make_slots(unsigned participants) {
    if constexpr (kInline) {
      return slot_storage{};
    } else {
      return std::make_unique<slot[]>(participants);
    }
  }

  const unsigned participants_;
  const wait_budgets budgets_;
  phase_word phase_;
  slot_storage slots_;
  cpu_union cpus_;
};

// The registry's two entries: the default layout, and the other one.
using futex_spin = basic_futex_spin<kDefaultPhaseLines>;
using futex_spin_alternative = basic_futex_spin<kDefaultPhaseLines == phase_lines::one_line ? phase_lines::split_lines
                                                                                            : phase_lines::one_line>;
static_assert(phase_barrier<futex_spin>);
static_assert(phase_barrier<futex_spin_alternative>);

// The registry's futex_spin for processes that share its memory.
using process_shared_futex_spin = basic_futex_spin<kDefaultPhaseLines, platform::futex_scope::process_shared>;
static_assert(phase_barrier<process_shared_futex_spin>);
static_assert(std::is_trivially_destructible_v<process_shared_futex_spin>,
              "a process-shared futex_spin owns no resource (no heap pointer another process could not follow)");

}  // namespace lockstep::sync
