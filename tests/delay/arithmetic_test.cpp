// What the delay commands add to platform/stats.hpp (JSON forms, histogram
// filling) and their CPU-list parsing, on known inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <vector>

#include "bench/cli/options.hpp"
#include "bench/results/result_json.hpp"

namespace {

namespace bench = lockstep::bench;
namespace cli = lockstep::cli;

TEST(DelayJson, DistributionOfKnownSamples) {
  const auto json = bench::distribution_json(std::vector<double>{5, 1, 4, 2, 3});
  EXPECT_EQ(json["count"], 5);
  EXPECT_EQ(json["min"], 1.0);
  EXPECT_EQ(json["p50"], 3.0);
  EXPECT_EQ(json["max"], 5.0);
  EXPECT_TRUE(json["p99"].is_number());
  EXPECT_TRUE(json["p999"].is_number());
}

TEST(DelayJson, NoSamplesIsNullNotZero) {
  const auto json = bench::distribution_json(std::vector<double>{});
  EXPECT_EQ(json["count"], 0);
  for (const char* key : {"min", "p50", "p99", "p999", "max"}) EXPECT_TRUE(json[key].is_null()) << key;
}

TEST(DelayJson, HistogramHoldsEverySample) {
  const std::vector<double> samples = {3, 3.5, 4, 7, 12};
  const auto h = bench::histogram_of(samples);
  EXPECT_EQ(h.total(), samples.size());
  EXPECT_EQ(h.below(), 0u);
  EXPECT_EQ(h.above(), 0u);
  const auto json = bench::histogram_json(h);
  EXPECT_EQ(json["bucket_ns"], 1);
  EXPECT_EQ(json["first_ns"], 3);
  ASSERT_EQ(json["counts"].size(), 10u);  // 3..12
  EXPECT_EQ(json["counts"][0], 2);        // 3 and 3.5
  std::uint64_t sum = 0;
  for (const auto& count : json["counts"]) sum += count.get<std::uint64_t>();
  EXPECT_EQ(sum, samples.size());
}

TEST(CpuList, ParsesRangesAndRejectsGarbage) {
  EXPECT_EQ(cli::parse_cpu_list("3,0-2,2", "--cores"), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_THROW(cli::parse_cpu_list("a", "--cores"), lockstep::cli::usage_error);
  EXPECT_THROW(cli::parse_cpu_list("3-1", "--cores"), lockstep::cli::usage_error);
  EXPECT_THROW(cli::parse_cpu_list("", "--cores"), lockstep::cli::usage_error);
  EXPECT_THROW(cli::parse_cpu_list("1,,2", "--cores"), lockstep::cli::usage_error);
}

}  // namespace
