// `lockstep topology` as a user runs it.
#include <unistd.h>

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
  for (const char* placement : {"none threads=1", "compact threads=2", "scatter threads=4", "migrate threads=1"}) {
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
