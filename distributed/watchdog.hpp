#pragma once
// A rank's watchdog: a rank that stops making progress (its peer died, or
// stalls, and an MPI wait never returns) says so on stderr in one line and
// ends its process, so that mpirun ends the job: never a silent hang.
//
// The rank's main thread calls beat() whenever it makes progress (every step,
// every phase of the benchmark); a thread of the watchdog's own wakes every
// limit / 16 and, when the beat has not changed for `limit`, prints
//     lockstep mpi: rank R on HOST made no progress for 10 s (in <what>, step S): ...
// and calls std::_Exit(kExitStalled). It never calls MPI (the job runs with
// MPI_THREAD_FUNNELED).
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

namespace lockstep::distributed {

inline constexpr int kExitStalled = 3;

class watchdog {
 public:
  watchdog(std::chrono::nanoseconds limit, std::string who);
  ~watchdog();
  watchdog(const watchdog&) = delete;
  watchdog& operator=(const watchdog&) = delete;

  // What the rank is doing (a string literal: it is read by the watchdog's
  // thread, so it must outlive the run); also a beat.
  void phase(const char* what) noexcept {
    phase_.store(what, std::memory_order_relaxed);
    beat(progress_.load(std::memory_order_relaxed) + 1);
  }
  // relaxed: the watchdog needs to see the value change eventually, nothing
  // else is published through it.
  void beat(std::uint64_t value) noexcept { progress_.store(value, std::memory_order_relaxed); }
  std::atomic<std::uint64_t>& heartbeat() noexcept { return progress_; }

 private:
  void watch();

  std::chrono::nanoseconds limit_;
  std::string who_;
  std::atomic<std::uint64_t> progress_{0};
  std::atomic<const char*> phase_{"start-up"};
  std::mutex mutex_;
  std::condition_variable stop_signal_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace lockstep::distributed
