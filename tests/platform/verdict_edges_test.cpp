// The paired-ratio verdict at its exact edges: known answers at each edge of
// the noise band and one double beside it, on either side, for the rule
// (platform::verdict_of, platform/statistics.hpp) and for the paired ratios
// that call it (bench::verdict_of on an estimate, bench/results/paired_ratio.hpp).
//
// The band for noise p is [1 / (1 + p), 1 + p]; an interval end exactly on an
// edge lies inside it. So, with U = 1 + p and L = 1 / U:
//     penalty       low > U             gain          high < L
//     within noise  L <= low, high <= U  unsure        anything else
// The edges below are the contract's expressions (1.0 + noise, 1.0 / that), and
// each case moves one interval end by one double (std::nextafter) across the
// edge it tests. The literal cases beside them pin the edges' values, so that
// a band computed another way (1 - p for the lower edge) fails too.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "bench/results/paired_ratio.hpp"
#include "platform/statistics.hpp"

namespace {

namespace platform = lockstep::platform;
namespace bench = lockstep::bench;
using platform::verdict;

constexpr double kInfinity = std::numeric_limits<double>::infinity();

double above(double value) { return std::nextafter(value, kInfinity); }
double below(double value) { return std::nextafter(value, -kInfinity); }

struct edge_case {
  double low;
  double high;
  verdict expected;
  const char* what;
};

void expect_cases(double noise, const std::vector<edge_case>& cases) {
  for (const edge_case& c : cases) {
    SCOPED_TRACE(std::string(c.what) + " at noise " + std::to_string(noise));
    const verdict found = platform::verdict_of(c.low, c.high, noise);
    EXPECT_EQ(platform::to_string(found), platform::to_string(c.expected))
        << std::hexfloat << "[" << c.low << ", " << c.high << "]";
    // The paired ratios judge the estimate's two ends, whatever its median.
    for (const double median : {c.low, c.high, 1.0, 100.0}) {
      const bench::ratio_estimate estimate{median, c.low, c.high};
      EXPECT_EQ(bench::verdict_of(estimate, noise), c.expected) << "median " << median;
    }
    // Read the other way round, the verdict is the mirrored one.
    const bench::ratio_estimate estimate{1.0, c.low, c.high};
    EXPECT_EQ(bench::inverse(bench::verdict_of(estimate, noise)),
              c.expected == verdict::penalty ? verdict::gain
              : c.expected == verdict::gain  ? verdict::penalty
                                             : c.expected);
  }
}

std::vector<edge_case> cases_at(double noise) {
  const double upper = 1.0 + noise;
  const double lower = 1.0 / upper;
  const double far_above = 2.0 * upper;  // well beyond the band on either side
  const double far_below = lower / 2.0;
  return {
      // The upper edge from above: penalty needs the whole interval above it.
      {above(upper), far_above, verdict::penalty, "low one double above the upper edge"},
      {upper, far_above, verdict::unsure, "low on the upper edge (inside the band)"},
      {below(upper), far_above, verdict::unsure, "low one double below the upper edge"},
      {above(upper), above(upper), verdict::penalty, "a point one double above the upper edge"},
      {upper, upper, verdict::within_noise, "a point on the upper edge"},
      // The upper edge from inside: within noise needs high at or below it.
      {1.0, upper, verdict::within_noise, "high on the upper edge"},
      {1.0, below(upper), verdict::within_noise, "high one double below the upper edge"},
      {1.0, above(upper), verdict::unsure, "high one double above the upper edge"},
      // The lower edge from below: gain needs the whole interval below it.
      {far_below, below(lower), verdict::gain, "high one double below the lower edge"},
      {far_below, lower, verdict::unsure, "high on the lower edge (inside the band)"},
      {far_below, above(lower), verdict::unsure, "high one double above the lower edge"},
      {below(lower), below(lower), verdict::gain, "a point one double below the lower edge"},
      {lower, lower, verdict::within_noise, "a point on the lower edge"},
      // The lower edge from inside: within noise needs low at or above it.
      {lower, 1.0, verdict::within_noise, "low on the lower edge"},
      {above(lower), 1.0, verdict::within_noise, "low one double above the lower edge"},
      {below(lower), 1.0, verdict::unsure, "low one double below the lower edge"},
      // The whole band, and one double more on either side.
      {lower, upper, verdict::within_noise, "the band itself"},
      {below(lower), upper, verdict::unsure, "the band and one double below it"},
      {lower, above(upper), verdict::unsure, "the band and one double above it"},
      {far_below, far_above, verdict::unsure, "across both edges"},
  };
}

TEST(VerdictEdges, AtAndOneDoubleBesideEachEdgeOfTheDefaultBand) {
  ASSERT_DOUBLE_EQ(bench::kDefaultNoise, 0.05);
  expect_cases(bench::kDefaultNoise, cases_at(bench::kDefaultNoise));
}

TEST(VerdictEdges, AtAndOneDoubleBesideEachEdgeOfOtherBands) {
  for (const double noise : {0.01, 0.2, 1.0}) expect_cases(noise, cases_at(noise));
}

// Noise 0: the band is the single point 1; any interval that leaves it by
// one double is a change or unsure.
TEST(VerdictEdges, AZeroBandIsTheOnePointOne) {
  expect_cases(0.0, {
                        {1.0, 1.0, verdict::within_noise, "exactly 1"},
                        {above(1.0), above(1.0), verdict::penalty, "one double above 1"},
                        {below(1.0), below(1.0), verdict::gain, "one double below 1"},
                        {below(1.0), above(1.0), verdict::unsure, "1 and a double either side"},
                        {1.0, above(1.0), verdict::unsure, "1 and a double above"},
                    });
}

// The edges' values, written out: the lower edge is 1 / 1.05 = 0.952380...,
// not 1 - 0.05 = 0.95, so that an interval ending at 0.951 is a gain.
TEST(VerdictEdges, TheDefaultBandIsFrom1Over105To105) {
  const double noise = bench::kDefaultNoise;
  EXPECT_EQ(platform::verdict_of(1.0501, 1.2, noise), verdict::penalty);
  EXPECT_EQ(platform::verdict_of(1.0499, 1.2, noise), verdict::unsure);
  EXPECT_EQ(platform::verdict_of(0.97, 1.0499, noise), verdict::within_noise);
  EXPECT_EQ(platform::verdict_of(0.9, 0.951, noise), verdict::gain);
  EXPECT_EQ(platform::verdict_of(0.9, 0.9524, noise), verdict::unsure);
  EXPECT_EQ(platform::verdict_of(0.9524, 1.0, noise), verdict::within_noise);
  EXPECT_EQ(platform::verdict_of(0.9523, 1.0, noise), verdict::unsure);
  EXPECT_EQ(platform::to_string(verdict::within_noise), "within noise");
}

}  // namespace
