#pragma once
// p2p: the dataflow exchange. Each rank receives only the blocks its own block
// reads (the producers of kernels::participant_plan) and sends its block only
// to the ranks that read it, with nonblocking MPI_Isend / MPI_Irecv completed
// by one MPI_Waitall per stage: the message-passing counterpart of the
// threaded mailbox and seqlock.
//
// Contract (exchange.hpp): after share(g) the rank's dependencies of stage g
// are in its private copy. Ordering: MPI's non-overtaking rule (messages
// between one pair on one communicator and tag match in the order sent) keeps
// a producer that runs stages ahead from being received out of order; tags
// carry the stage within the step for readability of traces only.
// Flow control: none of its own. A producer that leads a consumer by many
// stages leaves its messages in the consumer's unexpected queue (eager
// protocol for blocks this small), as any MPI dataflow code would; the
// consumer's later stages then find their data already there.
//
// Receives are pre-posted: prepare(g) posts stage g's receives before the rank
// computes its values, so a message that arrives meanwhile lands in its buffer
// rather than in the unexpected queue, and the timed share(g) is the sends and
// the wait, as the ping-pong's one-way time is a send to a receive already
// posted. (Posted inside share, they put the last arrival's posting on the
// critical path: stage p50 190 ns against 160-170 ns, 2 ranks over shared
// memory in the fast pace mode, 4 alternating runs.) A receive fills only the
// producers' equations of stage g's slot, which the rank neither reads nor
// writes until share(g) returns (private_copies keeps x_{n+1} apart from x_n
// for stage 3). share(g) posts them itself when prepare(g) was not called.
#include <vector>

#include "distributed/exchange.hpp"

namespace lockstep::distributed {

class p2p_exchange final : public private_copies {
 public:
  explicit p2p_exchange(const exchange_setup& setup);
  void prepare(std::uint64_t global_stage) override;
  void share(std::uint64_t global_stage) override;
  void reset(std::span<const double> initial) override;

 private:
  MPI_Comm comm_;
  std::size_t own_first_;
  int own_count_;
  std::vector<producer_block> producers_;
  std::vector<int> consumers_;
  std::vector<MPI_Request> requests_;  // the receives, one per producer, then the sends
  std::uint64_t posted_ = 0;           // 1 + the global stage whose receives are posted; 0: none
};

}  // namespace lockstep::distributed
