// `lockstep topology` as a user runs it.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/run_command.hpp"

namespace {

using lockstep::testing::count_lines;
using lockstep::testing::run_command;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(TopologyCli, ThisMachineShowsSummaryAffinityAndPlans) {
  const auto result = run_command({LOCKSTEP_BINARY, "topology"});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_TRUE(contains(result.out, "summary: packages=")) << result.out;
  EXPECT_TRUE(contains(result.out, "affinity: CPUs")) << result.out;
  for (const char* placement :
       {"none threads=1", "compact threads=2", "compact_smt threads=2", "scatter threads=4", "migrate threads=1"}) {
    EXPECT_TRUE(contains(result.out, placement)) << placement;
  }
}

TEST(TopologyCli, SyntheticTwoSocketMachine) {
  const auto result = run_command({LOCKSTEP_BINARY, "topology", "--synthetic", "package:2 l3:2 core:4 pu:2"});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_TRUE(contains(result.out, "packages=2 l3=4 cores=16 pus=32")) << result.out;
  EXPECT_TRUE(contains(result.out, "scatter threads=4: 0->pu0 1->pu16 2->pu8 3->pu24")) << result.out;
  EXPECT_TRUE(contains(result.out, "compact threads=16")) << "the core count is one of the thread counts";
}

TEST(TopologyCli, JsonFileHasTheAgreedKeys) {
  char path[] = "/tmp/lockstep-topology-json-XXXXXX";
  const int fd = ::mkstemp(path);
  ASSERT_GE(fd, 0);
  ::close(fd);
  const auto result =
      run_command({LOCKSTEP_BINARY, "topology", "--synthetic", "package:1 l3:1 core:2 pu:1", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  std::ifstream file(path);
  const auto json = nlohmann::json::parse(file);
  std::remove(path);
  EXPECT_EQ(json.at("kind"), "topology");
  EXPECT_EQ(json.at("topology"), "packages=1 l3=1 cores=2 pus=2");
  EXPECT_EQ(json.at("topology_cores"), 2);
  EXPECT_FALSE(json.at("hwloc_version").get<std::string>().empty());
  bool found = false;
  for (const auto& plan : json.at("plans")) {
    if (plan.at("placement") == "compact" && plan.at("threads") == 4) {
      found = true;
      EXPECT_TRUE(plan.at("wrapped").get<bool>());
      EXPECT_TRUE(plan.at("oversubscribed").get<bool>());
      EXPECT_EQ(plan.at("pus"), nlohmann::json({0, 1, 0, 1}));
    }
  }
  EXPECT_TRUE(found);
}

// The plans at 16 and 64 CPUs stay readable: no line wider than 120 columns.
TEST(TopologyCli, NoLineIsWiderThan120ColumnsAt16And64Cpus) {
  for (const char* shape : {"pack:2 [numa] core:4 pu:2", "pack:2 [numa] l3:2 core:8 pu:2", "pack:1 l3:2 core:4 pu:2"}) {
    const auto result = run_command({LOCKSTEP_BINARY, "topology", "--synthetic", shape});
    ASSERT_EQ(result.exit_status, 0) << result.err;
    std::size_t start = 0;
    while (start < result.out.size()) {
      const std::size_t end = std::min(result.out.find('\n', start), result.out.size());
      EXPECT_LE(end - start, 120U) << shape << ": " << result.out.substr(start, end - start);
      start = end + 1;
    }
  }
}

TEST(TopologyCli, NumaNodesInTheTextAndTheJson) {
  char path[] = "/tmp/lockstep-topology-numa-XXXXXX";
  const int fd = ::mkstemp(path);
  ASSERT_GE(fd, 0);
  ::close(fd);
  const auto result =
      run_command({LOCKSTEP_BINARY, "topology", "--synthetic", "pack:2 [numa] l3:1 core:2 pu:2", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_TRUE(contains(result.out, "packages=2 l3=2 cores=4 pus=8 numa=2")) << result.out;
  EXPECT_TRUE(contains(result.out, "  node 0: CPUs 0-3\n  node 1: CPUs 4-7\n")) << result.out;
  EXPECT_TRUE(contains(result.out, "core   2: package 1, node 1, L3 1, L2 -, PUs 4-5")) << result.out;
  EXPECT_TRUE(contains(result.out, "scatter threads=2: 0->pu0 1->pu4 on nodes 0,1")) << result.out;
  std::ifstream file(path);
  const auto json = nlohmann::json::parse(file);
  std::remove(path);
  EXPECT_EQ(json.at("topology_numa_nodes"), 2);
  EXPECT_EQ(json.at("cpu_table").at("numa_node"), "0,0,0,0,1,1,1,1");
  EXPECT_EQ(json.at("cores").at(3).at("numa_node"), 1);
  for (const auto& plan : json.at("plans")) {
    if (plan.at("placement") == "scatter" && plan.at("threads") == 2) {
      EXPECT_EQ(plan.at("pu_numa_nodes"), nlohmann::json({0, 1}));
      EXPECT_EQ(plan.at("numa_nodes"), nlohmann::json({0, 1}));
      EXPECT_EQ(plan.at("memory_node"), 0);
    }
  }
}

TEST(TopologyCli, HybridXmlNamesTheKinds) {
  const std::string xml = std::string(LOCKSTEP_SOURCE_DIR) + "/tests/fixtures/topology/hybrid-8p-8e.xml";
  const auto result = run_command({LOCKSTEP_BINARY, "topology", "--xml", xml});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_TRUE(contains(result.out, "packages=1 l3=1 cores=16 pus=24 kinds=2")) << result.out;
  EXPECT_TRUE(contains(result.out, "  IntelCore: CPUs 0-15 (efficiency 1, up to 5200 MHz)\n"
                                   "  IntelAtom: CPUs 16-23 (efficiency 0, up to 3900 MHz)\n"))
      << result.out;
  EXPECT_TRUE(contains(result.out, "compact threads=4: 0->pu0 1->pu2 2->pu4 3->pu6 on IntelCore\n")) << result.out;
  EXPECT_TRUE(contains(result.out, "compact_smt threads=4: 0->pu0 1->pu1 2->pu2 3->pu3 on IntelCore\n"))
      << result.out;
  EXPECT_TRUE(contains(result.out, "(mixed kinds)")) << "16 threads fit no one kind: " << result.out;
}

TEST(TopologyCli, BadInputIsOneLineAndExitTwo) {
  for (const auto& arguments : std::vector<std::vector<std::string>>{
           {LOCKSTEP_BINARY, "topology", "--synthetic", "bogus:7"},
           {LOCKSTEP_BINARY, "topology", "--xml", "/nonexistent/machine.xml"},
           {LOCKSTEP_BINARY, "topology", "--synthetic", "package:1 core:2 pu:1", "--xml", "/tmp/x.xml"},
           {LOCKSTEP_BINARY, "topology", "--out", "/nonexistent/dir/out.json"},
           {LOCKSTEP_BINARY, "topology", "--frobnicate"},
       }) {
    const auto result = run_command(arguments);
    EXPECT_EQ(result.exit_status, 2) << arguments.back() << ": " << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_TRUE(contains(result.err, "lockstep: ")) << result.err;
  }
}

}  // namespace
