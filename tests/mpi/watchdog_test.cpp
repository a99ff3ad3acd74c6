// The ranks' watchdog (distributed/watchdog.hpp) in a process with a second
// thread, as a rank has beside Open MPI's progress threads: its signal goes
// to the thread that armed it, never to the other one, and disarming it while
// a signal is pending ends nothing. Each case runs in a forked child (the
// watchdog ends its process when it fires); the parent reads the exit status.
#include <gtest/gtest.h>

#include <pthread.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <optional>
#include <string>
#include <thread>

#include "distributed/watchdog.hpp"

namespace {

using lockstep::distributed::watchdog;

// The pending-signal masks of one thread of this process, from
// /proc/self/task/TID/status: SigPnd (directed at that thread) and ShdPnd
// (directed at the process, any thread may take it).
struct pending_masks {
  unsigned long long thread = 0;
  unsigned long long process = 0;
};

pending_masks pending_of(pid_t tid) {
  std::ifstream status("/proc/self/task/" + std::to_string(tid) + "/status");
  pending_masks masks;
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("SigPnd:", 0) == 0) masks.thread = std::stoull(line.substr(7), nullptr, 16);
    if (line.rfind("ShdPnd:", 0) == 0) masks.process = std::stoull(line.substr(7), nullptr, 16);
  }
  return masks;
}

constexpr unsigned long long kAlarmBit = 1ULL << (SIGALRM - 1);

// Exit statuses of the child, for the parent's message.
enum child_status : int {
  kFinished = 0,
  kNeverPending = 10,        // no SIGALRM became pending for the arming thread
  kPendingForProcess = 11,   // it was pending for the process, not the thread
};

// The child: a second thread that takes any signal it is given (SIGALRM
// unblocked, as in Open MPI's threads) and sleeps; the main thread arms a
// watchdog that would fire after 160 ms without a beat, blocks SIGALRM for
// itself and waits until the timer's signal is pending. A signal aimed at
// the process would be taken by the second thread instead (its handler would
// find no beat and end the process with the watchdog's status 3, or, once
// the handler is gone, SIGALRM's default action would). Then it disarms the
// watchdog with the signal still pending, unblocks SIGALRM and exits 0.
[[noreturn]] void child_body() {
  alarm(0);
  std::atomic<bool> done{false};
  std::thread other([&done] {
    sigset_t alarm_only;
    sigemptyset(&alarm_only);
    sigaddset(&alarm_only, SIGALRM);
    pthread_sigmask(SIG_UNBLOCK, &alarm_only, nullptr);
    while (!done.load(std::memory_order_relaxed)) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  });
  std::optional<watchdog> dog;
  dog.emplace(std::chrono::milliseconds(160), "the test");
  sigset_t alarm_only;
  sigemptyset(&alarm_only);
  sigaddset(&alarm_only, SIGALRM);
  pthread_sigmask(SIG_BLOCK, &alarm_only, nullptr);
  const pid_t me = gettid();
  pending_masks masks;
  // A bound, not a measurement: the timer fires every 10 ms.
  for (int poll = 0; poll < 5000; ++poll) {
    masks = pending_of(me);
    if (((masks.thread | masks.process) & kAlarmBit) != 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  int result = kFinished;
  if ((masks.process & kAlarmBit) != 0)
    result = kPendingForProcess;
  else if ((masks.thread & kAlarmBit) == 0)
    result = kNeverPending;
  dog.reset();  // disarm with the signal pending
  pthread_sigmask(SIG_UNBLOCK, &alarm_only, nullptr);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));  // room for a stray signal to land
  done.store(true, std::memory_order_relaxed);
  other.join();
  _exit(result);
}

TEST(MpiWatchdog, SignalGoesToTheArmingThreadAndDisarmingWithOnePendingEndsNothing) {
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) child_body();
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_FALSE(WIFSIGNALED(status)) << "the process died of signal " << WTERMSIG(status)
                                    << " (SIGALRM is " << SIGALRM << "): the pending signal outlived the watchdog";
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_NE(WEXITSTATUS(status), lockstep::distributed::kExitStalled)
      << "the watchdog's handler ran on the second thread (the signal was aimed at the process)";
  EXPECT_NE(WEXITSTATUS(status), kPendingForProcess) << "the signal was pending for the process, not the arming thread";
  EXPECT_NE(WEXITSTATUS(status), kNeverPending) << "no signal became pending for the arming thread";
  EXPECT_EQ(WEXITSTATUS(status), kFinished);
}

// The watchdog still ends a process that stops beating, with its status and
// one line, when the arming thread takes its signal.
TEST(MpiWatchdog, NoBeatEndsTheProcessWithItsStatus) {
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    std::atomic<bool> done{false};
    std::thread other([&done] {
      while (!done.load(std::memory_order_relaxed)) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    });
    other.detach();
    const watchdog dog(std::chrono::milliseconds(160), "the test");
    for (int second = 0; second < 30; ++second) std::this_thread::sleep_for(std::chrono::seconds(1));
    _exit(0);  // the watchdog did not fire
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status)) << "status " << status;
  EXPECT_EQ(WEXITSTATUS(status), lockstep::distributed::kExitStalled);
}

}  // namespace
