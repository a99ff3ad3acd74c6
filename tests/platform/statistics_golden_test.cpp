// platform/statistics.hpp against the golden file it shares with
// reports/lockstep_reports/common/statistics.py (tests/fixtures/statistics/golden.json,
// numpy's answers and the verdict rule's; reports/tests/test_statistics.py
// checks the Python side against the same file).
#include "platform/statistics.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace {

namespace platform = lockstep::platform;

const nlohmann::json& golden() {
  static const nlohmann::json document = [] {
    std::ifstream in(std::string(LOCKSTEP_SOURCE_DIR) + "/tests/fixtures/statistics/golden.json");
    return nlohmann::json::parse(in);
  }();
  return document;
}

// Within the file's relative tolerance (numpy's interpolation and the rule's
// differ by a few ulp; a changed rule moves a figure by far more).
::testing::AssertionResult near(double actual, double expected) {
  const double tolerance = golden().at("tolerance").get<double>() * std::max(1.0, std::fabs(expected));
  if (std::fabs(actual - expected) <= tolerance) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << actual << " is not " << expected;
}

// Within the file's seeded_ulps of the expected value (the same draws and the
// same expressions give the same bits; a fused multiply-add may move an
// interpolated end by one ulp: platform/statistics.hpp).
::testing::AssertionResult within_ulps(double actual, double expected) {
  const int ulps = golden().at("seeded_ulps").get<int>();
  double below = expected;
  double above = expected;
  for (int step = 0; step < ulps; ++step) {
    below = std::nextafter(below, -std::numeric_limits<double>::infinity());
    above = std::nextafter(above, std::numeric_limits<double>::infinity());
  }
  if (actual >= below && actual <= above) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << std::hexfloat << actual << " is not " << expected << " within " << ulps
                                       << " ulp";
}

TEST(StatisticsGolden, MediansAndQuantiles) {
  ASSERT_FALSE(golden().at("samples").empty());
  for (const auto& sample : golden().at("samples")) {
    SCOPED_TRACE(sample.at("name").get<std::string>());
    const auto values = sample.at("values").get<std::vector<double>>();
    EXPECT_TRUE(near(platform::median(values), sample.at("median").get<double>()));
    for (const auto& point : sample.at("quantiles")) {
      const double q = point.at(0).get<double>();
      SCOPED_TRACE("q = " + std::to_string(q));
      EXPECT_TRUE(near(platform::quantile(values, q), point.at(1).get<double>()));
    }
  }
}

TEST(StatisticsGolden, BootstrapIntervalsOverTheFilesResamples) {
  ASSERT_FALSE(golden().at("bootstraps").empty());
  for (const auto& item : golden().at("bootstraps")) {
    SCOPED_TRACE(item.at("name").get<std::string>());
    const auto values = item.at("values").get<std::vector<double>>();
    const auto resamples = item.at("resamples").get<std::vector<std::vector<std::size_t>>>();
    const platform::interval found = platform::bootstrap_interval(values, resamples, item.at("confidence").get<double>());
    EXPECT_TRUE(near(platform::median(values), item.at("median").get<double>()));
    EXPECT_TRUE(near(found.low, item.at("low").get<double>()));
    EXPECT_TRUE(near(found.high, item.at("high").get<double>()));
  }
}

TEST(StatisticsGolden, Verdicts) {
  ASSERT_FALSE(golden().at("verdicts").empty());
  for (const auto& item : golden().at("verdicts")) {
    SCOPED_TRACE(item.at("name").get<std::string>());
    const platform::verdict outcome = platform::verdict_of(item.at("low").get<double>(), item.at("high").get<double>(),
                                                           item.at("noise").get<double>());
    EXPECT_EQ(platform::to_string(outcome), item.at("verdict").get<std::string>());
  }
}

TEST(StatisticsGolden, TheSeededDrawsAreSplitmix64MappedByMultiplyShift) {
  ASSERT_FALSE(golden().at("draws").empty());
  for (const auto& item : golden().at("draws")) {
    const auto seed = item.at("seed").get<std::uint64_t>();
    const auto n = item.at("n").get<std::uint64_t>();
    SCOPED_TRACE("seed " + std::to_string(seed) + ", n " + std::to_string(n));
    platform::bootstrap_draws outputs(seed);
    for (const auto& expected : item.at("outputs")) EXPECT_EQ(outputs.next(), expected.get<std::uint64_t>());
    platform::bootstrap_draws indices(seed);
    for (const auto& expected : item.at("indices"))
      EXPECT_EQ(indices.next_index(static_cast<std::size_t>(n)), expected.get<std::size_t>());
  }
}

TEST(StatisticsGolden, SeededBootstrapMedians) {
  ASSERT_FALSE(golden().at("seeded").empty());
  for (const auto& item : golden().at("seeded")) {
    SCOPED_TRACE(item.at("name").get<std::string>());
    const auto values = item.at("values").get<std::vector<double>>();
    const platform::median_estimate found =
        platform::bootstrap_median(values, item.at("confidence").get<double>(), item.at("resamples").get<unsigned>(),
                                   item.at("seed").get<std::uint64_t>());
    EXPECT_TRUE(within_ulps(found.median, item.at("median").get<double>()));
    EXPECT_TRUE(within_ulps(found.low, item.at("low").get<double>()));
    EXPECT_TRUE(within_ulps(found.high, item.at("high").get<double>()));
  }
}

TEST(Statistics, TheSeededBootstrapIsDeterministicAndBracketsTheMedian) {
  const std::vector<double> ratios{1.02, 0.97, 1.10, 1.01, 0.99, 1.05, 1.03};
  const auto first = platform::bootstrap_median(ratios, 0.95, 2000, 7);
  const auto again = platform::bootstrap_median(ratios, 0.95, 2000, 7);
  EXPECT_EQ(first.low, again.low);
  EXPECT_EQ(first.high, again.high);
  EXPECT_DOUBLE_EQ(first.median, 1.02);
  EXPECT_LE(first.low, first.median);
  EXPECT_GE(first.high, first.median);
  const auto one = platform::bootstrap_median(std::vector<double>{1.5}, 0.95, 2000, 7);
  EXPECT_EQ(one.low, 1.5);
  EXPECT_EQ(one.high, 1.5);
}

TEST(Statistics, BadInputIsRefused) {
  EXPECT_THROW(platform::median(std::vector<double>{}), std::invalid_argument);
  EXPECT_THROW(platform::quantile({1.0}, 1.5), std::invalid_argument);
  const std::vector<double> values{1.0, 2.0};
  EXPECT_THROW(platform::bootstrap_interval(values, {{0, 2}}, 0.95), std::invalid_argument);
  EXPECT_THROW(platform::bootstrap_interval(values, {{0}}, 0.95), std::invalid_argument);
  EXPECT_THROW(platform::bootstrap_interval(values, {{0, 1}}, 1.0), std::invalid_argument);
}

}  // namespace
