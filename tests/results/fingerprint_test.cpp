// One machine context (bench/results/machine_context.hpp): `run`, `c2c` and
// `delay`, run briefly on one machine, write the same fingerprint keys with
// the same values, and `lockstep compare` calls them one machine.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "bench/results/machine_context.hpp"
#include "bench/results/machine_state_context.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/scratch_directory.hpp"
#include "tests/support/watchdog.hpp"

namespace {

using lockstep::bench::kMeasuredContextKeys;
using lockstep::testing::command_result;
using lockstep::testing::run_command;
using lockstep::testing::scratch_directory;
using lockstep::testing::watchdog;

nlohmann::json context_of(const std::string& path) {
  std::ifstream file(path);
  const nlohmann::json document = nlohmann::json::parse(file);
  return document.at("context");
}

TEST(Fingerprint, RunC2cAndDelayWriteOneMachineContext) {
  watchdog guard(std::chrono::seconds(180 * lockstep::testing::kSlowdown), "run, c2c and delay did not finish");
  scratch_directory scratch("lockstep-fingerprint");
  const std::string run = scratch.file("run.json");
  const std::string c2c = scratch.file("c2c.json");
  const std::string delay = scratch.file("delay.json");

  command_result result = run_command({LOCKSTEP_BINARY, "run", "--quick", "--sync", "futex_spin", "--layout",
                                       "padded64", "--threads", "2", "--pin", "compact", "--repetitions", "1",
                                       "--min-time", "1ms", "--out", run});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  result = run_command({LOCKSTEP_BINARY, "c2c", "--samples", "5", "--rounds", "5", "--method", "cas", "--out", c2c});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  result = run_command({LOCKSTEP_BINARY, "delay", "--threads", "2", "--period", "1ms", "--duration", "20ms",
                        "--sync", "futex_spin", "--out", delay});
  ASSERT_EQ(result.exit_status, 0) << result.err;

  // The fingerprint is what c2c writes (it writes nothing but the machine
  // context); run and delay carry every one of those keys with the same value,
  // but the constants each process measures at start-up (kMeasuredContextKeys:
  // the spin poll's cost and the futex round trip), which each carries with a
  // value of its own.
  const nlohmann::json reference = context_of(c2c);
  for (const char* key : {"cpu_model", "hypervisor", "kernel", "topology", "num_cpus", "host_name", "compiler",
                          "git_revision", "hwloc_version", "lockstep_version", "lockstep_schema", "cache_line_bytes",
                          "cache_line_source", "spin_hint"})
    EXPECT_TRUE(reference.contains(key)) << key;
  // The machine state's per-command readings (the frequency during the
  // command, the IRQs' effective CPUs) are every file's own: present, not equal.
  const auto per_command = [](const std::string& key) {
    for (const char* own : lockstep::bench::kPerCommandStateKeys)
      if (key == own) return true;
    return false;
  };
  for (const std::string& other : {run, delay}) {
    const nlohmann::json context = context_of(other);
    for (const auto& [key, value] : reference.items()) {
      ASSERT_TRUE(context.contains(key)) << other << " lacks " << key;
      const bool measured =
          std::find(kMeasuredContextKeys.begin(), kMeasuredContextKeys.end(), key) != kMeasuredContextKeys.end();
      if (per_command(key) || measured) continue;
      EXPECT_EQ(context.at(key), value) << other << ": " << key;
    }
  }

  // The machine's constants, in every file: the line and the futex round trip
  // as whole numbers of bytes and ns, the poll's cost in ns, and where each
  // came from.
  for (const std::string& file : {run, c2c, delay}) {
    const nlohmann::json context = context_of(file);
    for (const std::string_view key : kMeasuredContextKeys)
      ASSERT_TRUE(context.contains(std::string(key))) << file << ": " << key;
    const std::size_t line = std::stoul(context.at("cache_line_bytes").get<std::string>());
    EXPECT_EQ(line & (line - 1), 0U) << file << ": a line of " << line << " bytes";
    EXPECT_GT(std::stod(context.at("futex_round_trip_ns").get<std::string>()), 0.0) << file;
    EXPECT_GT(std::stod(context.at("spin_poll_ns").get<std::string>()), 0.0) << file;
    EXPECT_GT(std::stoul(context.at("spin_budget_polls").get<std::string>()), 0U) << file;
    EXPECT_FALSE(context.at("futex_round_trip_source").get<std::string>().empty()) << file;
    EXPECT_FALSE(context.at("cache_line_source").get<std::string>().empty()) << file;
    EXPECT_EQ(context.at("spin_hint"), reference.at("spin_hint")) << file;
  }

  result = run_command({LOCKSTEP_BINARY, "compare", run, c2c, delay});
  EXPECT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("machines: 1 distinct"), std::string::npos) << result.out << result.err;
}

}  // namespace
