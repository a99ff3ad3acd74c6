// The migrate probe (migrate.hpp).
#include "bench/probes/migrate.hpp"

#include <sys/mman.h>

#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

#include "platform/cache_line.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"

namespace lockstep::bench::probes {
namespace {

// The working set: touched one 64-bit word per cache line, read-modify-write,
// so that a pass needs every line in the modified state in this core's cache
// (after a move every line must come from the old core's caches or beyond).
class working_set {
 public:
  explicit working_set(std::uint64_t bytes) : bytes_(bytes) {
    memory_ = ::mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (memory_ == MAP_FAILED) throw std::runtime_error("cannot map a working set of " + std::to_string(bytes) + " bytes");
    words_ = static_cast<std::uint64_t*>(memory_);
  }
  working_set(const working_set&) = delete;  // owns a mapping
  working_set& operator=(const working_set&) = delete;
  ~working_set() { ::munmap(memory_, bytes_); }

  // One pass; returns its duration in ns.
  std::int64_t pass() {
    constexpr std::size_t kWordsPerLine = platform::kCacheLine / sizeof(std::uint64_t);
    const std::size_t words = bytes_ / sizeof(std::uint64_t);
    const std::int64_t began = platform::now_ns();
    for (std::size_t i = 0; i < words; i += kWordsPerLine) words_[i] += 1;
    asm volatile("" ::: "memory");  // the writes are the measurement: keep them
    return platform::now_ns() - began;
  }

 private:
  void* memory_ = nullptr;
  std::uint64_t* words_ = nullptr;
  std::uint64_t bytes_ = 0;
};

// Moves the calling thread to `cpu`; returns ns until it runs there.
std::int64_t move_to(unsigned cpu) {
  const std::int64_t began = platform::now_ns();
  platform::pin_current_thread_to_pu(cpu);
  // sched_setaffinity returns once the kernel has moved the running task, so
  // this loop normally exits at once; it guards against a kernel that defers.
  while (platform::current_cpu() != cpu) std::this_thread::yield();
  return platform::now_ns() - began;
}

}  // namespace

migrate_result measure_migration(const migrate_settings& settings) {
  migrate_result samples;
  std::string error;
  // A thread of its own: the caller's affinity stays untouched. Everything it
  // writes happens-before join returns.
  std::thread mover([&] {
    try {
      working_set set(settings.bytes);
      move_to(settings.from);
      set.pass();
      set.pass();
      unsigned here = settings.from;
      unsigned there = settings.to;
      for (int repeat = 0; repeat < settings.repeats; ++repeat) {
        samples.stay_ns.push_back(static_cast<double>(move_to(here)));  // no move: the baseline
        samples.move_ns.push_back(static_cast<double>(move_to(there)));
        const std::int64_t cold = set.pass();
        const std::int64_t warm = set.pass();
        samples.first_pass_ns.push_back(static_cast<double>(cold));
        samples.next_pass_ns.push_back(static_cast<double>(warm));
        samples.refill_ns.push_back(static_cast<double>(cold - warm));
        std::swap(here, there);  // alternate directions: each repeat is one migration
        if (settings.on_progress && (repeat + 1) % 100 == 0) settings.on_progress(repeat + 1, settings.repeats);
      }
    } catch (const std::exception& e) {
      error = e.what();
    }
  });
  mover.join();
  if (!error.empty()) throw std::runtime_error(error);
  return samples;
}

}  // namespace lockstep::bench::probes
