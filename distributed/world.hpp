#pragma once
// The MPI job a rank belongs to: who it is, where it runs, what library runs it.
//
// mpi_session initialises MPI once for the process (MPI_Init: a rank is one
// thread; its watchdog is a timer signal, not a thread, see watchdog.hpp)
// and finalises it when it goes. world describes
// MPI_COMM_WORLD: the rank, the size, the host this rank runs on and how many
// hosts the job spans (ranks that share memory, MPI_COMM_TYPE_SHARED, count as
// one host), and this rank's place among the ranks of its host. (Placement
// groups ranks by kernel, not by host: rank_placement.hpp.)
#include <mpi.h>

#include <string>
#include <vector>

namespace lockstep::distributed {

class mpi_session {
 public:
  mpi_session();
  ~mpi_session();
  mpi_session(const mpi_session&) = delete;
  mpi_session& operator=(const mpi_session&) = delete;
};

struct world {
  MPI_Comm comm = MPI_COMM_WORLD;
  MPI_Comm host_comm = MPI_COMM_NULL;  // the ranks that share this rank's memory
  int rank = 0;
  int size = 1;
  int host_rank = 0;   // this rank's index among the ranks of its host
  int host_size = 1;   // ranks on this rank's host
  int hosts = 1;       // hosts the job spans
  int ranks_per_host_max = 1;
  std::string host;    // MPI_Get_processor_name
  std::vector<std::string> host_of_rank;  // every rank's host, index = rank

  [[nodiscard]] bool one_host() const noexcept { return hosts == 1; }
};

// Collective over MPI_COMM_WORLD.
[[nodiscard]] world describe_world();

// "Open MPI v4.1.4, package: Debian OpenMPI, ..." (the first line of
// MPI_Get_library_version) and the standard's version ("3.1").
[[nodiscard]] std::string library_version();
[[nodiscard]] std::string standard_version();

}  // namespace lockstep::distributed
