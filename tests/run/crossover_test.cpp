// The crossover finder (bench/run/crossover.hpp) on constructed curves: the
// speedups and intervals are made up, so every answer is known. And the
// ceiling's side of a pair (chain_split_runner) runs.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "bench/run/crossover.hpp"
#include "bench/run/crossover_sweep.hpp"
#include "bench/run/answer.hpp"
#include "bench/run/run_book.hpp"
#include "bench/run/rk4_entries.hpp"
#include "bench/run/team_driver.hpp"
#include "tests/support/run_file_entries.hpp"
#include "platform/placement.hpp"
#include "platform/topology.hpp"
#include "tests/support/watchdog.hpp"

namespace lockstep::bench {
namespace {

// A doubling grid from 2 masses, one (median, low, high) per point.
std::vector<crossover_point> curve(const std::vector<ratio_estimate>& speedups) {
  std::vector<crossover_point> points;
  double masses = 2.0;
  for (const auto& speedup : speedups) {
    points.push_back({masses, speedup});
    masses *= 2.0;
  }
  return points;
}

TEST(CrossoverFinder, OneCrossingIsInterpolatedInLogMassesAndConfirmedAbove) {
  // 2: 0.25, 4: 0.5, 8: 2 (log-linear: 1 is crossed at 4 * 2^(1/2)), 16: 4.
  const auto found = find_crossover(curve({{0.25, 0.2, 0.3}, {0.5, 0.4, 0.6}, {2.0, 1.5, 2.5}, {4.0, 3.0, 5.0}}));
  EXPECT_EQ(found.status, crossover_status::crossed);
  ASSERT_TRUE(found.masses);
  EXPECT_NEAR(*found.masses, 4.0 * std::sqrt(2.0), 1e-9);
  ASSERT_TRUE(found.low && found.high);
  EXPECT_LE(*found.low, *found.masses);
  EXPECT_GE(*found.high, *found.masses);
  EXPECT_GT(*found.low, 4.0);  // the high end (0.6 at 4) rises above 1 only after 4
  EXPECT_LT(*found.high, 8.0);  // the low end is above 1 at 8
  ASSERT_TRUE(found.confirmed_at);
  EXPECT_EQ(*found.confirmed_at, 8.0);
  EXPECT_FALSE(found.contradicted_at);
}

TEST(CrossoverFinder, ACrossingOverSizesSetAsideIsOnlyKnownToLieBetweenTheSizesMeasured) {
  // 8 and 256 measured, 16 to 128 set aside: the speedup's narrow intervals
  // would interpolate to a narrow S*; the interval is the gap's.
  const std::vector<crossover_point> points{
      {4.0, {0.3, 0.29, 0.31}}, {8.0, {0.5, 0.49, 0.51}}, {256.0, {2.0, 1.98, 2.02}}, {512.0, {3.0, 2.9, 3.1}}};
  const auto found = find_crossover(points);
  EXPECT_EQ(found.status, crossover_status::crossed);
  ASSERT_TRUE(found.masses && found.low && found.high);
  EXPECT_GT(*found.masses, 8.0);
  EXPECT_LT(*found.masses, 256.0);
  EXPECT_EQ(*found.low, 8.0);
  EXPECT_EQ(*found.high, 256.0);
  // On the doubling grid the same curve's ends are interpolated.
  const auto adjacent = find_crossover(curve({{0.5, 0.49, 0.51}, {2.0, 1.98, 2.02}, {3.0, 2.9, 3.1}}));
  ASSERT_TRUE(adjacent.low && adjacent.high);
  EXPECT_GT(*adjacent.low, 2.0);
  EXPECT_LT(*adjacent.high, 4.0);
}

TEST(CrossoverFinder, NoneWithinTheBudgetWhenTheMedianNeverRisesAboveOne) {
  const auto found = find_crossover(curve({{0.1, 0.08, 0.12}, {0.3, 0.2, 0.4}, {0.6, 0.5, 0.7}, {0.9, 0.8, 1.05}}));
  EXPECT_EQ(found.status, crossover_status::none_within_sweep);
  EXPECT_FALSE(found.masses);
  EXPECT_FALSE(found.confirmed_at);
  EXPECT_EQ(find_crossover({}).status, crossover_status::none_within_sweep);
}

TEST(CrossoverFinder, ANoisyCrossingIsTheLastRiseAndItsIntervalIsWide) {
  // The median rises above 1 at 8, falls back at 16, rises again at 32 to stay.
  const auto found = find_crossover(curve({{0.5, 0.4, 0.6},
                                           {0.8, 0.6, 1.1},
                                           {1.05, 0.8, 1.3},
                                           {0.97, 0.7, 1.2},
                                           {1.2, 0.95, 1.4},
                                           {1.6, 1.3, 1.9}}));
  EXPECT_EQ(found.status, crossover_status::crossed);
  ASSERT_TRUE(found.masses);
  EXPECT_GT(*found.masses, 16.0);
  EXPECT_LT(*found.masses, 32.0);
  // The high end is above 1 from 4 on but falls to 1.2 only: its last rise is
  // before 4; the low end clears 1 between 32 and 64.
  ASSERT_TRUE(found.low && found.high);
  EXPECT_LT(*found.low, 4.0);
  EXPECT_GT(*found.high, 32.0);
  EXPECT_LT(*found.high, 64.0);
  ASSERT_TRUE(found.confirmed_at);
  EXPECT_EQ(*found.confirmed_at, 64.0);
}

TEST(CrossoverFinder, ACrossingThePointAboveContradictsIsUnconfirmed) {
  // Above 1 at 8, then back below at 16 and 32: a point above S* contradicts it.
  const auto found =
      find_crossover(curve({{0.5, 0.4, 0.6}, {0.8, 0.7, 0.9}, {1.1, 1.02, 1.2}, {0.9, 0.85, 0.95}, {0.8, 0.7, 0.9}}));
  EXPECT_EQ(found.status, crossover_status::crossed_unconfirmed);
  ASSERT_TRUE(found.masses);
  EXPECT_GT(*found.masses, 4.0);
  EXPECT_LT(*found.masses, 8.0);
  ASSERT_TRUE(found.contradicted_at);
  EXPECT_EQ(*found.contradicted_at, 16.0);
  EXPECT_FALSE(found.confirmed_at);
  EXPECT_FALSE(found.high);  // the low end is not above 1 at the end of the sweep
}

TEST(CrossoverFinder, ACrossingWithNoPointAboveClearOfOneIsUnconfirmed) {
  // The last point rises above 1, its interval straddling 1: nothing confirms it.
  const auto found = find_crossover(curve({{0.5, 0.4, 0.6}, {0.8, 0.7, 0.9}, {1.1, 0.9, 1.3}}));
  EXPECT_EQ(found.status, crossover_status::crossed_unconfirmed);
  EXPECT_FALSE(found.confirmed_at);
  EXPECT_FALSE(found.contradicted_at);
  EXPECT_FALSE(found.high);
}

TEST(CrossoverFinder, AboveOneFromTheFirstPointIsAlways) {
  const auto found = find_crossover(curve({{1.5, 1.2, 1.8}, {2.0, 1.7, 2.3}}));
  EXPECT_EQ(found.status, crossover_status::always);
  ASSERT_TRUE(found.masses);
  EXPECT_EQ(*found.masses, 2.0);
  EXPECT_FALSE(found.low);
  ASSERT_TRUE(found.confirmed_at);
  EXPECT_EQ(*found.confirmed_at, 2.0);
  EXPECT_EQ(to_string(found.status), "always");
}

// A sweep of two series at 2 threads: the leader crosses, the baseline does not.
crossover_sweep two_series() {
  crossover_sweep sweep;
  sweep.budget_ns = 120'000'000'000;
  sweep.max_masses = 16;
  const auto series_of = [](const char* sync, bool leader, const std::vector<ratio_estimate>& speedups) {
    crossover_series series;
    series.threads = 2;
    series.pin = platform::placement::compact;
    series.sync = sync;
    series.layout = "per_thread";
    series.leader = leader;
    series.stage_sync_ns = 100.0;
    std::size_t masses = 2;
    for (const auto& speedup : speedups) {
      crossover_sweep_point point;
      point.masses = masses;
      point.threads = 2;
      point.serial_ns = 10.0 * static_cast<double>(masses);
      point.parallel_ns = point.serial_ns / speedup.median;
      point.speedup = speedup;
      point.pairs = 16;
      point.model_ns = point.serial_ns / 2.0 + 400.0;
      series.points.push_back(point);
      masses *= 2;
    }
    series.crossover = find_crossover(crossover_points(series));
    return series;
  };
  sweep.series.push_back(series_of("mailbox", true, {{0.25, 0.2, 0.3}, {0.5, 0.4, 0.6}, {2.0, 1.5, 2.5}, {4.0, 3.0, 5.0}}));
  sweep.series.back().stop_reason = "confirmed";
  sweep.series.push_back(series_of("std_barrier", false, {{0.1, 0.08, 0.12}, {0.2, 0.1, 0.3}, {0.4, 0.3, 0.5}, {0.6, 0.5, 0.7}}));
  sweep.series.back().stop_reason = "largest_size";
  sweep.series.back().points.back().pairs_set_aside = 2;
  return sweep;
}

TEST(CrossoverLines, OneLinePerThreadCountTheLeaderFirstInFull) {
  const auto lines = crossover_lines(two_series());
  ASSERT_EQ(lines.size(), 1u);
  const std::string& line = lines.front();
  EXPECT_EQ(line.rfind("Crossover at 2 threads (pin:compact): mailbox pays off from about 6 masses [", 0), 0u) << line;
  EXPECT_NE(line.find("(6 equations a thread)"), std::string::npos) << line;
  EXPECT_NE(line.find("std_barrier: none within the sweep up to 16 masses (best 0.60x [0.50, 0.70] at 16"),
            std::string::npos)
      << line;
  EXPECT_NE(line.find("below that, step serially"), std::string::npos) << line;
  EXPECT_NE(line.find("2 pairs set aside"), std::string::npos) << line;
}

TEST(CrossoverLines, AboveOneFromTheFirstSizeMeasuredSaysTheSizesBelowWereNot) {
  crossover_sweep sweep = two_series();
  sweep.series.resize(1);
  crossover_series& series = sweep.series.front();
  series.points[0].pairs = 0;
  series.points[0].pairs_set_aside = 16;
  series.points[0].failure = "every pair set aside: another process took a CPU";
  series.points[1].speedup = {1.2, 1.1, 1.3};
  series.crossover = find_crossover(crossover_points(series));
  ASSERT_EQ(series.crossover.status, crossover_status::always);
  const std::string line = crossover_lines(sweep).front();
  EXPECT_NE(line.find("mailbox pays off at every size measured, from 4 masses (the sizes below were not measured"),
            std::string::npos)
      << line;
}

TEST(CrossoverJson, TheReadersNamesWithEveryPointAndTheModel) {
  const nlohmann::json json = crossover_json(two_series());
  ASSERT_EQ(json["crossovers"].size(), 2u);
  const auto& leader = json["crossovers"][0];
  EXPECT_EQ(leader["status"], "crossed");
  EXPECT_EQ(leader["sync"], "mailbox");
  EXPECT_EQ(leader["layout"], "per_thread");
  EXPECT_EQ(leader["confirmed_at"], 8.0);
  EXPECT_TRUE(leader["masses"].is_number());
  EXPECT_TRUE(leader["ci_low"].is_number());
  EXPECT_TRUE(leader["ci_high"].is_number());
  ASSERT_EQ(leader["points"].size(), 4u);
  const auto& point = leader["points"][2];
  EXPECT_EQ(point["masses"], 8);
  EXPECT_EQ(point["equations_per_thread"], 8.0);
  EXPECT_DOUBLE_EQ(point["model_ns"].get<double>(), 40.0 + 400.0);
  EXPECT_DOUBLE_EQ(point["measured_over_model"].get<double>(), 40.0 / 440.0);
  const auto& baseline = json["crossovers"][1];
  EXPECT_EQ(baseline["status"], "none_within_sweep");
  EXPECT_TRUE(baseline["masses"].is_null());
  EXPECT_TRUE(baseline["ci_low"].is_null());
  EXPECT_EQ(baseline["points"][3]["cpu_taken"], true);
  EXPECT_EQ(json["lines"].size(), 1u);
}

// The ceiling at 2 threads beside two_series(): 1.8x at every size, measured
// up to `largest` masses.
crossover_sweep with_ceiling(std::size_t largest) {
  crossover_sweep sweep = two_series();
  crossover_ceiling ceiling{2, platform::placement::compact, {}};
  for (std::size_t masses = 2; masses <= largest; masses *= 2) {
    crossover_sweep_point point;
    point.masses = masses;
    point.threads = 2;
    point.serial_ns = 10.0 * static_cast<double>(masses);
    point.parallel_ns = point.serial_ns / 1.8;
    point.speedup = {1.8, 1.7, 1.9};
    point.pairs = 16;
    ceiling.points.push_back(point);
  }
  sweep.ceilings.push_back(ceiling);
  return sweep;
}

TEST(CrossoverLines, TheCeilingAtTheLargestSizeTheLeaderMeasuredAndTheShareItReached) {
  const auto lines = crossover_lines(with_ceiling(16));
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].rfind("Crossover at 2 threads", 0), 0u) << lines[0];
  const std::string& line = lines[1];
  EXPECT_EQ(line.rfind("Ceiling at 2 threads (pin:compact), 16 masses: 2 blocks of the chain stepped at once", 0), 0u)
      << line;
  EXPECT_NE(line.find("no exchange and no sync (what the machine gives an even split) give"), std::string::npos) << line;
  EXPECT_NE(line.find("give 1.80x [1.70, 1.90] the serial step's speed; mailbox gives 4.00x [3.00, 5.00], 2.22 of it"),
            std::string::npos)
      << line;
}

TEST(CrossoverLines, ACeilingBeyondTheLeadersSizesIsQuotedWhereTheLeaderWasMeasured) {
  crossover_sweep sweep = with_ceiling(64);
  sweep.series.front().points.pop_back();  // the leader measured up to 8 masses
  const auto lines = crossover_lines(sweep);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[1].find("), 8 masses:"), std::string::npos) << lines[1];
  EXPECT_NE(lines[1].find("mailbox gives 2.00x [1.50, 2.50], 1.11 of it"), std::string::npos) << lines[1];
}

TEST(CrossoverLines, NoCeilingLineWithoutAMeasuredCeiling) {
  crossover_sweep sweep = with_ceiling(16);
  for (auto& point : sweep.ceilings.front().points) {
    point.pairs = 0;
    point.failure = "every pair set aside: another process took a CPU";
  }
  EXPECT_EQ(crossover_lines(sweep).size(), 1u);
  EXPECT_FALSE(share_of_ceiling(sweep, sweep.series.front().points.back()).has_value());
}

// A rival the matrix's pair could not tell from the choice leads in the
// sweep too, and both are named in the ceiling's line.
TEST(CrossoverLines, ARivalTiedWithTheChoiceIsNamedAsSuchAndInTheCeilingLine) {
  crossover_sweep sweep = with_ceiling(16);
  crossover_series tied = sweep.series.front();
  tied.sync = "seqlock";
  tied.points.back().speedup = {1.2, 1.1, 1.3};
  tied.crossover = find_crossover(crossover_points(tied));
  sweep.series.insert(sweep.series.begin() + 1, tied);
  const auto lines = crossover_lines(sweep);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].rfind("Crossover at 2 threads (pin:compact): mailbox pays off from about 6 masses [", 0), 0u)
      << lines[0];
  EXPECT_NE(lines[0].find("; seqlock (tied with it in the matrix) from about 6 ["), std::string::npos) << lines[0];
  EXPECT_NE(lines[0].find("; std_barrier: none within the sweep"), std::string::npos) << lines[0];
  EXPECT_NE(lines[1].find("; mailbox gives 4.00x [3.00, 5.00], 2.22 of it; seqlock gives 1.20x [1.10, 1.30], 0.67 of it"),
            std::string::npos)
      << lines[1];
}

// Two series of one primitive at a thread count are told apart by layout.
TEST(CrossoverLines, TwoSeriesOfOnePrimitiveAreNamedByLayout) {
  crossover_sweep sweep = two_series();
  crossover_series tied = sweep.series.front();
  tied.layout = "packed";
  sweep.series.insert(sweep.series.begin() + 1, tied);
  const std::string line = crossover_lines(sweep).front();
  EXPECT_NE(line.find(": mailbox + per_thread pays off from about 6 masses"), std::string::npos) << line;
  EXPECT_NE(line.find("; mailbox + packed (tied with it in the matrix) from about 6"), std::string::npos) << line;
}

// A point whose interval is wide takes another batch: the batches' pairs
// pooled, the estimate made again over all of them.
TEST(CrossoverBatches, AWideIntervalTakesAnotherBatchPooledWithTheFirst) {
  paired_result first;
  first.ratios = {1.0, 1.9, 1.2, 1.8, 1.1, 1.7};
  first.unit_ns_a = {10.0, 19.0, 12.0, 18.0, 11.0, 17.0};
  first.unit_ns_b = std::vector<double>(6, 10.0);
  first.set_aside = {3.0};
  first.estimate = bootstrap_median(first.ratios);
  EXPECT_TRUE(interval_too_wide(first));
  paired_result narrow = first;
  narrow.estimate = {1.5, 1.45, 1.55};
  EXPECT_FALSE(interval_too_wide(narrow));
  paired_result failed = first;
  failed.failure = "stalled";
  EXPECT_FALSE(interval_too_wide(failed));

  const double first_width = first.estimate.high - first.estimate.low;
  paired_result second;
  second.ratios = std::vector<double>(12, 1.75);
  second.unit_ns_a = std::vector<double>(12, 17.5);
  second.unit_ns_b = std::vector<double>(12, 10.0);
  second.set_aside = {2.0, 4.0};
  add_batch(first, second, kDefaultNoise);
  EXPECT_EQ(first.ratios.size(), 18u);
  EXPECT_EQ(first.unit_ns_a.size(), 18u);
  EXPECT_EQ(first.set_aside.size(), 3u);
  EXPECT_DOUBLE_EQ(first.estimate.median, 1.75);
  EXPECT_LT(first.estimate.high - first.estimate.low, first_width);
  EXPECT_EQ(first.verdict, ratio_verdict::penalty);
}

// The series the sweep plans from a run book and its choices.
class CrossoverPlan : public ::testing::Test {
 protected:
  void SetUp() override {
    add_step("mailbox", "per_thread", 1000.0);
    add_step("seqlock", "per_thread", 1040.0);
    add_step("std_barrier", "packed", 6100.0);
    add_step("std_barrier", "padded64", 5800.0);
    choice.threads = 2;
    choice.pin = platform::placement::compact;
    choice.entry = name_of("mailbox", "per_thread");
    choice.sync = "mailbox";
    choice.layout = "per_thread";
  }
  static std::string name_of(const std::string& sync, const std::string& layout) {
    return "rk4/sync:" + sync + "/layout:" + layout + "/pin:compact/threads:2";
  }
  void add_step(const std::string& sync, const std::string& layout, double ns_per_step) {
    captured_entry entry;
    entry.name = name_of(sync, layout);
    entry.spec = lockstep::testing::spec_from_old_name(entry.name);
    entry.repetitions.push_back({{"ns_per_step", ns_per_step}, {"sync_ns_per_stage", ns_per_step / 8.0}});
    book.record(std::move(entry));
  }
  void tie_with(const std::string& sync, const std::string& layout) {
    choice.tied = true;
    choice.runner_up = answer_rival{name_of(sync, layout), sync, layout, {1.01, 0.98, 1.04}, ratio_verdict::unsure};
  }
  static std::vector<std::string> names(const std::vector<crossover_series>& planned) {
    std::vector<std::string> found;
    for (const auto& series : planned)
      found.push_back(series.sync + "+" + series.layout + (series.leader ? " leads" : ""));
    return found;
  }
  run_book book;
  answer_choice choice;
};

TEST_F(CrossoverPlan, TheChoiceAndTheBaselineOnItsBestLayout) {
  EXPECT_EQ(names(plan_crossover_series(book, {choice})),
            (std::vector<std::string>{"mailbox+per_thread leads", "std_barrier+padded64"}));
}

TEST_F(CrossoverPlan, ARivalTiedWithTheChoiceLeadsToo) {
  tie_with("seqlock", "per_thread");
  const auto planned = plan_crossover_series(book, {choice});
  EXPECT_EQ(names(planned), (std::vector<std::string>{"mailbox+per_thread leads", "seqlock+per_thread leads",
                                                      "std_barrier+padded64"}));
  ASSERT_TRUE(planned[1].stage_sync_ns.has_value());
  EXPECT_DOUBLE_EQ(*planned[1].stage_sync_ns, 130.0);
  EXPECT_EQ(planned[1].stage_sync_entry, name_of("seqlock", "per_thread"));
}

TEST_F(CrossoverPlan, ABaselineTiedWithTheChoiceIsSweptOnce) {
  tie_with("std_barrier", "packed");
  EXPECT_EQ(names(plan_crossover_series(book, {choice})),
            (std::vector<std::string>{"mailbox+per_thread leads", "std_barrier+padded64"}));
}

TEST(CrossoverJson, TheCeilingAndEachPointsShareOfIt) {
  const nlohmann::json json = crossover_json(with_ceiling(16));
  ASSERT_EQ(json["ceilings"].size(), 1u);
  const auto& ceiling = json["ceilings"][0];
  EXPECT_EQ(ceiling["threads"], 2);
  EXPECT_EQ(ceiling["pin"], "compact");
  ASSERT_EQ(ceiling["points"].size(), 4u);
  EXPECT_DOUBLE_EQ(ceiling["points"][3]["blocks_ns"].get<double>(), 160.0 / 1.8);
  EXPECT_DOUBLE_EQ(ceiling["points"][3]["speedup"].get<double>(), 1.8);
  EXPECT_DOUBLE_EQ(json["crossovers"][0]["points"][3]["of_ceiling"].get<double>(), 4.0 / 1.8);
  EXPECT_TRUE(crossover_json(two_series())["crossovers"][0]["points"][3]["of_ceiling"].is_null());
  EXPECT_EQ(json["lines"].size(), 2u);
}

// The ceiling's side: every participant steps its own block of the chain,
// with no sync, in blocks of units like any side of a pair; a chain with
// fewer masses than threads has no such split.
TEST(CeilingRunner, StepsTheBlocksAtOnceAndRefusesAChainWithFewerMassesThanThreads) {
  using namespace std::chrono_literals;
  const lockstep::testing::watchdog guard(60s * lockstep::testing::kSlowdown, "the ceiling's block runner");
  const platform::topology machine = platform::topology::this_machine();
  harness_state harness;
  harness.machine = &machine;
  for (const unsigned threads : {1u, 2u, 4u}) {
    const block_runner_factory factory =
        chain_split_runner(harness, platform::placement::compact, threads, 8, true);
    ASSERT_TRUE(factory) << threads << " threads";
    const std::unique_ptr<block_runner> runner = factory();
    const auto unit_ns = runner->run_block(32);
    ASSERT_TRUE(unit_ns.has_value()) << threads << " threads";
    EXPECT_GT(*unit_ns, 0.0);
    EXPECT_TRUE(runner->last_facts().has_value()) << "accounting on: the block says what it saw";
  }
  EXPECT_FALSE(chain_split_runner(harness, platform::placement::compact, 4, 3, true));
}

}  // namespace
}  // namespace lockstep::bench
