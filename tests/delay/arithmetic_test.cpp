// Percentile, summary and histogram arithmetic on known inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <vector>

#include "bench/delay_common.hpp"

namespace {

namespace delay = lockstep::bench::delay;

TEST(Percentiles, NearestRankOnOneToHundred) {
  std::vector<double> values(100);
  std::iota(values.begin(), values.end(), 1.0);  // 1..100, sorted
  EXPECT_EQ(delay::percentile_sorted(values, 0.0), 1.0);
  EXPECT_EQ(delay::percentile_sorted(values, 0.5), 50.0);
  EXPECT_EQ(delay::percentile_sorted(values, 0.99), 99.0);
  EXPECT_EQ(delay::percentile_sorted(values, 0.999), 100.0);
  EXPECT_EQ(delay::percentile_sorted(values, 1.0), 100.0);
}

TEST(Percentiles, SummaryOfUnsortedInput) {
  const auto s = delay::summarize({5, 1, 4, 2, 3});
  EXPECT_EQ(s.count, 5u);
  EXPECT_EQ(s.min, 1);
  EXPECT_EQ(s.p50, 3);
  EXPECT_EQ(s.p99, 5);
  EXPECT_EQ(s.p999, 5);
  EXPECT_EQ(s.max, 5);
}

TEST(Percentiles, EmptyInputIsNullNotZero) {
  const auto s = delay::summarize({});
  EXPECT_EQ(s.count, 0u);
  EXPECT_TRUE(std::isnan(s.p50));
  const auto json = delay::to_json(s);
  EXPECT_TRUE(json["p50"].is_null());
  EXPECT_EQ(json["count"], 0);
}

TEST(Percentiles, OneInThousandOutlierShowsOnlyAtTheTop) {
  std::vector<double> values(1000, 10.0);
  values[500] = 1e6;
  const auto s = delay::summarize(values);
  EXPECT_EQ(s.p50, 10.0);
  EXPECT_EQ(s.p99, 10.0);
  EXPECT_EQ(s.p999, 10.0);  // rank 999 of 1000
  EXPECT_EQ(s.max, 1e6);
}

TEST(Histogram, CoversEverySampleInUnitBuckets) {
  const auto h = delay::histogram::of({3, 3.5, 4, 7, 12});
  EXPECT_EQ(h.bucket_ns, 1);
  EXPECT_EQ(h.first_ns, 3);
  ASSERT_EQ(h.counts.size(), 10u);  // 3..12
  EXPECT_EQ(h.counts[0], 2u);       // 3 and 3.5
  EXPECT_EQ(h.counts[1], 1u);
  EXPECT_EQ(h.counts[4], 1u);
  EXPECT_EQ(h.counts[9], 1u);
  EXPECT_EQ(h.total(), 5u);
}

TEST(Histogram, WidensInOneTwoFiveSteps) {
  // 1000..100999 ns in at most 60 buckets: 1000, 2000 do not fit, 2000 * 60 > 100000 > 1000 * 60.
  std::vector<double> values;
  for (int v = 1000; v < 101000; v += 7) values.push_back(v);
  const auto h = delay::histogram::of(values, 60);
  EXPECT_EQ(h.bucket_ns, 2000);
  EXPECT_EQ(h.first_ns, 0);
  EXPECT_LE(h.counts.size(), 60u);
  EXPECT_EQ(h.total(), values.size());
  const auto json = h.to_json();
  EXPECT_EQ(json["bucket_ns"], 2000);
  EXPECT_EQ(json["counts"].size(), h.counts.size());
}

TEST(Histogram, TextHasOneLinePerBucket) {
  const auto h = delay::histogram::of({1, 2, 2, 3});
  const auto text = h.text(10);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 3);
  EXPECT_NE(text.find("##########"), std::string::npos);  // the fullest bucket has the full bar
}

TEST(Histogram, EmptyInput) {
  const auto h = delay::histogram::of({});
  EXPECT_TRUE(h.counts.empty());
  EXPECT_EQ(h.total(), 0u);
}

TEST(CpuList, ParsesRangesAndRejectsGarbage) {
  EXPECT_EQ(delay::parse_cpu_list("3,0-2,2", "--cores"), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_THROW(delay::parse_cpu_list("a", "--cores"), lockstep::cli::usage_error);
  EXPECT_THROW(delay::parse_cpu_list("3-1", "--cores"), lockstep::cli::usage_error);
  EXPECT_THROW(delay::parse_cpu_list("", "--cores"), lockstep::cli::usage_error);
  EXPECT_THROW(delay::parse_cpu_list("1,,2", "--cores"), lockstep::cli::usage_error);
}

}  // namespace
