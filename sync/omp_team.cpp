// omp_team and omp_barrier's barrier call: the only translation unit compiled
// with OpenMP flags (sync/CMakeLists.txt, target lockstep_sync_omp).
#include <omp.h>

#include <atomic>
#include <stdexcept>
#include <string>

#include "sync/omp_barrier.hpp"
#include "sync/team.hpp"

namespace lockstep::sync {

void omp_team::run_region(const std::function<void(unsigned)>& body) {
  const int requested = static_cast<int>(participants_);
  std::atomic<int> granted{0};
  // A region of the wrong size must not run the body: the barrier inside is
  // sized for `participants_` and would wait forever for threads that do not
  // exist. Every thread checks the size before the body; all agree.
#pragma omp parallel num_threads(requested)
  {
    if (omp_get_thread_num() == 0) granted.store(omp_get_num_threads(), std::memory_order_relaxed);
    if (omp_get_num_threads() == requested) body(static_cast<unsigned>(omp_get_thread_num()));
  }
  // relaxed: the end of the parallel region is a barrier that orders the store.
  if (const int threads = granted.load(std::memory_order_relaxed); threads != requested)
    throw std::runtime_error("omp_team: asked OpenMP for " + std::to_string(requested) + " threads, got " +
                             std::to_string(threads) + " (OMP_THREAD_LIMIT or OMP_DYNAMIC?)");
}

void omp_barrier::wait_in_region() noexcept {
  // An orphaned barrier: it binds to the innermost enclosing parallel region,
  // the one omp_team::run_region opened.
#pragma omp barrier
}

// omp_get_level, not omp_in_parallel: a region of one thread is inactive, yet the barrier is valid in it.
bool omp_barrier::in_parallel_region() noexcept { return omp_get_level() > 0; }

}  // namespace lockstep::sync
