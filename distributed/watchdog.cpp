#include "distributed/watchdog.hpp"

#include <cstdio>
#include <cstdlib>

namespace lockstep::distributed {

watchdog::watchdog(std::chrono::nanoseconds limit, std::string who)
    : limit_(limit), who_(std::move(who)), thread_([this] { watch(); }) {}

watchdog::~watchdog() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  stop_signal_.notify_all();
  thread_.join();
}

void watchdog::watch() {
  std::uint64_t last = progress_.load(std::memory_order_relaxed);
  auto last_change = std::chrono::steady_clock::now();
  std::unique_lock lock(mutex_);
  while (!stop_signal_.wait_for(lock, limit_ / 16, [this] { return stop_; })) {
    const std::uint64_t now_value = progress_.load(std::memory_order_relaxed);
    const auto now = std::chrono::steady_clock::now();
    if (now_value != last) {
      last = now_value;
      last_change = now;
      continue;
    }
    if (now - last_change >= limit_) {
      const double seconds = std::chrono::duration<double>(limit_).count();
      std::fprintf(stderr,
                   "lockstep mpi: %s made no progress for %.3g s (in %s, at %llu): another rank died or stalled, "
                   "or this one did; ending the job (--watchdog sets the limit)\n",
                   who_.c_str(), seconds, phase_.load(std::memory_order_relaxed),
                   static_cast<unsigned long long>(now_value));
      std::fflush(stderr);
      std::_Exit(kExitStalled);
    }
  }
}

}  // namespace lockstep::distributed
