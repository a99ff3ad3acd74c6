#pragma once
// The CPUs a thread may run on, as the spinning primitives in sync/ need it to
// decide whether spinning can pay off (oversubscription: more runnable
// participants than CPUs in the union of their affinity sets).
//
// What it is: sched_getaffinity of the calling thread, folded into a union
// that several threads can add to concurrently.
// Progress: wait-free (a fixed number of relaxed fetch_or).
// Memory ordering: relaxed throughout; whoever reads the union must be ordered
// after every add by something else (futex_spin reads it only after a barrier
// phase in which every participant added its set first).
#include <array>
#include <atomic>
#include <bit>
#include <cstdint>

#include <sched.h>

namespace lockstep::sync {

class cpu_union {
 public:
  static constexpr unsigned kWords = CPU_SETSIZE / 64;

  // Adds the calling thread's affinity set. If the kernel refuses to say,
  // nothing is added (and the union may under-count: callers treat an empty
  // union as "unknown").
  void add_calling_thread() noexcept {
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof(set), &set) != 0) return;
    for (unsigned cpu = 0; cpu < CPU_SETSIZE; ++cpu)
      if (CPU_ISSET(cpu, &set))
        // relaxed: a set bit is all that is published; readers are ordered by
        // the caller (see the header).
        words_[cpu / 64].fetch_or(std::uint64_t{1} << (cpu % 64), std::memory_order_relaxed);
  }

  unsigned count() const noexcept {
    unsigned cpus = 0;
    for (const auto& word : words_) cpus += static_cast<unsigned>(std::popcount(word.load(std::memory_order_relaxed)));
    return cpus;
  }

 private:
  std::array<std::atomic<std::uint64_t>, kWords> words_{};
};

// CPUs in the calling thread's own affinity set (0 if the kernel refuses).
inline unsigned cpus_of_calling_thread() noexcept {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) != 0) return 0;
  return static_cast<unsigned>(CPU_COUNT(&set));
}

}  // namespace lockstep::sync
