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
      {LOCKSTEP_BINARY, "falseshare", "--window", "2ms", "--repeats", "1", "--strides", "8,64,128", "--out", path});
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
  expect_usage_error({"delay", "--threads", "5"});  // the model has 4 equations
  expect_usage_error({"delay", "--sync", "seqlock", "--layout", "packed"});  // not applicable
  expect_usage_error({"delay", "--fifo", "0"});
  expect_usage_error({"delay", "--fifo", "100"});
  expect_usage_error({"delay", "--compare-pinning", "--pin", "none"});
  expect_usage_error({"delay", "--out", "/nonexistent-dir/d.json"});
}

void expect_delay_json(const nlohmann::json& document, int periods, int threads) {
  EXPECT_EQ(document["kind"], "delay");
  EXPECT_EQ(document["lockstep_schema"], 1);
  EXPECT_TRUE(document["context"]["kernel"].is_string());
  const auto& settings = document["settings"];
  EXPECT_EQ(settings["period_ns"], 1'000'000);
  EXPECT_EQ(settings["threads"], threads);
  for (const char* key : {"duration_s", "sync", "layout", "pin", "fifo_priority", "mlock"})
    EXPECT_TRUE(settings.contains(key)) << key;
  EXPECT_EQ(document["wakeup_latency_ns"]["count"], periods * threads);
  EXPECT_EQ(document["completion_ns"]["count"], periods);
  for (const char* key : {"min", "p50", "p99", "p999", "max"}) {
    EXPECT_TRUE(document["wakeup_latency_ns"][key].is_number()) << key;
    EXPECT_TRUE(document["completion_ns"][key].is_number()) << key;
  }
  EXPECT_LE(document["deadline_misses"].get<int>(), periods);
  std::uint64_t in_histogram = 0;
  for (const auto& count : document["histogram"]["counts"]) in_histogram += count.get<std::uint64_t>();
  EXPECT_EQ(in_histogram, static_cast<std::uint64_t>(periods * threads));
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
  EXPECT_TRUE(document["settings"]["fifo_priority"].is_null());
  EXPECT_EQ(document["settings"]["mlock"], false);
  EXPECT_FALSE(document.contains("figure5_unpinned"));
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
  EXPECT_EQ(document["unpinned"]["completion_ns"]["count"], 10);
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
  lockstep::testing::watchdog guard(std::chrono::seconds(60), "delay without CAP_SYS_NICE");
  const auto result = run_without(CAP_SYS_NICE, RLIMIT_RTPRIO, {"delay", "--fifo", "50", "--duration", "10ms"});
  EXPECT_EQ(result.exit_status, 2) << result.err;
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find("SCHED_FIFO"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("without --fifo"), std::string::npos) << result.err;
}

TEST(DelayCommand, WithoutMlockPermissionExitsTwoAndSaysHowToRunWithout) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60), "delay without CAP_IPC_LOCK");
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
  if (result.exit_status == 2) GTEST_SKIP() << "not permitted here: " << result.err;
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const auto document = read_json(path);
  expect_delay_json(document, 10, 1);
  EXPECT_EQ(document["settings"]["fifo_priority"], 10);
  EXPECT_EQ(document["settings"]["mlock"], true);
}

const std::string kScript = std::string(LOCKSTEP_SOURCE_DIR) + "/bench/vs_cyclictest.sh";

TEST(VsCyclictestScript, BadInputExitsTwoWithOneLine) {
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"--priority", "0"}, {"--period-us", "5"}, {"--cpu", "4095"}, {"--duration-s", "x"}, {"--bogus"}}) {
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
  lockstep::testing::watchdog guard(std::chrono::seconds(120), "vs_cyclictest.sh");
  const auto result = run_command({kScript, "--lockstep", LOCKSTEP_BINARY, "--duration-s", "1", "--cpu", "0",
                                   "--period-us", "2000"});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  for (const char* row : {"min", "median", "p99", "max", "samples"}) EXPECT_NE(result.out.find(row), std::string::npos) << row;
  EXPECT_NE(result.out.find("cyclictest"), std::string::npos);
  EXPECT_NE(result.out.find(" 500 "), std::string::npos) << result.out;  // 1 s / 2 ms periods, both tools
}

}  // namespace
