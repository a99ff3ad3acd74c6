// Google Benchmark's own tools accept lockstep's result JSON: a tiny
// `lockstep run` writes a file, and Google Benchmark's compare.py (Debian's
// libbenchmark-tools, which scripts/setup.sh --test installs) compares it
// with itself, exits 0 and lists the RK4 entry. And they read it as lockstep
// does (bench/run/team_driver.hpp, before measure_entry): every
// repetition's real_time of an rk4/ or barrier/ entry is its ns_per_step
// (ns_per_episode) and its cpu_time its cpu_ns_per_step (cpu_ns_per_episode),
// and for two tiny runs compare.py's ratio of the medians (its _median row)
// is `lockstep compare`'s ratio within 1 %. Skipped, saying why, only where
// compare.py is not installed.
#include <stdlib.h>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/scratch_directory.hpp"
#include "tests/support/watchdog.hpp"

namespace {

namespace fs = std::filesystem;
using lockstep::testing::run_command;
using lockstep::testing::scratch_directory;
using lockstep::testing::watchdog;

// Where Debian's libbenchmark-tools puts Google Benchmark's compare tool.
constexpr const char* kCompareTool = "/usr/share/benchmark/compare.py";
// Debian's interpreter: a pyenv python3 first on PATH cannot see Debian's scipy.
constexpr const char* kPython = "/usr/bin/python3";

nlohmann::json read_json(const std::string& path) {
  std::ifstream file(path);
  return nlohmann::json::parse(file);
}

bool starts_with(const std::string& text, const char* prefix) { return text.rfind(prefix, 0) == 0; }

// A tiny run of two primitives, one layout, two threads: rk4, barrier and the
// calibrations. std_barrier too: its entries omit futex_waits_per_step
// (unavailable), which the tools must take as well.
void tiny_run(const std::string& results) {
  const auto run = run_command({LOCKSTEP_BINARY, "run", "--quick", "--sync", "futex_spin,std_barrier", "--layout",
                                "padded64", "--threads", "2", "--pin", "compact", "--repetitions", "3",
                                "--min-time", "1ms", "--out", results});
  ASSERT_EQ(run.exit_status, 0) << run.err;
  ASSERT_TRUE(fs::exists(results)) << run.out;
}


TEST(GoogleBenchmarkTools, CompareAcceptsTheResultJson) {
  if (!fs::exists(kCompareTool))
    GTEST_SKIP() << kCompareTool << " is absent: install Debian's libbenchmark-tools (scripts/setup.sh --test)";
  watchdog guard(std::chrono::seconds(150 * lockstep::testing::kSlowdown),
                 "a tiny lockstep run or Google Benchmark's compare.py did not finish");
  scratch_directory scratch("lockstep-gbench-compare");
  const std::string results = (scratch.path() / "tiny.json").string();

  tiny_run(results);
  if (HasFatalFailure()) return;

  const auto compare = run_command({kPython, kCompareTool, "--no-color", "benchmarks", results, results});
  ASSERT_EQ(compare.exit_status, 0) << "compare.py refused the result JSON:\n" << compare.out << compare.err;
  for (const char* entry : {"rk4/sync:futex_spin/layout:padded64/pin:compact/threads:2",
                            "rk4/sync:std_barrier/layout:padded64/pin:compact/threads:2", "rk4/serial"})
    EXPECT_NE(compare.out.find(entry), std::string::npos) << entry << " not listed by compare.py:\n" << compare.out;
}

// Every repetition of an rk4/ or barrier/ entry: real_time (ns) is its time
// per unit, cpu_time its per-unit CPU time counter, the batch a counter.
TEST(GoogleBenchmarkTools, TimesArePerStep) {
  watchdog guard(std::chrono::seconds(150 * lockstep::testing::kSlowdown), "a tiny lockstep run did not finish");
  scratch_directory scratch("lockstep-gbench-per-step");
  const std::string results = (scratch.path() / "tiny.json").string();
  tiny_run(results);
  if (HasFatalFailure()) return;

  const nlohmann::json document = read_json(results);
  EXPECT_EQ(document["context"]["lockstep_schema"], "2");
  unsigned checked = 0;
  for (const auto& row : document["benchmarks"]) {
    const std::string name = row["run_name"];
    const bool rk4 = starts_with(name, "rk4/");
    if (!(rk4 || starts_with(name, "barrier/")) || row["run_type"] != "iteration" || row.contains("error_occurred"))
      continue;
    const std::string unit = rk4 ? "step" : "episode";
    SCOPED_TRACE(name + " repetition " + row["repetition_index"].dump());
    ASSERT_EQ(row["time_unit"], "ns");
    ASSERT_TRUE(row.contains("ns_per_" + unit) && row.contains("cpu_ns_per_" + unit) &&
                row.contains(unit + "s_per_batch"));
    const double per_unit = row["ns_per_" + unit];
    const double cpu_per_unit = row["cpu_ns_per_" + unit];
    EXPECT_NEAR(row["real_time"].get<double>(), per_unit, per_unit * 1e-9);
    EXPECT_NEAR(row["cpu_time"].get<double>(), cpu_per_unit, cpu_per_unit * 1e-9);
    EXPECT_GT(cpu_per_unit, 0.0);
    EXPECT_GE(row[unit + "s_per_batch"].get<double>(), 1.0);
    ++checked;
  }
  EXPECT_GE(checked, 9u) << "3 repetitions each of rk4/serial and at least two team entries";
}

// Two tiny runs: Google Benchmark's compare.py and `lockstep compare` give the
// same B/A for every entry both compare (compare.py's _median row: real_time of
// B's median aggregate over A's; lockstep's: the median of B's ns_per_step over
// A's), to 1 %.
TEST(GoogleBenchmarkTools, CompareRatiosAgreeWithLockstepCompare) {
  if (!fs::exists(kCompareTool))
    GTEST_SKIP() << kCompareTool << " is absent: install Debian's libbenchmark-tools (scripts/setup.sh --test)";
  watchdog guard(std::chrono::seconds(240 * lockstep::testing::kSlowdown),
                 "two tiny lockstep runs or the two compare tools did not finish");
  scratch_directory scratch("lockstep-gbench-ratios");
  const std::string a = (scratch.path() / "a.json").string();
  const std::string b = (scratch.path() / "b.json").string();
  tiny_run(a);
  if (HasFatalFailure()) return;
  tiny_run(b);
  if (HasFatalFailure()) return;

  const std::string google = (scratch.path() / "google.json").string();
  const auto theirs =
      run_command({kPython, kCompareTool, "--no-color", "--dump_to_json", google, "benchmarks", a, b});
  ASSERT_EQ(theirs.exit_status, 0) << theirs.out << theirs.err;
  const std::string ours_path = (scratch.path() / "lockstep.json").string();
  const auto ours = run_command({LOCKSTEP_BINARY, "compare", a, b, "--out", ours_path});
  ASSERT_EQ(ours.exit_status, 0) << ours.out << ours.err;

  std::map<std::string, double> lockstep_ratio;
  const nlohmann::json comparison = read_json(ours_path)["comparisons"].at(0);
  for (const char* table : {"rows", "calibrations"})
    for (const auto& row : comparison[table])
      if (row["measure"] == "time") lockstep_ratio[row["name"].get<std::string>()] = row["ratio"].get<double>();

  unsigned compared = 0;
  for (const auto& entry : read_json(google)) {
    const std::string name = entry["name"];
    const std::string suffix = "_median";
    if (!(starts_with(name, "rk4/") || starts_with(name, "barrier/")) || name.size() <= suffix.size() ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    const auto ours_ratio = lockstep_ratio.find(name.substr(0, name.size() - suffix.size()));
    if (ours_ratio == lockstep_ratio.end()) continue;  // errored in a file: lockstep compare lists it apart
    const auto& measured = entry["measurements"].at(0);
    const double google_ratio = measured["real_time_other"].get<double>() / measured["real_time"].get<double>();
    EXPECT_NEAR(google_ratio / ours_ratio->second, 1.0, 0.01)
        << name << ": compare.py " << google_ratio << ", lockstep compare " << ours_ratio->second;
    ++compared;
  }
  EXPECT_GE(compared, 3u) << "rk4/serial and the team entries of both primitives:\n" << ours.out;
}

}  // namespace
