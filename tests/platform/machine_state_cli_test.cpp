// The machine's state as a user sees it: `lockstep topology`'s state lines
// and a command's context, read from the fixture trees of
// tests/fixtures/machine_state/ (LOCKSTEP_STATE_ROOT), against the files
// beside them (<tree>.topology.txt, <tree>.context.json; "{root}" stands for
// the tree's path); and on this machine, whatever it is.
#include <sched.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/scratch_directory.hpp"
#include "tests/support/watchdog.hpp"

namespace {

namespace fs = std::filesystem;
using lockstep::testing::run_command;

const fs::path kFixtures = fs::path(LOCKSTEP_SOURCE_DIR) / "tests" / "fixtures" / "machine_state";

std::string slurp(const fs::path& path) {
  std::ifstream file(path);
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

std::string with_root(std::string text, const std::string& root) {
  for (std::size_t at = text.find("{root}"); at != std::string::npos; at = text.find("{root}", at + root.size()))
    text.replace(at, 6, root);
  return text;
}

// From "\nmachine state (" to the end: the state lines of `lockstep topology`.
std::string state_section(const std::string& out) {
  const std::size_t at = out.find("\nmachine state (");
  return at == std::string::npos ? std::string() : out.substr(at + 1);
}

// LOCKSTEP_STATE_ROOT for the commands this test starts, while it lives.
class state_root {
 public:
  explicit state_root(const fs::path& root) { ::setenv("LOCKSTEP_STATE_ROOT", root.c_str(), 1); }
  ~state_root() { ::unsetenv("LOCKSTEP_STATE_ROOT"); }
  state_root(const state_root&) = delete;  // owns the variable
  state_root& operator=(const state_root&) = delete;
};

// This process, and the commands it starts, on the first CPU it may use, while
// it lives: the context's CPU-dependent keys (the IRQs on the command's CPUs,
// the CPUs sampled) then name that one CPU whatever the machine.
class one_cpu {
 public:
  one_cpu() {
    ::sched_getaffinity(0, sizeof saved_, &saved_);
    for (unsigned cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
      if (!CPU_ISSET(cpu, &saved_)) continue;
      cpu_ = cpu;
      cpu_set_t only;
      CPU_ZERO(&only);
      CPU_SET(cpu, &only);
      ::sched_setaffinity(0, sizeof only, &only);
      break;
    }
  }
  ~one_cpu() { ::sched_setaffinity(0, sizeof saved_, &saved_); }
  one_cpu(const one_cpu&) = delete;  // restores the affinity once
  one_cpu& operator=(const one_cpu&) = delete;
  unsigned cpu() const noexcept { return cpu_; }

 private:
  cpu_set_t saved_{};
  unsigned cpu_ = 0;
};

struct tree {
  const char* name;
  const char* synthetic;  // a machine of the tree's CPUs, so that topology's affinity set is all of them
};
const tree kTrees[] = {{"intel_powersave_turbo", "core:2 pu:2"},
                       {"amd_performance_noboost", "core:4 pu:2"},
                       {"vm_no_cpufreq", "core:2 pu:1"}};

// The machine-state keys of a context (those the golden file names).
nlohmann::json state_keys(const nlohmann::json& context, const nlohmann::json& golden) {
  nlohmann::json keys = nlohmann::json::object();
  for (const auto& [key, value] : golden.items()) keys[key] = context.contains(key) ? context.at(key) : nullptr;
  return keys;
}

TEST(MachineStateCli, TopologyShowsEachTreesStateLines) {
  for (const auto& [name, synthetic] : kTrees) {
    const fs::path root = kFixtures / name;
    const state_root guard(root);
    const auto result = run_command({LOCKSTEP_BINARY, "topology", "--synthetic", synthetic});
    ASSERT_EQ(result.exit_status, 0) << name << ": " << result.err;
    EXPECT_EQ(state_section(result.out), with_root(slurp(kFixtures / (std::string(name) + ".topology.txt")),
                                                   root.string()))
        << name;
  }
}

TEST(MachineStateCli, VerifysContextCarriesEachTreesState) {
  lockstep::testing::watchdog guard(std::chrono::seconds(120 * lockstep::testing::kSlowdown), "verify hung");
  lockstep::testing::scratch_directory scratch("lockstep-machine-state");
  const one_cpu pinned;
  if (pinned.cpu() != 0) GTEST_SKIP() << "the golden files name CPU 0, which this process may not use";
  for (const auto& [name, synthetic] : kTrees) {
    const fs::path root = kFixtures / name;
    const state_root root_guard(root);
    const std::string out = scratch.file(std::string(name) + ".json");
    const auto result = run_command({LOCKSTEP_BINARY, "verify", "--out", out});
    ASSERT_EQ(result.exit_status, 0) << name << ": " << result.err;
    std::ifstream file(out);
    const nlohmann::json context = nlohmann::json::parse(file).at("context");
    const nlohmann::json golden =
        nlohmann::json::parse(with_root(slurp(kFixtures / (std::string(name) + ".context.json")), root.string()));
    EXPECT_EQ(state_keys(context, golden), golden) << name;
  }
}

TEST(MachineStateCli, ARunsContextCarriesTheIntelTreesState) {
  lockstep::testing::watchdog guard(std::chrono::seconds(180 * lockstep::testing::kSlowdown), "the run hung");
  lockstep::testing::scratch_directory scratch("lockstep-machine-state");
  const one_cpu pinned;
  if (pinned.cpu() != 0) GTEST_SKIP() << "the golden files name CPU 0, which this process may not use";
  const fs::path root = kFixtures / "intel_powersave_turbo";
  const state_root root_guard(root);
  const std::string out = scratch.file("run.json");
  const auto result =
      run_command({LOCKSTEP_BINARY, "run", "--quick", "--sync", "std_barrier", "--layout", "padded64", "--threads", "1",
                   "--pin", "none", "--repetitions", "1", "--pairs", "0", "--min-time", "1ms", "--out", out});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  std::ifstream file(out);
  const nlohmann::json context = nlohmann::json::parse(file).at("context");
  const nlohmann::json golden =
      nlohmann::json::parse(with_root(slurp(kFixtures / "intel_powersave_turbo.context.json"), root.string()));
  EXPECT_EQ(state_keys(context, golden), golden);
}

// This machine as it is: the state lines fit 120 columns, and where cpufreq
// is absent (a VM) they say so and no bias line follows.
TEST(MachineStateCli, ThisMachinesStateLines) {
  const auto result = run_command({LOCKSTEP_BINARY, "topology"});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const std::string section = state_section(result.out);
  ASSERT_FALSE(section.empty()) << result.out;
  EXPECT_EQ(section.rfind("machine state (read under /):\n", 0), 0U) << section;
  std::istringstream lines(section);
  for (std::string line; std::getline(lines, line);) EXPECT_LE(line.size(), 120U) << line;
  if (!fs::exists("/sys/devices/system/cpu/cpu0/cpufreq/scaling_governor")) {
    EXPECT_NE(section.find("  cpufreq: unavailable"), std::string::npos) << section;
    EXPECT_EQ(section.find("a run here:"), std::string::npos) << "nothing known, no warning:\n" << section;
  }
}

}  // namespace
