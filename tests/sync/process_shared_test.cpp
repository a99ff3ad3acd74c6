// The process-shared futex_spin (sync/futex_spin.hpp with
// futex_scope::process_shared): the barrier that distributed/shm_window.hpp
// places in an MPI-3 shared window, here in an anonymous shared mapping
// between forked processes, placed where distributed/shared_window_layout.hpp
// puts it in a window whose base is 8 mod 64 (Open MPI 4.1's osc/sm hands
// out such bases). It lands on its alignment, no phase is left early, and it
// makes progress when the processes outnumber the CPUs (so they sleep on
// shared futexes and must be woken across processes).
#include <gtest/gtest.h>

#include <sched.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <stdexcept>
#include <vector>

#include "distributed/shared_window_layout.hpp"
#include "sync/futex_spin.hpp"
#include "sync/mailbox.hpp"
#include "sync/storage.hpp"

namespace {

using lockstep::distributed::barrier_window_layout;
using lockstep::sync::participant;
using lockstep::sync::process_shared_futex_spin;

// Where Open MPI 4.1's osc/sm puts a shared window's base: 8 bytes past a
// page boundary (distributed/shared_window_layout.hpp).
constexpr std::size_t kWindowBaseOffset = 8;

// An anonymous shared mapping whose usable part starts kWindowBaseOffset
// bytes past its (page-aligned) start, as an MPI shared window's does.
class shared_window {
 public:
  explicit shared_window(std::size_t bytes) : length_(kWindowBaseOffset + bytes) {
    mapping_ = mmap(nullptr, length_, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (mapping_ == MAP_FAILED) throw std::runtime_error("mmap failed");
  }
  ~shared_window() { munmap(mapping_, length_); }
  shared_window(const shared_window&) = delete;
  shared_window& operator=(const shared_window&) = delete;
  [[nodiscard]] std::byte* base() const noexcept { return static_cast<std::byte*>(mapping_) + kWindowBaseOffset; }

 private:
  std::size_t length_;
  void* mapping_;
};

bool aligned_for(const void* place, std::size_t alignment) {
  return reinterpret_cast<std::uintptr_t>(place) % alignment == 0;
}

// What the processes count, beside the window.
struct shared_counters {
  std::atomic<std::uint64_t> arrivals{0};
  std::atomic<std::uint64_t> futex_waits{0};
  std::atomic<int> failures{0};
};

// Each process: per phase, count its arrival, wait, then check that every
// process of this phase arrived (none left early). Returns through the shared
// failure count; the child's exit status says it finished.
void take_part(process_shared_futex_spin& barrier, shared_counters& region, unsigned id, unsigned processes,
               unsigned phases) {
  participant self;
  self.id = id;
  for (unsigned phase = 1; phase <= phases; ++phase) {
    region.arrivals.fetch_add(1, std::memory_order_relaxed);
    barrier.arrive_and_wait(self);
    // The barrier orders every arrival of this phase before this load.
    if (region.arrivals.load(std::memory_order_relaxed) < std::uint64_t{phase} * processes)
      region.failures.fetch_add(1, std::memory_order_relaxed);
    barrier.arrive_and_wait(self);  // nobody starts the next phase's count before all checked
  }
  region.futex_waits.fetch_add(self.counters.futex_waits, std::memory_order_relaxed);
}

// Every child exited 0 (a hang ends by its alarm, a signal the status shows).
void expect_children_finish(const std::vector<pid_t>& children) {
  for (pid_t child : children) {
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "a process did not finish (status " << status << ")";
  }
}

void run_processes(unsigned processes, unsigned phases, bool one_cpu) {
  // The barrier in a window laid out as shm_window's (no values here), with
  // the window's base 8 mod 64; the counters in a mapping of their own.
  const shared_window window(barrier_window_layout::window_bytes(0));
  const barrier_window_layout layout(window.base());
  ASSERT_TRUE(aligned_for(layout.barrier_place(), alignof(process_shared_futex_spin)))
      << "the barrier needs " << alignof(process_shared_futex_spin) << "-byte alignment; the window's base is "
      << reinterpret_cast<std::uintptr_t>(window.base()) % 64 << " mod 64 and the barrier went to offset "
      << layout.barrier_offset();
  ASSERT_TRUE(aligned_for(layout.values_place(), lockstep::platform::kCacheLine))
      << "the values start on a line of their own";
  ASSERT_LE(layout.values_place() - window.base(), static_cast<std::ptrdiff_t>(barrier_window_layout::window_bytes(0)))
      << "the barrier fits in the window";
  process_shared_futex_spin* const barrier = layout.place_barrier(true, processes);
  const shared_window counters_mapping(sizeof(shared_counters));
  auto* region = new (counters_mapping.base()) shared_counters();
  std::vector<pid_t> children;
  for (unsigned id = 0; id < processes; ++id) {
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      alarm(60);  // the test's watchdog: a hang kills the child, and the parent sees the signal
      if (one_cpu) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET(0, &set);
        sched_setaffinity(0, sizeof(set), &set);
      }
      // Each process finds the barrier from the base, as each rank does.
      process_shared_futex_spin* const found = barrier_window_layout(window.base()).place_barrier(false, processes);
      if (found != barrier) _exit(4);
      take_part(*found, *region, id, processes, phases);
      _exit(0);
    }
    children.push_back(child);
  }
  expect_children_finish(children);
  EXPECT_EQ(region->failures.load(), 0) << "a process left a phase before every process arrived";
  EXPECT_EQ(region->arrivals.load(), std::uint64_t{phases} * processes);
  if (one_cpu) {
    EXPECT_GT(region->futex_waits.load(), 0U) << "oversubscribed, some waits must have slept";
  }
}

TEST(ProcessSharedFutexSpin, TwoProcessesNoPhaseLeftEarly) { run_processes(2, 2000, false); }

// Four processes on one CPU: waiters run out of their budget and sleep on the
// shared futex; only a wake from another process frees them.
TEST(ProcessSharedFutexSpin, FourProcessesOnOneCpuSleepAndAreWoken) { run_processes(4, 300, true); }

// The process-shared mailbox: two processes, each a producer and a consumer
// of the other (all to all), over one anonymous shared mapping whose base is
// 8 mod 64, the block rounded up from it as shm_mailbox_exchange rounds it
// (distributed/shm_window.cpp); every value arrives, in order, and the
// storage's size is the heap mailbox's.
TEST(ProcessSharedMailbox, TwoProcessesExchangeEveryStageInOrder) {
  using lockstep::distributed::alignment_gap;
  using lockstep::sync::dependency_graph;
  using lockstep::sync::process_shared_mailbox;
  using lockstep::sync::process_shared_storage;
  constexpr std::size_t kWidth = 9;  // a first line and one more
  constexpr std::uint64_t kStages = 3000;
  const dependency_graph graph = dependency_graph::all_to_all(2);
  const std::size_t bytes = lockstep::sync::mailbox(graph, kWidth).storage_bytes();
  const shared_window window(bytes + lockstep::platform::kPrefetchPair);
  std::byte* const block = window.base() + alignment_gap(window.base(), lockstep::platform::kPrefetchPair);
  ASSERT_TRUE(aligned_for(block, lockstep::platform::kPrefetchPair));
  const shared_window counters_mapping(sizeof(std::atomic<int>));
  auto* failures = new (counters_mapping.base()) std::atomic<int>(0);
  // The initialiser builds the shared words before any process forks.
  process_shared_mailbox first(graph, kWidth, process_shared_storage(block, bytes, true));
  std::vector<pid_t> children;
  for (unsigned id = 0; id < 2; ++id) {
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      alarm(60);
      process_shared_mailbox mine(graph, kWidth, process_shared_storage(block, bytes, false));
      participant self;
      self.id = id;
      std::vector<double> out(kWidth);
      for (std::uint64_t stage = 0; stage < kStages; ++stage) {
        std::vector<double> values(kWidth, static_cast<double>(stage * 10 + id));
        mine.publish(self, stage, values);
        mine.receive(self, 1 - id, stage, out);
        for (double value : out)
          if (value != static_cast<double>(stage * 10 + (1 - id))) failures->fetch_add(1, std::memory_order_relaxed);
      }
      _exit(0);
    }
    children.push_back(child);
  }
  expect_children_finish(children);
  EXPECT_EQ(failures->load(), 0) << "a value arrived torn, late or from another stage";
}

}  // namespace
