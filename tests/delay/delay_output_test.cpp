// delay's histograms, noisiest CPU and idle-state hold, without running a
// paced step: the cyclictest text format read back by a reader written from
// cyclictest's documentation, the logarithmic terminal view, the noisiest-CPU
// rule, the search's set-by-stalls rule at its edge, and the PM QoS hold on
// files that stand in for /dev/cpu_dma_latency.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "bench/delay/delay_output.hpp"
#include "bench/delay/delay_report.hpp"
#include "bench/probes/latency_histogram.hpp"
#include "platform/idle_states.hpp"
#include "tests/delay/cyclictest_histogram_parser.hpp"

namespace {

namespace probes = lockstep::bench::probes;

TEST(LatencyHistogram, BucketsAreWholeMicrosecondsAndOverflowsAreCounted) {
  // periods:                0      1       2       3        4          5
  const std::vector<double> samples{999.0, 1000.0, 4999.9, 5000.0, 12'000.0, 7'000'000.0};
  const auto column = probes::histogram_column(samples, 5, "worker 0", 1);
  ASSERT_EQ(column.counts.size(), 5u);
  EXPECT_EQ(column.counts[0], 1u);  // 999 ns -> 0 us
  EXPECT_EQ(column.counts[1], 1u);  // 1000 ns -> 1 us
  EXPECT_EQ(column.counts[4], 1u);  // 4999.9 ns -> 4 us
  EXPECT_EQ(column.overflow, 3u);   // 5 us, 12 us, 7000 us
  EXPECT_EQ(column.overflow_periods, (std::vector<std::int64_t>{3, 4, 5}));
  EXPECT_EQ(column.samples, 6u);
  EXPECT_EQ(column.in_buckets(), 3u);
  EXPECT_EQ(column.min_us, 0);
  EXPECT_EQ(column.max_us, 7000);
  EXPECT_EQ(column.avg_us, (0 + 1 + 4 + 5 + 12 + 7000) / 6);
}

TEST(CyclictestFormat, ReadsBackThroughAReaderOfTheDocumentedFormat) {
  probes::latency_histogram histogram;
  histogram.bound_us = 20;
  std::vector<double> first;
  std::vector<double> second;
  for (int period = 0; period < 200; ++period) {
    first.push_back(1000.0 * (period % 25));           // 0..24 us: 5 of 25 overflow
    second.push_back(1000.0 * ((period * 7) % 19) + 500);  // never overflows
  }
  histogram.columns.push_back(probes::histogram_column(first, 20, "worker 0"));
  histogram.columns.push_back(probes::histogram_column(second, 20, "worker 1"));
  std::istringstream text(lockstep::bench::cyclictest_histogram_text(histogram));
  const auto parsed = lockstep::testing::parse_cyclictest_histogram(text);
  ASSERT_EQ(parsed.error, "");
  ASSERT_EQ(parsed.buckets.size(), 20u);
  for (std::size_t bucket = 0; bucket < 20; ++bucket) EXPECT_EQ(parsed.buckets[bucket], static_cast<int>(bucket));
  ASSERT_EQ(parsed.counts.size(), 2u);
  for (std::size_t thread = 0; thread < 2; ++thread) {
    const auto& column = histogram.columns[thread];
    EXPECT_EQ(parsed.counts[thread], column.counts) << thread;
    EXPECT_EQ(parsed.total[thread], column.in_buckets());
    EXPECT_EQ(parsed.min[thread], static_cast<std::uint64_t>(column.min_us));
    EXPECT_EQ(parsed.avg[thread], static_cast<std::uint64_t>(column.avg_us));
    EXPECT_EQ(parsed.max[thread], static_cast<std::uint64_t>(column.max_us));
    EXPECT_EQ(parsed.overflows[thread], column.overflow);
  }
  EXPECT_EQ(parsed.overflows[0], 200u / 25 * 5);
  EXPECT_EQ(parsed.overflows[1], 0u);
  // The first bound_us overflow cycles are listed, the rest counted.
  ASSERT_EQ(parsed.overflow_cycles.size(), 2u);
  EXPECT_EQ(parsed.overflow_cycles[0].size(), 20u);
  EXPECT_EQ(parsed.overflow_cycles[0][0], 20u);
  EXPECT_EQ(parsed.others[0], 40u - 20u);
  EXPECT_TRUE(parsed.overflow_cycles[1].empty());
  EXPECT_EQ(parsed.others[1], 0u);
}

TEST(CyclictestFormat, UsesCyclictestsFieldWidths) {
  probes::latency_histogram histogram;
  histogram.bound_us = 3;
  histogram.columns.push_back(probes::histogram_column({1500.0, 1500.0, 9000.0}, 3, "worker 0"));
  histogram.columns.push_back(probes::histogram_column({500.0}, 3, "worker 1"));
  const std::string text = lockstep::bench::cyclictest_histogram_text(histogram);
  EXPECT_EQ(text,
            "# Histogram\n"
            "000000 000000\t000001\n"
            "000001 000002\t000000\n"
            "000002 000000\t000000\n"
            "# Total: 000000002 000000001\n"
            "# Min Latencies: 00001 00000\n"
            "# Avg Latencies: 00003 00000\n"
            "# Max Latencies: 00009 00000\n"
            "# Histogram Overflows: 00001 00000\n"
            "# Histogram Overflow at cycle number:\n"
            "# Thread 0: 00002\n"
            "# Thread 1:\n"
            "\n");
}

TEST(LogHistogram, SpreadsTheBulkAndKeepsTheTail) {
  std::vector<double> samples(9990, 15'000.0);  // 15 us: the bulk
  for (int i = 0; i < 10; ++i) samples.push_back(3'000'000.0);  // 3 ms: the tail
  const std::string text = lockstep::bench::log_histogram_text({{"count", samples}});
  EXPECT_NE(text.find("[    10,     20)"), std::string::npos) << text;
  EXPECT_NE(text.find("[  2000,   5000)"), std::string::npos) << text;
  // The one-sample-per-mille tail still draws a bar.
  const auto tail_row = text.substr(text.find("[  2000,   5000)"));
  EXPECT_NE(tail_row.find('#'), std::string::npos) << text;
}

TEST(LogHistogram, HasAColumnPerSeriesAndAnAllColumn) {
  const std::string text = lockstep::bench::log_histogram_text({{"cpu 0", {1500.0}}, {"cpu 1", {1500.0, 700'000.0}}});
  EXPECT_NE(text.find("cpu 0"), std::string::npos);
  EXPECT_NE(text.find("cpu 1"), std::string::npos);
  EXPECT_NE(text.find("all"), std::string::npos);
  EXPECT_EQ(lockstep::bench::log_histogram_text({}), "  no samples\n");
}

TEST(NoisiestCpu, HighestP99ThenHighestMaxThenLowestCpu) {
  using lockstep::bench::cpu_latency;
  EXPECT_FALSE(lockstep::bench::noisiest_cpu({}).has_value());
  EXPECT_EQ(lockstep::bench::noisiest_cpu({{0, 10, 50}, {1, 20, 30}, {2, 15, 900}}), 1u);
  EXPECT_EQ(lockstep::bench::noisiest_cpu({{0, 20, 50}, {1, 20, 60}}), 1u);
  EXPECT_EQ(lockstep::bench::noisiest_cpu({{3, 20, 60}, {1, 20, 60}}), 1u);
}

// The search's answer was set by the machine's stalls when it is more than
// kStallDominatedFactor (10) times the largest completion p99 of its trials:
// at exactly 10 times it was not, one nanosecond above it was; no answer, or
// no p99 to compare with, is never set by stalls.
lockstep::bench::search_reading search_reading_of(std::vector<double> trial_p99_ns,
                                                  std::optional<std::int64_t> found_period_ns) {
  probes::delay_measurement measured;
  measured.searched.emplace();
  for (double p99 : trial_p99_ns) {
    probes::period_trial trial;
    trial.outcome.completion_p99_ns = p99;
    measured.searched->search.trials.push_back(trial);
  }
  measured.searched->search.found_period_ns = found_period_ns;
  const auto analysis = lockstep::bench::analyse_delay(measured);
  EXPECT_TRUE(analysis.search.has_value());
  return analysis.search.value_or(lockstep::bench::search_reading{});
}

TEST(SetByStalls, OnlyAnAnswerAboveTenTimesTheLargestTrialP99) {
  EXPECT_EQ(lockstep::bench::kStallDominatedFactor, 10.0) << "the known answers below are for a factor of 10";
  const auto at_edge = search_reading_of({100'000, 150'000, 120'000}, 1'500'000);
  EXPECT_EQ(at_edge.largest_completion_p99_ns, 150'000.0) << "the largest p99 of every trial, not the last";
  EXPECT_FALSE(at_edge.set_by_stalls) << "exactly 10 times is not above it";
  EXPECT_TRUE(search_reading_of({100'000, 150'000, 120'000}, 1'500'001).set_by_stalls);
  EXPECT_FALSE(search_reading_of({100'000, 150'000, 120'000}, 1'499'999).set_by_stalls);
  EXPECT_FALSE(search_reading_of({100'000, 150'000}, std::nullopt).set_by_stalls) << "no answer";
  EXPECT_FALSE(search_reading_of({0, 0}, 1'000'000).set_by_stalls) << "no p99 to compare with";
}

std::string scratch_file(const std::string& name) {
  return "/tmp/lockstep-idle-test-" + std::to_string(::getpid()) + "-" + name;
}

TEST(DmaLatencyHold, WritesTheValueAsFourBytesAndReadsItBack) {
  const std::string path = scratch_file("qos");
  { std::ofstream create(path); }
  {
    const lockstep::platform::dma_latency_hold hold(7, path);
    EXPECT_TRUE(hold.held()) << hold.problem();
    EXPECT_EQ(hold.requested_us(), 7);
    ASSERT_TRUE(hold.in_force_us().has_value());
    EXPECT_EQ(*hold.in_force_us(), 7);
  }
  std::ifstream in(path, std::ios::binary);
  std::int32_t value = -1;
  in.read(reinterpret_cast<char*>(&value), sizeof value);
  EXPECT_EQ(in.gcount(), 4);
  EXPECT_EQ(value, 7);
  EXPECT_EQ(in.peek(), std::ifstream::traits_type::eof());  // exactly four bytes
  std::remove(path.c_str());
}

TEST(DmaLatencyHold, AFileThatCannotBeOpenedIsReportedNotThrown) {
  const lockstep::platform::dma_latency_hold hold(0, "/nonexistent-lockstep-dir/cpu_dma_latency");
  EXPECT_FALSE(hold.held());
  EXPECT_NE(hold.problem().find("open"), std::string::npos) << hold.problem();
  EXPECT_FALSE(hold.in_force_us().has_value());
}

TEST(CpuIdle, NamesTheDriverAndGovernorOrSaysUnavailable) {
  EXPECT_FALSE(lockstep::platform::cpuidle_driver().empty());
  EXPECT_FALSE(lockstep::platform::cpuidle_governor().empty());
}

}  // namespace
