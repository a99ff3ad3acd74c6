#pragma once
// rma_put: one-sided communication, passive target, the way osu_put_latency
// times a put. The producer puts its block into each consumer's window, flushes
// (remote completion), then raises a per-producer flag in the consumer's window
// (MPI_Accumulate with MPI_REPLACE, flushed); the consumer polls its own flags
// and copies the blocks it depends on into its private copy.
//
// Window of each rank (MPI_Win_allocate, locked for the whole run with
// MPI_Win_lock_all, displacement unit one byte):
//     data      kDepth slots of n doubles: stage g lands in slot g % kDepth
//     ready     one word per producer: stages it has published into this window
//     consumed  one word per consumer: stages that consumer has copied out
// Flow control: before putting stage g into a consumer's slot g % kDepth the
// producer waits until that consumer has copied stage g - kDepth out of it
// (consumed >= g - kDepth + 1). Consumers acknowledge once per step (after
// stage 3), one accumulate per producer, so a producer may lead a consumer by
// one step without waiting; the acknowledgement is part of what this exchange
// costs.
// Ordering: two hand-offs, each a write, a flag and a read, with the MPI
// call that orders each edge (numbered as in rma_put.cpp). With Open MPI's
// osc/sm (ranks on one host) a put is a plain copy into the target's memory,
// an accumulate a plain store under a lock, and MPI_Win_flush and
// MPI_Win_sync are full memory barriers; nothing else orders a rank's own
// loads and stores on a CPU that reorders them (AArch64, POWER; x86-64 keeps
// loads before later stores, so it needs none of this to work).
//   Data, producer to consumer:
//     (D1) MPI_Put of stage g into the consumer's slot;
//     (D2) MPI_Win_flush: the put complete at the target before
//     (D3) MPI_Accumulate raises the ready flag (then flushed);
//     (D4) the consumer's poll sees the flag (MPI_Fetch_and_op, then
//          MPI_Win_flush) and
//     (D5) MPI_Win_sync makes the window's memory current for
//     (D6) its loads of the slot. (D2) pairs with (D4)/(D5).
//   Acknowledgement, consumer to producer (the slot's reuse):
//     (A1) MPI_Win_sync after the consumer's loads (D6) of the step: they are
//          done before
//     (A2) MPI_Accumulate writes the acknowledgement (then flushed);
//     (A3) the producer's poll sees it (MPI_Fetch_and_op, MPI_Win_flush),
//          and only then
//     (A4) its puts (D1) overwrite the slots. (A1) pairs with (A3): without
//          (A1), a consumer's load could still be pending when its
//          acknowledgement is visible, and read the next stage's value.
// Polling: the consumer reads its own flags with MPI_Fetch_and_op(MPI_NO_OP)
// and a flush, which also drives MPI's progress engine (over TCP, Open MPI's
// one-sided component needs the target to enter MPI). With more ranks than
// CPUs on the host it yields the CPU after every kPollsBeforeYield polls, as
// Open MPI's own waits do when oversubscribed (mpi_yield_when_idle): a rank
// that spins through its time slice keeps the rank it waits for off the CPU
// (4 ranks on 2 CPUs: 78 ms a step without the yield, the scheduler's slices).
#include <cstdint>
#include <vector>

#include "distributed/exchange.hpp"

namespace lockstep::distributed {

class rma_put_exchange final : public private_copies {
 public:
  static constexpr std::uint64_t kDepth = 8;  // stage slots per consumer window: two steps
  static constexpr unsigned kPollsBeforeYield = 16;

  explicit rma_put_exchange(const exchange_setup& setup);
  ~rma_put_exchange() override;
  rma_put_exchange(const rma_put_exchange&) = delete;
  rma_put_exchange& operator=(const rma_put_exchange&) = delete;

  void share(std::uint64_t global_stage) override;
  void reset(std::span<const double> initial) override;

 private:
  [[nodiscard]] MPI_Aint data_displacement(std::uint64_t slot, std::size_t equation) const noexcept;
  [[nodiscard]] MPI_Aint ready_displacement(int producer) const noexcept;
  [[nodiscard]] MPI_Aint consumed_displacement(int consumer) const noexcept;
  // Polls this rank's own word at `displacement` until it reaches `target`;
  // `seen` caches the last value read.
  void wait_local(MPI_Aint displacement, std::uint64_t& seen, std::uint64_t target);

  MPI_Comm comm_;
  int rank_;
  int ranks_;
  bool oversubscribed_;
  std::size_t equations_;
  std::size_t own_first_;
  int own_count_;
  std::vector<producer_block> producers_;
  std::vector<int> consumers_;
  std::vector<std::uint64_t> ready_seen_;     // per producer (index into producers_)
  std::vector<std::uint64_t> consumed_seen_;  // per consumer (index into consumers_)
  MPI_Win window_ = MPI_WIN_NULL;
  std::byte* base_ = nullptr;
  std::size_t bytes_ = 0;
  std::uint64_t flag_ = 0;  // origin buffers of the accumulates: live until their flush
  std::uint64_t ack_ = 0;
};

}  // namespace lockstep::distributed
