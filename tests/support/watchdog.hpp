#pragma once
// A watchdog for multi-threaded tests: a hang becomes a failure with a message,
// never a CI timeout.
//
// Construct one at the top of a test that starts threads. If the test is still
// running when the deadline passes, the watchdog prints what was running and
// the message it was given, then ends the process with status 1 (a deadlocked
// thread cannot be unwound, so the process is the unit of failure). Destroying
// the watchdog disarms it.
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

#include <gtest/gtest.h>

namespace lockstep::testing {

class watchdog {
 public:
  explicit watchdog(std::chrono::milliseconds deadline, std::string what = {})
      : what_(std::move(what)), thread_([this, deadline] { guard(deadline); }) {}

  watchdog(const watchdog&) = delete;  // owns a thread that points back at it
  watchdog& operator=(const watchdog&) = delete;

  ~watchdog() {
    {
      std::lock_guard lock(mutex_);
      disarmed_ = true;
    }
    wake_.notify_one();
    thread_.join();
  }

 private:
  void guard(std::chrono::milliseconds deadline) {
    std::unique_lock lock(mutex_);
    if (wake_.wait_for(lock, deadline, [this] { return disarmed_; })) return;
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    std::fprintf(stderr, "\nWATCHDOG: %s%s%s did not finish within %lld ms: %s\n",
                 test ? test->test_suite_name() : "", test ? "." : "", test ? test->name() : "",
                 static_cast<long long>(deadline.count()),
                 what_.empty() ? "a thread is stuck (hang or lost wake-up)" : what_.c_str());
    std::fflush(stderr);
    std::_Exit(1);
  }

  std::string what_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool disarmed_ = false;
  std::thread thread_;  // last: starts after the members it reads
};

// Sanitizer builds run several times slower; deadlines scale with this (and
// CTest's timeouts by the same factor, tests/CMakeLists.txt).
inline constexpr int kSlowdown =
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
    10;
#else
    1;
#endif

}  // namespace lockstep::testing
