#pragma once
// A rank's watchdog: a rank that stops making progress (its peer died, or
// stalls, and an MPI wait never returns) says so on stderr in one line and
// ends its process, so that mpirun ends the job: never a silent hang.
//
// The rank calls beat() whenever it makes progress (every step, every phase
// of the benchmark), and says when it waits for other ranks (waiting(): the
// exchange between stages, the ping-pong's receives). A POSIX interval timer
// (SIGALRM every limit / 16, aimed at the thread that constructs the watchdog
// and at no other, its handler async-signal-safe: relaxed atomic loads,
// write(2), _exit) finds the beat unchanged and calls _exit(kExitStalled)
// after one line that says which rank stopped:
//   - a rank that stopped outside any wait (it is the one that stopped), after `limit`:
//     lockstep mpi: rank R on HOST stopped: no progress for 10 s outside any wait for another rank (in <what>, at S): ...
//   - a rank that waits for others, after twice `limit`, so that the rank it
//     waits for, if that one stopped by itself, ends the job first and names itself:
//     lockstep mpi: rank R on HOST made no progress for 20 s waiting for other ranks (in <what>, at S): ...
// (A rank that died is named by mpirun; a host whose network went down, by
// mpirun's lost daemon, distributed/launcher.hpp.) No thread: the rank stays the single thread
// MPI_Init promised (a thread of its own would need MPI_THREAD_FUNNELED, and
// Open MPI 4.1 at that level took a 0-byte ping-pong from about 118 ns to
// about 190 ns one-way on the development VM). One watchdog per process.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>

namespace lockstep::distributed {

inline constexpr int kExitStalled = 3;

class watchdog {
 public:
  // Throws std::runtime_error when the timer cannot be set, or when another
  // watchdog is armed in this process. The constructing thread is the one
  // that beats and the one the signal goes to.
  watchdog(std::chrono::nanoseconds limit, const std::string& who);
  // Deletes the timer, and leaves SIGALRM ignored (a signal still pending is
  // discarded, never taken by its default action).
  ~watchdog();
  watchdog(const watchdog&) = delete;
  watchdog& operator=(const watchdog&) = delete;

  // What the rank is doing (a string literal: the handler reads it, so it
  // must outlive the run); also a beat.
  void phase(const char* what) noexcept;
  // relaxed: the handler needs to see the value change eventually, nothing
  // else is published through it.
  void beat(std::uint64_t value) noexcept;
  std::atomic<std::uint64_t>& heartbeat() noexcept;
  // Set while the rank waits for other ranks (relaxed, as the beat).
  std::atomic<bool>& waiting() noexcept;
};

}  // namespace lockstep::distributed
