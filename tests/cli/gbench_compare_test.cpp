// Google Benchmark's own tools accept lockstep's result JSON: a tiny
// `lockstep run` writes a file, and Google Benchmark's compare.py (Debian's
// libbenchmark-tools, which scripts/setup.sh --test installs) compares it
// with itself, exits 0 and lists the RK4 entry. Skipped, saying why, only
// where compare.py is not installed.
#include <stdlib.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>

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


TEST(GoogleBenchmarkTools, CompareAcceptsTheResultJson) {
  if (!fs::exists(kCompareTool))
    GTEST_SKIP() << kCompareTool << " is absent: install Debian's libbenchmark-tools (scripts/setup.sh --test)";
  watchdog guard(std::chrono::seconds(150 * lockstep::testing::kSlowdown),
                 "a tiny lockstep run or Google Benchmark's compare.py did not finish");
  scratch_directory scratch("lockstep-gbench-compare");
  const std::string results = (scratch.path() / "tiny.json").string();

  // std_barrier too: its entries omit futex_waits_per_step (unavailable), which
  // the tools must take as well.
  const auto run = run_command({LOCKSTEP_BINARY, "run", "--quick", "--sync", "futex_spin,std_barrier", "--layout",
                                "padded64", "--threads", "2", "--pin", "compact", "--repetitions", "2",
                                "--min-time", "1ms", "--out", results});
  ASSERT_EQ(run.exit_status, 0) << run.err;
  ASSERT_TRUE(fs::exists(results)) << run.out;

  const auto compare = run_command({kPython, kCompareTool, "--no-color", "benchmarks", results, results});
  ASSERT_EQ(compare.exit_status, 0) << "compare.py refused the result JSON:\n" << compare.out << compare.err;
  for (const char* entry : {"rk4/sync:futex_spin/layout:padded64/pin:compact/threads:2",
                            "rk4/sync:std_barrier/layout:padded64/pin:compact/threads:2", "rk4/serial"})
    EXPECT_NE(compare.out.find(entry), std::string::npos) << entry << " not listed by compare.py:\n" << compare.out;
}

}  // namespace
