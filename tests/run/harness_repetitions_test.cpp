// The harness's contract with Google Benchmark's repetitions (measure_entry,
// bench/run/team_driver.hpp): once a call of an entry stopped, every later call
// of it stops too.
//
// Why it matters: Google Benchmark 1.7.1 computes an entry's aggregates from
// its first repetition's statistics list, a pointer it leaves uninitialised
// when that repetition was flagged (google/benchmark#1406). A call that stops
// while Google Benchmark is still sizing the first repetition (the first call
// measured one batch, the next, with the predicted iteration count, runs out
// of its budget) becomes that repetition; if the next two repetitions then
// measured, `lockstep run` read a wild pointer and died with exit status 139
// (seen on a loaded 2-CPU machine after pinned 4-thread entries). This test
// makes that sequence happen on purpose, with a one-participant team and a
// call budget of zero for the second call, and checks what reaches the
// reporter: the first repetition flagged, and so every repetition flagged.
#include <benchmark/benchmark.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "bench/run/run_book.hpp"
#include "bench/run/team_driver.hpp"
#include "platform/placement.hpp"
#include "platform/topology.hpp"
#include "sync/concepts.hpp"
#include "sync/team.hpp"
#include "tests/support/watchdog.hpp"

namespace {

using namespace std::chrono_literals;
namespace bench = lockstep::bench;
namespace platform = lockstep::platform;
namespace sync = lockstep::sync;

// What Google Benchmark reported for each repetition (aggregates counted apart).
class repetition_recorder : public benchmark::BenchmarkReporter {
 public:
  struct repetition {
    bool flagged;
    std::string message;
  };

  bool ReportContext(const Context& /*context*/) override { return true; }
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      if (run.run_type == Run::RT_Iteration) {
        repetitions.push_back({run.error_occurred, run.error_message});
      } else {
        ++aggregates;
      }
    }
  }

  std::vector<repetition> repetitions;
  int aggregates = 0;
};

TEST(HarnessRepetitions, ACallStoppedWhileSizingTheFirstRepetitionStopsEveryLaterCall) {
  const lockstep::testing::watchdog guard(120s * lockstep::testing::kSlowdown,
                                          "measure_entry under Google Benchmark's repetitions");
  const platform::topology machine = platform::topology::this_machine();
  bench::run_book book;
  bench::harness_state harness;
  harness.machine = &machine;
  harness.book = &book;
  harness.settings.accounting = false;
  harness.settings.target_batch_ns = 100'000;  // batches of 0.1 ms: the first call is far below min_time
  const std::int64_t normal_budget = harness.settings.call_budget_ns;
  const platform::placement_plan plan = platform::plan_placement(machine, platform::placement::none, 1);
  const std::string name = "harness_test/stop_while_sizing";

  int calls = 0;
  benchmark::RegisterBenchmark(name.c_str(),
                               [&](benchmark::State& state) {
                                 ++calls;
                                 // The second call (the first repetition, sized) runs out of
                                 // its budget after its warm-up batch.
                                 harness.settings.call_budget_ns = calls == 2 ? 0 : normal_budget;
                                 sync::std_thread_team team(1);
                                 std::vector<bench::participant_slot> slots(1);
                                 std::uint64_t sink = 0;
                                 auto work = [&sink](sync::participant& /*self*/, std::uint64_t units) {
                                   for (std::uint64_t unit = 0; unit < units; ++unit)
                                     benchmark::DoNotOptimize(sink += unit);
                                 };
                                 bench::entry_call call{state, harness, name,  nullptr,
                                                        plan,  false,   bench::entry_unit::step, {}};
                                 (void)bench::measure_entry(
                                     call, bench::team_call_runner(team, slots, plan, harness.settings, work));
                                 harness.settings.call_budget_ns = normal_budget;
                               })
      ->UseManualTime()
      ->Repetitions(3)
      ->MinTime(0.5);

  repetition_recorder recorder;
  benchmark::RunSpecifiedBenchmarks(&recorder);
  benchmark::ClearRegisteredBenchmarks();

  ASSERT_EQ(recorder.repetitions.size(), 3u);
  ASSERT_GE(calls, 4) << "Google Benchmark did not size the first repetition over two calls";
  ASSERT_TRUE(recorder.repetitions[0].flagged)
      << "the stopped call did not become the first repetition: " << recorder.repetitions[0].message;
  for (const auto& repetition : recorder.repetitions) {
    EXPECT_TRUE(repetition.flagged) << "a repetition measured after a flagged first one";
    EXPECT_FALSE(repetition.message.empty());
  }
  EXPECT_EQ(recorder.aggregates, 0);
}

}  // namespace
