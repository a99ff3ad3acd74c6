#pragma once
// Where the ranks of a job run, and whether two of them must share a CPU.
//
// Hosts that share a kernel are one machine. mpirun's hosts can be one
// machine: containers or network namespaces on one kernel (the two hosts of
// tests/mpi/netns-hosts.sh are). Placed host by host, each host's ranks would
// start from the host's first CPU, so rank 0 on one host and rank 1 on the
// other would both run on CPU 0; MPI ranks wait by polling, so each would
// keep the CPU until the scheduler's tick took it away, and every hop would
// cost a tick (on the development VM, HZ=250: a ping-pong of 4000 us one-way
// instead of about 5 us). So the ranks are grouped by kernel
// (kernel_identity), and each machine's ranks are placed together, as the
// ranks of one host: the placement plan (platform/placement.hpp) for all of
// them, in rank order, each rank kept inside the CPUs it was started with (its
// affinity set: mpirun's binding, a taskset, a container's cpuset), by a
// matching, so that no two share a CPU where they need not (plan_machine).
//
// Whether ranks must share a CPU is decided from what every rank reports once
// placed, before anything is measured: its kernel and the CPUs it is bound to.
// Ranks of one kernel that are bound to fewer CPUs between them than there
// are ranks (two ranks bound to one CPU; more ranks than CPUs) are crowded:
// some two of them share a CPU whatever the scheduler does (Hall's condition,
// find_crowding). Their remedy: they yield when idle (yield_when_idle.hpp),
// so that a wait hands the CPU to the rank it waits for. What was found and
// done is one line (sharing_line), and the result file's `placement`
// (docs/result-files.md).
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "distributed/world.hpp"
#include "platform/placement.hpp"
#include "platform/topology.hpp"

namespace lockstep::distributed {

// What one rank says about itself.
struct rank_report {
  int rank = 0;
  std::string host;                             // MPI_Get_processor_name
  std::string kernel;                           // kernel_identity
  std::vector<unsigned> cpus_given;             // its affinity set when it started, ascending
  std::optional<unsigned> cpu_host_by_host;     // where its host's own plan would pin it (none: `none`)
  std::vector<unsigned> cpus_bound;             // what placement bound it to, ascending
  std::optional<bool> yields_when_idle;         // once placed; nothing: the MPI library does not say
};

// The kernel this process runs on, as a name that two processes share
// exactly when they share the kernel: "boot id <uuid>" (Linux's
// /proc/sys/kernel/random/boot_id, new at every boot, the same in every
// container and namespace of that boot); where it cannot be read, "machine id
// <id>, <topology summary>, PUs <list>" (systemd's /etc/machine-id, which a
// cloned image can share, so the hwloc topology must match too); where
// neither can, "host <host>": the host is its own machine.
[[nodiscard]] std::string kernel_identity(const platform::topology& hardware, const std::string& host);

// The ranks of one kernel.
struct machine {
  std::string kernel;
  std::vector<std::string> hosts;  // in the order of their first rank
  std::vector<int> ranks;          // ascending
  std::vector<unsigned> cpus;      // every CPU one of them was started with, ascending
};

// Every kernel's ranks, in the order of their first rank. `reports` is
// indexed by rank.
[[nodiscard]] std::vector<machine> machines_of(std::span<const rank_report> reports);

// Where one machine's ranks go: per rank of `ranks.ranks` (same index), the
// CPUs it is to be bound to: one CPU for a pinned placement, its given CPUs
// for `none`. `hardware`: the machine's topology (any of its ranks' copy).
// The plan of `kind` for all the machine's ranks over every CPU one of them
// was given says which CPU each prefers (rank order, as the threads of one
// process); a rank whose preferred CPU is not among its own, or is taken,
// gets another of its own by an augmenting path, so that the ranks get
// distinct CPUs whenever their given sets allow it; a rank left over (they do
// not) takes its preferred CPU if it may, else its least used one.
[[nodiscard]] std::vector<std::vector<unsigned>> plan_machine(const platform::topology& hardware,
                                                              platform::placement kind, const machine& ranks,
                                                              std::span<const rank_report> reports);

// Ranks of one machine bound to fewer CPUs between them than there are
// ranks (from cpus_bound): the set a maximum matching of ranks to their
// bound CPUs leaves a rank out of, with every rank and CPU reachable from it
// by alternating paths (Konig's construction: those ranks have exactly the
// reached CPUs between them, and those are fewer). Nothing when every rank
// can have a bound CPU of its own.
struct crowding {
  std::vector<int> ranks;      // ascending
  std::vector<unsigned> cpus;  // the CPUs they are bound to between them, ascending
};
[[nodiscard]] std::optional<crowding> find_crowding(const machine& ranks, std::span<const rank_report> reports);

// CPUs that placing each host alone would have given to two or more ranks
// of one machine (from cpu_host_by_host), ascending by CPU.
struct shared_cpu {
  unsigned cpu = 0;
  std::vector<int> ranks;  // ascending
};
[[nodiscard]] std::vector<shared_cpu> host_by_host_sharing(const machine& ranks,
                                                           std::span<const rank_report> reports);

// What was done about busy-polling ranks that could share a CPU.
enum class sharing_remedy {
  none,             // none could (or, crowded, the MPI library cannot be made to yield)
  placed_apart,     // placed host by host they would have; placed as one machine they do not
  yield_when_idle,  // they must (crowded): they yield when idle
};
[[nodiscard]] std::string_view to_string(sharing_remedy remedy) noexcept;  // "none", "placed_apart", "yield_when_idle"

struct machine_verdict {
  std::optional<crowding> crowded;
  std::vector<shared_cpu> host_by_host;  // what placing host by host would have shared
  sharing_remedy remedy = sharing_remedy::none;
};

// Every machine's verdict (same index): crowded ranks yield when idle when
// every one of them reports it does (else none: the library cannot); ranks
// that are not crowded but would have shared placed host by host were placed
// apart (pinned placements only).
[[nodiscard]] std::vector<machine_verdict> judge(std::span<const machine> machines,
                                                 std::span<const rank_report> reports);

// The job's remedy: yield_when_idle if a machine's ranks yield, else
// placed_apart if a machine's were, else none.
[[nodiscard]] sharing_remedy job_remedy(std::span<const machine_verdict> verdicts) noexcept;

// The one line about it (without the "lockstep mpi: " every line of the
// command starts with), or empty when no machine's ranks could share a CPU:
//   busy-polling ranks could share a CPU: ranks 0 and 1 on host h are bound to CPU 0 between them; they
//   yield when idle (Open MPI's mpi_yield_when_idle) ...
//   busy-polling ranks could share a CPU: hosts a and b share one kernel (boot id ...): placed host by host,
//   ranks 0 and 1 would both run on CPU 0; placed as one machine instead: rank 0 on CPU 0, rank 1 on CPU 1
// (one clause per machine that needs one, joined by "; also ").
[[nodiscard]] std::string sharing_line(std::span<const machine> machines, std::span<const machine_verdict> verdicts,
                                       std::span<const rank_report> reports);

// The whole of it for a job.
struct rank_placement {
  std::vector<rank_report> ranks;  // index = rank; complete on every rank
  std::vector<machine> machines;
  std::vector<machine_verdict> verdicts;  // index = machine
  sharing_remedy remedy = sharing_remedy::none;
  std::string line;                // sharing_line, or empty
  std::size_t my_machine = 0;      // this rank's machine (index into machines)
  platform::placement_plan plan;   // this rank's machine's plan (its note: wrapped, oversubscribed)

  // This rank's machine is crowded: some two of its ranks share a CPU.
  [[nodiscard]] bool crowded_here() const { return verdicts.at(my_machine).crowded.has_value(); }
  // The one CPU this rank is bound to, or nothing (bound to several: `none`).
  [[nodiscard]] std::optional<unsigned> bound_cpu(int rank) const;
};

// Collective over job.comm. Every rank reports its kernel and the CPUs it
// was started with; every rank places itself by its machine's plan
// (plan_machine) and pins its thread there; every rank reports the CPUs it
// is bound to; the ranks of a crowded machine make their MPI library yield
// when idle, and every rank reports whether it does. `hardware`: this
// machine's topology, loaded before anything pinned the calling thread (its
// affinity set is what the rank was given). Throws platform::placement_error
// when a rank cannot be pinned.
[[nodiscard]] rank_placement place_ranks(const world& job, platform::placement kind,
                                         const platform::topology& hardware);

}  // namespace lockstep::distributed
