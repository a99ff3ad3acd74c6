// The delay commands as a user runs them: bad input exits 2 with one line;
// each command runs briefly and writes parseable JSON in the agreed shape.
// No test asserts a latency.
#include <gtest/gtest.h>
#include <linux/capability.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "tests/delay/cyclictest_histogram_parser.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/watchdog.hpp"

namespace {

using lockstep::testing::count_lines;
using lockstep::testing::run_command;

std::string temp_json(const std::string& name) {
  return "/tmp/lockstep-delay-test-" + std::to_string(::getpid()) + "-" + name + ".json";
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  nlohmann::json document = nlohmann::json::parse(in);
  std::remove(path.c_str());
  return document;
}

bool two_cpus() { return std::thread::hardware_concurrency() >= 2; }

void expect_usage_error(std::vector<std::string> argv) {
  argv.insert(argv.begin(), LOCKSTEP_BINARY);
  std::string shown;
  for (const auto& a : argv) shown += a + " ";
  const auto result = run_command(argv);
  EXPECT_EQ(result.exit_status, 2) << shown << "\n" << result.err;
  EXPECT_EQ(count_lines(result.err), 1) << shown << "\n" << result.err;
  EXPECT_EQ(result.err.rfind("lockstep: ", 0), 0u) << result.err;
}

TEST(C2cCommand, BadInputExitsTwoWithOneLine) {
  expect_usage_error({"c2c", "--method", "swap"});
  expect_usage_error({"c2c", "--samples", "0"});
  expect_usage_error({"c2c", "--rounds", "-3"});
  expect_usage_error({"c2c", "--max-pairs", "0"});
  expect_usage_error({"c2c", "--cores", "0,x"});
  expect_usage_error({"c2c", "--cores", "0"});
  expect_usage_error({"c2c", "--cores", "0,4095"});
  expect_usage_error({"c2c", "--out", "/nonexistent-dir/c2c.json"});
  expect_usage_error({"c2c", "--synthetic", "pack:zero"});
}

TEST(C2cCommand, WritesTheAgreedJson) {
  if (!two_cpus()) GTEST_SKIP() << "needs two CPUs";
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "lockstep c2c");
  const auto path = temp_json("c2c");
  const auto result =
      run_command({LOCKSTEP_BINARY, "c2c", "--samples", "5", "--rounds", "5", "--cores", "0,1", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("median one-way latency"), std::string::npos);
  const auto document = read_json(path);
  EXPECT_EQ(document["kind"], "c2c");
  EXPECT_EQ(document["lockstep_schema"], 2);
  EXPECT_EQ(document["sampled"], false);
  EXPECT_TRUE(document["context"]["topology"].is_string());
  ASSERT_EQ(document["pairs"].size(), 2u);  // one pair, two methods
  for (const auto& pair : document["pairs"]) {
    EXPECT_EQ(pair["a"], 0);
    EXPECT_EQ(pair["b"], 1);
    EXPECT_TRUE(pair["relation"].is_string());
    EXPECT_EQ(pair["samples"], 5);
    for (const char* key : {"min", "p50", "p99"}) EXPECT_TRUE(pair["one_way_ns"][key].is_number()) << key;
  }
}

TEST(C2cCommand, SamplesPairsAndSaysSo) {
  const auto result = run_command({LOCKSTEP_BINARY, "c2c", "--synthetic", "pack:2 core:8 pu:1", "--max-pairs", "10"});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("sampled 10 of 120 pairs"), std::string::npos) << result.out;
  EXPECT_EQ(count_lines(result.out), 11);  // the note and ten labelled pairs
}

TEST(FalseshareCommand, BadInputExitsTwoWithOneLine) {
  expect_usage_error({"falseshare", "--threads", "1"});
  expect_usage_error({"falseshare", "--threads", "4096"});
  expect_usage_error({"falseshare", "--strides", "12"});
  expect_usage_error({"falseshare", "--strides", "8,x"});
  expect_usage_error({"falseshare", "--window", "0"});
  expect_usage_error({"falseshare", "--repeats", "0"});
  expect_usage_error({"falseshare", "--cores", "0,4095"});
  expect_usage_error({"falseshare", "--out", "/nonexistent-dir/f.json"});
  expect_usage_error({"falseshare", "--bogus"});
}

TEST(FalseshareCommand, WritesParseableJson) {
  if (!two_cpus()) GTEST_SKIP() << "needs two CPUs";
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "lockstep falseshare");
  const auto path = temp_json("falseshare");
  const auto result = run_command(
      {LOCKSTEP_BINARY, "falseshare", "--window", "2ms", "--repeats", "3", "--strides", "8,64,128", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("ns per access by stride"), std::string::npos) << result.out;
  // The text ends with the answer, one line, which the file holds too.
  const std::string last_line = result.out.substr(result.out.rfind('\n', result.out.size() - 2) + 1);
  EXPECT_EQ(last_line.rfind("answer: ", 0), 0u) << result.out;
  const auto document = read_json(path);
  EXPECT_EQ(document["kind"], "falseshare");
  EXPECT_EQ(document["answer"].get<std::string>() + "\n", last_line);
  // Every pattern: plain stores swept over the three strides, the others at
  // the penalty's two (8 shares a line, 128 nothing), each with its penalty.
  ASSERT_EQ(document["patterns"].size(), 4u);
  const auto& plain = document["patterns"][0];
  EXPECT_EQ(plain["pattern"], "plain_store");
  ASSERT_EQ(plain["strides"].size(), 3u);
  EXPECT_EQ(plain["strides"][0]["stride_bytes"], 8);
  EXPECT_EQ(plain["strides"][0]["share_line"], true);
  EXPECT_EQ(plain["strides"][1]["share_line"], false);
  EXPECT_EQ(plain["strides"][1]["share_line_pair"], true);
  EXPECT_EQ(plain["strides"][2]["share_line_pair"], false);
  for (std::size_t index = 0; index < document["patterns"].size(); ++index) {
    const auto& pattern = document["patterns"][index];
    SCOPED_TRACE(pattern["pattern"].get<std::string>());
    for (const auto& stride : pattern["strides"]) EXPECT_TRUE(stride["ns_per_access"].contains("p50"));
    if (index > 0) {
      ASSERT_EQ(pattern["strides"].size(), 2u);
      EXPECT_EQ(pattern["strides"][0]["stride_bytes"], 8);
      EXPECT_EQ(pattern["strides"][1]["stride_bytes"], 128);
    }
    // A penalty pairs the two strides within one repeat; a repeat in which
    // some thread was never scheduled (a loaded machine, a 2 ms window) has
    // no mean, and a pattern left without a pair says so instead.
    if (!pattern.contains("penalty")) {
      const std::size_t said = result.out.find("  " + pattern["words"].get<std::string>() + " ",
                                               result.out.find("penalty of one line against apart"));
      ASSERT_NE(said, std::string::npos) << result.out;
      const std::string line = result.out.substr(said, result.out.find('\n', said) - said);
      EXPECT_NE(line.find("not measured both on one line and apart"), std::string::npos) << result.out;
      continue;
    }
    EXPECT_EQ(pattern["penalty"]["a_stride_bytes"], 8);
    EXPECT_EQ(pattern["penalty"]["b_stride_bytes"], 128);
  }
}

TEST(MigrateCommand, BadInputExitsTwoWithOneLine) {
  expect_usage_error({"migrate", "--bytes", "8"});
  expect_usage_error({"migrate", "--repeats", "0"});
  expect_usage_error({"migrate", "--cores", "0"});
  expect_usage_error({"migrate", "--cores", "0,1,2"});
  expect_usage_error({"migrate", "--cores", "0,4095"});
  expect_usage_error({"migrate", "--out", "/nonexistent-dir/m.json"});
}

TEST(MigrateCommand, WritesParseableJson) {
  if (!two_cpus()) GTEST_SKIP() << "needs two CPUs";
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "lockstep migrate");
  const auto path = temp_json("migrate");
  const auto result =
      run_command({LOCKSTEP_BINARY, "migrate", "--repeats", "5", "--bytes", "65536", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("refill"), std::string::npos);
  const auto document = read_json(path);
  EXPECT_EQ(document["kind"], "migrate");
  EXPECT_EQ(document["settings"]["bytes"], 65536);
  for (const char* key : {"move_ns", "refill_ns", "setaffinity_no_move_ns", "first_pass_ns", "next_pass_ns"}) {
    EXPECT_EQ(document[key]["count"], 5) << key;
    EXPECT_TRUE(document[key]["p50"].is_number()) << key;
  }
}

TEST(DelayCommand, BadInputExitsTwoWithOneLine) {
  expect_usage_error({"delay", "--period", "1x"});
  expect_usage_error({"delay", "--period", "1"});
  expect_usage_error({"delay", "--period", "5us"});
  expect_usage_error({"delay", "--period", "fast"});
  expect_usage_error({"delay", "--duration", "0s"});
  expect_usage_error({"delay", "--period", "10ms", "--duration", "5ms"});
  expect_usage_error({"delay", "--sync", "nope"});
  expect_usage_error({"delay", "--layout", "nope"});
  expect_usage_error({"delay", "--pin", "nope"});
  expect_usage_error({"delay", "--threads", "0"});
  expect_usage_error({"delay", "--threads", "2000"});
  expect_usage_error({"delay", "--masses", "2", "--threads", "8"});  // 8 threads, 4 equations
  expect_usage_error({"delay", "--masses", "0"});
  expect_usage_error({"delay", "--masses", "4", "--per-cpu"});  // per CPU: the two-mass step
  expect_usage_error({"delay", "--sync", "seqlock", "--layout", "packed"});  // not applicable
  expect_usage_error({"delay", "--fifo", "0"});
  expect_usage_error({"delay", "--fifo", "100"});
  expect_usage_error({"delay", "--compare-pinning", "--pin", "none"});
  expect_usage_error({"delay", "--out", "/nonexistent-dir/d.json"});
  // idle states
  expect_usage_error({"delay", "--dma-latency", "5"});  // a time needs its unit
  expect_usage_error({"delay", "--dma-latency", "-1us"});
  expect_usage_error({"delay", "--dma-latency", "1.5us"});  // PM QoS takes whole microseconds
  expect_usage_error({"delay", "--dma-latency", "0us", "--no-dma-latency"});
  // histograms
  expect_usage_error({"delay", "--histogram-bound", "0us"});
  expect_usage_error({"delay", "--histogram-bound", "1.5us"});
  expect_usage_error({"delay", "--histogram-bound", "200ms"});
  expect_usage_error({"delay", "--histogram-bound", "x"});
  expect_usage_error({"delay", "--histogram-file", "/nonexistent-dir/h.txt"});
  // per CPU
  expect_usage_error({"delay", "--per-cpu", "--threads", "2"});
  expect_usage_error({"delay", "--per-cpu", "--pin", "scatter"});
  expect_usage_error({"delay", "--per-cpu", "--compare-pinning"});
  expect_usage_error({"delay", "--per-cpu", "--sync", "omp_barrier"});
  expect_usage_error({"delay", "--per-cpu", "--sync", "nope"});
  // stop on a threshold
  expect_usage_error({"delay", "--stop-above", "0us"});
  expect_usage_error({"delay", "--stop-above", "10"});
  // the period search
  expect_usage_error({"delay", "--find-period"});
  expect_usage_error({"delay", "--miss-rate", "1e-3"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "0"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-9"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "often"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-3", "--duration", "1s"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-3", "--stop-above", "1ms"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-3", "--per-cpu"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-3", "--compare-pinning"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-3", "--trial-periods", "100"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-3", "--trial-periods", "-5"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-3", "--search-budget", "0.5s"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-3", "--search-budget", "10"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-3", "--period", "5us"});
  expect_usage_error({"delay", "--search-budget", "10s"});
  expect_usage_error({"delay", "--trial-periods", "5000"});
  expect_usage_error({"delay", "--find-period", "--miss-rate", "1e-3", "--out", "/nonexistent-dir/d.json"});
}

// `periods`: the schedule's. Each ran a step, or was skipped after a step
// that overran (the run re-anchors: bench/probes/paced.hpp); on a busy
// machine some may be, so the counts are of the steps kept.
void expect_delay_json(const nlohmann::json& document, int periods, int threads) {
  EXPECT_EQ(document["kind"], "delay");
  const int steps = document["periods_measured"].get<int>();
  EXPECT_EQ(document["periods_scheduled"], periods);
  EXPECT_EQ(steps + document["skipped_periods"].get<int>(), periods);
  EXPECT_GE(steps, 1);
  EXPECT_EQ(document["lockstep_schema"], 2);
  EXPECT_TRUE(document["context"]["kernel"].is_string());
  const auto& settings = document["settings"];
  EXPECT_EQ(settings["period_ns"], 1'000'000);
  EXPECT_EQ(settings["threads"], threads);
  for (const char* key : {"duration_s", "sync", "layout", "pin", "fifo_priority", "mlock"})
    EXPECT_TRUE(settings.contains(key)) << key;
  EXPECT_EQ(document["wakeup_latency_ns"]["count"], steps * threads);
  EXPECT_EQ(document["completion_ns"]["count"], steps);
  for (const char* key : {"min", "p50", "p99", "p999", "max"}) {
    EXPECT_TRUE(document["wakeup_latency_ns"][key].is_number()) << key;
    EXPECT_TRUE(document["completion_ns"][key].is_number()) << key;
  }
  // A miss is a completion above the period: there are some exactly when the
  // longest completion is above it, and every step missed exactly when the
  // shortest is. A skipped period follows a miss, and a miss skips at least
  // the period after it, except one in the schedule's last period, which has
  // none left to skip (paced.hpp: the run ends there).
  const int misses = document["deadline_misses"].get<int>();
  const int skipped = document["skipped_periods"].get<int>();
  const double period = document["settings"]["period_ns"].get<double>();
  EXPECT_EQ(misses > 0, document["completion_ns"]["max"].get<double>() > period) << misses;
  EXPECT_EQ(misses == steps, document["completion_ns"]["min"].get<double>() > period) << misses;
  if (skipped > 0) {
    EXPECT_GT(misses, 0) << skipped;
  }
  if (misses > 0 && skipped == 0) {
    EXPECT_EQ(misses, 1) << "only a miss in the last period skips nothing";
  }
  // The idle setting in force, in the context (strings) and in "idle".
  for (const char* key : {"dma_latency", "dma_latency_in_force_us", "cpuidle_driver", "cpuidle_governor", "clocksource"})
    EXPECT_TRUE(document["context"][key].is_string()) << key;
  for (const char* key : {"requested_us", "held", "in_force_us", "path", "cpuidle_driver", "cpuidle_governor",
                          "clocksource"})
    EXPECT_TRUE(document["idle"].contains(key)) << key;
  // cyclictest's histogram: one column per thread, 1 us buckets to the bound.
  const auto& latency = document["latency_histogram"];
  EXPECT_EQ(latency["bucket_us"], 1);
  EXPECT_EQ(latency["bound_us"], document["settings"]["histogram_bound_us"]);
  ASSERT_EQ(latency["columns"].size(), static_cast<std::size_t>(threads));
  for (const auto& column : latency["columns"]) {
    EXPECT_EQ(column["counts"].size(), latency["bound_us"].get<std::size_t>());
    std::uint64_t in_buckets = 0;
    for (const auto& count : column["counts"]) in_buckets += count.get<std::uint64_t>();
    EXPECT_EQ(in_buckets + column["overflow"].get<std::uint64_t>(), static_cast<std::uint64_t>(steps));
    EXPECT_EQ(column["samples"], steps);
  }
  std::uint64_t in_histogram = 0;
  for (const auto& count : document["histogram"]["counts"]) in_histogram += count.get<std::uint64_t>();
  EXPECT_EQ(in_histogram, static_cast<std::uint64_t>(steps * threads));
  EXPECT_GT(document["histogram"]["bucket_ns"].get<int>(), 0);
  ASSERT_EQ(document["figure5"].size(), static_cast<std::size_t>(threads + 1));
  EXPECT_EQ(document["figure5"][0]["thread"], "main");
  for (const auto& row : document["figure5"]) {
    for (const char* key : {"thread", "role", "cross_core_csw", "total_csw", "pct"}) EXPECT_TRUE(row.contains(key));
    if (row["cross_core_csw"].is_number()) {
      EXPECT_LE(row["cross_core_csw"], row["total_csw"]);
    }
  }
}

TEST(DelayCommand, PacedRunWritesTheAgreedJson) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "lockstep delay");
  const auto path = temp_json("delay");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "2", "--period", "1ms", "--duration",
                                   "20ms", "--sync", "futex_spin", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("wake-up latency"), std::string::npos);
  EXPECT_NE(result.out.find("Figure 5"), std::string::npos);
  const auto document = read_json(path);
  expect_delay_json(document, 20, 2);
  // The paper's two masses: no model segment in the name, as before chains.
  EXPECT_EQ(document["name"], "rk4/sync:futex_spin/layout:padded64/pin:compact/threads:2");
  EXPECT_EQ(document["settings"]["model"], "two_mass");
  EXPECT_EQ(document["settings"]["equations"], 4);
  EXPECT_TRUE(document["settings"]["fifo_priority"].is_null());
  EXPECT_EQ(document["settings"]["mlock"], false);
  EXPECT_FALSE(document.contains("figure5_unpinned"));
}

TEST(DelayCommand, ARecordedRunSaysWhyItsLateStepsWereLate) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "lockstep delay causes");
  const auto path = temp_json("delay-causes");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "2", "--period", "1ms", "--duration",
                                   "200ms", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("why the late steps were late"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("record: per stage"), std::string::npos) << result.out;
  const auto document = read_json(path);
  ASSERT_TRUE(document["causes"].is_object());
  const auto& causes = document["causes"];
  EXPECT_TRUE(causes["unavailable"].is_null());
  for (const auto& row : causes["tail"]) {
    double total = 0;
    for (const auto& [cause, ns] : row["cause_ns"].items()) total += ns.get<double>();
    EXPECT_NEAR(total, row["excess_ns"].get<double>(), 1e-6 * row["excess_ns"].get<double>() + 1)
        << row["label"] << ": the causes add up to the excess";
  }
  for (const auto& step : causes["worst"])
    EXPECT_EQ(step["line"].get<std::string>().rfind("step ", 0), 0u) << step["line"];
}

TEST(DelayCommand, NoRecordWritesNoCausesAndRecordingCostIsAPair) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "lockstep delay record");
  const auto path = temp_json("delay-no-record");
  const auto plain = run_command({LOCKSTEP_BINARY, "delay", "--threads", "2", "--period", "1ms", "--duration",
                                  "20ms", "--no-record", "--out", path});
  ASSERT_EQ(plain.exit_status, 0) << plain.err;
  EXPECT_TRUE(read_json(path)["causes"].is_null());
  EXPECT_EQ(plain.out.find("why the late steps"), std::string::npos);
  const auto cost = run_command({LOCKSTEP_BINARY, "delay", "--threads", "2", "--period", "1ms", "--duration",
                                 "1100ms", "--recording-cost", "--out", path});
  ASSERT_EQ(cost.exit_status, 0) << cost.err;
  const auto document = read_json(path);
  EXPECT_EQ(document["periods_scheduled"], 1100);
  // The blocks are of the steps kept: 1100 when no step overran; an overrun
  // skips periods (re-anchoring), and a loaded machine may leave fewer.
  const auto pairs = document["periods_measured"].get<std::int64_t>() / (2 * 250);
  if (pairs == 0) {
    EXPECT_TRUE(document["causes"]["recording_cost"].is_null());
  } else {
    EXPECT_NE(cost.out.find("recording cost: completion p50"), std::string::npos) << cost.out;
    ASSERT_TRUE(document["causes"]["recording_cost"].is_object());
    EXPECT_EQ(document["causes"]["recording_cost"]["pairs"], pairs)
        << document["periods_measured"] << " steps hold that many pairs of 250-step blocks";
    EXPECT_EQ(document["causes"]["recording_cost"]["block_periods"], 250);
  }
  const auto both = run_command({LOCKSTEP_BINARY, "delay", "--no-record", "--recording-cost"});
  EXPECT_EQ(both.exit_status, 2);
}

TEST(DelayCommand, ComparePinningAddsTheUnpinnedTable) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "delay --compare-pinning");
  const auto path = temp_json("delay-compare");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "2", "--duration", "10ms", "--layout",
                                   "per_thread", "--sync", "seqlock", "--compare-pinning", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("unpinned"), std::string::npos);
  const auto document = read_json(path);
  expect_delay_json(document, 10, 2);
  ASSERT_EQ(document["figure5_unpinned"].size(), 3u);
  EXPECT_EQ(document["unpinned"]["completion_ns"]["count"].get<int>() +
                document["unpinned"]["skipped_periods"].get<int>(),
            10);
}

// Beyond four threads the team paces a chain of one equation per thread
// (oversubscribed on two CPUs: the run must still complete and say so).
TEST(DelayCommand, EightThreadsPaceAFourMassChain) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "delay --threads 8");
  const auto path = temp_json("delay-chain");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "8", "--period", "1ms", "--duration",
                                   "300ms", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("rk4/model:chain4/sync:std_barrier/layout:padded64/pin:compact/threads:8"),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("a chain of 4 masses (8 equations)"), std::string::npos) << result.out;
  const auto document = read_json(path);
  expect_delay_json(document, 300, 8);
  EXPECT_EQ(document["name"], "rk4/model:chain4/sync:std_barrier/layout:padded64/pin:compact/threads:8");
  EXPECT_EQ(document["settings"]["model"], "chain4");
  EXPECT_EQ(document["settings"]["equations"], 8);
}

// --masses chooses the chain whatever the threads: blocks of equations.
TEST(DelayCommand, MassesChoosesTheChain) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "delay --masses");
  const auto path = temp_json("delay-masses");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--masses", "8", "--threads", "2", "--period", "1ms",
                                   "--duration", "20ms", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const auto document = read_json(path);
  expect_delay_json(document, 20, 2);
  EXPECT_EQ(document["name"], "rk4/model:chain8/sync:std_barrier/layout:padded64/pin:compact/threads:2");
  EXPECT_EQ(document["settings"]["model"], "chain8");
  EXPECT_EQ(document["settings"]["equations"], 16);
}

// A chain too small for the threads is refused before anything runs, in one
// line that gives the counts.
TEST(DelayCommand, MoreThreadsThanTheChainsEquationsExitsTwoBeforeMeasuring) {
  const auto path = temp_json("delay-too-few-equations");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--masses", "2", "--threads", "8", "--out", path});
  EXPECT_EQ(result.exit_status, 2) << result.err;
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find("8 threads but 4 equations"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("a chain of 2 masses"), std::string::npos) << result.err;
  EXPECT_EQ(result.out, "");
  EXPECT_FALSE(std::ifstream(path).good()) << "nothing measured, nothing written";
}

// Runs lockstep in a child that has really lost a permission: the capability
// is dropped from the bounding set (so even root does not regain it at exec)
// and the matching resource limit is set to 0.
lockstep::testing::command_result run_without(int capability, int resource, const std::vector<std::string>& args) {
  char err_name[] = "/tmp/lockstep-delay-err-XXXXXX";
  const int err_fd = ::mkstemp(err_name);
  const pid_t child = ::fork();
  if (child == 0) {
    ::prctl(PR_CAPBSET_DROP, capability, 0, 0, 0);  // fails without CAP_SETPCAP: then we never had it
    const rlimit none{0, 0};
    ::setrlimit(resource, &none);
    ::dup2(err_fd, STDERR_FILENO);
    const int null_fd = ::open("/dev/null", O_WRONLY);
    ::dup2(null_fd, STDOUT_FILENO);
    std::vector<char*> argv{const_cast<char*>(LOCKSTEP_BINARY)};
    for (const auto& arg : args) argv.push_back(const_cast<char*>(arg.c_str()));
    argv.push_back(nullptr);
    ::execv(LOCKSTEP_BINARY, argv.data());
    ::_exit(127);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  lockstep::testing::command_result result;
  result.exit_status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  ::lseek(err_fd, 0, SEEK_SET);
  result.err = lockstep::testing::detail::slurp(err_fd);
  ::unlink(err_name);
  return result;
}

TEST(DelayCommand, WithoutFifoPermissionExitsTwoAndSaysHowToRunWithout) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown),
                                    "delay without CAP_SYS_NICE");
  const auto result = run_without(CAP_SYS_NICE, RLIMIT_RTPRIO, {"delay", "--fifo", "50", "--duration", "10ms"});
  EXPECT_EQ(result.exit_status, 2) << result.err;
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find("SCHED_FIFO"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("without --fifo"), std::string::npos) << result.err;
}

TEST(DelayCommand, WithoutMlockPermissionExitsTwoAndSaysHowToRunWithout) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown),
                                    "delay without CAP_IPC_LOCK");
  const auto result = run_without(CAP_IPC_LOCK, RLIMIT_MEMLOCK, {"delay", "--mlock", "--duration", "10ms"});
  EXPECT_EQ(result.exit_status, 2) << result.err;
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find("mlock"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("without --mlock"), std::string::npos) << result.err;
}

TEST(DelayCommand, FifoAndMlockWhenPermitted) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "delay --fifo --mlock");
  const auto path = temp_json("delay-fifo");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "1", "--duration", "10ms", "--fifo", "10",
                                   "--mlock", "--out", path});
  // Skipped only where the permission is missing, as the Without*Permission
  // tests above word it (platform/scheduling.cpp): any other refusal of
  // these options is a failure.
  const bool not_permitted = result.exit_status == 2 && count_lines(result.err) == 1 &&
                             (result.err.find("SCHED_FIFO priority 10 not permitted (EPERM") != std::string::npos ||
                              result.err.find("mlockall not permitted (EPERM") != std::string::npos ||
                              result.err.find("mlockall not permitted (ENOMEM") != std::string::npos ||
                              result.err.find("mlockall not permitted (EAGAIN") != std::string::npos);
  if (not_permitted) GTEST_SKIP() << "not permitted here: " << result.err;
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const auto document = read_json(path);
  expect_delay_json(document, 10, 1);
  EXPECT_EQ(document["settings"]["fifo_priority"], 10);
  EXPECT_EQ(document["settings"]["mlock"], true);
}

// The PM QoS file, pointed elsewhere for one run (LOCKSTEP_DMA_LATENCY_PATH,
// read only by `lockstep delay`).
class dma_latency_path {
 public:
  explicit dma_latency_path(const std::string& path) { ::setenv("LOCKSTEP_DMA_LATENCY_PATH", path.c_str(), 1); }
  ~dma_latency_path() { ::unsetenv("LOCKSTEP_DMA_LATENCY_PATH"); }
  dma_latency_path(const dma_latency_path&) = delete;  // owns the variable
  dma_latency_path& operator=(const dma_latency_path&) = delete;
};

std::string line_starting(const std::string& text, const std::string& prefix) {
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line))
    if (line.rfind(prefix, 0) == 0) return line;
  return {};
}

TEST(DelayCommand, WithoutTheQosFileTheRunCompletesAndSaysSo) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "delay without QoS");
  const dma_latency_path missing("/nonexistent-lockstep-dir/cpu_dma_latency");
  const auto path = temp_json("delay-no-qos");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "1", "--duration", "10ms", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const std::string idle = line_starting(result.out, "idle: ");
  EXPECT_NE(idle.find("could not be held at 0 us"), std::string::npos) << result.out;
  EXPECT_NE(idle.find("idle states not limited"), std::string::npos) << idle;
  EXPECT_NE(result.err.find("cannot hold /nonexistent-lockstep-dir/cpu_dma_latency"), std::string::npos)
      << result.err;
  const auto document = read_json(path);
  expect_delay_json(document, 10, 1);
  EXPECT_EQ(document["idle"]["held"], false);
  EXPECT_EQ(document["idle"]["requested_us"], 0);
  EXPECT_TRUE(document["idle"]["problem"].is_string());
  EXPECT_EQ(document["context"]["dma_latency"].get<std::string>().rfind("not held (cannot hold", 0), 0u);
}

TEST(DelayCommand, HoldsTheRequestedLatencyForTheRun) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "delay --dma-latency");
  const std::string qos = "/tmp/lockstep-delay-test-" + std::to_string(::getpid()) + "-qos";
  { std::ofstream create(qos); }
  const dma_latency_path stand_in(qos);
  const auto path = temp_json("delay-qos");
  const auto result = run_command(
      {LOCKSTEP_BINARY, "delay", "--threads", "1", "--duration", "10ms", "--dma-latency", "7us", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(line_starting(result.out, "idle: ").find(qos + " held at 7 us for the run"), std::string::npos)
      << result.out;
  std::ifstream in(qos, std::ios::binary);
  std::int32_t written = -1;
  in.read(reinterpret_cast<char*>(&written), sizeof written);
  EXPECT_EQ(written, 7);
  std::remove(qos.c_str());
  const auto document = read_json(path);
  EXPECT_EQ(document["settings"]["dma_latency_us"], 7);
  EXPECT_EQ(document["idle"]["held"], true);
  EXPECT_EQ(document["idle"]["in_force_us"], 7);
  EXPECT_EQ(document["context"]["dma_latency"], "held at 7 us");
}

TEST(DelayCommand, NoDmaLatencyLeavesTheFileAlone) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "delay --no-dma-latency");
  const std::string qos = "/tmp/lockstep-delay-test-" + std::to_string(::getpid()) + "-untouched";
  { std::ofstream create(qos); }
  const dma_latency_path stand_in(qos);
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "1", "--duration", "10ms", "--no-dma-latency"});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(line_starting(result.out, "idle: ").find("left alone (--no-dma-latency)"), std::string::npos) << result.out;
  std::ifstream in(qos, std::ios::binary);
  EXPECT_EQ(in.peek(), std::ifstream::traits_type::eof());  // nothing written
  std::remove(qos.c_str());
}

// --stop-above 1us: some wake-up of the run is later than 1 us on any
// machine this runs on; whichever, the result must be complete and valid.
TEST(DelayCommand, StopAboveLeavesACompleteResult) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "delay --stop-above");
  const auto path = temp_json("delay-stop");
  const std::string histogram = temp_json("delay-stop-histogram");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "2", "--duration", "200ms", "--stop-above",
                                   "1us", "--histogram-file", histogram, "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const auto document = read_json(path);
  ASSERT_TRUE(document.contains("stop"));
  const auto& stop = document["stop"];
  EXPECT_EQ(stop["threshold_ns"], 1000);
  const int kept = document["periods_measured"].get<int>();
  EXPECT_EQ(stop["periods_kept"], kept);
  EXPECT_EQ(document["wakeup_latency_ns"]["count"], kept * 2);
  EXPECT_EQ(document["completion_ns"]["count"], kept);
  EXPECT_EQ(document["figure5"].size(), 3u);
  if (stop["stopped"].get<bool>()) {
    EXPECT_EQ(stop["step"].get<int>() + 1, kept);
    EXPECT_GE(stop["period"].get<int>(), stop["step"].get<int>());  // skipped periods between, if any
    EXPECT_GT(stop["wakeup_latency_ns"].get<std::int64_t>(), 1000);
    EXPECT_EQ(stop["period_ns"], 1'000'000);
    EXPECT_TRUE(stop["thread"].is_string());
    EXPECT_GE(stop["since_start_ns"].get<std::int64_t>(), stop["wakeup_latency_ns"].get<std::int64_t>());
    EXPECT_NE(result.out.find("stopped: period " + std::to_string(stop["period"].get<int>())), std::string::npos)
        << result.out;
  } else {
    EXPECT_EQ(kept + document["skipped_periods"].get<int>(), 200);
    EXPECT_NE(result.out.find("no wake-up was later"), std::string::npos) << result.out;
  }
  std::ifstream in(histogram);
  const auto parsed = lockstep::testing::parse_cyclictest_histogram(in);
  std::remove(histogram.c_str());
  ASSERT_EQ(parsed.error, "");
  ASSERT_EQ(parsed.total.size(), 2u);
  EXPECT_EQ(parsed.total[0] + parsed.overflows[0], static_cast<std::uint64_t>(kept));
}

TEST(DelayCommand, HistogramFileReadsBackAsCyclictestsFormat) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "delay --histogram-file");
  const auto path = temp_json("delay-histogram");
  const std::string histogram = temp_json("delay-histogram-text");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "2", "--duration", "30ms", "--histogram-bound",
                                   "50us", "--histogram-file", histogram, "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  std::ifstream in(histogram);
  const auto parsed = lockstep::testing::parse_cyclictest_histogram(in);
  std::remove(histogram.c_str());
  ASSERT_EQ(parsed.error, "");
  const auto document = read_json(path);
  expect_delay_json(document, 30, 2);
  const auto& columns = document["latency_histogram"]["columns"];
  ASSERT_EQ(parsed.counts.size(), 2u);
  ASSERT_EQ(parsed.buckets.size(), 50u);
  EXPECT_EQ(parsed.buckets.front(), 0);
  EXPECT_EQ(parsed.buckets.back(), 49);
  for (std::size_t thread = 0; thread < 2; ++thread) {
    const auto& column = columns[thread];
    for (std::size_t bucket = 0; bucket < 50; ++bucket)
      EXPECT_EQ(parsed.counts[thread][bucket], column["counts"][bucket].get<std::uint64_t>()) << thread << " " << bucket;
    // Every step kept, each wake-up once: 30 when no step overran; an
    // overrun skips periods (re-anchoring), and a loaded machine may keep fewer.
    EXPECT_EQ(parsed.total[thread] + parsed.overflows[thread], document["periods_measured"].get<std::uint64_t>());
    EXPECT_EQ(parsed.overflows[thread], column["overflow"].get<std::uint64_t>());
    EXPECT_EQ(parsed.min[thread], column["min_us"].get<std::uint64_t>());
    EXPECT_EQ(parsed.avg[thread], column["avg_us"].get<std::uint64_t>());
    EXPECT_EQ(parsed.max[thread], column["max_us"].get<std::uint64_t>());
    EXPECT_EQ(parsed.overflow_cycles[thread].size() + parsed.others[thread], parsed.overflows[thread]);
  }
  // The JSON's whole-run maximum agrees with the histogram's (us, truncated).
  const auto max_ns = document["wakeup_latency_ns"]["max"].get<double>();
  EXPECT_EQ(std::max(parsed.max[0], parsed.max[1]), static_cast<std::uint64_t>(max_ns / 1000));
}

// The reader is written from cyclictest's documented format: it must read
// cyclictest's own file too (when cyclictest is here and may run).
TEST(CyclictestHistogram, TheReaderReadsCyclictestsOwnFile) {
  if (::access("/usr/bin/cyclictest", X_OK) != 0) GTEST_SKIP() << "cyclictest is not installed";
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "cyclictest -h");
  const std::string histogram = temp_json("cyclictest-histogram");
  const auto result = run_command({"/usr/bin/cyclictest", "-q", "-t", "2", "-i", "1000", "-l", "50", "-h", "30",
                                   "--histfile=" + histogram});
  if (result.exit_status != 0) GTEST_SKIP() << "cyclictest did not run here: " << result.err;
  std::ifstream in(histogram);
  const auto parsed = lockstep::testing::parse_cyclictest_histogram(in);
  std::remove(histogram.c_str());
  ASSERT_EQ(parsed.error, "");
  ASSERT_EQ(parsed.counts.size(), 2u);
  EXPECT_EQ(parsed.buckets.size(), 30u);
  ASSERT_EQ(parsed.total.size(), 2u);
  ASSERT_EQ(parsed.overflows.size(), 2u);
  // cyclictest ends every thread once the first has run its -l 50 loops, so
  // on a loaded machine the other may have run fewer (47 of 50 beside two
  // busy loops): the first to finish holds 50, none more.
  std::uint64_t most = 0;
  for (std::size_t thread = 0; thread < 2; ++thread) {
    std::uint64_t sum = 0;
    for (std::uint64_t count : parsed.counts[thread]) sum += count;
    EXPECT_EQ(sum, parsed.total[thread]);
    EXPECT_LE(parsed.total[thread] + parsed.overflows[thread], 50u);
    most = std::max<std::uint64_t>(most, parsed.total[thread] + parsed.overflows[thread]);
  }
  EXPECT_EQ(most, 50u) << "-l 50: the thread that ended the run ran 50 loops";
}

TEST(DelayCommand, PerCpuShowsEveryCpuAndNamesTheNoisiest) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "delay --per-cpu");
  const auto path = temp_json("delay-per-cpu");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--per-cpu", "--duration", "20ms", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("noisiest CPU: "), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("like for like with cyclictest -S"), std::string::npos) << result.out;
  const auto document = read_json(path);
  const int cpus = document["settings"]["threads"].get<int>();
  ASSERT_GE(cpus, 1);
  EXPECT_EQ(document["settings"]["per_cpu"], true);
  EXPECT_EQ(document["settings"]["pin"], "per_cpu");
  ASSERT_EQ(document["per_cpu"]["cpus"].size(), static_cast<std::size_t>(cpus));
  int samples = 0;
  for (const auto& cpu : document["per_cpu"]["cpus"]) {
    EXPECT_TRUE(cpu["cpu"].is_number());
    // Each CPU's thread runs the 20 periods on its own schedule: a step or a
    // skipped period each.
    const int steps = cpu["completion_ns"]["count"].get<int>();
    EXPECT_EQ(steps + cpu["skipped_periods"].get<int>(), 20);
    EXPECT_EQ(cpu["wakeup_latency_ns"]["count"], steps);
    samples += steps;
  }
  EXPECT_TRUE(document["per_cpu"]["noisiest"]["cpu"].is_number());
  EXPECT_TRUE(document["per_cpu"]["noisiest"]["rule"].is_string());
  ASSERT_EQ(document["latency_histogram"]["columns"].size(), static_cast<std::size_t>(cpus));
  EXPECT_EQ(document["latency_histogram"]["columns"][0]["name"].get<std::string>().rfind("cpu ", 0), 0u);
  EXPECT_EQ(document["wakeup_latency_ns"]["count"], samples);
  EXPECT_EQ(document["completion_ns"]["count"], samples);  // each CPU its own deadline
}

// A rate of 0.5 needs trials of 5 periods: the search runs in a moment.
TEST(DelayCommand, FindPeriodRecordsTheSearch) {
  lockstep::testing::watchdog guard(std::chrono::seconds(120 * lockstep::testing::kSlowdown), "delay --find-period");
  const auto path = temp_json("delay-find");
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "2", "--find-period", "--miss-rate", "0.5",
                                   "--period", "2ms", "--search-budget", "20s", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("find-period: "), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("rule: a period holds when the one-sided 95 % Clopper-Pearson"), std::string::npos);
  EXPECT_NE(result.out.find("answer: "), std::string::npos) << result.out;
  const auto document = read_json(path);
  const auto& search = document["find_period"];
  EXPECT_EQ(search["miss_rate"], 0.5);
  EXPECT_EQ(search["trial_periods"], 5);
  EXPECT_EQ(search["start_period_ns"], 2'000'000);
  ASSERT_FALSE(search["trials"].empty());
  EXPECT_EQ(search["trials"][0]["period_ns"], 2'000'000);
  for (const auto& trial : search["trials"]) {
    for (const char* key : {"period_ns", "periods", "misses", "miss_rate", "upper_bound", "holds"})
      EXPECT_TRUE(trial.contains(key)) << key;
    EXPECT_EQ(trial["holds"].get<bool>(), trial["upper_bound"].get<double>() <= 0.5);
  }
  for (const char* key : {"budget_cut", "stopped_because", "elapsed_s", "rule", "confidence"})
    EXPECT_TRUE(search.contains(key)) << key;
  // Whether stalls, not the step, set the answer: said in the JSON and, only
  // then, in one line of the output (the rule's known answers at its edge are
  // delay_output_test's SetByStalls).
  ASSERT_TRUE(search["set_by_stalls"].is_boolean());
  double largest_p99 = 0;
  for (const auto& trial : search["trials"]) largest_p99 = std::max(largest_p99, trial["completion_p99_ns"].get<double>());
  EXPECT_DOUBLE_EQ(search["largest_completion_p99_ns"].get<double>(), largest_p99);
  EXPECT_EQ(result.out.find("set by stalls: ") != std::string::npos, search["set_by_stalls"].get<bool>())
      << result.out;
  if (search["found_period_ns"].is_number()) {
    ASSERT_TRUE(search["confirm"].is_object());
    EXPECT_EQ(search["confirm"]["period_ns"], search["found_period_ns"]);
    EXPECT_EQ(document["settings"]["period_ns"], search["found_period_ns"]);
    EXPECT_EQ(document["completion_ns"]["count"].get<int>() + search["confirm"]["skipped_periods"].get<int>(),
              search["confirm"]["periods"].get<int>());
    EXPECT_NE(result.out.find("confirming run at "), std::string::npos);
  } else {
    EXPECT_TRUE(search["confirm"].is_null());
  }
}

TEST(DelayCommand, HelpSaysWhichViewIsLikeForLike) {
  const auto result = run_command({LOCKSTEP_BINARY, "delay", "--help"});
  ASSERT_EQ(result.exit_status, 0);
  EXPECT_NE(result.out.find("the paper's model: 4 participants"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("like for like with cyclictest -t1"), std::string::npos);
  EXPECT_NE(result.out.find("like for like with cyclictest -S"), std::string::npos);
  // Threads beyond the paper's four equations integrate a chain.
  EXPECT_EQ(result.out.find("at most the model's 4 equations"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("--masses"), std::string::npos);
  EXPECT_NE(result.out.find("model:chainS"), std::string::npos);
}

const std::string kScript = std::string(LOCKSTEP_SOURCE_DIR) + "/bench/vs_cyclictest.sh";

TEST(VsCyclictestScript, BadInputExitsTwoWithOneLine) {
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"--priority", "0"}, {"--period-us", "5"}, {"--cpu", "4095"}, {"--duration-s", "x"}, {"--bogus"},
           {"--rounds", "0"}, {"--rounds", "x"}, {"--dma-latency-us", "-1"}, {"--dma-latency-us"}}) {
    std::vector<std::string> argv{kScript, "--lockstep", LOCKSTEP_BINARY};
    argv.insert(argv.end(), args.begin(), args.end());
    const auto result = run_command(argv);
    EXPECT_EQ(result.exit_status, 2) << args[0] << "\n" << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << args[0] << "\n" << result.err;
  }
}

TEST(VsCyclictestScript, PrintsBothDistributions) {
  if (::access("/usr/bin/cyclictest", X_OK) != 0) GTEST_SKIP() << "cyclictest is not installed";
  if (::geteuid() != 0) GTEST_SKIP() << "SCHED_FIFO and mlock need root here";
  lockstep::testing::watchdog guard(std::chrono::seconds(120 * lockstep::testing::kSlowdown), "vs_cyclictest.sh");
  const auto result = run_command({kScript, "--lockstep", LOCKSTEP_BINARY, "--duration-s", "1", "--cpu", "0",
                                   "--period-us", "2000", "--rounds", "2"});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  for (const char* row : {"min", "median", "p99", "max", "samples", "median ratio:", "p99 ratio:"})
    EXPECT_NE(result.out.find(row), std::string::npos) << row;
  EXPECT_NE(result.out.find("cyclictest"), std::string::npos);
  EXPECT_NE(result.out.find("2 rounds)"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("held at 0 us by both"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("lockstep's idle: "), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("      500"), std::string::npos) << result.out;  // 1 s / 2 ms periods
}

}  // namespace
