// `lockstep mpi` as a user runs it: the binary launches mpirun for its ranks
// (as root with the run-as-root variables, oversubscribed on this 2-CPU
// machine), measures few steps, and writes its JSON; these tests check what
// it did, never how fast (README.md and docs/result-files.md say what that is).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/scratch_directory.hpp"

namespace {

using lockstep::testing::command_result;
using lockstep::testing::count_lines;
using lockstep::testing::run_command;
using lockstep::testing::scratch_directory;

// Few steps: the tests check behaviour. The oversubscribed 4-rank runs cost
// about 10-100 us a step here when the machine is otherwise idle, and a
// thousand times that when other work keeps both CPUs busy (CMakeLists.txt).
std::vector<std::string> small_run(const std::string& ranks, const std::string& out) {
  return {LOCKSTEP_BINARY, "mpi", "--ranks", ranks, "--steps", "60", "--warmup", "6", "--rounds", "2",
          "--pingpong", "100", "--watchdog", "20s", "--out", out};
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream file(path);
  return nlohmann::json::parse(file);
}

// Every exchange entry bitwise, with its figures; one ping-pong per round.
void expect_complete(const nlohmann::json& document, int ranks, const std::set<std::string>& exchanges,
                     const std::string& transport) {
  EXPECT_EQ(document.at("kind"), "mpi");
  EXPECT_EQ(document.at("context").at("mpi_transport"), transport);
  EXPECT_EQ(document.at("context").at("mpi_ranks"), std::to_string(ranks));
  EXPECT_EQ(document.at("context").at("mpi_hosts"), "1");
  EXPECT_NE(document.at("context").at("mpi_library").get<std::string>().find("MPI"), std::string::npos);
  EXPECT_EQ(document.at("settings").at("ranks"), ranks);
  std::set<std::string> seen;
  int pingpongs = 0;
  for (const auto& entry : document.at("benchmarks")) {
    const std::string name = entry.at("name");
    if (name.rfind("mpi/pingpong/", 0) == 0) {
      ++pingpongs;
      EXPECT_GT(entry.at("real_time").get<double>(), 0.0);
      EXPECT_LE(entry.at("one_way_min_ns").get<double>(), entry.at("one_way_p99_ns").get<double>());
      continue;
    }
    const std::string exchange = name.substr(name.find("exchange:") + 9, name.find('/', name.find("exchange:")) -
                                                                            name.find("exchange:") - 9);
    seen.insert(exchange);
    EXPECT_NE(name.find("/ranks:" + std::to_string(ranks) + "/hosts:1"), std::string::npos) << name;
    EXPECT_EQ(entry.at("bitwise"), 1) << name;
    EXPECT_GT(entry.at("real_time").get<double>(), 0.0) << name;
    EXPECT_LE(entry.at("stage_p50_ns").get<double>(), entry.at("stage_p99_ns").get<double>()) << name;
    EXPECT_LE(entry.at("stage_p99_ns").get<double>(), entry.at("stage_max_ns").get<double>()) << name;
    EXPECT_LE(entry.at("skew_p50_ns").get<double>(), entry.at("skew_max_ns").get<double>()) << name;
    EXPECT_LT(entry.at("slowest_rank").get<int>(), ranks) << name;
  }
  EXPECT_EQ(seen, exchanges);
  EXPECT_EQ(pingpongs, 2);
  std::set<std::string> detailed;
  for (const auto& details : document.at("exchanges")) {
    detailed.insert(details.at("exchange").get<std::string>());
    EXPECT_EQ(details.at("per_rank").size(), static_cast<std::size_t>(ranks));
    EXPECT_EQ(details.at("slowest_rank_counts").size(), static_cast<std::size_t>(ranks));
  }
  EXPECT_EQ(detailed, exchanges);
  // shm_window runs lockstep's own primitives across the processes: both of them.
  if (exchanges.count("shm_window") != 0) {
    std::set<std::string> syncs;
    for (const auto& details : document.at("exchanges"))
      if (details.at("exchange") == "shm_window") syncs.insert(details.at("sync").get<std::string>());
    EXPECT_EQ(syncs, (std::set<std::string>{"futex_spin", "mailbox"}));
  }
}

// The lines on stderr that say busy-polling ranks could share a CPU
// (distributed/rank_placement.hpp: rank 0 prints one, whatever the ranks).
std::vector<std::string> sharing_lines(const std::string& err) {
  std::vector<std::string> found;
  std::istringstream lines(err);
  for (std::string line; std::getline(lines, line);)
    if (line.find("busy-polling ranks could share a CPU") != std::string::npos) found.push_back(line);
  return found;
}

// Each rank's CPUs as it reported them once placed (the file's placement).
std::vector<std::vector<unsigned>> bound_cpus(const nlohmann::json& document) {
  std::vector<std::vector<unsigned>> result;
  for (const auto& rank : document.at("placement").at("ranks"))
    result.push_back(rank.at("cpus_bound").get<std::vector<unsigned>>());
  return result;
}

const std::set<std::string> kEveryExchange{"p2p", "allgather", "rma_put", "shm_window"};
const std::set<std::string> kNetworkExchanges{"p2p", "allgather", "rma_put"};

TEST(MpiCommand, TwoRanksSharedMemoryEveryExchangeBitwise) {
  scratch_directory scratch("lockstep-mpi-test");
  const std::string out = scratch.file("two.json");
  const command_result result = run_command(small_run("2", out));
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.err.find("lockstep mpi: running: "), std::string::npos) << "the launcher shows its command";
  EXPECT_NE(result.err.find("OMPI_ALLOW_RUN_AS_ROOT"), std::string::npos);
  EXPECT_NE(result.out.find("ping-pong"), std::string::npos);
  const nlohmann::json document = read_json(out);
  expect_complete(document, 2, kEveryExchange, "shm");
  // Two ranks given two CPUs or more, compact: a CPU each, nothing to say.
  if (document.at("placement").at("ranks").at(0).at("cpus_given").size() >= 2) {
    EXPECT_TRUE(sharing_lines(result.err).empty()) << result.err;
    EXPECT_EQ(document.at("placement").at("remedy"), "none");
    EXPECT_TRUE(document.at("placement").at("warning").is_null());
    const auto bound = bound_cpus(document);
    ASSERT_EQ(bound.size(), 2U);
    ASSERT_EQ(bound[0].size(), 1U);
    ASSERT_EQ(bound[1].size(), 1U);
    EXPECT_NE(bound[0], bound[1]);
    for (const auto& details : document.at("exchanges"))
      for (std::size_t rank = 0; rank < 2; ++rank) EXPECT_EQ(details.at("per_rank").at(rank).at("cpu"), bound[rank][0]);
  }
}

// Two ranks forced onto CPU 0: by the affinity set lockstep is started with
// (taskset), and by the user's own mpirun binding both ranks to slot 0 (a
// rankfile). Neither is oversubscribed to mpirun (it leaves
// mpi_yield_when_idle alone), so lockstep finds them bound to one CPU, says
// so in one line on stderr before measuring, makes them yield when idle, and
// records it; the measurement completes, bitwise.
TEST(MpiCommand, TwoRanksForcedOntoOneCpuAreSaidYieldAndRecorded) {
  scratch_directory scratch("lockstep-mpi-test");
  const std::string rankfile = scratch.file("rankfile");
  std::ofstream(rankfile) << "rank 0=localhost slot=0\nrank 1=localhost slot=0\n";
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  const std::vector<std::string> words{"--exchange", "p2p,shm_window", "--steps", "40", "--warmup", "4", "--rounds",
                                       "1", "--pingpong", "100", "--watchdog", "20s"};
  struct way {
    std::string name;
    std::vector<std::string> before;  // the command lockstep runs under
    bool launches = true;             // lockstep launches mpirun itself
  };
  const std::vector<way> ways{
      {"taskset", {"taskset", "-c", "0"}, true},
      {"rankfile", {"mpirun", "--np", "2", "--rankfile", rankfile, "--mca", "btl", "self,vader", "--mca",
                    "btl_vader_single_copy_mechanism", "none"}, false}};
  for (const way& forced : ways) {
    SCOPED_TRACE(forced.name);
    const std::string out = scratch.file(forced.name + ".json");
    std::vector<std::string> argv = forced.before;
    argv.insert(argv.end(), {LOCKSTEP_BINARY, "mpi"});
    if (forced.launches) argv.insert(argv.end(), {"--ranks", "2"});
    argv.insert(argv.end(), words.begin(), words.end());
    argv.insert(argv.end(), {"--out", out});
    const command_result result = run_command(argv);
    ASSERT_EQ(result.exit_status, 0) << result.err;
    const std::vector<std::string> said = sharing_lines(result.err);
    ASSERT_EQ(said.size(), 1U) << result.err;
    EXPECT_TRUE(std::regex_search(said[0], std::regex(R"(^lockstep mpi: busy-polling ranks could share a CPU: ranks 0 and 1 on host \S+ are bound to CPU 0 between them; they yield when idle)")))
        << said[0];
    // Said before anything was measured.
    EXPECT_LT(result.err.find(said[0]), result.err.find("ping-pong")) << result.err;

    const nlohmann::json document = read_json(out);
    const nlohmann::json& placement = document.at("placement");
    EXPECT_EQ(placement.at("remedy"), "yield_when_idle");
    EXPECT_EQ("lockstep mpi: " + placement.at("warning").get<std::string>(), said[0]);
    EXPECT_EQ(bound_cpus(document), (std::vector<std::vector<unsigned>>{{0}, {0}}));
    for (const auto& rank : placement.at("ranks")) {
      EXPECT_EQ(rank.at("cpus_given"), nlohmann::json::array({0}));
      EXPECT_EQ(rank.at("yields_when_idle"), true);
      EXPECT_EQ(rank.at("kernel"), placement.at("ranks").at(0).at("kernel"));
    }
    ASSERT_EQ(placement.at("machines").size(), 1U);
    EXPECT_EQ(placement.at("machines").at(0).at("crowded"),
              (nlohmann::json{{"ranks", {0, 1}}, {"cpus", {0}}}));
    for (const auto& entry : document.at("benchmarks")) {
      if (entry.contains("bitwise")) {
        EXPECT_EQ(entry.at("bitwise"), 1) << entry.at("name");
      }
    }
  }
}

TEST(MpiCommand, FourRanksOversubscribedEveryExchangeBitwise) {
  scratch_directory scratch("lockstep-mpi-test");
  const std::string out = scratch.file("four.json");
  const command_result result = run_command(small_run("4", out));
  ASSERT_EQ(result.exit_status, 0) << result.err;
  expect_complete(read_json(out), 4, kEveryExchange, "shm");
}

TEST(MpiCommand, TcpTransportTwoAndFourRanks) {
  for (const std::string ranks : {"2", "4"}) {
    scratch_directory scratch("lockstep-mpi-test");
    const std::string out = scratch.file("tcp.json");
    auto argv = small_run(ranks, out);
    argv.insert(argv.end(), {"--transport", "tcp"});
    const command_result result = run_command(argv);
    ASSERT_EQ(result.exit_status, 0) << result.err;
    EXPECT_NE(result.err.find("btl self,tcp"), std::string::npos) << result.err;
    const nlohmann::json document = read_json(out);
    expect_complete(document, std::stoi(ranks), kNetworkExchanges, "tcp");
    EXPECT_TRUE(document.at("not_applicable").contains("shm_window/futex_spin"));
    EXPECT_TRUE(document.at("not_applicable").contains("shm_window/mailbox"));
  }
}

TEST(MpiCommand, BeyondFourRanksIntegratesTheChain) {
  scratch_directory scratch("lockstep-mpi-test");
  const std::string out = scratch.file("chain.json");
  auto argv = small_run("6", out);
  argv.insert(argv.end(), {"--exchange", "p2p,shm_window"});
  const command_result result = run_command(argv);
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const nlohmann::json document = read_json(out);
  EXPECT_EQ(document.at("settings").at("model"), "chain3");
  expect_complete(document, 6, {"p2p", "shm_window"}, "shm");
}

TEST(MpiCommand, CompareReadsTwoRuns) {
  scratch_directory scratch("lockstep-mpi-test");
  const std::string a = scratch.file("a.json");
  const std::string b = scratch.file("b.json");
  for (const std::string& out : {a, b}) {
    auto argv = small_run("2", out);
    argv.insert(argv.end(), {"--exchange", "p2p,shm_window"});
    ASSERT_EQ(run_command(argv).exit_status, 0);
  }
  // --all: the short answer lists only the entries that changed.
  const command_result result = run_command({LOCKSTEP_BINARY, "compare", "--all", a, b});
  EXPECT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("exchange:p2p"), std::string::npos) << result.out;
}

TEST(MpiCommand, UnderTheUsersMpirun) {
  scratch_directory scratch("lockstep-mpi-test");
  const std::string out = scratch.file("external.json");
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  const std::vector<std::string> mpirun{"mpirun", "--np", "2", "--oversubscribe", "--mca", "btl", "self,vader",
                                        "--mca", "btl_vader_single_copy_mechanism", "none"};
  auto argv = mpirun;
  argv.insert(argv.end(), {LOCKSTEP_BINARY, "mpi", "--exchange", "allgather", "--steps", "100", "--rounds", "1",
                           "--pingpong", "100", "--out", out});
  const command_result result = run_command(argv);
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_EQ(read_json(out).at("context").at("mpi_launch").get<std::string>().rfind("external", 0), 0U);

  // --ranks that disagree with the job: every rank refuses, each in one line
  // that names it and its host; none leaves silently.
  argv = mpirun;
  argv.insert(argv.end(), {LOCKSTEP_BINARY, "mpi", "--ranks", "3", "--steps", "100"});
  const command_result mismatch = run_command(argv);
  EXPECT_NE(mismatch.exit_status, 0);
  EXPECT_NE(mismatch.err.find("--ranks 3 but mpirun started 2 ranks"), std::string::npos) << mismatch.err;
  for (const std::string rank : {"0", "1"})
    EXPECT_NE(mismatch.err.find("lockstep mpi: rank " + rank + " on "), std::string::npos) << mismatch.err;
}

// An mpirun for --mpirun that stands between the launcher and Open MPI's: it
// writes the words it was given to WORDS (one a line), and for its own
// --hostfile F (the first; the ranks' words come after the executable) it
// hands mpirun a copy of F and removes F first, so that the launcher and
// mpirun read the hostfile and the ranks cannot.
std::string write_mpirun_between(const scratch_directory& scratch) {
  const std::string path = scratch.file("mpirun-between");
  std::ofstream(path) << "#!/bin/sh\n"
                         "printf '%s\\n' \"$@\" > '"
                      << scratch.file("words") << "'\n"
                         "previous=\n"
                         "copied=\n"
                         "for word do\n"
                         "  shift\n"
                         "  if [ \"$previous\" = --hostfile ] && [ -z \"$copied\" ]; then\n"
                         "    cp \"$word\" \"$word.mpirun\" && rm \"$word\" && word=\"$word.mpirun\" && copied=1\n"
                         "  fi\n"
                         "  set -- \"$@\" \"$word\"\n"
                         "  previous=$word\n"
                         "done\n"
                         "exec mpirun \"$@\"\n";
  ::chmod(path.c_str(), 0755);
  return path;
}

std::vector<std::string> read_lines(const std::string& path) {
  std::ifstream file(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(file, line);) lines.push_back(line);
  return lines;
}

// The ranks get the user's own words, as typed (every option reaches them,
// in the user's spelling), and act on them: each non-default value is in the
// settings rank 0 writes.
TEST(MpiCommand, TheRanksGetTheOptionsAsTyped) {
  scratch_directory scratch("lockstep-mpi-test");
  const std::string out = scratch.file("typed.json");
  const std::string mpirun = write_mpirun_between(scratch);
  const std::vector<std::string> typed{"mpi", "--ranks", "2", "--steps=40", "--warmup", "3", "--rounds=1",
                                       "--pingpong", "50", "--pin", "none", "--watchdog=25s", "--masses", "3",
                                       "--exchange", "p2p", "--mpirun", mpirun, "--out", out};
  std::vector<std::string> argv{LOCKSTEP_BINARY};
  argv.insert(argv.end(), typed.begin(), typed.end());
  const command_result result = run_command(argv);
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const std::vector<std::string> words = read_lines(scratch.file("words"));
  ASSERT_GE(words.size(), typed.size());
  EXPECT_EQ(std::vector<std::string>(words.end() - static_cast<std::ptrdiff_t>(typed.size()), words.end()), typed)
      << "the words after the executable are not the user's";
  const nlohmann::json settings = read_json(out).at("settings");
  EXPECT_EQ(settings.at("steps"), 40);
  EXPECT_EQ(settings.at("warmup_steps"), 3);
  EXPECT_EQ(settings.at("rounds"), 1);
  EXPECT_EQ(settings.at("pingpong_round_trips"), 50);
  EXPECT_EQ(settings.at("pin"), "none");
  EXPECT_EQ(settings.at("watchdog_ns"), 25'000'000'000LL);
  EXPECT_EQ(settings.at("equations"), 6);
  EXPECT_EQ(settings.at("exchanges").size(), 1U);
}

// The launcher reads --hostfile (and mpirun does); a rank never does, so a
// hostfile the ranks cannot read (on another host, or gone, as here) stops
// nothing.
TEST(MpiCommand, AHostfileOnlyTheLauncherReadsStopsNoRank) {
  scratch_directory scratch("lockstep-mpi-test");
  const std::string out = scratch.file("hosts.json");
  const std::string hostfile = scratch.file("hosts");
  std::ofstream(hostfile) << "localhost slots=2\n";
  const std::string mpirun = write_mpirun_between(scratch);
  const command_result result = run_command({LOCKSTEP_BINARY, "mpi", "--ranks", "2", "--steps", "40", "--warmup", "3",
                                             "--rounds", "1", "--pingpong", "50", "--exchange", "allgather",
                                             "--hostfile", hostfile, "--mpirun", mpirun, "--out", out});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_FALSE(std::filesystem::exists(hostfile)) << "the stand-in mpirun removed it before the ranks started";
  EXPECT_EQ(read_json(out).at("settings").at("ranks"), 2);
}

// A rank that stops (or dies) ends the job within the watchdog's bound, with
// a message; never a hang (the CTest timeout is far behind).
//
// Rank 1 stalls at step 50 of the first exchange (p2p), outside any wait for
// another rank; the others block in the exchange waiting for it (directly, or
// for a rank that waits for it). The watchdog (distributed/watchdog.hpp)
// ends a rank that stopped outside a wait after the limit, and a waiting one
// after twice it, so rank 1's own line comes first and names it, its host and
// the place; any other line is a waiting rank's, at the same place, and says
// so. A watchdog that fired on a healthy rank (before the stall, elsewhere,
// or one that took a waiting rank for the stopped one) fails here.
TEST(MpiCommand, StalledRankIsNamedByItsOwnWatchdog) {
  ::setenv("LOCKSTEP_MPI_FAULT", "stall:1:50", 1);
  const command_result result = run_command({LOCKSTEP_BINARY, "mpi", "--ranks", "4", "--steps", "200", "--rounds",
                                             "1", "--pingpong", "100", "--watchdog", "1s"});
  ::unsetenv("LOCKSTEP_MPI_FAULT");
  EXPECT_EQ(result.exit_status, 3) << result.err;
  EXPECT_NE(result.err.find("the MPI job failed"), std::string::npos) << result.err;
  char host[256] = {};
  ASSERT_EQ(::gethostname(host, sizeof host - 1), 0);
  const std::regex stopped_here("^lockstep mpi: rank 1 on " + std::string(host) +
                                R"( stopped: no progress for 1 s outside any wait for another rank \(in p2p, at 50\): this rank is the one that stopped)");
  const std::regex waiting_here(
      R"(^lockstep mpi: rank [023] on \S+ made no progress for 2 s waiting for other ranks \(in p2p, at 50\): )");
  std::vector<std::string> watchdog_lines;
  std::istringstream lines(result.err);
  for (std::string line; std::getline(lines, line);)
    if (line.find(" stopped: no progress") != std::string::npos || line.find("made no progress") != std::string::npos)
      watchdog_lines.push_back(line);
  ASSERT_FALSE(watchdog_lines.empty()) << result.err;
  EXPECT_TRUE(std::regex_search(watchdog_lines.front(), stopped_here))
      << "the first watchdog line does not name rank 1 as the one that stopped: " << watchdog_lines.front();
  for (std::size_t index = 1; index < watchdog_lines.size(); ++index)
    EXPECT_TRUE(std::regex_search(watchdog_lines[index], waiting_here))
        << "a watchdog fired elsewhere than at the stall, or named another rank as stopped: " << watchdog_lines[index];
}

// A job that is slow but progressing is left alone: rank 1 sleeps 200 ms
// before each of the first exchange's 42 steps (8.4 s in all against a 2 s
// watchdog; every sleep is a tenth of the limit, and so is every wait of the
// ranks that wait for it, which leaves the rest for a loaded machine: beside
// two busy loops, a build and the suite, four ranks on two CPUs once went a
// whole second without progress at step 0 when the sleep was 300 ms and the
// limit 1 s). The job must finish, bitwise, with no watchdog line.
TEST(MpiCommand, SlowButProgressingJobIsLeftAlone) {
  scratch_directory scratch("lockstep-mpi-test");
  const std::string out = scratch.file("slow.json");
  ::setenv("LOCKSTEP_MPI_FAULT", "slow:1:200", 1);
  const command_result result =
      run_command({LOCKSTEP_BINARY, "mpi", "--ranks", "4", "--exchange", "p2p", "--steps", "20", "--warmup", "2",
                   "--rounds", "1", "--pingpong", "100", "--watchdog", "2s", "--out", out});
  ::unsetenv("LOCKSTEP_MPI_FAULT");
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_EQ(result.err.find("no progress"), std::string::npos) << result.err;
  const nlohmann::json document = read_json(out);
  ASSERT_EQ(document.at("benchmarks").size(), 2U);  // the ping-pong and p2p, one round
  for (const auto& entry : document.at("benchmarks")) {
    if (entry.at("name").get<std::string>().find("exchange:p2p") != std::string::npos) {
      EXPECT_EQ(entry.at("bitwise"), 1);
    }
  }
}

TEST(MpiCommand, KilledRankEndsTheJobWithAMessage) {
  ::setenv("LOCKSTEP_MPI_FAULT", "die:2:50", 1);
  const command_result result = run_command({LOCKSTEP_BINARY, "mpi", "--ranks", "4", "--steps", "200", "--rounds",
                                             "1", "--pingpong", "100", "--watchdog", "5s"});
  ::unsetenv("LOCKSTEP_MPI_FAULT");
  EXPECT_EQ(result.exit_status, 3) << result.err;
  EXPECT_NE(result.err.find("the MPI job failed"), std::string::npos) << result.err;
}

// Bad input: one line, exit 2, before anything is launched, nothing written.
TEST(MpiCommand, BadInputIsOneLineAndNothingLaunched) {
  scratch_directory scratch("lockstep-mpi-test");
  const std::string out = scratch.file("never.json");
  const std::string hostfile = scratch.file("no-such-hostfile");
  const std::vector<std::vector<std::string>> cases{
      {"--steps", "10"},                                    // no --ranks outside mpirun
      {"--ranks", "1"},                                     // nothing to exchange
      {"--ranks", "5", "--masses", "2"},                    // the model cannot be split
      {"--ranks", "2", "--exchange", "nope"},               // unknown exchange
      {"--ranks", "2", "--sync", "std_barrier"},            // not a primitive shm_window runs
      {"--ranks", "2", "--transport", "udp"},               // unknown transport
      {"--ranks", "2", "--transport", "tcp", "--exchange", "shm_window"},  // conflicting
      {"--ranks", "2", "--hostfile", hostfile},             // unreadable hostfile
      {"--ranks", "2", "--mpirun", "/nonexistent/mpirun"},  // mpirun missing
      {"--ranks", "2", "--pin", "migrate"},                 // a placement ranks cannot take
      {"--ranks", "2", "--watchdog", "10"},                 // a duration without its unit
      {"--ranks", "2", "--out", scratch.file("missing/dir.json")},  // unwritable output
  };
  for (const auto& arguments : cases) {
    std::vector<std::string> argv{LOCKSTEP_BINARY, "mpi"};
    argv.insert(argv.end(), arguments.begin(), arguments.end());
    if (std::find(arguments.begin(), arguments.end(), "--out") == arguments.end()) argv.insert(argv.end(), {"--out", out});
    const command_result result = run_command(argv);
    std::string shown;
    for (const auto& word : arguments) shown += word + " ";
    EXPECT_EQ(result.exit_status, 2) << shown << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << shown << result.err;
    EXPECT_EQ(result.err.find("running:"), std::string::npos) << shown << "launched anyway";
  }
  EXPECT_TRUE(scratch.entries().empty()) << "nothing written";
}

}  // namespace
