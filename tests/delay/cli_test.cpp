// The delay commands as a user runs them: bad input exits 2 with one line;
// each command runs briefly and writes parseable JSON in the agreed shape.
// No test asserts a latency.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

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
  expect_usage_error({"c2c", "--json", "/nonexistent-dir/c2c.json"});
  expect_usage_error({"c2c", "--synthetic", "pack:zero"});
}

TEST(C2cCommand, WritesTheAgreedJson) {
  if (!two_cpus()) GTEST_SKIP() << "needs two CPUs";
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "lockstep c2c");
  const auto path = temp_json("c2c");
  const auto result =
      run_command({LOCKSTEP_BINARY, "c2c", "--samples", "5", "--rounds", "5", "--cores", "0,1", "--json", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("median one-way latency"), std::string::npos);
  const auto document = read_json(path);
  EXPECT_EQ(document["kind"], "c2c");
  EXPECT_EQ(document["lockstep_schema"], 1);
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
  expect_usage_error({"falseshare", "--ms", "0"});
  expect_usage_error({"falseshare", "--repeats", "0"});
  expect_usage_error({"falseshare", "--cores", "0,4095"});
  expect_usage_error({"falseshare", "--json", "/nonexistent-dir/f.json"});
  expect_usage_error({"falseshare", "--bogus"});
}

TEST(FalseshareCommand, WritesParseableJson) {
  if (!two_cpus()) GTEST_SKIP() << "needs two CPUs";
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "lockstep falseshare");
  const auto path = temp_json("falseshare");
  const auto result = run_command(
      {LOCKSTEP_BINARY, "falseshare", "--ms", "2", "--repeats", "1", "--strides", "8,64,128", "--json", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("time per write"), std::string::npos);
  const auto document = read_json(path);
  EXPECT_EQ(document["kind"], "falseshare");
  ASSERT_EQ(document["strides"].size(), 3u);
  EXPECT_EQ(document["strides"][0]["stride_bytes"], 8);
  EXPECT_EQ(document["strides"][0]["share_line"], true);
  EXPECT_EQ(document["strides"][1]["share_line"], false);
  EXPECT_EQ(document["strides"][1]["share_line_pair"], true);
  EXPECT_EQ(document["strides"][2]["share_line_pair"], false);
  for (const auto& stride : document["strides"]) EXPECT_TRUE(stride["ns_per_write"].contains("p50"));
}

TEST(MigrateCommand, BadInputExitsTwoWithOneLine) {
  expect_usage_error({"migrate", "--bytes", "8"});
  expect_usage_error({"migrate", "--repeats", "0"});
  expect_usage_error({"migrate", "--cores", "0"});
  expect_usage_error({"migrate", "--cores", "0,1,2"});
  expect_usage_error({"migrate", "--cores", "0,4095"});
  expect_usage_error({"migrate", "--json", "/nonexistent-dir/m.json"});
}

TEST(MigrateCommand, WritesParseableJson) {
  if (!two_cpus()) GTEST_SKIP() << "needs two CPUs";
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "lockstep migrate");
  const auto path = temp_json("migrate");
  const auto result =
      run_command({LOCKSTEP_BINARY, "migrate", "--repeats", "5", "--bytes", "65536", "--json", path});
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

}  // namespace
