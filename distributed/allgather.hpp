#pragma once
// allgather: one collective per stage. Every rank contributes its block and
// receives every other block (MPI_Allgatherv in place): the barrier-like
// exchange, whatever the model's dependencies; the counterpart of a barrier
// primitive with the per_thread layout's board.
//
// Contract (exchange.hpp): after share(g) every equation of stage g is in the
// rank's private copy. Ordering: the collective's completion.
#include <vector>

#include "distributed/exchange.hpp"

namespace lockstep::distributed {

class allgather_exchange final : public private_copies {
 public:
  explicit allgather_exchange(const exchange_setup& setup);
  void share(std::uint64_t global_stage) override;
  void reset(std::span<const double> initial) override;

 private:
  MPI_Comm comm_;
  std::vector<int> counts_;         // per rank: its block's size
  std::vector<int> displacements_;  // per rank: its block's first equation
};

}  // namespace lockstep::distributed
