#pragma once
// Real-time scheduling and locked memory, for paced runs (`lockstep delay`,
// `--fifo PRIO`, `--mlock`).
//
// SCHED_FIFO at a priority is the Linux form of the paper's "priority raised
// one step above normal": a FIFO thread runs until it blocks or a higher
// priority thread wakes, so the scheduler does not preempt it for ordinary
// work. mlockall keeps page faults out of the measured periods.
//
// Both need privileges that a normal user usually lacks. Each call either
// succeeds or throws scheduling_error whose message is one line saying what is
// missing and how to run without it. The message text comes from the pure
// functions describe_fifo_failure / describe_mlock_failure, so tests check the
// failure path for any errno without having to drop privileges.
#include <stdexcept>
#include <string>

namespace lockstep::platform {

class scheduling_error : public std::runtime_error {
 public:
  scheduling_error(int error_number, const std::string& message)
      : std::runtime_error(message), error_number_(error_number) {}
  int error_number() const noexcept { return error_number_; }  // the errno that failed

 private:
  int error_number_;
};

// The priority range the kernel accepts for SCHED_FIFO (1..99 on Linux).
int fifo_min_priority() noexcept;
int fifo_max_priority() noexcept;

// Puts the calling thread under SCHED_FIFO at `priority`
// (pthread_setschedparam). Throws scheduling_error on failure.
void set_current_thread_fifo(int priority);
// Puts the calling thread back under SCHED_OTHER (nice unchanged).
// Throws scheduling_error on failure (it cannot fail for lack of rights).
void set_current_thread_normal();
// The calling thread's policy as a word: "SCHED_OTHER", "SCHED_FIFO 50", ...
std::string current_thread_policy();

// mlockall(MCL_CURRENT | MCL_FUTURE). Throws scheduling_error on failure.
void lock_all_memory();
// munlockall(); never throws.
void unlock_all_memory() noexcept;

// One-line messages for a failed call with this errno (EPERM, EINVAL, ...).
// They name what is missing (CAP_SYS_NICE, RLIMIT_RTPRIO with its current
// value, CAP_IPC_LOCK, RLIMIT_MEMLOCK ...) and how to run without it (drop
// --fifo / --mlock). `option` is the command-line flag to name ("--fifo").
std::string describe_fifo_failure(int error_number, int priority, const std::string& option = "--fifo");
std::string describe_mlock_failure(int error_number, const std::string& option = "--mlock");

}  // namespace lockstep::platform
