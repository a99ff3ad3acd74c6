// `lockstep mpi --hostfile` across two hosts: two network namespaces joined
// by a veth pair, made by tests/mpi/netns-hosts.sh, which runs this test and
// tears them down (CTest: mpi.two_hosts). Each host has its own address,
// network stack and name; mpirun starts on host A and reaches host B through
// the script's rsh agent. Run any other way, every case skips, saying so.
//
// What is checked: 2 and 4 ranks (one and two per host) with p2p, allgather
// and rma_put over TCP between the hosts, bitwise against the serial step,
// named hosts:2, the ranks of each host and the slowest rank's host in the
// file, the ping-pong between the hosts; shm_window refused with its reason;
// a rank that stalls on B named by its own watchdog; a rank killed on B and
// B's link taken down mid-run each end the job with a message naming B and
// leave no process in either namespace; the two hosts, which share this
// machine's kernel, placed as one machine (disjoint CPUs, from what each rank
// reports it is bound to), and ranks that must share a CPU yielding, said in
// one line and recorded. Behaviour only, never a time; the runs
// are a few steps (a hop between the namespaces costs some microseconds
// here, and far more on a busy 2-CPU VM).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/scratch_directory.hpp"

namespace {

using lockstep::testing::command_result;
using lockstep::testing::count_lines;
using lockstep::testing::run_command;
using lockstep::testing::scratch_directory;

struct two_hosts {
  std::string script, a, b, address_a, address_b, link_b, network, hostfile;
};

// The hosts netns-hosts.sh made, or nothing when it did not run this test.
std::optional<two_hosts> hosts_here() {
  two_hosts hosts;
  const std::pair<std::string*, const char*> variables[] = {
      {&hosts.script, "LOCKSTEP_HOSTS_SCRIPT"},     {&hosts.a, "LOCKSTEP_HOSTS_A"},
      {&hosts.b, "LOCKSTEP_HOSTS_B"},               {&hosts.address_a, "LOCKSTEP_HOSTS_ADDRESS_A"},
      {&hosts.address_b, "LOCKSTEP_HOSTS_ADDRESS_B"}, {&hosts.link_b, "LOCKSTEP_HOSTS_LINK_B"},
      {&hosts.network, "LOCKSTEP_HOSTS_NETWORK"},   {&hosts.hostfile, "LOCKSTEP_HOSTS_HOSTFILE"}};
  for (const auto& [field, name] : variables) {
    const char* value = std::getenv(name);
    if (value == nullptr || *value == '\0') return std::nullopt;
    *field = value;
  }
  return hosts;
}

#define REQUIRE_TWO_HOSTS(hosts)                                                                             \
  const std::optional<two_hosts> maybe_hosts = hosts_here();                                                 \
  if (!maybe_hosts) GTEST_SKIP() << "not run under tests/mpi/netns-hosts.sh run (CTest: mpi.two_hosts)";     \
  const two_hosts& hosts = *maybe_hosts

// lockstep mpi on host A across both hosts, with the words given.
command_result on_a(const two_hosts& hosts, const std::vector<std::string>& words) {
  std::vector<std::string> argv{hosts.script, "on", hosts.a, LOCKSTEP_BINARY, "mpi", "--hostfile", hosts.hostfile,
                                "--network", hosts.network};
  argv.insert(argv.end(), words.begin(), words.end());
  return run_command(argv);
}

std::vector<std::string> few_steps(const std::string& ranks) {
  return {"--ranks", ranks, "--steps", "10", "--warmup", "2", "--rounds", "1", "--pingpong", "20"};
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream file(path);
  return nlohmann::json::parse(file);
}

// The processes left in a host's namespace (ip netns pids), one pid a word.
std::string left_in(const std::string& host) {
  return run_command({"ip", "netns", "pids", host}).out;
}

// After a failed job: every process of it, on either host, ends within the
// ranks' watchdog (a rank whose daemon is gone ends by its own watchdog);
// then none may be left. Polled, not timed: the bound only stops the wait.
void expect_nothing_left(const two_hosts& hosts, std::chrono::seconds bound) {
  const auto deadline = std::chrono::steady_clock::now() + bound;
  while ((!left_in(hosts.a).empty() || !left_in(hosts.b).empty()) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  for (const std::string& host : {hosts.a, hosts.b}) {
    const std::string pids = left_in(host);
    if (pids.empty()) continue;
    std::string shown;
    std::istringstream words(pids);
    for (std::string pid; words >> pid;) shown += run_command({"ps", "-o", "pid=,comm=,args=", "-p", pid}).out;
    ADD_FAILURE() << "left on " << host << ":\n" << shown;
  }
}

const std::set<std::string> kNetworkExchanges{"p2p", "allgather", "rma_put"};

// The lines on stderr that say busy-polling ranks could share a CPU.
std::vector<std::string> sharing_lines(const std::string& err) {
  std::vector<std::string> found;
  std::istringstream lines(err);
  for (std::string line; std::getline(lines, line);)
    if (line.find("busy-polling ranks could share a CPU") != std::string::npos) found.push_back(line);
  return found;
}

// The two hosts share this machine's kernel: each rank reports the same
// kernel, and they are placed as the ranks of one host, on disjoint CPUs
// (each host placing its own ranks from its CPU 0 put both on CPU 0, where
// each polling rank waited a scheduler tick for the other). Checked from the
// CPUs every rank reported it was bound to, before measuring; lockstep says
// what it did in one line and records it.
TEST(MpiTwoHosts, HostsOfOneKernelArePlacedOnDisjointCpus) {
  REQUIRE_TWO_HOSTS(hosts);
  scratch_directory scratch("lockstep-two-hosts-test");
  const std::string out = scratch.file("one-kernel.json");
  auto words = few_steps("2");
  words.insert(words.end(), {"--exchange", "p2p", "--out", out});
  const command_result result = on_a(hosts, words);
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const nlohmann::json placement = read_json(out).at("placement");
  const nlohmann::json& ranks = placement.at("ranks");
  ASSERT_EQ(ranks.size(), 2U);
  EXPECT_EQ(ranks.at(0).at("host"), hosts.a);
  EXPECT_EQ(ranks.at(1).at("host"), hosts.b);
  EXPECT_EQ(ranks.at(0).at("kernel"), ranks.at(1).at("kernel"));
  EXPECT_EQ(ranks.at(0).at("kernel").get<std::string>().rfind("boot id ", 0), 0U) << ranks.at(0).at("kernel");
  ASSERT_EQ(placement.at("machines").size(), 1U);
  EXPECT_EQ(placement.at("machines").at(0).at("hosts"), (nlohmann::json{hosts.a, hosts.b}));
  if (ranks.at(0).at("cpus_given").size() < 2) GTEST_SKIP() << "fewer than 2 CPUs here: the ranks must share one";
  const auto bound_0 = ranks.at(0).at("cpus_bound").get<std::vector<unsigned>>();
  const auto bound_1 = ranks.at(1).at("cpus_bound").get<std::vector<unsigned>>();
  ASSERT_EQ(bound_0.size(), 1U);
  ASSERT_EQ(bound_1.size(), 1U);
  EXPECT_NE(bound_0, bound_1) << "two hosts of one kernel put their ranks on one CPU";
  EXPECT_TRUE(placement.at("machines").at(0).at("crowded").is_null());
  // Each host alone would have pinned its rank to its own first CPU: the same one.
  EXPECT_EQ(ranks.at(0).at("cpu_host_by_host"), ranks.at(1).at("cpu_host_by_host"));
  EXPECT_EQ(placement.at("remedy"), "placed_apart");
  const std::vector<std::string> said = sharing_lines(result.err);
  ASSERT_EQ(said.size(), 1U) << result.err;
  EXPECT_NE(said[0].find("hosts " + hosts.a + " and " + hosts.b + " share one kernel"), std::string::npos) << said[0];
  EXPECT_EQ("lockstep mpi: " + placement.at("warning").get<std::string>(), said[0]);
}

TEST(MpiTwoHosts, TwoAndFourRanksAcrossTheHostsBitwise) {
  REQUIRE_TWO_HOSTS(hosts);
  for (const std::string ranks : {"2", "4"}) {
    SCOPED_TRACE(ranks + " ranks");
    scratch_directory scratch("lockstep-two-hosts-test");
    const std::string out = scratch.file("two-hosts.json");
    auto words = few_steps(ranks);
    words.insert(words.end(), {"--out", out});
    const command_result result = on_a(hosts, words);
    ASSERT_EQ(result.exit_status, 0) << result.err;
    EXPECT_NE(result.err.find("--map-by node"), std::string::npos) << result.err;
    EXPECT_NE(result.err.find("--mca btl self,vader,tcp"), std::string::npos) << result.err;
    const int count = std::stoi(ranks);
    // The ping-pong's ranks 0 and 1 are on the two hosts; each host's ranks are listed.
    EXPECT_NE(result.out.find("ping-pong, ranks 0 and 1 (on " + hosts.a + " and " + hosts.b + ")"), std::string::npos)
        << result.out;
    EXPECT_NE(result.out.find(count == 2 ? hosts.a + ": rank 0; " + hosts.b + ": rank 1"
                                         : hosts.a + ": ranks 0, 2; " + hosts.b + ": ranks 1, 3"),
              std::string::npos)
        << result.out;

    const nlohmann::json document = read_json(out);
    EXPECT_EQ(document.at("context").at("mpi_hosts"), "2");
    EXPECT_EQ(document.at("settings").at("hosts"), 2);
    EXPECT_EQ(document.at("settings").at("ranks_per_host"),
              (nlohmann::json{{hosts.a, count / 2}, {hosts.b, count / 2}}));
    std::set<std::string> seen;
    int pingpongs = 0;
    for (const auto& entry : document.at("benchmarks")) {
      const std::string name = entry.at("name");
      EXPECT_NE(name.find("/ranks:"), std::string::npos) << name;
      EXPECT_EQ(name.substr(name.size() - 8), "/hosts:2") << name;
      if (name.rfind("mpi/pingpong/", 0) == 0) {
        ++pingpongs;
        EXPECT_GT(entry.at("real_time").get<double>(), 0.0);
        continue;
      }
      seen.insert(name.substr(name.find("exchange:") + 9, name.find('/', name.find("exchange:")) -
                                                             name.find("exchange:") - 9));
      EXPECT_EQ(entry.at("bitwise"), 1) << name;
      EXPECT_LE(entry.at("skew_p50_ns").get<double>(), entry.at("skew_max_ns").get<double>()) << name;
    }
    EXPECT_EQ(seen, kNetworkExchanges);
    EXPECT_EQ(pingpongs, 1);
    for (const auto& details : document.at("exchanges")) {
      const std::string host = details.at("slowest_rank_host");
      EXPECT_TRUE(host == hosts.a || host == hosts.b) << host;
      ASSERT_EQ(details.at("per_rank").size(), static_cast<std::size_t>(count));
      for (int rank = 0; rank < count; ++rank)
        EXPECT_EQ(details.at("per_rank").at(rank).at("host"), rank % 2 == 0 ? hosts.a : hosts.b);
    }
    for (const std::string shm : {"shm_window/futex_spin", "shm_window/mailbox"})
      EXPECT_NE(document.at("not_applicable").value(shm, "").find("span 2 hosts"), std::string::npos) << shm;
    // One kernel: the hosts' ranks are placed as one machine's. Four ranks
    // on fewer CPUs must share them: they yield when idle, said in one line.
    const nlohmann::json& placement = document.at("placement");
    ASSERT_EQ(placement.at("machines").size(), 1U);
    EXPECT_EQ(sharing_lines(result.err).size(), 1U) << result.err;
    const std::size_t cpus = placement.at("machines").at(0).at("cpus").size();
    if (static_cast<std::size_t>(count) > cpus) {
      EXPECT_EQ(placement.at("remedy"), "yield_when_idle");
      for (const auto& rank : placement.at("ranks")) EXPECT_EQ(rank.at("yields_when_idle"), true);
    }
  }
}

TEST(MpiTwoHosts, SharedWindowIsRefusedAcrossHosts) {
  REQUIRE_TWO_HOSTS(hosts);
  auto words = few_steps("2");
  words.insert(words.end(), {"--exchange", "shm_window"});
  const command_result result = on_a(hosts, words);
  EXPECT_EQ(result.exit_status, 2) << result.err;
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find("the ranks span 2 hosts: a shared-memory window needs them on one"), std::string::npos)
      << result.err;
}

// One-host and two-host files of the same exchanges: compare says what
// differs and sets the exchanges side by side.
TEST(MpiTwoHosts, CompareSaysWhatDiffersFromOneHost) {
  REQUIRE_TWO_HOSTS(hosts);
  scratch_directory scratch("lockstep-two-hosts-test");
  const std::string one = scratch.file("one-host.json");
  const std::string two = scratch.file("two-hosts.json");
  std::vector<std::string> local{LOCKSTEP_BINARY, "mpi"};
  for (const auto& word : few_steps("2")) local.push_back(word);
  local.insert(local.end(), {"--exchange", "p2p,allgather", "--out", one});
  ASSERT_EQ(run_command(local).exit_status, 0);
  auto words = few_steps("2");
  words.insert(words.end(), {"--exchange", "p2p,allgather", "--out", two});
  ASSERT_EQ(on_a(hosts, words).exit_status, 0);
  const command_result result = run_command({LOCKSTEP_BINARY, "compare", one, two});
  EXPECT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("mpi jobs differ in hosts, transport: [A] 2 ranks on 1 host (transport shm); [B] 2 ranks on 2 "
                            "hosts (transport shm+tcp)"),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("exchange p2p, median step: [A] "), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("exchange allgather, median step: [A] "), std::string::npos) << result.out;
}

// Rank 1 (on B) stalls at step 5 of p2p: its own watchdog names it and B,
// and its line reaches host A's mpirun.
TEST(MpiTwoHosts, StalledRankOnTheSecondHostIsNamed) {
  REQUIRE_TWO_HOSTS(hosts);
  ::setenv("LOCKSTEP_MPI_FAULT", "stall:1:5", 1);
  auto words = few_steps("2");
  words.insert(words.end(), {"--exchange", "p2p", "--watchdog", "2s"});
  const command_result result = on_a(hosts, words);
  ::unsetenv("LOCKSTEP_MPI_FAULT");
  EXPECT_EQ(result.exit_status, 3) << result.err;
  EXPECT_TRUE(std::regex_search(
      result.err, std::regex("lockstep mpi: rank 1 on " + hosts.b +
                             R"( stopped: no progress for 2 s outside any wait for another rank \(in p2p, at 5\))")))
      << result.err;
  expect_nothing_left(hosts, std::chrono::seconds(10));
}

// Rank 1 (on B) is killed: mpirun ends the job naming B's node.
TEST(MpiTwoHosts, KilledRankOnTheSecondHostEndsTheJobNamingIt) {
  REQUIRE_TWO_HOSTS(hosts);
  ::setenv("LOCKSTEP_MPI_FAULT", "die:1:5", 1);
  auto words = few_steps("4");
  words.insert(words.end(), {"--exchange", "p2p", "--watchdog", "4s"});
  const command_result result = on_a(hosts, words);
  ::unsetenv("LOCKSTEP_MPI_FAULT");
  EXPECT_EQ(result.exit_status, 3) << result.err;
  EXPECT_TRUE(std::regex_search(result.err, std::regex("process rank 1 with PID [0-9]+ on node " +
                                                       std::regex_replace(hosts.address_b, std::regex(R"(\.)"), R"(\.)") +
                                                       " exited on signal 9")))
      << result.err;
  EXPECT_NE(result.err.find("the MPI job failed"), std::string::npos) << result.err;
  expect_nothing_left(hosts, std::chrono::seconds(8));
}

// B's end of the link goes down once the run is in its ping-pong: mpirun's
// daemon on B is lost (the keepalive the launcher sets from --watchdog) and
// mpirun ends the job naming B's node; B's ranks, cut off from their daemon,
// end by their own watchdogs. The link comes back up for the next case.
TEST(MpiTwoHosts, LinkDownMidRunEndsTheJobNamingTheHost) {
  REQUIRE_TWO_HOSTS(hosts);
  scratch_directory scratch("lockstep-two-hosts-test");
  const std::string err = scratch.file("err");
  std::string job = "'" + hosts.script + "' on " + hosts.a + " '" + LOCKSTEP_BINARY + "' mpi --hostfile '" +
                    hosts.hostfile + "' --network " + hosts.network +
                    " --ranks 2 --exchange p2p --steps 100000 --rounds 1 --pingpong 20 --watchdog 4s";
  // Waits for the first round's ping-pong line (at most 600 polls: the
  // bound of a wait, not a time asserted), then takes B's link down.
  const std::string shell = job + " 2>'" + err + "' & job=$!\n" +
                            "polls=0; until grep -q 'round 1/1: ping-pong' '" + err +
                            "' || [ $polls -ge 600 ]; do sleep 0.1; polls=$((polls + 1)); done\n" +
                            "ip -n " + hosts.b + " link set " + hosts.link_b + " down\n" +
                            "wait $job; echo \"status $?\"\n";
  const command_result result = run_command({"sh", "-c", shell});
  run_command({"ip", "-n", hosts.b, "link", "set", hosts.link_b, "up"});
  std::ifstream file(err);
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("round 1/1: ping-pong"), std::string::npos) << "the link went down before the run began\n"
                                                                   << text;
  EXPECT_NE(result.out.find("status 3"), std::string::npos) << result.out << text;
  EXPECT_TRUE(std::regex_search(text, std::regex("Remote daemon: .* on node " +
                                                 std::regex_replace(hosts.address_b, std::regex(R"(\.)"), R"(\.)"))))
      << text;
  expect_nothing_left(hosts, std::chrono::seconds(12));
}

}  // namespace
