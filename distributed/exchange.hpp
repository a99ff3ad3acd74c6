#pragma once
// How the stage values of the distributed RK4 step travel between MPI ranks:
// the interface every exchange implements (p2p.hpp, allgather.hpp,
// rma_put.hpp, shm_window.hpp), the MPI counterpart of kernels/
// parallel_exchange.hpp for threads.
//
// One rank owns one block of equations (layouts::partition) and runs, per
// step (distributed/rank_step.hpp):
//     for stage s in 0..3:
//         prepare(step * 4 + s)
//         k_s of its block from the stage inputs (state(parity), stage(s-1))
//         at s = 3: x_{n+1} of its block into next_state(parity)
//         share(step * 4 + s)
// share(g) is collective in the exchange's sense: it returns once every value
// the rank's block reads at the next stage is in place where the rank reads
// it (the rank's dependencies for a dataflow exchange, every equation for a
// collective one). The rank wrote its own block's values of stage g % 4 (k_s,
// or x_{n+1} at s = 3) before the call, and must not write them again before
// the call returns. `global_stage` increases by one per call, from 0 after
// every reset().
// prepare(g) comes before the rank computes its values of stage g, outside
// the timed share(g): an exchange may post there what share(g) will wait for
// (p2p's receives), as a dataflow MPI code pre-posts its receives. share(g)
// must not depend on it having been called.
//
// Where the values live is the exchange's choice: private copies per rank
// (private_copies below) or one shared window (shm_window). Every exchange
// feeds the same IEEE operations (kernels/rk4.hpp) the same inputs, so every
// rank's block is the serial trajectory bit for bit.
#include <mpi.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "kernels/parallel_exchange.hpp"
#include "layouts/partition.hpp"
#include "sync/concepts.hpp"

namespace lockstep::distributed {

class exchange {
 public:
  virtual ~exchange() = default;

  // x_n, where the rank reads every equation it needs at step parity `parity`.
  [[nodiscard]] virtual const double* state(unsigned parity) = 0;
  // Where the rank writes x_{n+1} of its block.
  [[nodiscard]] virtual double* next_state(unsigned parity) = 0;
  // k_s for s in 0..2: the rank writes its block's values and reads its
  // dependencies' there. (k_3 is nobody else's business: the step keeps it.)
  [[nodiscard]] virtual double* stage(unsigned stage) = 0;

  virtual void prepare(std::uint64_t /*global_stage*/) {}
  virtual void share(std::uint64_t global_stage) = 0;

  // Collective: x_0 in place for every rank (parity 0), global stages restart
  // at 0. Returns when every rank has reset.
  virtual void reset(std::span<const double> initial) = 0;

  // What a participating primitive counted (shm_window's futex_spin); zero
  // for the MPI exchanges, whose waits MPI does not report.
  [[nodiscard]] virtual sync::sync_counters counters() const { return {}; }
};

// A block this rank receives: its owner, where it starts, how many equations.
struct producer_block {
  int rank;
  std::size_t first;
  std::size_t count;
};

// What an exchange is built from: this rank, the job, the blocks, the plans.
struct exchange_setup {
  MPI_Comm comm;
  MPI_Comm host_comm;
  int rank;
  int size;
  layouts::partition blocks;
  std::vector<kernels::participant_plan> plans;  // index = rank
  bool oversubscribed = false;  // ranks of this rank's machine share CPUs (rank_placement.hpp: crowded): waits must yield

  [[nodiscard]] const kernels::participant_plan& mine() const { return plans[static_cast<std::size_t>(rank)]; }
  // The ranks that read this rank's block, ascending.
  [[nodiscard]] std::vector<int> consumers() const;
  // The blocks this rank reads from others, by producer ascending.
  [[nodiscard]] std::vector<producer_block> producer_blocks() const;
};

// The values in private copies, one full-size vector per slot, for the
// exchanges that move values by messages (p2p, allgather, rma_put). The state
// has two copies, x_n at parity n % 2 and x_{n+1} at the other: stage 3
// publishes into x_{n+1} while the rank's stage-3 derivatives still read x_n,
// so a receive posted before them (prepare) has a buffer nobody reads.
class private_copies : public exchange {
 public:
  explicit private_copies(std::size_t equations) {
    for (auto& values : states_) values.assign(equations, 0.0);
    for (auto& values : stages_) values.assign(equations, 0.0);
  }
  const double* state(unsigned parity) override { return states_[parity].data(); }
  double* next_state(unsigned parity) override { return states_[parity ^ 1U].data(); }
  double* stage(unsigned stage) override { return stages_[stage].data(); }

 protected:
  // The vector stage g % 4 published into: k_s, or x_{n+1} at s = 3 (the
  // owner's block from its update, its consumers' copies on receipt). Step n
  // = g / 4 reads x_n at parity n % 2 (reset() restarts both at 0).
  double* values_of(std::uint64_t global_stage) noexcept {
    const auto stage_in_step = static_cast<unsigned>(global_stage % 4);
    const auto next_parity = static_cast<unsigned>((global_stage / 4 + 1) % 2);
    return stage_in_step == 3 ? states_[next_parity].data() : stages_[stage_in_step].data();
  }
  void reset_copies(std::span<const double> initial) {
    for (auto& values : states_) values.assign(initial.begin(), initial.end());
    for (auto& values : stages_) std::fill(values.begin(), values.end(), 0.0);
  }

 private:
  std::vector<double> states_[2];
  std::vector<double> stages_[3];
};

}  // namespace lockstep::distributed
