#include "distributed/shm_window.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "distributed/shared_window_layout.hpp"
#include "platform/cache_line.hpp"

namespace lockstep::distributed {
namespace {
// Every rank on one host maps one window of `bytes` that rank 0 allocates;
// returns its start as this rank sees it (the same memory in every rank, at
// an address of each rank's own, not aligned for what goes in it:
// distributed/shared_window_layout.hpp).
std::byte* map_shared_window(const exchange_setup& setup, std::size_t bytes, MPI_Win& window) {
  int host_size = 0;
  MPI_Comm_size(setup.host_comm, &host_size);
  if (host_size != setup.size) throw std::logic_error("shm_window needs every rank on one host");
  void* base = nullptr;
  MPI_Win_allocate_shared(static_cast<MPI_Aint>(setup.rank == 0 ? bytes : 0), 1, MPI_INFO_NULL, setup.host_comm,
                          &base, &window);
  MPI_Aint size = 0;
  int unit = 0;
  MPI_Win_shared_query(window, 0, &size, &unit, &base);
  return static_cast<std::byte*>(base);
}

// Every rank rounded up to the same offset from its base (so they all use
// the same words); collective over `comm`.
void check_same_offset(MPI_Comm comm, std::size_t offset) {
  auto mine = static_cast<unsigned long long>(offset);
  unsigned long long first = mine;
  MPI_Bcast(&first, 1, MPI_UNSIGNED_LONG_LONG, 0, comm);
  if (first != mine)
    throw std::logic_error("shm_window: the ranks' shared-window bases differ in alignment (offset " +
                           std::to_string(mine) + " here, " + std::to_string(first) + " on rank 0)");
}

// The window is ready for everyone: locked for load/store access (passive
// target, for MPI_Win_sync) and rank 0's first writes visible to every rank.
// MPI's pattern for a store in one process and a load in another under the
// unified memory model: MPI_Win_sync, MPI_Barrier, MPI_Win_sync.
//  (1) MPI_Win_sync in every rank, after rank 0's first writes (the barrier
//      built, the mailbox's words initialised): their release; with Open
//      MPI's osc/sm a full memory barrier (opal_atomic_mb).
//  (2) MPI_Barrier: no rank leaves before rank 0 has passed (1); pairs (1)
//      with (3).
//  (3) MPI_Win_sync after the barrier: the acquire, before this rank's first
//      load of the window (its first arrive_and_wait or publish). Without it
//      a CPU that reorders loads (AArch64, POWER) may read the words from
//      before (1); x86-64 does not, which is why its absence went unseen.
void open_shared_window(MPI_Comm comm, MPI_Win window) {
  MPI_Win_lock_all(MPI_MODE_NOCHECK, window);
  MPI_Win_sync(window);  // (1)
  MPI_Barrier(comm);     // (2)
  MPI_Win_sync(window);  // (3)
}

void close_shared_window(MPI_Win& window) {
  MPI_Win_unlock_all(window);
  MPI_Win_free(&window);
}
}  // namespace

shm_window_exchange::shm_window_exchange(const exchange_setup& setup)
    : comm_(setup.comm), equations_(setup.blocks.equations()) {
  // The barrier on its alignment from wherever the base lies, the values on
  // the lines after it (distributed/shared_window_layout.hpp).
  std::byte* const base =
      map_shared_window(setup, barrier_window_layout::window_bytes(5 * equations_ * sizeof(double)), window_);
  const barrier_window_layout layout(base);
  check_same_offset(comm_, layout.barrier_offset());
  barrier_ = layout.place_barrier(setup.rank == 0, static_cast<unsigned>(setup.size));
  values_ = reinterpret_cast<double*>(layout.values_place());
  self_.id = static_cast<unsigned>(setup.rank);
  open_shared_window(comm_, window_);  // the barrier is built before anyone arrives at it
}

shm_window_exchange::~shm_window_exchange() {
  // process_shared_futex_spin is trivially destructible (asserted where it is
  // declared): freeing the window is all there is to do.
  close_shared_window(window_);
}

void shm_window_exchange::share(std::uint64_t /*global_stage*/) { barrier_->arrive_and_wait(self_); }

void shm_window_exchange::reset(std::span<const double> initial) {
  MPI_Barrier(comm_);
  if (self_.id == 0) {
    std::copy(initial.begin(), initial.end(), values_);
    std::fill(values_ + equations_, values_ + 5 * equations_, 0.0);
  }
  MPI_Win_sync(window_);
  MPI_Barrier(comm_);
  MPI_Win_sync(window_);
}

namespace {
sync::dependency_graph graph_of(const std::vector<kernels::participant_plan>& plans) {
  sync::dependency_graph graph;
  for (const kernels::participant_plan& plan : plans) graph.producers_of.push_back(plan.producers);
  return graph;
}
}  // namespace

shm_mailbox_exchange::shm_mailbox_exchange(const exchange_setup& setup)
    : private_copies(setup.blocks.equations()),
      comm_(setup.comm),
      own_first_(setup.mine().block.first),
      own_count_(setup.mine().block.size()),
      has_consumers_(setup.mine().has_consumers),
      width_(setup.blocks.largest_block()),
      producers_(setup.producer_blocks()),
      staging_(width_, 0.0) {
  const sync::dependency_graph graph = graph_of(setup.plans);
  // How large a block the mailbox's shared words need: the same mailbox on the
  // heap counts them (sync/storage.hpp), plus room to align the start.
  const std::size_t bytes = sync::mailbox(graph, width_).storage_bytes() + platform::kPrefetchPair;
  std::byte* const base = map_shared_window(setup, bytes, window_);
  const std::size_t gap = alignment_gap(base, platform::kPrefetchPair);
  check_same_offset(comm_, gap);
  channel_ = std::make_unique<sync::process_shared_mailbox>(
      graph, width_, sync::process_shared_storage(base + gap, bytes - gap, setup.rank == 0));
  self_.id = static_cast<unsigned>(setup.rank);
  open_shared_window(comm_, window_);  // rank 0 wrote the first words before anyone publishes
}

shm_mailbox_exchange::~shm_mailbox_exchange() {
  channel_.reset();  // this process's view; the shared words go with the window
  close_shared_window(window_);
}

void shm_mailbox_exchange::share(std::uint64_t global_stage) {
  double* const values = values_of(global_stage);
  const std::uint64_t stage = first_stage_ + global_stage;
  if (has_consumers_) {
    const double* source = values + own_first_;
    if (own_count_ != width_) {
      std::copy(source, source + own_count_, staging_.data());
      source = staging_.data();
    }
    channel_->publish(self_, stage, std::span<const double>(source, width_));
  }
  for (const producer_block& producer : producers_) {
    const auto rank = static_cast<unsigned>(producer.rank);
    if (producer.count == width_) {
      channel_->receive(self_, rank, stage, std::span<double>(values + producer.first, width_));
    } else {
      channel_->receive(self_, rank, stage, std::span<double>(staging_.data(), width_));
      std::copy(staging_.data(), staging_.data() + producer.count, values + producer.first);
    }
  }
  next_stage_ = stage + 1;
}

void shm_mailbox_exchange::reset(std::span<const double> initial) {
  reset_copies(initial);
  first_stage_ = next_stage_;  // every rank ran the same stages, so they agree
  MPI_Barrier(comm_);
}

}  // namespace lockstep::distributed
