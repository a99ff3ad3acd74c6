// The pace trace's modes and the paired ratios' statistics (bench/run:
// pace.hpp, paired_ratio.hpp) on synthetic traces and ratios whose answers are
// known: a trace with one switch of pace, a flat trace, a single outlier, the
// shares of an unevenly spaced trace, the mode gap and the smallest mode at
// their edges; a ratio set clearly above the noise band, one inside it, one
// clearly below.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "bench/run/pace.hpp"
#include "bench/results/paired_ratio.hpp"

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

// Readings every 10 ms with exactly these c2c values.
std::vector<bench::pace_reading> trace_of_exactly(const std::vector<double>& c2c) {
  std::vector<bench::pace_reading> trace;
  for (std::size_t index = 0; index < c2c.size(); ++index)
    trace.push_back({0.01 * static_cast<double>(index), c2c[index], 10.0 * c2c[index]});
  return trace;
}

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

// Readings at the given times (seconds) with the given c2c values exactly
// (no wobble: the known answers below sit on the rules' edges).
std::vector<bench::pace_reading> trace_at(const std::vector<double>& t_s, const std::vector<double>& c2c) {
  std::vector<bench::pace_reading> trace;
  for (std::size_t index = 0; index < t_s.size(); ++index) trace.push_back({t_s[index], c2c[index], 10.0 * c2c[index]});
  return trace;
}

std::vector<double> times_from(double start, double every, std::size_t count) {
  std::vector<double> times;
  for (std::size_t index = 0; index < count; ++index) times.push_back(start + every * static_cast<double>(index));
  return times;
}

// A mode's share is of the trace's time, not of its readings: each reading
// stands for the span to the next one, the last for the median span. Ten fast
// readings 10 ms apart (from 0 to 90 ms; the tenth's span runs to 100 ms),
// then ten slow ones 100 ms apart (100 ms to 1 s): the spans are ten of 10 ms
// and nine of 100 ms, whose median (10 ms) the last reading stands for. So
// the fast mode held 100 ms and the slow one 910 ms of 1010: shares of 10/101
// and 91/101, where counting readings would say half and half.
TEST(PaceModes, SharesAreOfTimeOnAnUnevenlySpacedTrace) {
  const auto trace = trace_at(joined(times_from(0.0, 0.01, 10), times_from(0.1, 0.1, 10)),
                              joined(repeated(25.0, 10), repeated(100.0, 10)));
  const bench::pace_modes modes = bench::find_modes(trace);
  ASSERT_EQ(modes.modes.size(), 2u);
  EXPECT_EQ(modes.modes[0].readings, 10u);
  EXPECT_EQ(modes.modes[1].readings, 10u);
  EXPECT_NEAR(modes.modes[0].share, 10.0 / 101.0, 1e-12);
  EXPECT_NEAR(modes.modes[1].share, 91.0 / 101.0, 1e-12);
  EXPECT_EQ(modes.changes, 1u);
}

// An outlier's span goes to the mode of the nearest earlier reading that has
// one; spans before the first moded reading go to no mode. Outliers at 0 s
// (before any mode) and at 0.3 s (span 0.5 s, inside the fast mode); the fast
// mode's readings at 0.1, 0.2 and 0.8 s, the slow mode's at 0.9, 1.0 and 1.1 s
// (the last stands for the median span, 0.1 s). The fast mode holds 0.1 + 0.1
// + 0.5 (the outlier's) + 0.1 = 0.8 s, the slow one 0.3 s; moving the first
// outlier back to -0.9 s (its span 1 s) changes nothing.
TEST(PaceModes, AnOutliersSpanGoesToTheModeBeforeIt) {
  const auto trace = trace_at({0.0, 1.0 / 10, 2.0 / 10, 3.0 / 10, 8.0 / 10, 9.0 / 10, 10.0 / 10, 11.0 / 10},
                              {900.0, 25.0, 25.0, 400.0, 25.0, 100.0, 100.0, 100.0});
  auto earlier = trace;
  earlier[0].t_s = -0.9;
  for (const auto& one : {trace, earlier}) {
    const bench::pace_modes modes = bench::find_modes(one);
    ASSERT_EQ(modes.modes.size(), 2u);
    EXPECT_EQ(modes.mode_of[0], -1);
    EXPECT_EQ(modes.mode_of[3], -1);
    EXPECT_NEAR(modes.modes[0].share, 0.8 / 1.1, 1e-12);
    EXPECT_NEAR(modes.modes[1].share, 0.3 / 1.1, 1e-12);
    EXPECT_EQ(modes.changes, 1u);
  }
}

// Two sorted neighbours more than kModeGap (1.5x) apart start a new mode; at
// exactly 1.5x they stay together. Neighbours, not the mode's ends: 20, 30
// and 45 ns (each 1.5x the one before) are one mode although 45 is 2.25x 20.
TEST(PaceModes, TheModeGapIsMoreThanOnePointFiveTimesTheNeighbour) {
  ASSERT_EQ(bench::kModeGap, 1.5) << "the known answers below are for a gap of 1.5";
  const auto at_gap = bench::find_modes(trace_of_exactly(joined(repeated(20.0, 3), repeated(30.0, 3))));
  EXPECT_EQ(at_gap.modes.size(), 1u) << "30 is exactly 1.5 x 20";
  const auto beyond = bench::find_modes(trace_of_exactly(joined(repeated(20.0, 3), repeated(30.000001, 3))));
  ASSERT_EQ(beyond.modes.size(), 2u) << "30.000001 is more than 1.5 x 20";
  EXPECT_EQ(beyond.modes[0].c2c_ns, 20.0);
  EXPECT_EQ(beyond.modes[1].c2c_ns, 30.000001);
  const auto chained =
      bench::find_modes(trace_of_exactly(joined(joined(repeated(20.0, 3), repeated(30.0, 3)), repeated(45.0, 3))));
  ASSERT_EQ(chained.modes.size(), 1u);
  EXPECT_EQ(chained.modes[0].readings, 9u);
  EXPECT_EQ(chained.modes[0].c2c_ns, 30.0) << "the median of the mode's readings";
}

// A cluster needs kMinModeReadings (3) readings to be a mode: two are
// outliers, and their time goes to the mode before them.
TEST(PaceModes, ThreeReadingsMakeAModeAndTwoDoNot) {
  ASSERT_EQ(bench::kMinModeReadings, 3u);
  const auto two = bench::find_modes(trace_of_exactly(joined(repeated(20.0, 4), repeated(100.0, 2))));
  ASSERT_EQ(two.modes.size(), 1u);
  EXPECT_EQ(two.mode_of[4], -1);
  EXPECT_DOUBLE_EQ(two.modes[0].share, 1.0);
  const auto three = bench::find_modes(trace_of_exactly(joined(repeated(20.0, 4), repeated(100.0, 3))));
  ASSERT_EQ(three.modes.size(), 2u);
  EXPECT_EQ(three.mode_of[4], 1);
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
