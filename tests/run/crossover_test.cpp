// The crossover finder (bench/run/crossover.hpp) on constructed curves: the
// speedups and intervals are made up, so every answer is known.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "bench/run/crossover.hpp"

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
    series.pin = "compact";
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

}  // namespace
}  // namespace lockstep::bench
