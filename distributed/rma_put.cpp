#include "distributed/rma_put.hpp"

#include <sched.h>

#include <cstring>

namespace lockstep::distributed {

rma_put_exchange::rma_put_exchange(const exchange_setup& setup)
    : private_copies(setup.blocks.equations()),
      comm_(setup.comm),
      rank_(setup.rank),
      ranks_(setup.size),
      oversubscribed_(setup.oversubscribed),
      equations_(setup.blocks.equations()),
      own_first_(setup.mine().block.first),
      own_count_(static_cast<int>(setup.mine().block.size())),
      producers_(setup.producer_blocks()),
      consumers_(setup.consumers()) {
  ready_seen_.assign(producers_.size(), 0);
  consumed_seen_.assign(consumers_.size(), 0);
  bytes_ = kDepth * equations_ * sizeof(double) + 2 * static_cast<std::size_t>(setup.size) * sizeof(std::uint64_t);
  MPI_Win_allocate(static_cast<MPI_Aint>(bytes_), 1, MPI_INFO_NULL, comm_, &base_, &window_);
  std::memset(base_, 0, bytes_);
  MPI_Win_lock_all(MPI_MODE_NOCHECK, window_);
  MPI_Win_sync(window_);
  MPI_Barrier(comm_);
}

rma_put_exchange::~rma_put_exchange() {
  MPI_Win_unlock_all(window_);
  MPI_Win_free(&window_);
}

MPI_Aint rma_put_exchange::data_displacement(std::uint64_t slot, std::size_t equation) const noexcept {
  return static_cast<MPI_Aint>((slot * equations_ + equation) * sizeof(double));
}
MPI_Aint rma_put_exchange::ready_displacement(int producer) const noexcept {
  return static_cast<MPI_Aint>(kDepth * equations_ * sizeof(double) + static_cast<std::size_t>(producer) * 8);
}
MPI_Aint rma_put_exchange::consumed_displacement(int consumer) const noexcept {
  return ready_displacement(ranks_) + static_cast<MPI_Aint>(static_cast<std::size_t>(consumer) * 8);
}

// The poll is (D4) for a ready flag and (A3) for an acknowledgement: an
// atomic read of the word (MPI_Fetch_and_op), then MPI_Win_flush, which
// completes it before anything this rank does next (with osc/sm a full
// memory barrier): the copy (D6) reads no slot, and the puts (D1) write none,
// before the word was seen.
void rma_put_exchange::wait_local(MPI_Aint displacement, std::uint64_t& seen, std::uint64_t target) {
  unsigned polls = 0;
  while (seen < target) {
    if (oversubscribed_ && ++polls % kPollsBeforeYield == 0) sched_yield();
    std::uint64_t value = 0;
    MPI_Fetch_and_op(nullptr, &value, MPI_UINT64_T, rank_, displacement, MPI_NO_OP, window_);
    MPI_Win_flush(rank_, window_);
    seen = value;
  }
}

void rma_put_exchange::share(std::uint64_t global_stage) {
  double* const values = values_of(global_stage);
  const std::uint64_t slot = global_stage % kDepth;
  if (!consumers_.empty()) {
    if (global_stage >= kDepth)
      for (std::size_t index = 0; index < consumers_.size(); ++index)
        wait_local(consumed_displacement(consumers_[index]), consumed_seen_[index], global_stage - kDepth + 1);
    // (A4) after (A3) saw the acknowledgement: the puts below overwrite
    // slot g % kDepth, which the consumer read at stage g - kDepth.
    for (int consumer : consumers_)
      MPI_Put(values + own_first_, own_count_, MPI_DOUBLE, consumer, data_displacement(slot, own_first_), own_count_,
              MPI_DOUBLE, window_);  // (D1)
    for (int consumer : consumers_) MPI_Win_flush(consumer, window_);  // (D2)
    flag_ = global_stage + 1;
    for (int consumer : consumers_)
      MPI_Accumulate(&flag_, 1, MPI_UINT64_T, consumer, ready_displacement(rank_), 1, MPI_UINT64_T, MPI_REPLACE,
                     window_);  // (D3)
    for (int consumer : consumers_) MPI_Win_flush(consumer, window_);
  }
  if (producers_.empty()) return;
  for (std::size_t index = 0; index < producers_.size(); ++index)
    wait_local(ready_displacement(producers_[index].rank), ready_seen_[index], global_stage + 1);
  MPI_Win_sync(window_);  // (D5)
  const auto* slot_values = reinterpret_cast<const double*>(base_ + data_displacement(slot, 0));
  for (const producer_block& producer : producers_)
    std::memcpy(values + producer.first, slot_values + producer.first, producer.count * sizeof(double));  // (D6)
  if (global_stage % 4 == 3) {
    // (A1) the loads of (D6) from every slot this step read are done before
    // (A2) tells the producers they may overwrite them.
    MPI_Win_sync(window_);
    ack_ = global_stage + 1;
    for (const producer_block& producer : producers_)
      MPI_Accumulate(&ack_, 1, MPI_UINT64_T, producer.rank, consumed_displacement(rank_), 1, MPI_UINT64_T,
                     MPI_REPLACE, window_);  // (A2)
    for (const producer_block& producer : producers_) MPI_Win_flush(producer.rank, window_);
  }
}

void rma_put_exchange::reset(std::span<const double> initial) {
  // Every put and accumulate of the last round was flushed before its
  // share() returned; once all ranks are here nothing is in flight.
  MPI_Barrier(comm_);
  std::memset(base_, 0, bytes_);
  MPI_Win_sync(window_);
  std::fill(ready_seen_.begin(), ready_seen_.end(), 0);
  std::fill(consumed_seen_.begin(), consumed_seen_.end(), 0);
  reset_copies(initial);
  MPI_Barrier(comm_);
}

}  // namespace lockstep::distributed
