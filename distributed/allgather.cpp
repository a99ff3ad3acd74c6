#include "distributed/allgather.hpp"

namespace lockstep::distributed {

allgather_exchange::allgather_exchange(const exchange_setup& setup)
    : private_copies(setup.blocks.equations()), comm_(setup.comm) {
  for (int rank = 0; rank < setup.size; ++rank) {
    const layouts::equation_block block = setup.blocks.block(static_cast<unsigned>(rank));
    counts_.push_back(static_cast<int>(block.size()));
    displacements_.push_back(static_cast<int>(block.first));
  }
}

void allgather_exchange::share(std::uint64_t global_stage) {
  MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, values_of(global_stage), counts_.data(), displacements_.data(),
                 MPI_DOUBLE, comm_);
}

void allgather_exchange::reset(std::span<const double> initial) {
  reset_copies(initial);
  MPI_Barrier(comm_);
}

}  // namespace lockstep::distributed
