// Where `lockstep mpi` puts its ranks and when it says two share a CPU
// (distributed/rank_placement.hpp): the pure part, on synthetic machines and
// the ranks' reports as place_ranks gathers them; no MPI job started. (The
// collective itself runs in tests/mpi/mpi_cli_test.cpp, one host, and
// tests/mpi/two_hosts_test.cpp, two hosts on one kernel.)
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "distributed/rank_placement.hpp"
#include "platform/topology.hpp"

namespace {

namespace dist = lockstep::distributed;
using lockstep::platform::placement;
using lockstep::platform::topology;

dist::rank_report report(int rank, const std::string& host, const std::string& kernel, std::vector<unsigned> given) {
  dist::rank_report result;
  result.rank = rank;
  result.host = host;
  result.kernel = kernel;
  result.cpus_given = std::move(given);
  return result;
}

// What place_ranks does with the reports, without MPI: place every machine,
// bind each rank where its machine's plan says, and judge.
struct placed_job {
  std::vector<dist::rank_report> ranks;
  std::vector<dist::machine> machines;
  std::vector<dist::machine_verdict> verdicts;
  std::string line;
};

placed_job place(const topology& hardware, placement kind, std::vector<dist::rank_report> ranks,
                 bool yields = true) {
  placed_job job;
  job.machines = dist::machines_of(ranks);
  for (const dist::machine& each : job.machines) {
    const auto cpus = dist::plan_machine(hardware, kind, each, ranks);
    for (std::size_t index = 0; index < each.ranks.size(); ++index) {
      auto& rank = ranks[static_cast<std::size_t>(each.ranks[index])];
      rank.cpus_bound = cpus[index];
    }
  }
  for (auto& rank : ranks) rank.yields_when_idle = yields;
  job.verdicts = dist::judge(job.machines, ranks);
  job.line = dist::sharing_line(job.machines, job.verdicts, ranks);
  job.ranks = std::move(ranks);
  return job;
}

const topology& two_cpus() {
  static const topology machine = topology::from_synthetic("core:2 pu:1");
  return machine;
}

// The two namespace hosts of tests/mpi/netns-hosts.sh: one kernel, each host
// given both CPUs, each host's own plan starting at CPU 0.
TEST(RankPlacement, HostsOfOneKernelArePlacedAsOneMachineOnDisjointCpus) {
  std::vector<dist::rank_report> ranks{report(0, "a", "boot id K", {0, 1}), report(1, "b", "boot id K", {0, 1})};
  ranks[0].cpu_host_by_host = 0;
  ranks[1].cpu_host_by_host = 0;
  const placed_job job = place(two_cpus(), placement::compact, ranks);
  ASSERT_EQ(job.machines.size(), 1U);
  EXPECT_EQ(job.machines[0].hosts, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(job.ranks[0].cpus_bound, std::vector<unsigned>{0});
  EXPECT_EQ(job.ranks[1].cpus_bound, std::vector<unsigned>{1});
  EXPECT_FALSE(job.verdicts[0].crowded);
  ASSERT_EQ(job.verdicts[0].host_by_host.size(), 1U);
  EXPECT_EQ(job.verdicts[0].host_by_host[0].cpu, 0U);
  EXPECT_EQ(job.verdicts[0].host_by_host[0].ranks, (std::vector<int>{0, 1}));
  EXPECT_EQ(job.verdicts[0].remedy, dist::sharing_remedy::placed_apart);
  EXPECT_EQ(dist::job_remedy(job.verdicts), dist::sharing_remedy::placed_apart);
  EXPECT_EQ(job.line,
            "busy-polling ranks could share a CPU: hosts a and b share one kernel (boot id K): placed host by host, "
            "ranks 0 and 1 would both run on CPU 0; placed as one machine instead: rank 0 on CPU 0, rank 1 on CPU 1");
}

// Four ranks dealt out over two hosts of one 4-CPU kernel: every rank a CPU
// of its own, in rank order, whichever host it is on.
TEST(RankPlacement, FourRanksOnTwoHostsOfOneKernelGetFourCpus) {
  const topology machine = topology::from_synthetic("core:4 pu:1");
  std::vector<dist::rank_report> ranks;
  for (int rank = 0; rank < 4; ++rank) ranks.push_back(report(rank, rank % 2 == 0 ? "a" : "b", "K", {0, 1, 2, 3}));
  const placed_job job = place(machine, placement::compact, ranks);
  std::set<unsigned> used;
  for (const auto& rank : job.ranks) {
    ASSERT_EQ(rank.cpus_bound.size(), 1U);
    used.insert(rank.cpus_bound[0]);
  }
  EXPECT_EQ(used.size(), 4U);
  EXPECT_FALSE(job.verdicts[0].crowded);
}

// Two real hosts: CPU 0 of each is a different CPU. Nothing to say.
TEST(RankPlacement, HostsOfTwoKernelsAreTwoMachines) {
  std::vector<dist::rank_report> ranks{report(0, "a", "boot id K1", {0, 1}), report(1, "b", "boot id K2", {0, 1})};
  ranks[0].cpu_host_by_host = 0;
  ranks[1].cpu_host_by_host = 0;
  const placed_job job = place(two_cpus(), placement::compact, ranks);
  ASSERT_EQ(job.machines.size(), 2U);
  EXPECT_EQ(job.ranks[0].cpus_bound, std::vector<unsigned>{0});
  EXPECT_EQ(job.ranks[1].cpus_bound, std::vector<unsigned>{0});
  for (const auto& verdict : job.verdicts) {
    EXPECT_FALSE(verdict.crowded);
    EXPECT_TRUE(verdict.host_by_host.empty());
    EXPECT_EQ(verdict.remedy, dist::sharing_remedy::none);
  }
  EXPECT_EQ(job.line, "");
}

// Two ranks given only CPU 0 (a taskset, a rankfile's binding): they must
// share it; they yield when idle, and the line says so.
TEST(RankPlacement, TwoRanksGivenOneCpuAreCrowdedAndYield) {
  for (const placement kind : {placement::compact, placement::none}) {
    SCOPED_TRACE(std::string(lockstep::platform::to_string(kind)));
    const placed_job job = place(two_cpus(), kind, {report(0, "h", "K", {0}), report(1, "h", "K", {0})});
    EXPECT_EQ(job.ranks[0].cpus_bound, std::vector<unsigned>{0});
    EXPECT_EQ(job.ranks[1].cpus_bound, std::vector<unsigned>{0});
    ASSERT_TRUE(job.verdicts[0].crowded);
    EXPECT_EQ(job.verdicts[0].crowded->ranks, (std::vector<int>{0, 1}));
    EXPECT_EQ(job.verdicts[0].crowded->cpus, std::vector<unsigned>{0});
    EXPECT_EQ(job.verdicts[0].remedy, dist::sharing_remedy::yield_when_idle);
    EXPECT_EQ(job.line,
              "busy-polling ranks could share a CPU: ranks 0 and 1 on host h are bound to CPU 0 between them; they "
              "yield when idle (Open MPI's mpi_yield_when_idle), so that a wait hands the CPU over");
  }
}

// A library that cannot be made to yield: crowded still, remedy none, said.
TEST(RankPlacement, CrowdedRanksThatCannotYieldAreSaidSo) {
  const placed_job job =
      place(two_cpus(), placement::compact, {report(0, "h", "K", {0}), report(1, "h", "K", {0})}, false);
  ASSERT_TRUE(job.verdicts[0].crowded);
  EXPECT_EQ(job.verdicts[0].remedy, dist::sharing_remedy::none);
  EXPECT_NE(job.line.find("cannot be made to yield when idle"), std::string::npos) << job.line;
}

// More ranks than CPUs on one kernel, pinned or not: crowded, all of them.
TEST(RankPlacement, MoreRanksThanCpusAreCrowded) {
  for (const placement kind : {placement::compact, placement::none}) {
    SCOPED_TRACE(std::string(lockstep::platform::to_string(kind)));
    std::vector<dist::rank_report> ranks;
    for (int rank = 0; rank < 4; ++rank) ranks.push_back(report(rank, rank % 2 == 0 ? "a" : "b", "K", {0, 1}));
    const placed_job job = place(two_cpus(), kind, ranks);
    ASSERT_TRUE(job.verdicts[0].crowded);
    EXPECT_EQ(job.verdicts[0].crowded->ranks, (std::vector<int>{0, 1, 2, 3}));
    EXPECT_EQ(job.verdicts[0].crowded->cpus, (std::vector<unsigned>{0, 1}));
    EXPECT_NE(job.line.find("ranks 0, 1, 2 and 3 on hosts a and b (one kernel, K) are bound to CPUs 0 and 1"),
              std::string::npos)
        << job.line;
    if (kind == placement::compact) {
      // Pinned, they wrap as one host's ranks do: two on each CPU.
      EXPECT_EQ(job.ranks[0].cpus_bound, job.ranks[2].cpus_bound);
      EXPECT_EQ(job.ranks[1].cpus_bound, job.ranks[3].cpus_bound);
      EXPECT_NE(job.ranks[0].cpus_bound, job.ranks[1].cpus_bound);
    }
  }
}

// Unpinned ranks that have as many CPUs as ranks between them: the scheduler
// can give each its own, so nothing is crowded.
TEST(RankPlacement, UnpinnedRanksWithEnoughCpusAreNotCrowded) {
  const placed_job job = place(two_cpus(), placement::none, {report(0, "h", "K", {0, 1}), report(1, "h", "K", {0, 1})});
  EXPECT_EQ(job.ranks[0].cpus_bound, (std::vector<unsigned>{0, 1}));
  EXPECT_FALSE(job.verdicts[0].crowded);
  EXPECT_EQ(job.line, "");
}

// A rank that may run only on CPU 1 keeps it, and the rank that may run on
// either gets CPU 0, though the plan's order would give it CPU 1: no two
// share a CPU where their given sets let them each have one.
TEST(RankPlacement, TheMatchingKeepsEachRankInsideItsOwnCpus) {
  const placed_job job = place(two_cpus(), placement::compact, {report(0, "h", "K", {1}), report(1, "h", "K", {0, 1})});
  EXPECT_EQ(job.ranks[0].cpus_bound, std::vector<unsigned>{1});
  EXPECT_EQ(job.ranks[1].cpus_bound, std::vector<unsigned>{0});
  EXPECT_FALSE(job.verdicts[0].crowded);
}

// Crowding is found in a part of the machine, not only in the whole: ranks
// 0-2 bound to CPUs 0 and 1 are crowded though CPU 2 is free for rank 3.
TEST(RankPlacement, CrowdingNamesTheRanksThatShare) {
  std::vector<dist::rank_report> ranks{report(0, "h", "K", {}), report(1, "h", "K", {}), report(2, "h", "K", {}),
                                       report(3, "h", "K", {})};
  ranks[0].cpus_bound = {0};
  ranks[1].cpus_bound = {0, 1};
  ranks[2].cpus_bound = {1};
  ranks[3].cpus_bound = {1, 2};
  const auto machines = dist::machines_of(ranks);
  const auto crowded = dist::find_crowding(machines[0], ranks);
  ASSERT_TRUE(crowded);
  EXPECT_EQ(crowded->ranks, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(crowded->cpus, (std::vector<unsigned>{0, 1}));
}

// This process's kernel has a name, the same every time it is asked.
TEST(RankPlacement, KernelIdentityIsStable) {
  const topology machine = topology::this_machine();
  const std::string first = dist::kernel_identity(machine, "here");
  EXPECT_FALSE(first.empty());
  EXPECT_EQ(first, dist::kernel_identity(machine, "here"));
}

// `lockstep mpi --ranks 8` on a machine of two NUMA nodes (2 packages of one
// node, 4 cores with SMT each: node N holds CPUs 8N .. 8N+7), every rank given
// every CPU: the ranks follow the placement's plan across the nodes.
std::vector<int> nodes_of_ranks(const topology& machine, const placed_job& job) {
  std::vector<int> nodes;
  for (const auto& rank : job.ranks) {
    EXPECT_EQ(rank.cpus_bound.size(), 1U) << "rank " << rank.rank;
    nodes.push_back(rank.cpus_bound.empty() ? -1 : machine.pu(rank.cpus_bound.front()).numa);
  }
  return nodes;
}

TEST(RankPlacementNuma, EightRanksFollowThePlansAcrossTwoNodes) {
  const topology machine = topology::from_synthetic("pack:2 [numa] l3:1 core:4 pu:2");
  ASSERT_EQ(machine.numa_nodes(), 2U);
  std::vector<unsigned> every_cpu;
  for (unsigned cpu = 0; cpu < 16; ++cpu) every_cpu.push_back(cpu);
  for (const bool two_hosts : {false, true}) {
    std::vector<dist::rank_report> ranks;
    for (int rank = 0; rank < 8; ++rank)
      ranks.push_back(report(rank, two_hosts && rank >= 4 ? "b" : "a", "boot id K", every_cpu));
    const placed_job compact = place(machine, placement::compact, ranks);
    EXPECT_EQ(nodes_of_ranks(machine, compact), (std::vector<int>{0, 0, 0, 0, 1, 1, 1, 1}))
        << "compact fills node 0's cores, then node 1's";
    const placed_job scatter = place(machine, placement::scatter, ranks);
    EXPECT_EQ(nodes_of_ranks(machine, scatter), (std::vector<int>{0, 1, 0, 1, 0, 1, 0, 1}))
        << "scatter alternates the nodes";
    std::set<unsigned> cores;
    for (const auto& rank : compact.ranks) cores.insert(machine.pu(rank.cpus_bound.front()).core);
    EXPECT_EQ(cores.size(), 8U) << "one rank a core: no SMT sibling while a core is free";
    EXPECT_FALSE(compact.verdicts[0].crowded);
  }
  std::vector<dist::rank_report> four;
  for (int rank = 0; rank < 4; ++rank) four.push_back(report(rank, "a", "K", every_cpu));
  EXPECT_EQ(nodes_of_ranks(machine, place(machine, placement::compact, four)), (std::vector<int>{0, 0, 0, 0}))
      << "four ranks fit one node";
}

}  // namespace
