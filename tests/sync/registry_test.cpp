// The registry lists every primitive of docs/design.md once, with the facts
// docs/design.md and sync/README.md state for it; and every primitive it lists
// (those or a new one) declares traits that are consistent with each other.
#include <set>
#include <string>
#include <string_view>
#include <type_traits>

#include <gtest/gtest.h>

#include "sync/registry.hpp"

namespace lockstep::sync {
namespace {

// The facts the design states, primitive by primitive: the specification the
// traits are checked against (the harness and the tests read the traits).
struct design_facts {
  std::string_view name;
  primitive_kind kind;
  bool pure_spin;
  bool spins_long;
  bool may_lose_wakeups;
  bool counts_futex_waits;  // only the library barriers hide their futex calls
  bool visible_to_tsan;     // ck: inline assembly; libgomp: not instrumented
};
constexpr auto kBarrier = primitive_kind::barrier;
constexpr auto kChannel = primitive_kind::channel;
constexpr design_facts kDesign[] = {
    // name                kind      pure   long   loses  counts tsan
    {"std_barrier",        kBarrier, false, false, false, false, true},
    {"win_event_faithful", kBarrier, false, false, true,  true,  true},
    {"win_event",          kBarrier, false, false, false, true,  true},
    {"futex_spin",         kBarrier, false, false, false, true,  true},
    {futex_spin_alternative::kName, kBarrier, false, false, false, true, true},
    {"seqlock",            kChannel, false, false, false, true,  true},
    {"spsc_queue",         kChannel, false, false, false, true,  true},
    {"mailbox",            kChannel, false, false, false, true,  true},
    {"pthread_barrier",    kBarrier, false, false, false, false, true},
    {"omp_barrier",        kBarrier, false, true,  false, false, false},
    {"ck_centralized",     kBarrier, true,  true,  false, true,  false},
    {"ck_dissemination",   kBarrier, true,  true,  false, true,  false},
    {"ck_tournament",      kBarrier, true,  true,  false, true,  false},
    {"ck_mcs",             kBarrier, true,  true,  false, true,  false},
    {"ck_combining",       kBarrier, true,  true,  false, true,  false},
};

TEST(Registry, ListsEveryPrimitiveOfTheDesignWithItsFacts) {
  for (const design_facts& design : kDesign) {
    const primitive_info* info = find_primitive(design.name);
    ASSERT_NE(info, nullptr) << design.name << " is in docs/design.md but not in the registry";
    EXPECT_EQ(info->kind, design.kind) << design.name;
    EXPECT_EQ(info->pure_spin, design.pure_spin) << design.name;
    EXPECT_EQ(info->spins_long, design.spins_long) << design.name;
    EXPECT_EQ(info->may_lose_wakeups, design.may_lose_wakeups) << design.name;
    EXPECT_EQ(info->counts_futex_waits, design.counts_futex_waits) << design.name;
    EXPECT_EQ(info->visible_to_tsan, design.visible_to_tsan) << design.name;
  }
}

TEST(Registry, NamesOnceAndOneLineDescriptions) {
  std::set<std::string_view> listed;
  for (const auto& info : all_primitive_info) {
    EXPECT_TRUE(listed.insert(info.name).second) << info.name << " listed twice";
    EXPECT_FALSE(info.name.empty());
    EXPECT_FALSE(info.description.empty()) << info.name;
    EXPECT_EQ(info.description.find('\n'), std::string_view::npos) << info.name << ": one line";
  }
  EXPECT_EQ(listed.size(), all_primitives::size);
  // One lookup, checked then read: GCC 12 at -O3 (the release and aarch64
  // presets) warned of a null dereference when a second lookup was read.
  const auto* futex_spin = find_primitive("futex_spin");
  ASSERT_NE(futex_spin, nullptr);
  EXPECT_EQ(futex_spin->name, "futex_spin");
  EXPECT_EQ(find_primitive("no_such_sync"), nullptr);
}

TEST(Registry, TraitsAgreeWithEachOther) {
  for (const auto& info : all_primitive_info) {
    // Checked at compile time too (registered_primitive); here for the table.
    EXPECT_TRUE(!info.pure_spin || info.spins_long) << info.name << ": a pure spinner keeps its CPU";
    EXPECT_EQ(checked_by_tsan(info), info.visible_to_tsan && !info.may_lose_wakeups) << info.name;
  }
}

TEST(Registry, EveryPrimitiveRunsAsABarrierOnItsTeam) {
  std::size_t visited = 0;
  for_each_primitive([&]<class Primitive>() {
    static_assert(registered_primitive<Primitive>);
    static_assert(phase_barrier<as_barrier_t<Primitive>>);
    using team = team_of_t<as_barrier_t<Primitive>>;
    static_assert(std::is_constructible_v<team, unsigned>);
    EXPECT_EQ(team(3).participants(), 3u) << Primitive::kName;
    ++visited;
  });
  EXPECT_EQ(visited, all_primitives::size);
  // OpenMP's barrier binds to an OpenMP parallel region: its own team.
  static_assert(std::is_same_v<team_of_t<omp_barrier>, omp_team>);
}

// A primitive lacking one trait is not a registered_primitive (the registry
// then fails to compile, naming the trait).
struct lacks_visible_to_tsan {
  static constexpr std::string_view kName = "lacks_visible_to_tsan";
  static constexpr std::string_view kDescription = "a barrier that forgot one trait";
  static constexpr primitive_kind kKind = primitive_kind::barrier;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = true;
  static constexpr bool kSpinsLong = false;
  explicit lacks_visible_to_tsan(unsigned /*participants*/) {}
  void arrive_and_wait(participant& /*self*/) {}
};
static_assert(phase_barrier<lacks_visible_to_tsan> && !declares_visible_to_tsan<lacks_visible_to_tsan> &&
              !registered_primitive<lacks_visible_to_tsan>);

}  // namespace
}  // namespace lockstep::sync
