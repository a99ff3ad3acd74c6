#include "distributed/p2p.hpp"

namespace lockstep::distributed {

std::vector<int> exchange_setup::consumers() const {
  std::vector<int> result;
  for (int consumer = 0; consumer < size; ++consumer) {
    const auto& producers = plans[static_cast<std::size_t>(consumer)].producers;
    if (std::find(producers.begin(), producers.end(), static_cast<unsigned>(rank)) != producers.end())
      result.push_back(consumer);
  }
  return result;
}

std::vector<producer_block> exchange_setup::producer_blocks() const {
  std::vector<producer_block> result;
  for (unsigned producer : mine().producers) {
    const layouts::equation_block block = blocks.block(producer);
    result.push_back({static_cast<int>(producer), block.first, block.size()});
  }
  return result;
}

p2p_exchange::p2p_exchange(const exchange_setup& setup)
    : private_copies(setup.blocks.equations()),
      comm_(setup.comm),
      own_first_(setup.mine().block.first),
      own_count_(static_cast<int>(setup.mine().block.size())),
      producers_(setup.producer_blocks()),
      consumers_(setup.consumers()) {
  requests_.resize(producers_.size() + consumers_.size());
}

void p2p_exchange::prepare(std::uint64_t global_stage) {
  double* const values = values_of(global_stage);
  const int tag = static_cast<int>(global_stage % 4);
  std::size_t request = 0;
  for (const producer_block& producer : producers_)
    MPI_Irecv(values + producer.first, static_cast<int>(producer.count), MPI_DOUBLE, producer.rank, tag, comm_,
              &requests_[request++]);
  posted_ = global_stage + 1;
}

void p2p_exchange::share(std::uint64_t global_stage) {
  if (posted_ != global_stage + 1) prepare(global_stage);
  posted_ = 0;
  const double* const own = values_of(global_stage) + own_first_;
  const int tag = static_cast<int>(global_stage % 4);
  std::size_t request = producers_.size();
  for (int consumer : consumers_)
    MPI_Isend(own, own_count_, MPI_DOUBLE, consumer, tag, comm_, &requests_[request++]);
  MPI_Waitall(static_cast<int>(request), requests_.data(), MPI_STATUSES_IGNORE);
}

void p2p_exchange::reset(std::span<const double> initial) {
  reset_copies(initial);
  MPI_Barrier(comm_);
}

}  // namespace lockstep::distributed
