#pragma once
// The bitwise-determinism scenario of the composed RK4 step, shared by the
// matrix suites (unit, sanitize subset, stress): run a sync x layout x
// threads x placement combination for some steps, in segments, and require
// the state after each segment to be bit for bit the serial staged RK4's.
//
// Registration is dynamic (::testing::RegisterTest), one CTest test per
// combination, named Matrix.<sync>/<layout>/threads<T>/pin_<placement>,
// so that a failure names its combination and a filter can pick one.
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <functional>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "kernels/oscillator.hpp"
#include "kernels/parallel_step.hpp"
#include "kernels/rk4.hpp"
#include "layouts/registry.hpp"
#include "platform/placement.hpp"
#include "platform/topology.hpp"
#include "sync/registry.hpp"
#include "tests/support/watchdog.hpp"

namespace lockstep::testing::matrix {

// 1 ms: the paper's oscillator (periods of 0.12 s and 0.32 s) is well
// resolved, and a few hundred steps cover a fraction of a period.
inline constexpr double kStepSize = 1e-3;

using platform::placement;

// The machine, loaded once before any test pins a thread (hwloc records the
// affinity set at load time).
inline const platform::topology& machine() {
  static const platform::topology loaded = platform::topology::this_machine();
  return loaded;
}

// Pins each participant by the platform's placement plan (none: the whole
// affinity set; compact: one per core, cores sharing caches first, wrapping
// when there are more participants than cores). A pinning failure is a test
// failure, never an exception out of a team body.
struct pin_hook {
  platform::placement_plan plan;

  pin_hook(placement kind, unsigned threads) : plan(platform::plan_placement(machine(), kind, threads)) {}

  void operator()(unsigned participant) const {
    try {
      platform::pin_current_thread(plan, participant);
    } catch (const std::exception& error) {
      ADD_FAILURE() << "pinning participant " << participant << ": " << error.what();
    }
  }
};

inline unsigned cpu_count() { return platform::affinity_cpu_count(); }

// Where two states first differ, with both values' bits, or empty if equal.
inline std::string first_difference(const std::vector<double>& parallel, std::span<const double> serial) {
  if (parallel.size() != serial.size()) return "sizes differ";
  for (std::size_t index = 0; index < parallel.size(); ++index) {
    if (std::memcmp(&parallel[index], &serial[index], sizeof(double)) != 0) {
      std::ostringstream out;
      out.precision(17);
      out << "x" << index + 1 << ": parallel " << parallel[index] << " serial " << serial[index];
      return out.str();
    }
  }
  return {};
}

// Steps for a combination: a few hundred, fewer where a primitive is slow by
// design in this regime, fewer still under a sanitizer:
//  * primitives whose waiters spin long (kSpinsLong: the pure-spin ck
//    barriers, and omp_barrier, whose libgomp waiters spin up to
//    GOMP_SPINCOUNT, 300000 by default, before sleeping). On a loaded 2-core
//    machine a phase can last a timeslice whenever the thread they wait for
//    is not running, which is always the case with more threads than CPUs
//    (measured here: 40-250 ms per phase with 4 threads on 2 busy CPUs): 10
//    steps, and 3 (12 phases) when oversubscribed;
//  * lost wake-ups (kMayLoseWakeups: win_event_faithful) cost a timeout
//    each: a fifth.
template <class Sync>
constexpr bool spins_long() {
  return sync::info_of<Sync>().spins_long;
}

template <class Sync>
std::uint64_t steps_for(unsigned threads, std::uint64_t base) {
  std::uint64_t steps = base;
  if (spins_long<Sync>() && threads > 1) return threads > cpu_count() ? 3 : 10;
  if (sync::info_of<Sync>().may_lose_wakeups && threads > 1) steps = base / 5;
  if (kSlowdown > 1) steps = steps / 3;
  return steps < 3 ? 3 : steps;
}

// The scenario: segments of 1, a third, and the rest of `steps` steps, each
// run by a fresh team on the same step object (so resuming is checked too).
template <class Sync, class Layout, class Model, kernels::sync_timing Timing = kernels::sync_timing::off>
void expect_bitwise_serial(const Model& model, unsigned threads, placement pin, std::uint64_t steps) {
  const watchdog guard(std::chrono::milliseconds(60'000 * kSlowdown),
                       std::string(Sync::kName) + " x " + std::string(Layout::kName) + " stalled");
  const std::vector<double> initial = model.initial_state();
  kernels::parallel_rk4<Sync, Layout, Model, Timing> parallel(model, kStepSize, threads, initial);
  kernels::staged_rk4<Model> serial(model, kStepSize, initial);
  const pin_hook hook(pin, threads);
  const std::uint64_t segments[] = {1, steps / 3, steps - 1 - steps / 3};
  std::uint64_t done = 0;
  for (std::uint64_t segment : segments) {
    const sync::sync_counters counters = kernels::run_team(parallel, segment, hook);
    serial.run(segment);
    done += segment;
    ASSERT_EQ(parallel.steps_taken(), done);
    if (sync::info_of<Sync>().may_lose_wakeups && counters.timeouts > 0) {
      // The paper's ThreadWaiter synchronises only while it loses no wake-up
      // (see tests/sync/conformance.hpp): after a timeout a participant may
      // read a stage that is not complete, so the trajectory is no longer an
      // oracle. The harness flags such entries the same way; the test is
      // reported as skipped, not passed.
      GTEST_SKIP() << Sync::kName << " x " << Layout::kName << " lost wake-ups (" << counters.timeouts
                   << " timeouts) in the segment ending after " << done
                   << " steps: the bitwise check is not applicable after a lost wake-up";
    }
    const std::string difference = first_difference(parallel.state(), serial.state());
    ASSERT_TRUE(difference.empty()) << "after " << done << " steps the trajectory is not bitwise serial: "
                                    << difference;
  }
  if constexpr (Timing != kernels::sync_timing::off) {
    // on: every stage; sampled: every stage of steps 0, 16, 32, ...
    const std::uint64_t timed_steps =
        Timing == kernels::sync_timing::on
            ? steps
            : (steps + kernels::kSyncTimingSampleSteps - 1) / kernels::kSyncTimingSampleSteps;
    for (unsigned participant = 0; participant < threads; ++participant)
      EXPECT_EQ(parallel.sync_time(participant).syncs, kernels::kRk4Stages * timed_steps)
          << "participant " << participant << " timed the wrong number of stage syncs";
  }
}

// A test whose body is a closure: what RegisterTest's factory returns.
class scenario_test : public ::testing::Test {
 public:
  explicit scenario_test(std::function<void()> body) : body_(std::move(body)) {}
  void TestBody() override { body_(); }

 private:
  std::function<void()> body_;
};

inline void register_scenario(const std::string& suite, const std::string& name, std::function<void()> body) {
  ::testing::RegisterTest(suite.c_str(), name.c_str(), nullptr, nullptr, __FILE__, __LINE__,
                          [body = std::move(body)]() -> ::testing::Test* { return new scenario_test(body); });
}

template <class Sync, class Layout>
std::string combination_name(unsigned threads, placement pin) {
  return std::string(Sync::kName) + "/" + std::string(Layout::kName) + "/threads" + std::to_string(threads) +
         "/pin_" + std::string(platform::to_string(pin));
}

// A chain's test name: <sync>/<layout>/masses<S>/threads<T>.
template <class Sync, class Layout>
std::string chain_name(std::size_t masses, unsigned threads) {
  return std::string(Sync::kName) + "/" + std::string(Layout::kName) + "/masses" + std::to_string(masses) +
         "/threads" + std::to_string(threads);
}

// The layouts a primitive runs with in the subsets that cannot afford every
// sync x layout pair (the sanitize and stress matrices): each primitive takes
// the applicable layout used least so far (registry order breaks ties), so
// that the layouts rotate through the primitives of the subset; cover() then
// names, for a layout no primitive took, the first primitive of the subset it
// applies to. Every primitive and every layout of the registries appears at
// least once, and no name is involved.
class layout_rotation {
 public:
  // The index (in layouts::all_layouts) of the layout for Sync; counts it.
  template <class Sync>
  std::size_t next() {
    std::size_t chosen = kNone;
    std::size_t index = 0;
    layouts::for_each_layout([&]<class Layout>() {
      if (kernels::applicable<Sync, Layout>().applicable && (chosen == kNone || uses_[index] < uses_[chosen]))
        chosen = index;
      ++index;
    });
    // Every primitive is a phase_barrier or a graph_channel, and per_thread
    // applies to both: no applicable layout is a broken registry, not a skip.
    if (chosen == kNone) throw std::logic_error(std::string(Sync::kName) + ": no layout of the registry applies");
    ++uses_[chosen];
    return chosen;
  }
  bool used(std::size_t layout) const noexcept { return uses_[layout] > 0; }
  void count(std::size_t layout) noexcept { ++uses_[layout]; }

  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);

 private:
  std::array<unsigned, std::tuple_size_v<layouts::all_layouts>> uses_{};
};

// Calls visit.template operator()<Layout>() for the layout at `index` of
// layouts::all_layouts (instantiating it only for the layouts Sync applies to).
template <class Sync, class Visitor>
void with_layout(std::size_t index, Visitor&& visit) {
  std::size_t position = 0;
  layouts::for_each_layout([&]<class Layout>() {
    if constexpr (kernels::applicable<Sync, Layout>().applicable) {
      if (position == index) visit.template operator()<Layout>();
    }
    ++position;
  });
}

// After a rotation over the primitives of a subset (in_subset<Sync>()): calls
// visit.template operator()<Sync, Layout>() for every layout the rotation did
// not use, with the first primitive of the subset it applies to.
template <class InSubset, class Visitor>
void cover_unused_layouts(layout_rotation& rotation, InSubset in_subset, Visitor&& visit) {
  std::size_t index = 0;
  layouts::for_each_layout([&]<class Layout>() {
    const std::size_t layout = index++;
    sync::for_each_primitive([&]<class Sync>() {
      if constexpr (kernels::applicable<Sync, Layout>().applicable) {
        if (!rotation.used(layout) && in_subset.template operator()<Sync>()) {
          rotation.count(layout);
          visit.template operator()<Sync, Layout>();
        }
      }
    });
  });
}

}  // namespace lockstep::testing::matrix
