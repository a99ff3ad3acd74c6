#pragma once
// How `lockstep mpi` starts its own MPI job when it is run directly: the
// mpirun command line, built from what the user asked, shown before it runs.
// No MPI here: the launcher is an ordinary process that starts mpirun and
// waits for it.
//
// With Open MPI's mpirun (the one Debian packages):
//     mpirun --np N [--hostfile F] [--oversubscribe] --bind-to none --mca pml ob1
//            --mca btl self,vader --mca btl_vader_single_copy_mechanism none      (--transport shm)
//            --mca btl self,tcp --mca btl_tcp_if_include lo --mca osc pt2pt        (--transport tcp, one host)
//            --map-by node --mca btl self,vader,tcp --mca osc sm,pt2pt             (--hostfile)
//              [--mca btl_tcp_if_include NET --mca oob_tcp_if_include NET]           (--network NET)
//              --mca oob_tcp_keepalive_time K --mca oob_tcp_keepalive_intvl K --mca oob_tcp_keepalive_probes 1
//            [-x VARIABLE ...] <this lockstep> <the user's own words>
//   --bind-to none: lockstep pins its ranks itself (--pin, the same plans as
//   threads); --oversubscribe when ranks exceed this host's CPUs; pml ob1 so
//   that the btl list is the path the ranks take (and osc pt2pt so that
//   rma_put's puts take it too); single-copy off because a
//   container forbids the kernel's cross-memory attach. As root, the two
//   OMPI_ALLOW_RUN_AS_ROOT variables are set (and shown).
//   Across hosts: --map-by node deals the ranks out host by host (ranks 0
//   and 1, the ping-pong's, on two hosts; 4 ranks on 2 hosts, two each);
//   osc sm,pt2pt: rma_put's windows over the btl between hosts (Open MPI
//   4.1's default one-sided component refuses a window over tcp), shared
//   memory when every rank is on one; the out-of-band keepalive at K = a
//   quarter of --watchdog (at least 1 s) notices a host whose network went
//   down after about 2K, before the ranks' watchdogs, and mpirun ends the
//   job naming it ("ORTE has lost communication with a remote daemon ...
//   on node HOST"). mpirun reaches the hosts through its rsh agent (ssh, or
//   OMPI_MCA_plm_rsh_agent; tests/mpi/netns-hosts.sh uses one that enters a
//   network namespace).
// Another MPI's mpirun (MPICH's hydra): mpirun -n N [-f F] ...; the transport
// is that library's own choice, so --transport tcp is refused.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "distributed/registry.hpp"

namespace lockstep::distributed {

// True when this process is a rank of an MPI job (started by mpirun / mpiexec
// / srun): the environment variables Open MPI, PMIx, MPICH and Slurm set.
[[nodiscard]] bool launched_by_mpi();

struct launch_request {
  std::string mpirun;       // the program's path
  bool open_mpi = true;     // mpirun is Open MPI's
  unsigned ranks = 2;
  transport how = transport::shared_memory;
  std::string hostfile;     // empty: this host only
  std::string network;      // with a hostfile: the interface or CIDR the ranks and daemons use (empty: Open MPI's choice)
  std::int64_t watchdog_ns = 10'000'000'000;  // the ranks' --watchdog (the keepalive across hosts follows it)
  unsigned host_cpus = 1;   // CPUs of this host (for --oversubscribe)
  bool as_root = false;
  std::string executable;   // this lockstep
  std::vector<std::string> arguments;  // after the executable: the user's words ("mpi", options...)
  std::vector<std::string> forwarded;  // environment variables every rank must see (-x)
};

struct launch_plan {
  std::vector<std::string> argv;
  std::vector<std::pair<std::string, std::string>> environment;  // set before exec
  [[nodiscard]] std::string shown() const;  // "OMPI_ALLOW_RUN_AS_ROOT=1 ... mpirun --np 4 ..." (shell-quoted)
};

// Throws std::invalid_argument (one line) when the request cannot be launched
// with this mpirun (--transport tcp or --network with another MPI than Open
// MPI, --network without a hostfile).
[[nodiscard]] launch_plan plan_launch(const launch_request& request);

// The program's path in PATH, or nothing.
[[nodiscard]] std::optional<std::string> find_program(std::string_view name);
// Whether `mpirun --version` says Open MPI (or its runtime, OpenRTE).
[[nodiscard]] bool is_open_mpi(const std::string& mpirun);
// The hosts a hostfile names (one per non-empty, non-comment line, its first
// word). Throws std::invalid_argument (one line) when the file cannot be read
// or names none.
[[nodiscard]] std::vector<std::string> read_hostfile(const std::string& path);
// Runs the plan and waits; the exit status (128 + signal when killed).
int run_plan(const launch_plan& plan);
// This process's executable (/proc/self/exe).
[[nodiscard]] std::string this_executable();
// The words this process was started with after its program name
// (/proc/self/cmdline: argv[1], argv[2], ...), as the user typed them: what
// the launcher hands its ranks, so that every option reaches them.
[[nodiscard]] std::vector<std::string> own_arguments();

}  // namespace lockstep::distributed
