#pragma once
// The contracts every synchronisation primitive in sync/ satisfies, and the
// per-participant counters they keep.
//
// Two shapes of primitive compose the RK4 step (kernels/parallel_step.hpp):
//
//  * phase_barrier: every participant calls arrive_and_wait() once per phase;
//    no participant returns from phase p before all participants have arrived
//    at phase p. Memory ordering: everything a participant wrote before
//    arriving happens-before everything any participant does after returning
//    (the barrier is a release by each arriver and an acquire by each leaver).
//
//  * stage_channel (dataflow): producer `self` publishes its values for a
//    stage; a consumer receives the values of one producer for one stage,
//    waiting until that producer has published them. A consumer waits only for
//    the producers it depends on. Memory ordering: the values received are
//    exactly the values published for that stage (no torn or stale read), and
//    everything the producer wrote before publish() happens-before everything
//    the consumer does after receive() returns.
//    Stage numbering: each producer publishes stages 0, 1, 2, ... in order
//    (the RK4 step numbers them step * 4 + stage); each consumer receives each
//    producer's stages in order too. A producer may run several stages ahead
//    of a consumer it does not itself depend on (in the RK4 graph up to about
//    3); every channel holds kDepth stages per producer and applies
//    back-pressure (the producer waits) before it would overwrite a stage a
//    consumer has not received, so an overrun cannot happen.
//    Every stage_channel is also usable as a phase_barrier through
//    channel_barrier (channel_barrier.hpp), which is how the conformance suite
//    checks it.
//
// Traits: every primitive declares, as static constexpr members, the facts
// that the harness and the tests act on (registered_primitive below; the
// registry, sync/registry.hpp, copies them into primitive_info). Nothing
// anywhere recovers a fact from a primitive's name.
//
// Teams: a primitive runs its participants on a team. Most use plain threads
// (std_thread_team); OpenMP's barrier only works inside an OpenMP parallel
// region, so omp_barrier names its own team. team_of<S> picks the right one.
#include <concepts>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "platform/cache_line.hpp"

namespace lockstep::sync {

// What a primitive did, counted per participant by the participant's own
// thread: a plain increment on a cache line that no other thread writes.
struct sync_counters {
  std::uint64_t futex_waits = 0;      // FUTEX_WAIT calls (or waits on an event) that slept
  std::uint64_t futex_wakes = 0;      // FUTEX_WAKE calls issued
  std::uint64_t yields = 0;           // sched_yield calls
  std::uint64_t spins_exhausted = 0;  // spin budgets that ran out before the phase completed
  std::uint64_t timeouts = 0;         // waits that ended by timeout (lost wake-ups)

  sync_counters& operator+=(const sync_counters& other) noexcept {
    futex_waits += other.futex_waits;
    futex_wakes += other.futex_wakes;
    yields += other.yields;
    spins_exhausted += other.spins_exhausted;
    timeouts += other.timeouts;
    return *this;
  }
};

// One participant: its index in [0, participants) and its counters. Owned and
// written only by the participant's thread; aligned so that neighbours in an
// array do not share a line.
struct alignas(platform::kCacheLine) participant {
  unsigned id = 0;
  sync_counters counters{};
};
static_assert(sizeof(participant) % platform::kCacheLine == 0,
              "participants in an array must not share a cache line");

// What kind of primitive a type is (sync/registry.hpp lists every one).
enum class primitive_kind { barrier, channel };

// Who reads whom in a dataflow stage: producers_of[consumer] lists the
// producers whose stage values `consumer` receives. A participant never
// receives from itself (it holds its own values). Channels need the graph at
// construction so that a producer knows which consumers it must not overrun.
struct dependency_graph {
  std::vector<std::vector<unsigned>> producers_of;

  unsigned participants() const noexcept { return static_cast<unsigned>(producers_of.size()); }

  bool depends(unsigned consumer, unsigned producer) const noexcept {
    for (unsigned candidate : producers_of[consumer])
      if (candidate == producer) return true;
    return false;
  }

  // Every participant depends on every other one: the graph that turns a
  // channel into a barrier (channel_barrier.hpp).
  static dependency_graph all_to_all(unsigned participants) {
    dependency_graph graph;
    graph.producers_of.resize(participants);
    for (unsigned consumer = 0; consumer < participants; ++consumer)
      for (unsigned producer = 0; producer < participants; ++producer)
        if (producer != consumer) graph.producers_of[consumer].push_back(producer);
    return graph;
  }

  // Throws std::invalid_argument on an out-of-range producer or a self-edge.
  void validate() const {
    for (unsigned consumer = 0; consumer < participants(); ++consumer)
      for (unsigned producer : producers_of[consumer])
        if (producer >= participants() || producer == consumer)
          throw std::invalid_argument("dependency_graph: a consumer names itself or a producer out of range");
  }
};

template <class B>
concept phase_barrier = std::constructible_from<B, unsigned> && requires(B& barrier, participant& self) {
  { B::kName } -> std::convertible_to<std::string_view>;
  barrier.arrive_and_wait(self);
};

template <class C>
concept stage_channel = requires(C& channel, participant& self, unsigned producer, std::uint64_t stage,
                                 std::span<const double> values, std::span<double> received) {
  { C::kName } -> std::convertible_to<std::string_view>;
  channel.publish(self, stage, values);
  channel.receive(self, producer, stage, received);
};

// A channel built from a dependency graph and the number of doubles each
// producer publishes per stage: what channel_barrier and the RK4 step construct.
template <class C>
concept graph_channel = stage_channel<C> && std::constructible_from<C, const dependency_graph&, std::size_t>;

// ---- The traits every registered primitive declares ------------------------
// One concept per trait, each named after it, so that a primitive lacking one
// fails with "required for the satisfaction of 'declares_visible_to_tsan<P>'
// ... the required expression 'P::kVisibleToTsan' is invalid" (and a trait of
// the wrong type with "does not satisfy return-type-requirement").

// kName: the name docs/design.md lists, unique in the registry; benchmark names carry it.
template <class P>
concept declares_name = requires {
  { P::kName } -> std::convertible_to<std::string_view>;
};
// kDescription: one line for `lockstep list`.
template <class P>
concept declares_description = requires {
  { P::kDescription } -> std::convertible_to<std::string_view>;
};
// kKind: barrier (phase_barrier) or channel (graph_channel, dataflow).
template <class P>
concept declares_kind = requires {
  { P::kKind } -> std::same_as<const primitive_kind&>;
};
// kPureSpin: its waiters never yield or sleep; with more participants than
// CPUs a phase completes only when the scheduler preempts a spinner.
template <class P>
concept declares_pure_spin = requires {
  { P::kPureSpin } -> std::same_as<const bool&>;
};
// kSpinsLong: a waiter may keep its CPU for a scheduler timeslice or more
// before it yields or sleeps (pure spin, or a spin count in the milliseconds
// such as libgomp's GOMP_SPINCOUNT), so a phase can last a timeslice whenever
// a participant it waits for is not running: bound such runs in steps.
template <class P>
concept declares_spins_long = requires {
  { P::kSpinsLong } -> std::same_as<const bool&>;
};
// kMayLoseWakeups: a wake-up can be lost; each loss ends in a timeout,
// counted in counters.timeouts, and after one the primitive may no longer
// order its participants (the paper's ThreadWaiter).
template <class P>
concept declares_may_lose_wakeups = requires {
  { P::kMayLoseWakeups } -> std::same_as<const bool&>;
};
// kCountsFutexWaits: counters.futex_waits (and wakes, yields, spins) is the
// truth: every sleep counted, or none can happen. False when the futex calls
// are hidden inside a library (libstdc++, glibc, libgomp).
template <class P>
concept declares_counts_futex_waits = requires {
  { P::kCountsFutexWaits } -> std::same_as<const bool&>;
};
// kVisibleToTsan: ThreadSanitizer sees the primitive's synchronisation (C++
// atomics, or library calls it intercepts or instruments). False for inline
// assembly and volatile accesses (ck) and uninstrumented libraries (libgomp):
// TSan would report races on the data the primitive does order.
template <class P>
concept declares_visible_to_tsan = requires {
  { P::kVisibleToTsan } -> std::same_as<const bool&>;
};

// What kKind says is what the type is.
template <class P>
concept shape_matches_kind = (P::kKind == primitive_kind::barrier && phase_barrier<P>) ||
                             (P::kKind == primitive_kind::channel && graph_channel<P>);
// A waiter that never yields keeps its CPU for as long as it waits.
template <class P>
concept pure_spin_spins_long = !P::kPureSpin || P::kSpinsLong;

// What sync/registry.hpp requires of every primitive it lists.
template <class P>
concept registered_primitive = declares_name<P> && declares_description<P> && declares_kind<P> &&
                               declares_pure_spin<P> && declares_spins_long<P> && declares_may_lose_wakeups<P> &&
                               declares_counts_futex_waits<P> && declares_visible_to_tsan<P> &&
                               shape_matches_kind<P> && pure_spin_spins_long<P>;

}  // namespace lockstep::sync
