#pragma once
// The exchanges of the distributed step, by name: the one list `lockstep mpi`,
// its names and its tests read. A new exchange = its header and source + one
// line in registry.cpp.
//
//   name         in names                               what moves the values
//   p2p          mpi/exchange:p2p/...                   MPI_Isend / MPI_Irecv to and from the ranks that need them
//   allgather    mpi/exchange:allgather/...             MPI_Allgatherv, every block to every rank
//   rma_put      mpi/exchange:rma_put/...               MPI_Put + flush + flag, passive target
//   shm_window   mpi/exchange:shm_window/sync:futex_spin/...
//                mpi/exchange:shm_window/sync:mailbox/...
//                                                       a shared window and lockstep's own primitive across
//                                                       processes: futex_spin (values read in place) or
//                                                       mailbox (dataflow into private copies)
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "distributed/exchange.hpp"

namespace lockstep::distributed {

// How the ranks reach each other (the launcher's --transport).
enum class transport { shared_memory, tcp };
[[nodiscard]] std::string_view to_string(transport how) noexcept;  // "shm", "tcp"

// What an exchange's applicability depends on.
struct job_shape {
  int ranks = 1;
  int hosts = 1;
  transport how = transport::shared_memory;
};

struct exchange_entry {
  std::string_view name;         // what --exchange selects: "p2p", "shm_window"
  std::string_view sync;         // lockstep's primitive inside it ("futex_spin", "mailbox"), or empty
  std::string_view label;        // one entry in the output: "p2p", "shm_window/mailbox"
  std::string_view segment;      // the name's key:value segments: "exchange:p2p"
  std::string_view description;  // one line, for --help and the JSON
  // Why it cannot run on this job; empty when it can.
  std::string (*not_applicable)(const job_shape& job);
  // Collective over setup.comm: every rank builds the same exchange together.
  std::unique_ptr<exchange> (*make)(const exchange_setup& setup);
};

[[nodiscard]] std::span<const exchange_entry> exchanges() noexcept;
// The names --exchange takes, and the primitives --sync takes (each once, in order).
[[nodiscard]] std::vector<std::string> exchange_names();
[[nodiscard]] std::vector<std::string> exchange_syncs();

}  // namespace lockstep::distributed
