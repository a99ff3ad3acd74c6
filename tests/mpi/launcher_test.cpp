// The mpirun command lines `lockstep mpi` builds (distributed/launcher.hpp),
// and the hostfile reader: pure functions, no MPI job started.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "distributed/launcher.hpp"
#include "tests/support/scratch_directory.hpp"

namespace {

using lockstep::distributed::launch_request;
using lockstep::distributed::plan_launch;
using lockstep::distributed::transport;

bool has_sequence(const std::vector<std::string>& argv, const std::vector<std::string>& words) {
  return std::search(argv.begin(), argv.end(), words.begin(), words.end()) != argv.end();
}

launch_request open_mpi_request() {
  launch_request request;
  request.mpirun = "/usr/bin/mpirun";
  request.ranks = 4;
  request.host_cpus = 2;
  request.executable = "/opt/lockstep";
  request.arguments = {"mpi", "--ranks", "4"};
  request.forwarded = {"LOCKSTEP_MPI_LAUNCH"};
  return request;
}

TEST(MpiLauncher, SharedMemoryOversubscribedAsRoot) {
  launch_request request = open_mpi_request();
  request.as_root = true;
  const auto plan = plan_launch(request);
  EXPECT_TRUE(has_sequence(plan.argv, {"/usr/bin/mpirun", "--np", "4"}));
  EXPECT_TRUE(has_sequence(plan.argv, {"--oversubscribe"}));
  EXPECT_TRUE(has_sequence(plan.argv, {"--bind-to", "none"}));
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "btl", "self,vader"}));
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "btl_vader_single_copy_mechanism", "none"}));
  EXPECT_TRUE(has_sequence(plan.argv, {"-x", "LOCKSTEP_MPI_LAUNCH", "/opt/lockstep", "mpi", "--ranks", "4"}));
  ASSERT_EQ(plan.environment.size(), 2U);
  EXPECT_EQ(plan.environment[0].first, "OMPI_ALLOW_RUN_AS_ROOT");
  EXPECT_EQ(plan.shown().rfind("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 /usr/bin/mpirun --np 4", 0),
            0U)
      << plan.shown();
}

TEST(MpiLauncher, NotRootNotOversubscribed) {
  launch_request request = open_mpi_request();
  request.ranks = 2;
  const auto plan = plan_launch(request);
  EXPECT_FALSE(has_sequence(plan.argv, {"--oversubscribe"}));
  EXPECT_TRUE(plan.environment.empty());
}

TEST(MpiLauncher, TcpOnLoopbackTakesOneSidedTrafficAlong) {
  launch_request request = open_mpi_request();
  request.how = transport::tcp;
  const auto plan = plan_launch(request);
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "btl", "self,tcp", "--mca", "btl_tcp_if_include", "lo"}));
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "osc", "pt2pt"}));
  EXPECT_FALSE(has_sequence(plan.argv, {"--mca", "btl", "self,vader"}));
}

TEST(MpiLauncher, HostfileSpansHosts) {
  launch_request request = open_mpi_request();
  request.hostfile = "hosts.txt";
  const auto plan = plan_launch(request);
  EXPECT_TRUE(has_sequence(plan.argv, {"--hostfile", "hosts.txt"}));
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "btl", "self,vader,tcp"}));
  EXPECT_FALSE(has_sequence(plan.argv, {"--oversubscribe"})) << "the hosts' slots decide, not this host's CPUs";
  EXPECT_TRUE(has_sequence(plan.argv, {"--map-by", "node"})) << "ranks 0 and 1 (the ping-pong's) on two hosts";
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "osc", "sm,pt2pt"})) << "rma_put's windows over the btl";
  EXPECT_FALSE(has_sequence(plan.argv, {"--mca", "btl_tcp_if_include"})) << "no --network: Open MPI's choice";
  // The daemons' keepalive notices a lost host at about twice a quarter of
  // the ranks' watchdog, before it fires.
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "oob_tcp_keepalive_time", "2", "--mca", "oob_tcp_keepalive_intvl",
                                       "2", "--mca", "oob_tcp_keepalive_probes", "1"}));
}

TEST(MpiLauncher, NetworkNamesTheInterfaceBetweenHosts) {
  launch_request request = open_mpi_request();
  request.hostfile = "hosts.txt";
  request.network = "10.231.1.0/24";
  request.how = transport::tcp;
  request.watchdog_ns = 1'000'000'000;
  const auto plan = plan_launch(request);
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "btl_tcp_if_include", "10.231.1.0/24", "--mca",
                                       "oob_tcp_if_include", "10.231.1.0/24"}));
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "btl", "self,tcp"}));
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "osc", "pt2pt"}));
  EXPECT_TRUE(has_sequence(plan.argv, {"--mca", "oob_tcp_keepalive_time", "1"})) << "at least 1 s";
  request.hostfile.clear();
  EXPECT_THROW((void)plan_launch(request), std::invalid_argument) << "--network without --hostfile";
}

TEST(MpiLauncher, AnotherMpiGetsItsOwnGrammarAndNoTransportChoice) {
  launch_request request = open_mpi_request();
  request.open_mpi = false;
  request.hostfile = "hosts.txt";
  const auto plan = plan_launch(request);
  EXPECT_TRUE(has_sequence(plan.argv, {"/usr/bin/mpirun", "-n", "4", "-f", "hosts.txt", "/opt/lockstep"}));
  request.how = transport::tcp;
  EXPECT_THROW((void)plan_launch(request), std::invalid_argument);
}

TEST(MpiLauncher, ShownCommandQuotesWhatTheShellWouldSplit) {
  launch_request request = open_mpi_request();
  request.arguments = {"mpi", "--out", "my results.json"};
  EXPECT_NE(plan_launch(request).shown().find("'my results.json'"), std::string::npos);
}

// A first word that looks like an assignment (NAME=...) would be read by sh
// as one, and the next word run as the command: the shown command quotes it,
// and sh runs it as the program it names.
TEST(MpiLauncher, ShownCommandQuotesAWordShWouldTakeForAnAssignment) {
  lockstep::testing::scratch_directory scratch("lockstep-mpi-launcher");
  const std::string directory = scratch.file("A=b");
  ASSERT_EQ(::mkdir(directory.c_str(), 0755), 0);
  const std::string program = directory + "/mpirun";
  std::ofstream(program) << "#!/bin/sh\necho \"ran with $#\"\n";
  ASSERT_EQ(::chmod(program.c_str(), 0755), 0);
  launch_request request = open_mpi_request();
  request.mpirun = "A=b/mpirun";  // relative, as a user may name it with --mpirun
  const std::string shown = plan_launch(request).shown();
  EXPECT_EQ(shown.rfind("'A=b/mpirun' ", 0), 0U) << shown;
  const std::string command = "cd '" + scratch.path().string() + "' && " + shown + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::array<char, 256> line{};
  std::string output;
  while (std::fgets(line.data(), static_cast<int>(line.size()), pipe) != nullptr) output += line.data();
  ::pclose(pipe);
  EXPECT_EQ(output.rfind("ran with ", 0), 0U) << "sh did not run A=b/mpirun: " << output;
}

TEST(MpiLauncher, HostfileNamesItsHosts) {
  lockstep::testing::scratch_directory scratch("lockstep-mpi-launcher");
  const std::string path = scratch.file("hosts");
  std::ofstream(path) << "# two hosts\nnode1 slots=2\n\n  node2\n";
  EXPECT_EQ(lockstep::distributed::read_hostfile(path), (std::vector<std::string>{"node1", "node2"}));
  const std::string empty = scratch.file("empty");
  std::ofstream(empty) << "# nothing\n";
  EXPECT_THROW((void)lockstep::distributed::read_hostfile(empty), std::invalid_argument);
  EXPECT_THROW((void)lockstep::distributed::read_hostfile(scratch.file("missing")), std::invalid_argument);
}

}  // namespace
