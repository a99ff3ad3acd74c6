// How the paired comparisons take their pairs (bench/run/paired_blocks.hpp):
// in rounds, one pair of every running comparison per round, so that a
// comparison's pairs lie spread over the pairing phase; a stalled side ends
// its comparison with a failure; the time budget cuts a comparison only after
// its first kMinPairs pairs. Block runners here are stand-ins that return a
// fixed time per unit and log the order in which blocks ran: no timing is
// asserted. And which comparisons a run plans (plan_comparisons: false sharing
// and migration) and which pace mode each repetition and pair is given
// (assign_pace_modes), on hand-made run books with known answers.
#include <gtest/gtest.h>

#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bench/run/pace.hpp"
#include "bench/run/paired_blocks.hpp"
#include "bench/run/reporters.hpp"
#include "bench/run/run_book.hpp"
#include "bench/run/team_driver.hpp"
#include "tests/support/run_file_entries.hpp"

namespace {

namespace bench = lockstep::bench;

// A side that takes `ns_per_unit` per unit (or stalls: empty) and appends its
// entry's name to `log` for every block.
class scripted_side final : public bench::block_runner {
 public:
  scripted_side(std::string name, std::optional<double> ns_per_unit, std::vector<std::string>& log)
      : name_(std::move(name)), ns_per_unit_(ns_per_unit), log_(log) {}
  std::optional<double> run_block(std::uint64_t /*units*/) override {
    log_.push_back(name_);
    return ns_per_unit_;
  }

 private:
  std::string name_;
  std::optional<double> ns_per_unit_;
  std::vector<std::string>& log_;
};

struct scripted_run {
  bench::run_book book;
  bench::harness_state harness;
  std::vector<std::string> log;
  std::vector<bench::comparison> plan;

  scripted_run() { harness.book = &book; }

  // A comparison of entry `name`/a against `name`/b, a taking `ratio` times b's time.
  void compare(const std::string& name, std::optional<double> ratio) {
    const std::string a = name + "/a";
    const std::string b = name + "/b";
    harness.block_runners[a] = [this, a, ratio] {
      return std::make_unique<scripted_side>(a, ratio ? std::optional<double>(*ratio * 100.0) : std::nullopt, log);
    };
    harness.block_runners[b] = [this, b] { return std::make_unique<scripted_side>(b, 100.0, log); };
    plan.push_back({bench::comparison_kind::false_sharing, name, a, b});
  }

  const bench::paired_result& result_of(const std::string& name) const {
    for (const auto& pair : book.pairs)
      if (pair.what.group == name) return pair;
    throw std::runtime_error("no result for " + name);
  }
};

TEST(PairedRounds, EveryRoundTakesOnePairOfEveryComparison) {
  scripted_run run;
  run.compare("first", 2.0);
  run.compare("second", 0.5);
  run.compare("third", 1.0);
  bench::pairing_settings settings;
  settings.pairs = 6;
  settings.budget_ns = std::int64_t{1} << 60;
  std::size_t progress_calls = 0;  // once a round, counting the rounds
  bench::measure_pairs(run.harness, run.plan, settings, [&](std::size_t round, std::size_t rounds) {
    ++progress_calls;
    EXPECT_EQ(round, progress_calls);
    EXPECT_EQ(rounds, 6u);
  });
  EXPECT_EQ(progress_calls, 6u);
  ASSERT_EQ(run.log.size(), 3u * 6u * 2u);
  // Round r holds blocks [6 r, 6 r + 6): each comparison's two blocks, once.
  for (std::size_t round = 0; round < 6; ++round) {
    std::map<std::string, int> blocks;
    for (std::size_t index = 6 * round; index < 6 * round + 6; ++index) ++blocks[run.log[index]];
    for (const char* name : {"first/a", "first/b", "second/a", "second/b", "third/a", "third/b"})
      EXPECT_EQ(blocks[name], 1) << "round " << round << ", " << name;
  }
  // The order alternates within a comparison: A B on even pairs, B A on odd ones.
  std::string first;  // the first comparison's sides in order, one letter per block
  for (const auto& name : run.log)
    if (name.rfind("first/", 0) == 0) first += name.back();
  EXPECT_EQ(first.substr(0, 4), "abba");
  EXPECT_DOUBLE_EQ(run.result_of("first").estimate.median, 2.0);
  EXPECT_DOUBLE_EQ(run.result_of("second").estimate.median, 0.5);
  EXPECT_EQ(run.result_of("first").verdict, bench::ratio_verdict::penalty);
  EXPECT_EQ(run.result_of("second").verdict, bench::ratio_verdict::gain);
  EXPECT_EQ(run.result_of("third").verdict, bench::ratio_verdict::within_noise);
  EXPECT_EQ(run.result_of("third").ratios.size(), 6u);
}

TEST(PairedRounds, AStalledSideEndsItsComparisonOnly) {
  scripted_run run;
  run.compare("stalls", std::nullopt);
  run.compare("runs", 2.0);
  bench::pairing_settings settings;
  settings.pairs = 5;
  settings.budget_ns = std::int64_t{1} << 60;
  bench::measure_pairs(run.harness, run.plan, settings, {});
  EXPECT_FALSE(run.result_of("stalls").failure.empty());
  EXPECT_TRUE(run.result_of("stalls").ratios.empty());
  EXPECT_TRUE(run.result_of("runs").failure.empty());
  EXPECT_EQ(run.result_of("runs").ratios.size(), 5u);
}

TEST(PairedRounds, TheBudgetCutsOnlyAfterTheFirstPairs) {
  scripted_run run;
  run.compare("cut", 2.0);
  bench::pairing_settings settings;
  settings.pairs = 10;
  settings.budget_ns = 0;
  bench::measure_pairs(run.harness, run.plan, settings, {});
  EXPECT_EQ(run.result_of("cut").ratios.size(), bench::kMinPairs);
  EXPECT_TRUE(run.result_of("cut").budget_cut);
}

TEST(PairedRounds, NoPairsMeasuresNothing) {
  scripted_run run;
  run.compare("none", 2.0);
  bench::pairing_settings settings;
  settings.pairs = 0;
  bench::measure_pairs(run.harness, run.plan, settings, {});
  EXPECT_TRUE(run.book.pairs.empty());
  EXPECT_TRUE(run.log.empty());
}

TEST(PairedRounds, AComparisonWithoutRunnersSaysSo) {
  scripted_run run;
  run.plan.push_back({bench::comparison_kind::migration, "orphan", "x/a", "x/b"});
  bench::pairing_settings settings;
  bench::measure_pairs(run.harness, run.plan, settings, {});
  ASSERT_EQ(run.book.pairs.size(), 1u);
  EXPECT_FALSE(run.book.pairs[0].failure.empty());
}

// ---- Which comparisons are planned (plan_comparisons), on hand-made books --

// An rk4 entry whose repetitions read these step times (and, for an unpinned
// entry, this many migrations per thousand steps).
bench::captured_entry step_entry(const std::string& name, const std::vector<double>& ns_per_step,
                                 double migrations_per_kstep = 0.0) {
  bench::captured_entry entry;
  entry.name = name;
  entry.spec = lockstep::testing::spec_from_old_name(name);
  for (const double value : ns_per_step)
    entry.repetitions.push_back({{"ns_per_step", value}, {"migrations_per_kstep", migrations_per_kstep}});
  return entry;
}

std::string step_name(const std::string& sync, const std::string& layout, const std::string& pin, unsigned threads) {
  return "rk4/sync:" + sync + "/layout:" + layout + "/pin:" + pin + "/threads:" + std::to_string(threads);
}

std::vector<bench::comparison> planned(const bench::run_book& book, bench::comparison_kind kind) {
  std::vector<bench::comparison> found;
  for (const bench::comparison& what : bench::plan_comparisons(book))
    if (what.kind == kind) found.push_back(what);
  return found;
}

// False sharing, per (sync, pin, threads): the layout whose writers share
// lines (packed) against the fastest layout that isolates them (padded64 or
// padded128, by the layout registry's writer_isolation), never against
// per_thread however fast (its writers share nothing, but it copies: another
// comparison). The medians decide, not the first repetition.
TEST(PlanComparisons, FalseSharingSetsPackedAgainstTheFastestPaddedLayout) {
  bench::run_book book;
  book.record(step_entry(step_name("futex_spin", "packed", "compact", 2), {100, 101, 99}));
  book.record(step_entry(step_name("futex_spin", "padded64", "compact", 2), {60, 90, 91}));  // median 90
  book.record(step_entry(step_name("futex_spin", "padded128", "compact", 2), {85, 80, 86}));  // median 85
  book.record(step_entry(step_name("futex_spin", "per_thread", "compact", 2), {10, 10, 10}));
  // Another placement is another group; without a padded layout, no comparison.
  book.record(step_entry(step_name("futex_spin", "packed", "none", 2), {100}));
  book.record(step_entry(step_name("futex_spin", "per_thread", "none", 2), {50}));
  const auto plan = planned(book, bench::comparison_kind::false_sharing);
  ASSERT_EQ(plan.size(), 1u);
  EXPECT_EQ(plan[0].group, "sync:futex_spin pin:compact threads:2");
  EXPECT_EQ(plan[0].a, step_name("futex_spin", "packed", "compact", 2));
  EXPECT_EQ(plan[0].b, step_name("futex_spin", "padded128", "compact", 2));
}

// A side that erred or collapsed is no side: the next fastest padded layout
// stands in, and without any the comparison is not planned.
TEST(PlanComparisons, FalseSharingLeavesOutEntriesThatErredOrCollapsed) {
  bench::run_book book;
  book.record(step_entry(step_name("mailbox", "packed", "compact", 4), {100}));
  auto erred = step_entry(step_name("mailbox", "padded128", "compact", 4), {70});
  erred.error = "stalled";
  book.record(erred);
  book.record(step_entry(step_name("mailbox", "padded64", "compact", 4), {80}));
  EXPECT_EQ(planned(book, bench::comparison_kind::false_sharing).at(0).b,
            step_name("mailbox", "padded64", "compact", 4));
  book.collapsed.insert(step_name("mailbox", "padded64", "compact", 4));
  EXPECT_TRUE(planned(book, bench::comparison_kind::false_sharing).empty());
}

// Migration, per (sync, threads): pin:none against pin:compact on the layout
// whose pinned entry is fastest among those whose unpinned entry migrated
// (migrations_per_kstep above 0: exactly 0 prices nothing).
TEST(PlanComparisons, MigrationIsOnTheBestPinnedLayoutThatMigrated) {
  bench::run_book book;
  // packed is the fastest pinned, but its unpinned entry never migrated.
  book.record(step_entry(step_name("std_barrier", "packed", "compact", 2), {50}));
  book.record(step_entry(step_name("std_barrier", "packed", "none", 2), {55}, 0.0));
  book.record(step_entry(step_name("std_barrier", "padded64", "compact", 2), {60}));
  book.record(step_entry(step_name("std_barrier", "padded64", "none", 2), {90}, 0.001));
  book.record(step_entry(step_name("std_barrier", "padded128", "compact", 2), {70}));
  book.record(step_entry(step_name("std_barrier", "padded128", "none", 2), {95}, 4.0));
  // A layout measured pinned only is not a side.
  book.record(step_entry(step_name("std_barrier", "per_thread", "compact", 2), {40}));
  const auto plan = planned(book, bench::comparison_kind::migration);
  ASSERT_EQ(plan.size(), 1u);
  EXPECT_EQ(plan[0].group, "sync:std_barrier threads:2 layout:padded64");
  EXPECT_EQ(plan[0].a, step_name("std_barrier", "padded64", "none", 2));
  EXPECT_EQ(plan[0].b, step_name("std_barrier", "padded64", "compact", 2));
}

TEST(PlanComparisons, NoMigrationWhereNoUnpinnedEntryMigrated) {
  bench::run_book book;
  book.record(step_entry(step_name("std_barrier", "packed", "compact", 4), {50}));
  book.record(step_entry(step_name("std_barrier", "packed", "none", 4), {55}, 0.0));
  auto uncounted = step_entry(step_name("std_barrier", "padded64", "none", 4), {90});
  for (auto& repetition : uncounted.repetitions) repetition.erase("migrations_per_kstep");  // not counted
  book.record(uncounted);
  book.record(step_entry(step_name("std_barrier", "padded64", "compact", 4), {60}));
  EXPECT_TRUE(planned(book, bench::comparison_kind::migration).empty());
}

// ---- The pace modes given to repetitions and pairs (assign_pace_modes) ------

// Modes by reading: 0 0 0 1 1 1 -1 (an outlier) 0.
bench::pace_modes six_readings_and_an_outlier() {
  bench::pace_modes modes;
  modes.modes.resize(2);
  modes.mode_of = {0, 0, 0, 1, 1, 1, -1, 0};
  return modes;
}

TEST(AssignPaceModes, ARepetitionGetsTheModeItsReadingsAgreeOnAndLosesTheIndices) {
  bench::run_book book;
  auto entry = step_entry(step_name("mailbox", "per_thread", "compact", 2), {10, 11, 12, 13, 14});
  const std::string before(bench::kPaceBeforeCounter);
  const std::string after(bench::kPaceAfterCounter);
  entry.repetitions[0].insert({{before, 0}, {after, 2}});  // both in mode 0
  entry.repetitions[1].insert({{before, 3}, {after, 5}});  // both in mode 1
  entry.repetitions[2].insert({{before, 2}, {after, 3}});  // straddles the change
  entry.repetitions[3].insert({{before, 5}, {after, 6}});  // ends on an outlier
  // repetitions[4]: no readings (a run without a pace probe): left alone.
  book.record(entry);
  bench::assign_pace_modes(book, six_readings_and_an_outlier());
  const auto& repetitions = book.entries().front().repetitions;
  const std::vector<double> expected{0, 1, -1, -1};
  for (std::size_t index = 0; index < expected.size(); ++index) {
    ASSERT_EQ(repetitions[index].count("pace_mode"), 1u) << index;
    EXPECT_EQ(repetitions[index].at("pace_mode"), expected[index]) << index;
    EXPECT_EQ(repetitions[index].count(before) + repetitions[index].count(after), 0u) << index;
  }
  EXPECT_EQ(repetitions[4].count("pace_mode"), 0u);
}

TEST(AssignPaceModes, EachPairGetsTheModeOfItsTwoReadings) {
  bench::run_book book;
  bench::paired_result pair;
  pair.ratios = {1.0, 1.1, 1.2, 1.3};
  // Pair 0 in mode 0, pair 1 across the change, pair 2 in mode 1, pair 3
  // after the last reading the trace knows (-1), and a reading pair with no
  // ratio (a failed last pair) adds no mode.
  pair.readings = {0, 1, 2, 3, 4, 5, 7, 9, 0, 0};
  pair.modes = {7, 7, 7, 7, 7};  // stale: replaced
  book.pairs.push_back(pair);
  bench::assign_pace_modes(book, six_readings_and_an_outlier());
  EXPECT_EQ(book.pairs[0].modes, (std::vector<int>{0, -1, 1, -1}));
}

}  // namespace
