#include "distributed/shm_window.hpp"

#include <algorithm>
#include <new>
#include <stdexcept>

#include "platform/cache_line.hpp"

namespace lockstep::distributed {
namespace {
// Where the values start: the barrier's size, rounded up to a whole line, so
// that no value shares a line with the barrier's words.
constexpr std::size_t kValuesOffset =
    (sizeof(sync::process_shared_futex_spin) + platform::kCacheLine - 1) / platform::kCacheLine * platform::kCacheLine;
}  // namespace

shm_window_exchange::shm_window_exchange(const exchange_setup& setup)
    : comm_(setup.comm), equations_(setup.blocks.equations()) {
  int host_size = 0;
  MPI_Comm_size(setup.host_comm, &host_size);
  if (host_size != setup.size) throw std::logic_error("shm_window needs every rank on one host");
  const std::size_t bytes = kValuesOffset + 5 * equations_ * sizeof(double);
  void* base = nullptr;
  MPI_Win_allocate_shared(static_cast<MPI_Aint>(setup.rank == 0 ? bytes : 0), 1, MPI_INFO_NULL, setup.host_comm,
                          &base, &window_);
  MPI_Aint size = 0;
  int unit = 0;
  MPI_Win_shared_query(window_, 0, &size, &unit, &base);
  auto* bytes_base = static_cast<std::byte*>(base);
  if (setup.rank == 0) new (bytes_base) sync::process_shared_futex_spin(static_cast<unsigned>(setup.size));
  barrier_ = std::launder(reinterpret_cast<sync::process_shared_futex_spin*>(bytes_base));
  values_ = reinterpret_cast<double*>(bytes_base + kValuesOffset);
  self_.id = static_cast<unsigned>(setup.rank);
  MPI_Win_lock_all(MPI_MODE_NOCHECK, window_);
  MPI_Win_sync(window_);
  MPI_Barrier(comm_);  // the barrier is built before anyone arrives at it
}

shm_window_exchange::~shm_window_exchange() {
  // process_shared_futex_spin is trivially destructible (asserted where it is
  // declared): freeing the window is all there is to do.
  MPI_Win_unlock_all(window_);
  MPI_Win_free(&window_);
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

}  // namespace lockstep::distributed
