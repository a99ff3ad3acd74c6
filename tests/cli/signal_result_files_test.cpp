// Every command that writes a result file, under every signal that ends a
// run from a terminal, a supervisor or a closed session: SIGINT, SIGTERM,
// SIGHUP, and SIGHUP inherited as ignored (nohup). One table row per command,
// one CTest case per command and signal.
//
// Each case puts an earlier result at the destination, starts the command as a
// user would (the lockstep binary, its smallest settings that still measure for
// a second or two), waits until the command says it is measuring (its own
// progress line on stderr), signals it, and then holds it to the one writer's
// promise (bench/results/result_file.hpp):
//  - every file the command writes holds the earlier result, untouched, or the
//    whole new one (JSON that parses, of the command's kind); nothing else is
//    left in the directory (no temporary ".partial-" file);
//  - the exit says what happened: a command that holds its result file from
//    the start (run) ends with status 128 + the signal and the line "no result
//    file was written"; the others hold it only while they write it, so a
//    signal mid-measurement ends them by the signal itself (the shell's status
//    128 + the signal, no file touched), and one that lands during the write
//    gets the writer's exit and line, true to what the directory holds;
//  - an ignored SIGHUP stays ignored: the command finishes, status 0, whole
//    files.
// No command marks partial results in a file: none writes one before its
// measurement ends, so "absent" (the earlier file kept) is the only outcome of
// a signal before the rename. The cases assert events and files, never a time.
#include <errno.h>
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/scratch_directory.hpp"
#include "tests/support/watchdog.hpp"

namespace {

namespace fs = std::filesystem;
using lockstep::testing::scratch_directory;
using lockstep::testing::watchdog;

// One command as the table knows it. In `args`, OUT stands for the result
// file and SIDE for the second file some commands write (delay's histogram,
// verify's trajectory).
struct command_row {
  const char* name;
  std::vector<std::string> args;
  // The stderr text that says the measurement is under way; empty where the
  // command prints none (topology, which measures nothing, and verify, which
  // prints progress only on runs far longer than a test's): those are
  // signalled `delay_ms` after they start and may already have finished.
  const char* measuring;
  int delay_ms;
  // The command holds its result file (and the writer's handlers) from before
  // the measurement: a signal is always the writer's exit, never the signal's.
  bool holds_file_from_start;
  // The JSON's "kind" (run files are Google Benchmark's, with "benchmarks").
  const char* kind;
  // What the side file starts with when whole ("" when there is none).
  const char* side_start;
  // CPUs the command needs (c2c, falseshare and migrate pin to two).
  unsigned cpus;
};

const std::vector<command_row>& rows() {
  static const std::vector<command_row> table{
      {"run",
       {"run", "--quick", "--sync", "std_barrier", "--threads", "2", "--pairs", "0", "--out", "OUT"},
       "lockstep run:", 0, true, "", "", 2},
      {"c2c", {"c2c", "--max-pairs", "1", "--samples", "10000", "--out", "OUT"}, "c2c: pair 1/", 0, false, "c2c", "", 2},
      {"delay",
       {"delay", "--threads", "1", "--period", "10ms", "--duration", "2s", "--no-dma-latency", "--histogram-file",
        "SIDE", "--out", "OUT"},
       "delay: rk4/", 0, false, "delay", "# Histogram", 1},
      {"falseshare",
       {"falseshare", "--strides", "8,64", "--repetitions", "20", "--window", "20ms", "--out", "OUT"},
       "falseshare: repetition 1/", 0, false, "falseshare", "", 2},
      {"migrate", {"migrate", "--repetitions", "15000", "--out", "OUT"}, "migrate: 100/", 0, false, "migrate", "", 2},
      {"topology", {"topology", "--out", "OUT"}, "", 0, false, "topology", "", 1},
      {"verify", {"verify", "--t-end", "20s", "--csv", "SIDE", "--out", "OUT"}, "", 300, false, "verify", "t,x1,x2", 1},
  };
  return table;
}

struct signal_case {
  int signal_number;
  bool inherited_ignored;  // the parent ignored it before the exec (nohup)
  const char* name;
};

const std::vector<signal_case>& signal_cases() {
  static const std::vector<signal_case> cases{
      {SIGINT, false, "SIGINT"},
      {SIGTERM, false, "SIGTERM"},
      {SIGHUP, false, "SIGHUP"},
      {SIGHUP, true, "SIGHUP_ignored_as_under_nohup"},
  };
  return cases;
}

std::string content_of(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

unsigned usable_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof(set), &set) != 0) return 1;
  return static_cast<unsigned>(CPU_COUNT(&set));
}

// Starts the lockstep binary with `args`, stdout and stderr into files, the
// three signals at their default (or `ignored` ignored, as nohup leaves SIGHUP)
// and none blocked, as a shell starts a command. Returns once the exec has
// happened (a close-on-exec pipe reaches its end), so that a signal sent at
// once meets the command's dispositions, not the child's before the exec.
pid_t start(const std::vector<std::string>& args, const std::string& out_file, const std::string& err_file,
            int ignored) {
  std::vector<std::string> owned{LOCKSTEP_BINARY};
  owned.insert(owned.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& arg : owned) argv.push_back(arg.data());
  argv.push_back(nullptr);
  int exec_done[2];
  if (::pipe2(exec_done, O_CLOEXEC) != 0) return -1;
  const pid_t pid = ::fork();
  if (pid == 0) {
    // The child: async-signal-safe calls only until the exec.
    for (const int number : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) ::signal(number, number == ignored ? SIG_IGN : SIG_DFL);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    const int in = ::open("/dev/null", O_RDONLY);
    const int out = ::open(out_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = ::open(err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (in >= 0 && out >= 0 && err >= 0) {
      ::dup2(in, STDIN_FILENO);
      ::dup2(out, STDOUT_FILENO);
      ::dup2(err, STDERR_FILENO);
      ::execv(argv[0], argv.data());
    }
    const char failed = 1;
    [[maybe_unused]] const ssize_t written = ::write(exec_done[1], &failed, 1);
    ::_exit(127);
  }
  ::close(exec_done[1]);
  char failed = 0;
  ssize_t got = 0;
  do {
    got = ::read(exec_done[0], &failed, 1);
  } while (got < 0 && errno == EINTR);
  ::close(exec_done[0]);
  if (pid < 0 || got != 0) return -1;  // no fork, or the exec failed
  return pid;
}

bool is_whole_result(const std::string& text, const command_row& row) {
  const auto document = nlohmann::json::parse(text, nullptr, false);
  if (document.is_discarded() || !document.is_object()) return false;
  if (std::string(row.kind).empty()) return document.contains("benchmarks") && document.contains("lockstep_answer");
  return document.value("kind", "") == row.kind;
}

class SignalResultFiles : public ::testing::TestWithParam<std::tuple<std::size_t, std::size_t>> {};

TEST_P(SignalResultFiles, EveryFileIsTheEarlierOneOrWholeAndTheExitSaysWhich) {
  const command_row& row = rows()[std::get<0>(GetParam())];
  const signal_case& signal = signal_cases()[std::get<1>(GetParam())];
  if (usable_cpus() < row.cpus) GTEST_SKIP() << row.name << " needs " << row.cpus << " usable CPUs";
  watchdog guard(std::chrono::seconds(120 * lockstep::testing::kSlowdown),
                 std::string("lockstep ") + row.name + " under " + signal.name + " did not end");

  scratch_directory scratch("lockstep-signal-test");
  scratch_directory logs("lockstep-signal-logs");  // apart, so the result directory holds only results
  const std::string out = scratch.file("result.json");
  const std::string side = scratch.file("side.txt");
  const std::string earlier = "{\"kind\": \"an earlier result\"}\n";
  const std::string earlier_side = "an earlier side file\n";
  std::set<std::string> names{"result.json"};
  std::vector<std::string> args;
  for (const std::string& arg : row.args) {
    if (arg == "OUT") {
      args.push_back(out);
    } else if (arg == "SIDE") {
      args.push_back(side);
      names.insert("side.txt");
    } else {
      args.push_back(arg);
    }
  }
  write_text(out, earlier);
  if (names.count("side.txt")) write_text(side, earlier_side);

  const std::string out_log = logs.file("stdout");
  const std::string err_log = logs.file("stderr");
  const pid_t pid = start(args, out_log, err_log, signal.inherited_ignored ? signal.signal_number : 0);
  ASSERT_GT(pid, 0);

  // Until the command says it is measuring (or, without such a line, for the
  // row's delay). A command that ends first fails the case: the table's
  // settings must keep it measuring past its first progress line.
  int status = 0;
  bool ended_early = false;
  if (std::string(row.measuring).empty()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(row.delay_ms));
  } else {
    while (content_of(err_log).find(row.measuring) == std::string::npos) {
      if (::waitpid(pid, &status, WNOHANG) == pid) {
        ended_early = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  ASSERT_FALSE(ended_early) << row.name << " ended before it printed '" << row.measuring << "'; stderr:\n"
                            << content_of(err_log);
  ASSERT_EQ(::kill(pid, signal.signal_number), 0);
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);

  const std::string err = content_of(err_log);
  const std::string described = std::string(row.name) + " under " + signal.name + "\nstderr:\n" + err;
  std::set<std::string> left;
  for (const auto& name : scratch.entries()) left.insert(name);
  EXPECT_EQ(left, names) << "a temporary or partial file was left behind: " << described;

  const std::string result = content_of(out);
  const bool result_kept = result == earlier;
  const bool result_whole = is_whole_result(result, row);
  EXPECT_TRUE(result_kept || result_whole) << "half a result file: " << described << "\nfile:\n"
                                           << result.substr(0, 400);
  if (names.count("side.txt")) {
    const std::string side_text = content_of(side);
    const bool side_whole = side_text.rfind(row.side_start, 0) == 0 && !side_text.empty() && side_text.back() == '\n';
    EXPECT_TRUE(side_text == earlier_side || side_whole) << "half a side file: " << described;
    // The side file is written first: a whole result file means a whole side file.
    if (result_whole) {
      EXPECT_TRUE(side_whole) << described;
    }
  }

  const bool exited = WIFEXITED(status);
  const int code = exited ? WEXITSTATUS(status) : -1;
  // What happened, for the log (which outcome each case met).
  std::printf("  %s under %s: %s, result file %s\n", row.name, signal.name,
              exited ? ("exit " + std::to_string(code)).c_str()
                     : (std::string("ended by ") + strsignal(WTERMSIG(status))).c_str(),
              result_kept ? "the earlier one" : result_whole ? "whole and new" : "HALF WRITTEN");
  if (signal.inherited_ignored) {
    EXPECT_TRUE(exited && code == 0) << "an inherited ignored " << strsignal(signal.signal_number)
                                     << " did not stay ignored: " << described;
    EXPECT_TRUE(result_whole) << described;
    return;
  }
  if (WIFSIGNALED(status)) {
    EXPECT_FALSE(row.holds_file_from_start) << "ended by the signal, not by the writer's handler: " << described;
    EXPECT_EQ(WTERMSIG(status), signal.signal_number) << described;
    EXPECT_FALSE(WCOREDUMP(status)) << described;
    EXPECT_TRUE(result_kept) << "killed by the signal, yet the result file changed: " << described;
    return;
  }
  ASSERT_TRUE(exited) << described;
  if (code == 0) {
    // Only a row without a progress line may have finished before its signal.
    EXPECT_TRUE(std::string(row.measuring).empty()) << "the signal was lost mid-measurement: " << described;
    EXPECT_TRUE(result_whole) << "exit 0 without a whole result file: " << described;
    return;
  }
  EXPECT_EQ(code, 128 + signal.signal_number) << described;
  if (result_kept) {
    EXPECT_NE(err.find("no result file was written"), std::string::npos) << described;
  } else {
    EXPECT_NE(err.find("the result file " + out + " was written"), std::string::npos) << described;
  }
}

INSTANTIATE_TEST_SUITE_P(
    EveryCommandEverySignal, SignalResultFiles,
    ::testing::Combine(::testing::Range<std::size_t>(0, rows().size()),
                       ::testing::Range<std::size_t>(0, signal_cases().size())),
    [](const ::testing::TestParamInfo<SignalResultFiles::ParamType>& param_info) {
      return std::string(rows()[std::get<0>(param_info.param)].name) + "_" +
             signal_cases()[std::get<1>(param_info.param)].name;
    });

}  // namespace
