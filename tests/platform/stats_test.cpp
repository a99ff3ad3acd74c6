// Percentiles and histograms on inputs whose answers are known by hand (and
// agree with numpy.percentile's default, linear interpolation).
#include "platform/stats.hpp"
#include "platform/statistics.hpp"

#include <cstdint>
#include <numeric>
#include <span>
#include <vector>

#include <gtest/gtest.h>

namespace {

using lockstep::platform::histogram;
using lockstep::platform::quantile_of_sorted;
using lockstep::platform::summarize;

TEST(Stats, MedianOfAnEvenCountIsTheMeanOfTheMiddleTwo) {
  const std::vector<std::int64_t> samples{4, 1, 3, 2};
  const auto result = summarize(samples);
  EXPECT_EQ(result.count, 4U);
  EXPECT_DOUBLE_EQ(result.min, 1);
  EXPECT_DOUBLE_EQ(result.p50, 2.5);
  EXPECT_DOUBLE_EQ(result.max, 4);
  EXPECT_DOUBLE_EQ(result.mean, 2.5);
  // numpy.percentile([1,2,3,4], 99) = 1 + 0.99*3 interpolated: h = 2.97 -> 3 + 0.97 = 3.97
  EXPECT_DOUBLE_EQ(result.p99, 3.97);
}

TEST(Stats, OneToAThousandAndOne) {
  std::vector<std::int64_t> samples(1001);
  std::iota(samples.begin(), samples.end(), 1);
  const auto result = summarize(samples);
  EXPECT_DOUBLE_EQ(result.p50, 501);
  EXPECT_DOUBLE_EQ(result.p99, 991);
  EXPECT_DOUBLE_EQ(result.p999, 1000);
  EXPECT_DOUBLE_EQ(result.max, 1001);
}

// The mean's sum is compensated in double (no long double, whose width is
// each architecture's own): additions a plain sum rounds away are carried.
TEST(Stats, TheMeanKeepsWhatAPlainSumRoundsAway) {
  // Sorted, the 1s come between -1e100 and 1e100: a plain double sum (and an
  // 80-bit long double one) absorbs them and gives 0; the exact sum is 2.
  const auto result = summarize(std::vector<double>{1.0, 1e100, 1.0, -1e100});
  EXPECT_EQ(result.mean, 0.5);
  // A million samples of 1e9 + 0.1 ns: each addition rounds in a plain double
  // sum; compensated, the mean is the sample itself, to the bit.
  const std::vector<double> near_a_second(1'000'000, 1e9 + 0.1);
  EXPECT_EQ(lockstep::platform::compensated_sum(std::span<const double>(near_a_second)) / 1e6, 1e9 + 0.1);
  EXPECT_EQ(summarize(near_a_second).mean, 1e9 + 0.1);
}

TEST(Stats, InterpolatesBetweenNeighbours) {
  const std::vector<double> sorted{10, 20, 30};
  EXPECT_DOUBLE_EQ(quantile_of_sorted(std::span<const double>(sorted), 0.0), 10);
  EXPECT_DOUBLE_EQ(quantile_of_sorted(std::span<const double>(sorted), 0.25), 15);
  EXPECT_DOUBLE_EQ(quantile_of_sorted(std::span<const double>(sorted), 0.9), 28);
  EXPECT_DOUBLE_EQ(quantile_of_sorted(std::span<const double>(sorted), 1.0), 30);
}

TEST(Stats, OneSampleIsEveryPercentile) {
  const auto result = summarize(std::vector<std::int64_t>{42});
  EXPECT_DOUBLE_EQ(result.min, 42);
  EXPECT_DOUBLE_EQ(result.p50, 42);
  EXPECT_DOUBLE_EQ(result.p999, 42);
  EXPECT_DOUBLE_EQ(result.max, 42);
}

TEST(Stats, NoSamplesIsAnErrorNotAZero) {
  EXPECT_THROW(summarize(std::vector<std::int64_t>{}), std::invalid_argument);
  const std::vector<double> one{1.0};
  EXPECT_THROW(quantile_of_sorted(std::span<const double>(one), 1.5), std::invalid_argument);
}

TEST(Histogram, BucketsAreHalfOpenAndOutliersCountedApart) {
  histogram buckets(100, 10, 3);  // [100,110) [110,120) [120,130)
  for (std::int64_t sample : {99, 100, 109, 110, 129, 130, 1000}) buckets.add(sample);
  EXPECT_EQ(buckets.below(), 1U);
  EXPECT_EQ(buckets.counts(), (std::vector<std::uint64_t>{2, 1, 1}));
  EXPECT_EQ(buckets.above(), 2U);
  EXPECT_EQ(buckets.total(), 7U);
  EXPECT_EQ(buckets.bucket_start(2), 120);
  const std::string text = buckets.render(10);
  EXPECT_NE(text.find("[100, 110) ns"), std::string::npos) << text;
  EXPECT_NE(text.find(">= 130 ns"), std::string::npos) << text;
  EXPECT_NE(text.find("< 100 ns"), std::string::npos) << text;
}

TEST(Histogram, CoveringChoosesARoundWidthThatHoldsEverySample) {
  const std::vector<std::int64_t> samples{1234, 1500, 2999, 4020};
  histogram buckets = histogram::covering(std::span<const std::int64_t>(samples), 50);
  EXPECT_EQ(buckets.bucket_ns(), 100);
  EXPECT_EQ(buckets.first_ns(), 1200);
  EXPECT_LE(buckets.bucket_count(), 50U);
  for (std::int64_t sample : samples) buckets.add(sample);
  EXPECT_EQ(buckets.below() + buckets.above(), 0U);
  EXPECT_EQ(buckets.total(), samples.size());
}

TEST(Histogram, RejectsNonsense) {
  EXPECT_THROW(histogram(0, 0, 3), std::invalid_argument);
  EXPECT_THROW(histogram(0, 10, 0), std::invalid_argument);
}

}  // namespace
