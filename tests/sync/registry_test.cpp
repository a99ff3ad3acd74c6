// The registry lists every primitive of DESIGN.md once, with what the harness
// needs to know about it.
#include <set>
#include <string>
#include <string_view>

#include <gtest/gtest.h>

#include "sync/registry.hpp"

namespace lockstep::sync {
namespace {

TEST(Registry, ListsEveryPrimitiveOfTheDesignOnce) {
  const std::set<std::string_view> design = {
      "std_barrier",    "win_event_faithful", "win_event",        "futex_spin",    "seqlock",
      "spsc_queue",     "pthread_barrier",    "omp_barrier",      "ck_centralized", "ck_dissemination",
      "ck_tournament",  "ck_mcs",             "ck_combining"};
  std::set<std::string_view> listed;
  for (const auto& info : all_primitive_info) {
    EXPECT_TRUE(listed.insert(info.name).second) << info.name << " listed twice";
    EXPECT_FALSE(info.description.empty()) << info.name;
    EXPECT_EQ(info.description.find('\n'), std::string_view::npos) << info.name << ": one line";
  }
  EXPECT_EQ(listed, design);
}

TEST(Registry, KindsAndRegimesAreWhatTheHarnessBoundsBy) {
  for (const auto& info : all_primitive_info) {
    const std::string name(info.name);
    EXPECT_EQ(info.pure_spin, name.rfind("ck_", 0) == 0) << name;
    EXPECT_EQ(info.may_lose_wakeups, name == "win_event_faithful") << name;
    EXPECT_EQ(info.kind == primitive_kind::channel, name == "seqlock" || name == "spsc_queue") << name;
    // Only the library barriers hide their futex calls; the others count every wait or never sleep.
    EXPECT_EQ(info.counts_futex_waits,
              name != "std_barrier" && name != "pthread_barrier" && name != "omp_barrier") << name;
  }
  ASSERT_NE(find_primitive("futex_spin"), nullptr);
  EXPECT_EQ(find_primitive("futex_spin")->name, "futex_spin");
  EXPECT_EQ(find_primitive("no_such_sync"), nullptr);
}

TEST(Registry, EveryPrimitiveRunsAsABarrierOnItsTeam) {
  std::size_t visited = 0;
  for_each_primitive([&]<class Primitive>() {
    static_assert(phase_barrier<as_barrier_t<Primitive>>);
    using team = team_of_t<as_barrier_t<Primitive>>;
    static_assert(std::is_same_v<team, omp_team> == std::is_same_v<Primitive, omp_barrier>);
    ++visited;
  });
  EXPECT_EQ(visited, all_primitives::size);
}

}  // namespace
}  // namespace lockstep::sync
