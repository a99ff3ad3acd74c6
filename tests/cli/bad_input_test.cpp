// One command-line grammar (bench/cli/options.hpp): every bad input of every
// command ends in exit status 2 with one line on stderr, before anything is
// measured (nothing on stdout, no progress line), and leaves no file behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/scratch_directory.hpp"

namespace {

using lockstep::testing::command_result;
using lockstep::testing::run_command;
using lockstep::testing::scratch_directory;

std::size_t count_lines(const std::string& text) {
  std::size_t lines = 0;
  for (char c : text) lines += c == '\n' ? 1 : 0;
  return lines;
}

struct bad_input {
  std::vector<std::string> arguments;  // after the binary; "@" stands for the scratch directory
  std::string names;                   // the message must mention this
};

class BadInput : public ::testing::TestWithParam<bad_input> {};

TEST_P(BadInput, ExitTwoOneLineNothingMeasuredNothingLeft) {
  scratch_directory scratch("lockstep-bad-input");
  std::vector<std::string> argv{LOCKSTEP_BINARY};
  std::string shown;
  for (std::string argument : GetParam().arguments) {
    if (const auto at = argument.find('@'); at != std::string::npos) argument.replace(at, 1, scratch.path().string());
    shown += argument + " ";
    argv.push_back(argument);
  }
  const command_result result = run_command(argv);
  EXPECT_EQ(result.exit_status, 2) << shown << "\n" << result.err;
  EXPECT_EQ(count_lines(result.err), 1u) << shown << "\n" << result.err;
  EXPECT_NE(result.err.find(GetParam().names), std::string::npos) << shown << "\n" << result.err;
  EXPECT_EQ(result.out, "") << shown;  // no summary, no table: nothing was measured
  EXPECT_TRUE(scratch.entries().empty()) << shown << ": left " << scratch.entries().front();
}

const bad_input kBadInputs[] = {
    // --out: a directory that is missing, a place where no file can be made,
    // a directory given as the file.
    {{"run", "--out", "@/missing/x.json"}, "--out"},
    {{"run", "--out", "/proc/lockstep-x.json"}, "--out"},
    {{"run", "--out", "@"}, "--out"},
    {{"c2c", "--out", "@/missing/c2c.json"}, "--out"},
    {{"c2c", "--out", "/proc/lockstep-c2c.json"}, "--out"},
    {{"delay", "--out", "/proc/lockstep-delay.json"}, "--out"},
    {{"delay", "--out", "@/missing/d.json"}, "--out"},
    {{"falseshare", "--out", "/proc/lockstep-f.json"}, "--out"},
    {{"migrate", "--out", "/proc/lockstep-m.json"}, "--out"},
    {{"verify", "--out", "/proc/lockstep-v.json"}, "--out"},
    {{"verify", "--csv", "@/missing/v.csv"}, "--csv"},
    {{"topology", "--out", "/proc/lockstep-t.json"}, "--out"},
    // --runs: a count of 1..100; its --out a directory whose parent exists;
    // the rest of the command checked before the directory is made.
    {{"run", "--runs", "0", "--out", "@/group"}, "--runs"},
    {{"run", "--runs", "2", "--out", "@/group.json"}, "--out: with --runs, a directory"},
    {{"run", "--runs", "2", "--out", "@/missing/group"}, "--out"},
    {{"run", "--runs", "2", "--sync", "nosuch", "--out", "@/group"}, "--sync"},
    // Counts: zero, negative, not a number.
    {{"run", "--repetitions", "0", "--out", "@/r.json"}, "--repetitions"},
    {{"run", "--repetitions", "-3", "--out", "@/r.json"}, "--repetitions"},
    {{"run", "--repetitions", "many", "--out", "@/r.json"}, "--repetitions"},
    {{"c2c", "--samples", "0"}, "--samples"},
    {{"c2c", "--rounds", "0"}, "--rounds"},
    {{"falseshare", "--repetitions", "0"}, "--repetitions"},
    {{"migrate", "--repetitions", "-1"}, "--repetitions"},
    {{"mpi", "--repetitions", "0"}, "--repetitions"},
    // The old names of --repetitions still parse, and are checked as it is.
    {{"falseshare", "--repeats", "0"}, "--repetitions"},
    {{"migrate", "--repeats", "-1"}, "--repetitions"},
    {{"mpi", "--rounds", "0"}, "--repetitions"},
    {{"falseshare", "--repeats", "2", "--out", "/proc/lockstep-f.json"}, "--out"},
    {{"migrate", "--repeats", "2", "--out", "/proc/lockstep-m.json"}, "--out"},
    // Sizes: a binary unit or none; the first error past a good size is --out's.
    {{"migrate", "--bytes", "256KiB", "--out", "/proc/lockstep-m.json"}, "--out"},
    {{"migrate", "--bytes", "65536", "--out", "/proc/lockstep-m.json"}, "--out"},
    {{"migrate", "--bytes", "256KB"}, "256KiB"},
    {{"migrate", "--bytes", "256 KiB"}, "--bytes"},
    {{"migrate", "--bytes", "32B"}, "--bytes"},
    {{"migrate", "--bytes", "17GiB"}, "--bytes"},
    {{"falseshare", "--strides", "8,1KiB", "--out", "/proc/lockstep-f.json"}, "--out"},
    {{"falseshare", "--strides", "8,8KiB"}, "--strides"},
    // The noise band: 5 and 5% alike, 0 to 100.
    {{"run", "--noise", "5%", "--out", "@/missing/x.json"}, "--out"},
    {{"run", "--noise", "0.5 %", "--out", "@/missing/x.json"}, "--out"},
    {{"run", "--noise", "5%%", "--out", "@/r.json"}, "--noise"},
    {{"run", "--noise", "-1", "--out", "@/r.json"}, "--noise"},
    // A mistyped command or option: named, with the nearest valid spelling.
    {{"runn"}, "unknown command 'runn'; did you mean 'run'?"},
    {{"dleay", "--period", "1ms"}, "unknown command 'dleay'; did you mean 'delay'?"},
    {{"help", "runn"}, "unknown command 'runn'; did you mean 'run'?"},
    {{"xyzzy"}, "unknown command 'xyzzy'; `lockstep --help` lists the commands"},
    {{}, "no command given"},
    {{"run", "--quik"}, "unknown option --quik; did you mean --quick?"},
    {{"run", "--quik", "--out", "@/r.json"}, "unknown option --quik; did you mean --quick?"},
    {{"run", "--nosie=5"}, "unknown option --nosie; did you mean --noise?"},
    {{"falseshare", "--repeat", "3"}, "unknown option --repeat; did you mean --repetitions?"},
    {{"mpi", "--round", "3"}, "unknown option --round; did you mean --repetitions?"},
    // run never had --repeats (README.md says whose old name it is): refused,
    // with the name run gives what falseshare's --repeats is.
    {{"run", "--repeats", "3"}, "unknown option --repeats; did you mean --repetitions?"},
    {{"c2c", "--repeats", "3"}, "unknown option --repeats (`lockstep c2c --help` lists the options)"},
    {{"c2c", "--sample", "5"}, "unknown option --sample; did you mean --samples?"},
    {{"migrate", "--byte", "4KiB"}, "unknown option --byte; did you mean --bytes?"},
    {{"verify", "--zzz"}, "unknown option --zzz (`lockstep verify --help` lists the options)"},
    {{"verify", "extra"}, "unexpected argument 'extra'"},
    {{"--quick", "run"}, "unknown option --quick"},
    // Durations: zero, no unit, not a time.
    {{"run", "--min-time", "0", "--out", "@/r.json"}, "--min-time"},
    {{"run", "--min-time", "0ms", "--out", "@/r.json"}, "--min-time: '0ms' is out of range (1ms to 60s)"},
    // A range is said in units, each bound in the largest unit that divides it.
    {{"run", "--min-time", "61s", "--out", "@/r.json"}, "(1ms to 60s)"},
    {{"falseshare", "--window", "500us"}, "--window: '500us' is out of range (1ms to 60s)"},
    {{"delay", "--find-period", "--miss-rate", "1e-3", "--search-budget", "10ms"}, "(1s to 86400s)"},
    {{"delay", "--histogram-bound", "200ms"}, "(1us to 100ms)"},
    {{"delay", "--dma-latency", "3000s"}, "(0 to 2000s)"},
    {{"mpi", "--ranks", "2", "--watchdog", "1ms"}, "--watchdog: '1ms' is out of range (100ms to 3600s)"},
    {{"run", "--min-time", "0.04", "--out", "@/r.json"}, "--min-time"},
    // No unit, and a unit not known, each said as it is, with the units taken.
    {{"run", "--min-time", "40", "--out", "@/r.json"}, "--min-time: '40' needs a unit (ns, us, ms or s"},
    {{"run", "--min-time", "40sec", "--out", "@/r.json"}, "--min-time: '40sec': unknown unit 'sec' (ns, us, ms or s)"},
    {{"delay", "--period", "1msec"}, "unknown unit 'msec' (ns, us, ms or s)"},
    {{"run", "--crossover", "--crossover-budget", "90", "--out", "@/r.json"},
     "--crossover-budget: '90' needs a unit (ns, us, ms or s"},
    {{"run", "--crossover", "--crossover-budget", "500ms", "--out", "@/r.json"}, "(1s to 3600s)"},
    {{"run", "--crossover-budget", "90s", "--out", "@/r.json"}, "--crossover"},
    {{"run", "--crossover", "--crossover-max-masses", "1", "--out", "@/r.json"}, "--crossover-max-masses"},
    {{"run", "--crossover", "--crossover-pairs", "1", "--out", "@/r.json"}, "--crossover-pairs"},
    {{"run", "--crossover-pairs", "32", "--out", "@/r.json"}, "--crossover"},
    {{"verify", "--dt", "1 ms"}, "unknown unit ' ms' (ns, us, ms or s)"},
    {{"migrate", "--bytes", "4XiB"}, "--bytes: '4XiB': unknown unit 'XiB' (B, KiB, MiB or GiB, or none for bytes)"},
    {{"delay", "--period", "1000"}, "--period"},
    {{"delay", "--duration", "soon"}, "--duration"},
    {{"falseshare", "--window", "100"}, "--window"},
    {{"run", "--pairs", "-1", "--out", "@/r.json"}, "--pairs"},
    {{"run", "--noise", "abc", "--out", "@/r.json"}, "--noise"},
    {{"run", "--noise", "150", "--out", "@/r.json"}, "--noise"},
    {{"verify", "--dt", "0.001"}, "--dt"},
    // Thread counts the model cannot split, and empty lists.
    {{"run", "--threads", "8", "--masses", "2", "--out", "@/r.json"}, "--threads"},
    {{"run", "--masses", "0", "--out", "@/r.json"}, "--masses"},
    {{"run", "--plan", "--out", "@/r.json"}, "--plan"},
    {{"run", "--threads", "0", "--out", "@/r.json"}, "--threads"},
    {{"run", "--threads", ",", "--out", "@/r.json"}, "--threads"},
    {{"run", "--sync", "", "--out", "@/r.json"}, "--sync"},
    {{"run", "--sync", "futex_spin,,seqlock", "--out", "@/r.json"}, "--sync"},
    {{"run", "--layout", "", "--out", "@/r.json"}, "--layout"},
    {{"run", "--pin", "compact,", "--out", "@/r.json"}, "--pin"},
    {{"run", "--sync", "nope", "--out", "@/r.json"}, "--sync: unknown value 'nope' (valid: std_barrier, "},
    // Every list of names suggests the nearest valid name to a mistyped one.
    {{"list", "syncs"}, "unknown list 'syncs' (did you mean sync?)"},
    {{"list", "nothing"}, "unknown list 'nothing' (valid: sync, layout, placement, exchange)"},
    {{"run", "--pin", "compakt", "--out", "@/r.json"}, "--pin: unknown value 'compakt' (did you mean compact?)"},
    {{"run", "--sync", "futex_spin,mailbx", "--out", "@/r.json"}, "--sync: unknown value 'mailbx' (did you mean mailbox?)"},
    {{"run", "--layout", "padded46", "--out", "@/r.json"}, "--layout: unknown value 'padded46' (did you mean padded64?)"},
    {{"delay", "--pin", "scater"}, "--pin: unknown value 'scater' (did you mean scatter?)"},
    {{"delay", "--sync", "seqlok"}, "--sync: unknown value 'seqlok' (did you mean seqlock?)"},
    {{"delay", "--per-cpu", "--layout", "perthread"}, "--layout: unknown value 'perthread' (did you mean per_thread?)"},
    {{"mpi", "--ranks", "2", "--exchange", "p2q"}, "--exchange: unknown value 'p2q' (did you mean p2p?)"},
    {{"mpi", "--ranks", "2", "--sync", "mailbx"}, "--sync: unknown value 'mailbx' (did you mean mailbox?)"},
    {{"mpi", "--ranks", "2", "--transport", "tpc"}, "--transport: unknown value 'tpc' (did you mean tcp?)"},
    {{"mpi", "--ranks", "2", "--pin", "compakt"}, "--pin: unknown value 'compakt' (did you mean compact?)"},
    {{"c2c", "--method", "store-load"}, "--method: unknown value 'store-load' (did you mean store_load?)"},
    {{"falseshare", "--strides", ""}, "--strides"},
    {{"falseshare", "--strides", "12"}, "--strides"},
    {{"delay", "--sync", "nope"}, "nope"},
    {{"delay", "--layout", "nope"}, "nope"},
    {{"delay", "--threads", "0"}, "--threads"},
};

INSTANTIATE_TEST_SUITE_P(EveryCommand, BadInput, ::testing::ValuesIn(kBadInputs));

// A run without --out writes to results/ in the working directory, which
// lockstep makes: a refused run makes nothing there, whether lockstep's own
// options refuse it or Google Benchmark's flags (read after the result file
// is opened).
class RefusedRun : public ::testing::TestWithParam<std::vector<std::string>> {};

TEST_P(RefusedRun, CreatesNothingInTheWorkingDirectory) {
  scratch_directory scratch("lockstep-refused-run");
  std::vector<std::string> argv{"/usr/bin/env", "-C", scratch.path().string(), LOCKSTEP_BINARY, "run"};
  argv.insert(argv.end(), GetParam().begin(), GetParam().end());
  const command_result result = run_command(argv);
  EXPECT_EQ(result.exit_status, 2) << result.err;
  EXPECT_EQ(count_lines(result.err), 1u) << result.err;
  EXPECT_EQ(result.out, "");
  EXPECT_TRUE(scratch.entries().empty()) << "left " << scratch.entries().front();
}

INSTANTIATE_TEST_SUITE_P(
    BadInput, RefusedRun,
    ::testing::Values(std::vector<std::string>{"--sync", "mailbx"}, std::vector<std::string>{"--threads", "0"},
                      std::vector<std::string>{"--min-time", "40"}, std::vector<std::string>{"--pin", "compakt"},
                      std::vector<std::string>{"--quik"},
                      std::vector<std::string>{"--", "--benchmark_no_such_flag=1"}));

// scripts/run.sh names the result file itself (so that it can write the
// report beside it) and makes results/ for it: a run that lockstep refuses
// leaves no results/ either. The script runs in a copy of the tree whose
// setup and build steps are stubs and whose release binary is this one.
TEST(RunScript, ARefusedRunLeavesNoResultsDirectory) {
  namespace fs = std::filesystem;
  scratch_directory scratch("lockstep-run-script");
  const fs::path tree = scratch.path();
  fs::create_directories(tree / "scripts");
  fs::create_directories(tree / "bin");
  fs::create_directories(tree / "build/release/bench");
  fs::copy_file(fs::path(LOCKSTEP_SOURCE_DIR) / "scripts/run.sh", tree / "scripts/run.sh");
  for (const fs::path& stub : {tree / "scripts/setup.sh", tree / "bin/cmake"}) {
    std::ofstream(stub) << "#!/bin/sh\nexit 0\n";
    fs::permissions(stub, fs::perms::owner_all);
  }
  fs::create_symlink(LOCKSTEP_BINARY, tree / "build/release/bench/lockstep");
  const std::vector<std::string> before = scratch.entries();
  for (const std::vector<std::string>& input : std::vector<std::vector<std::string>>{
           {"--sync", "mailbx"}, {"--threads", "0"}, {"--min-time", "40"}}) {
    std::vector<std::string> argv{"/usr/bin/env", "PATH=" + (tree / "bin").string() + ":/usr/bin:/bin", "bash",
                                  (tree / "scripts/run.sh").string()};
    argv.insert(argv.end(), input.begin(), input.end());
    const command_result result = run_command(argv);
    EXPECT_EQ(result.exit_status, 2) << input.front() << "\n" << result.err;
    EXPECT_EQ(count_lines(result.err), 1u) << input.front() << "\n" << result.err;
    std::vector<std::string> after = scratch.entries();
    std::sort(after.begin(), after.end());
    std::vector<std::string> expected = before;
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(after, expected) << input.front();
  }
}

}  // namespace
