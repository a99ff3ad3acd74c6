#pragma once
// Every synchronisation primitive of lockstep, as one compile-time type list,
// so that `lockstep list`, the bare `barrier/...` benchmarks, the `rk4/...`
// matrix and the conformance tests all iterate the same list: a new primitive
// joins everything by joining all_primitives.
//
// Every listed primitive satisfies registered_primitive (sync/concepts.hpp):
// it declares each trait below as a static constexpr member, and a primitive
// that lacks one fails to compile here with the trait's name.
//
// For each primitive P:
//   info_of<P>()       name (docs/design.md's), one-line description, kind
//                      (barrier or dataflow channel), pure_spin (may stall
//                      for a timeslice per phase when participants outnumber
//                      CPUs: bound it in time), spins_long (a waiter may keep
//                      its CPU for a timeslice or more before it yields or
//                      sleeps: pure spin, or libgomp's spin count; bound it in
//                      steps), visible_to_tsan (ThreadSanitizer sees its
//                      synchronisation), may_lose_wakeups (a lost
//                      wake-up ends in a timeout, counted in
//                      participant::counters.timeouts: bound it in time),
//                      counts_futex_waits (counters.futex_waits is the truth:
//                      every futex sleep counted, or none can happen; false
//                      for the library barriers whose futex calls are hidden
//                      inside libstdc++, glibc or libgomp: the harness then
//                      omits futex_waits_per_step rather than report a 0 it
//                      never counted; their wakes, yields and spins are just
//                      as hidden, so the bare entries omit those too);
//   as_barrier_t<P>    P itself for barriers, channel_barrier<P> for channels
//                      (every participant depending on all): what a bare
//                      barrier benchmark or the conformance suite runs;
//   team_of_t<as_barrier_t<P>>  the team its participants run on (team.hpp).
//   checked_by_tsan(info)  whether a ThreadSanitizer run can check P: it sees
//                      P's synchronisation and P orders its participants in
//                      every run (no lost wake-up). The TSan subsets of the
//                      tests are exactly the primitives for which it is true.
// Bounding a stalled run: phase_run.hpp (phase_stop: the same stop phase for
// every participant; run_phases: max phases + a time budget).
//
// Usage:
//   for_each_primitive<all_primitives>([]<class P>() { ... info_of<P>() ... });
//   for (const primitive_info& info : all_primitive_info) ...
#include <array>
#include <cstddef>
#include <string_view>

#include "sync/channel_barrier.hpp"
#include "sync/ck_centralized.hpp"
#include "sync/ck_combining.hpp"
#include "sync/ck_dissemination.hpp"
#include "sync/ck_mcs.hpp"
#include "sync/ck_tournament.hpp"
#include "sync/concepts.hpp"
#include "sync/futex_spin.hpp"
#include "sync/mailbox.hpp"
#include "sync/omp_barrier.hpp"
#include "sync/pthread_barrier.hpp"
#include "sync/seqlock.hpp"
#include "sync/spsc_queue.hpp"
#include "sync/std_barrier.hpp"
#include "sync/team.hpp"
#include "sync/win_event.hpp"
#include "sync/win_event_faithful.hpp"

namespace lockstep::sync {

template <class... Primitives>
struct type_list {
  static constexpr std::size_t size = sizeof...(Primitives);
};

// docs/design.md's table order (mailbox after spsc_queue); futex_spin's other
// phase layout right after it (futex_spin.hpp).
using all_primitives = type_list<std_barrier, win_event_faithful, win_event, futex_spin, futex_spin_alternative,
                                 seqlock, spsc_queue, mailbox, pthread_barrier, omp_barrier, ck_centralized,
                                 ck_dissemination, ck_tournament, ck_mcs, ck_combining>;

// The baseline the others are set against where one primitive must be
// (the run's answer, bench/run/answer.hpp: what synchronisation
// costs here, the paper's question): the C++20 standard's own barrier.
inline constexpr std::string_view kBaselinePrimitive = std_barrier::kName;

struct primitive_info {
  std::string_view name;
  std::string_view description;
  primitive_kind kind;
  bool pure_spin;         // may stall (a timeslice per phase) when participants outnumber CPUs
  bool may_lose_wakeups;  // a lost wake-up costs a timeout (counters.timeouts)
  bool counts_futex_waits;  // counters.futex_waits (wakes, yields, spins) are real, not a blind 0
  bool spins_long;          // a waiter may keep its CPU a timeslice or more before yielding or sleeping
  bool visible_to_tsan;     // ThreadSanitizer sees its synchronisation
};

// The traits are declared by the primitive and checked by registered_primitive
// (sync/concepts.hpp): a missing one is named in the compiler's message.
template <registered_primitive Primitive>
constexpr primitive_info info_of() noexcept {
  return {Primitive::kName,           Primitive::kDescription,     Primitive::kKind,
          Primitive::kPureSpin,       Primitive::kMayLoseWakeups, Primitive::kCountsFutexWaits,
          Primitive::kSpinsLong,      Primitive::kVisibleToTsan};
}

// A ThreadSanitizer run checks a primitive when TSan sees its synchronisation
// (otherwise it reports races on data the primitive does order: false
// positives) and the primitive orders its participants in every run (one that
// may lose wake-ups stops ordering them after a loss: the race TSan would then
// report is real and intended, and appears only in a run that loses one).
constexpr bool checked_by_tsan(const primitive_info& info) noexcept {
  return info.visible_to_tsan && !info.may_lose_wakeups;
}

template <class Primitive, primitive_kind Kind = Primitive::kKind>
struct as_barrier {
  using type = Primitive;
};
template <class Primitive>
struct as_barrier<Primitive, primitive_kind::channel> {
  using type = channel_barrier<Primitive>;
};
template <class Primitive>
using as_barrier_t = typename as_barrier<Primitive>::type;

// Calls visit.template operator()<P>() for every P in the list, in order.
template <class List>
struct for_each_primitive_in;
template <class... Primitives>
struct for_each_primitive_in<type_list<Primitives...>> {
  template <class Visitor>
  static constexpr void apply(Visitor&& visit) {
    (visit.template operator()<Primitives>(), ...);
  }
};
template <class List = all_primitives, class Visitor>
constexpr void for_each_primitive(Visitor&& visit) {
  for_each_primitive_in<List>::apply(visit);
}

template <class List>
struct primitive_info_table;
template <class... Primitives>
struct primitive_info_table<type_list<Primitives...>> {
  static constexpr std::array<primitive_info, sizeof...(Primitives)> value{info_of<Primitives>()...};
};
inline constexpr auto all_primitive_info = primitive_info_table<all_primitives>::value;

// nullptr when no primitive has that name (for --sync filters and `list`).
constexpr const primitive_info* find_primitive(std::string_view name) noexcept {
  for (const auto& info : all_primitive_info)
    if (info.name == name) return &info;
  return nullptr;
}

namespace detail {
template <class... Primitives>
constexpr bool names_unique(type_list<Primitives...>) {
  constexpr std::array<std::string_view, sizeof...(Primitives)> names{Primitives::kName...};
  for (std::size_t first = 0; first < names.size(); ++first)
    for (std::size_t second = first + 1; second < names.size(); ++second)
      if (names[first] == names[second]) return false;
  return true;
}
template <class... Primitives>
constexpr bool all_runnable_as_barriers(type_list<Primitives...>) {
  return (phase_barrier<as_barrier_t<Primitives>> && ...);
}
}  // namespace detail
static_assert(detail::names_unique(all_primitives{}), "every primitive needs its own name (the benchmark names use it)");
static_assert(detail::all_runnable_as_barriers(all_primitives{}),
              "every primitive must run as a phase_barrier (channels through channel_barrier)");

}  // namespace lockstep::sync
