// The pace trace's modes and the paired ratios' statistics (bench/harness:
// pace.hpp, paired_ratio.hpp) on synthetic traces and ratios whose answers are
// known: a trace with one switch of pace, a flat trace, a single outlier; a
// ratio set clearly above the noise band, one inside it, one clearly below.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "bench/harness/pace.hpp"
#include "bench/harness/paired_ratio.hpp"

namespace {

namespace bench = lockstep::bench;

// Readings every 10 ms with c2c values from `c2c` (a small wobble added so
// that no two are equal) and a serial step that follows the same pace.
std::vector<bench::pace_reading> trace_of(const std::vector<double>& c2c) {
  std::vector<bench::pace_reading> trace;
  for (std::size_t index = 0; index < c2c.size(); ++index) {
    const double wobble = 1.0 + 0.03 * std::sin(static_cast<double>(index));
    trace.push_back({0.01 * static_cast<double>(index), c2c[index] * wobble, 12.0 * c2c[index] * wobble});
  }
  return trace;
}

std::vector<double> repeated(double value, std::size_t count) { return std::vector<double>(count, value); }

std::vector<double> joined(std::vector<double> a, const std::vector<double>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

TEST(PaceModes, AKnownSwitchGivesTwoModesAndOneChange) {
  const auto trace = trace_of(joined(repeated(25.0, 30), repeated(118.0, 20)));
  const bench::pace_modes modes = bench::find_modes(trace);
  ASSERT_EQ(modes.modes.size(), 2u);
  EXPECT_NEAR(modes.modes[0].c2c_ns, 25.0, 1.0);
  EXPECT_NEAR(modes.modes[1].c2c_ns, 118.0, 4.0);
  EXPECT_EQ(modes.changes, 1u);
  EXPECT_NEAR(modes.modes[0].share, 0.6, 0.03);
  EXPECT_NEAR(modes.modes[1].share, 0.4, 0.03);
  EXPECT_EQ(modes.mode_of.front(), 0);
  EXPECT_EQ(modes.mode_of.back(), 1);
  // A repetition read before and after the switch straddles it.
  EXPECT_EQ(bench::agreed_mode(modes, 29, 30), -1);
  EXPECT_EQ(bench::agreed_mode(modes, 10, 12), 0);
  EXPECT_NE(modes.summary().find("1 change"), std::string::npos);
}

TEST(PaceModes, AFlatTraceIsOneModeWithoutChanges) {
  const bench::pace_modes modes = bench::find_modes(trace_of(repeated(55.0, 40)));
  ASSERT_EQ(modes.modes.size(), 1u);
  EXPECT_EQ(modes.changes, 0u);
  EXPECT_DOUBLE_EQ(modes.modes[0].share, 1.0);
  for (int mode : modes.mode_of) EXPECT_EQ(mode, 0);
  EXPECT_NE(modes.summary().find("the pace held"), std::string::npos);
}

TEST(PaceModes, ASingleOutlierIsNeitherAModeNorAChange) {
  std::vector<double> values = repeated(25.0, 40);
  values[17] = 300.0;  // one preempted reading
  const bench::pace_modes modes = bench::find_modes(trace_of(values));
  ASSERT_EQ(modes.modes.size(), 1u);
  EXPECT_EQ(modes.changes, 0u);
  EXPECT_EQ(modes.mode_of[17], -1);
  EXPECT_EQ(modes.mode_of[16], 0);
}

TEST(PaceModes, BackAndForthCountsEveryChange) {
  const auto trace =
      trace_of(joined(joined(repeated(25.0, 10), repeated(60.0, 10)), joined(repeated(25.0, 10), repeated(60.0, 10))));
  const bench::pace_modes modes = bench::find_modes(trace);
  ASSERT_EQ(modes.modes.size(), 2u);
  EXPECT_EQ(modes.changes, 3u);
}

TEST(PaceModes, WithoutCoreToCoreTheSerialStepSetsTheModes) {
  auto trace = trace_of(joined(repeated(25.0, 10), repeated(118.0, 10)));
  for (auto& reading : trace) reading.c2c_ns.reset();
  const bench::pace_modes modes = bench::find_modes(trace);
  EXPECT_FALSE(modes.has_c2c);
  ASSERT_EQ(modes.modes.size(), 2u);
  EXPECT_NE(modes.summary().find("serial step"), std::string::npos);
}

TEST(PaceModes, AnEmptyTraceHasNoModes) {
  const bench::pace_modes modes = bench::find_modes({});
  EXPECT_TRUE(modes.modes.empty());
  EXPECT_EQ(bench::agreed_mode(modes, 0, 1), -1);
}

TEST(PairedRatio, AClearPenaltyIsCalledAPenalty) {
  const std::vector<double> ratios{1.31, 1.28, 1.35, 1.30, 1.29, 1.33, 1.27, 1.32, 1.30, 1.34};
  const bench::ratio_estimate estimate = bench::bootstrap_median(ratios);
  EXPECT_NEAR(estimate.median, 1.305, 1e-9);
  EXPECT_LE(estimate.low, estimate.median);
  EXPECT_GE(estimate.high, estimate.median);
  EXPECT_GT(estimate.low, 1.05);
  EXPECT_EQ(bench::verdict_of(estimate), bench::ratio_verdict::penalty);
}

TEST(PairedRatio, AGainIsCalledAGain) {
  const std::vector<double> ratios{0.61, 0.64, 0.60, 0.66, 0.63, 0.62, 0.65, 0.59};
  EXPECT_EQ(bench::verdict_of(bench::bootstrap_median(ratios)), bench::ratio_verdict::gain);
}

TEST(PairedRatio, AnIntervalInsideTheBandIsWithinNoiseAndOneAcrossAnEdgeUnsure) {
  const std::vector<double> ratios{0.97, 1.02, 1.04, 0.99, 1.01, 1.03, 0.98, 1.00};
  const bench::ratio_estimate estimate = bench::bootstrap_median(ratios);
  EXPECT_EQ(bench::verdict_of(estimate), bench::ratio_verdict::within_noise);
  // A wide interval that crosses the band's edge is unsure, however high its median: neither a
  // penalty nor within noise (platform/statistics.hpp).
  const std::vector<double> scattered{0.9, 2.5, 1.0, 3.0, 0.95, 2.8};
  const bench::ratio_estimate wide = bench::bootstrap_median(scattered);
  EXPECT_LT(wide.low, 1.05);
  EXPECT_GT(wide.high, 1.05);
  EXPECT_EQ(bench::verdict_of(wide), bench::ratio_verdict::unsure);
  EXPECT_EQ(bench::to_string(bench::verdict_of(wide)), "unsure");
}

TEST(PairedRatio, OneWildPairDoesNotMoveTheMedian) {
  std::vector<double> ratios{1.30, 1.29, 1.31, 1.30, 1.28, 1.32, 1.30, 1.31, 1.29};
  ratios.push_back(6.0);  // a pair that straddled a change of pace
  const bench::ratio_estimate estimate = bench::bootstrap_median(ratios);
  EXPECT_NEAR(estimate.median, 1.30, 0.01);
  EXPECT_EQ(bench::verdict_of(estimate), bench::ratio_verdict::penalty);
}

TEST(PairedRatio, TheIntervalIsReproducibleAndTheNoiseBandIsTheCallers) {
  const std::vector<double> ratios{1.08, 1.10, 1.07, 1.09, 1.11, 1.08};
  const auto first = bench::bootstrap_median(ratios);
  const auto second = bench::bootstrap_median(ratios);
  EXPECT_DOUBLE_EQ(first.low, second.low);
  EXPECT_DOUBLE_EQ(first.high, second.high);
  EXPECT_EQ(bench::verdict_of(first, 0.05), bench::ratio_verdict::penalty);
  EXPECT_EQ(bench::verdict_of(first, 0.20), bench::ratio_verdict::within_noise);
}

TEST(PairedRatio, OneRatioIsItsOwnInterval) {
  const auto estimate = bench::bootstrap_median({1.5});
  EXPECT_DOUBLE_EQ(estimate.low, 1.5);
  EXPECT_DOUBLE_EQ(estimate.high, 1.5);
  const auto none = bench::bootstrap_median({});
  EXPECT_DOUBLE_EQ(none.median, 0.0);
}

}  // namespace
