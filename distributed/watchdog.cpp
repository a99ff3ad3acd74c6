#include "distributed/watchdog.hpp"

#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace lockstep::distributed {
namespace {

// The one armed watchdog's state, read by the signal handler: lock-free
// atomics and the message's two prefixes, written before the timer starts.
static_assert(std::atomic<std::uint64_t>::is_always_lock_free && std::atomic<const char*>::is_always_lock_free &&
                  std::atomic<bool>::is_always_lock_free,
              "the handler reads only lock-free atomics");
std::atomic<std::uint64_t> progress{0};
std::atomic<const char*> current_phase{"start-up"};
std::atomic<bool> waiting_for_others{false};
std::atomic<bool> armed{false};
// "lockstep mpi: rank R on HOST stopped: no progress for 10 s outside any wait for another rank (in "
std::array<char, 512> stopped_prefix{};
std::size_t stopped_length = 0;
// "lockstep mpi: rank R on HOST made no progress for 20 s waiting for other ranks (in "
std::array<char, 512> waiting_prefix{};
std::size_t waiting_length = 0;
constexpr unsigned kChecksPerLimit = 16;
constexpr unsigned kWaitingLimits = 2;  // a waiting rank allows twice the limit
// Touched only by the handler, which runs on one thread only (the timer's
// signal is aimed at the thread that armed it) and is not re-entered
// (SIGALRM is blocked while its handler runs).
std::uint64_t last_seen = 0;
unsigned unchanged_checks = 0;
timer_t timer{};

void write_all(const char* text, std::size_t length) noexcept {
  while (length > 0) {
    const ssize_t written = ::write(STDERR_FILENO, text, length);
    if (written <= 0) return;
    text += written;
    length -= static_cast<std::size_t>(written);
  }
}

// The loads are relaxed: they pair with the relaxed stores of beat() and
// phase(), and the handler (on the arming thread, where beat() is called)
// needs only to see the count change; the phase is a string literal, which
// needs no publishing.
void on_alarm(int /*signal*/) noexcept {
  const std::uint64_t now = progress.load(std::memory_order_relaxed);
  if (now != last_seen) {
    last_seen = now;
    unchanged_checks = 0;
    return;
  }
  const bool waiting = waiting_for_others.load(std::memory_order_relaxed);
  if (++unchanged_checks < (waiting ? kWaitingLimits * kChecksPerLimit : kChecksPerLimit)) return;
  // The whole line in one write(): shorter than PIPE_BUF, so the lines of
  // ranks whose watchdogs fire at once never interleave on a shared stderr
  // pipe (in pieces they did: tests/mpi read two ranks' words in one line).
  std::array<char, 1024> line{};
  std::size_t length = 0;
  const auto append = [&](const char* text, std::size_t size) noexcept {
    const std::size_t taken = std::min(size, line.size() - length);
    std::memcpy(line.data() + length, text, taken);
    length += taken;
  };
  if (waiting)
    append(waiting_prefix.data(), waiting_length);
  else
    append(stopped_prefix.data(), stopped_length);
  const char* what = current_phase.load(std::memory_order_relaxed);
  append(what, std::strlen(what));
  char digits[24];
  std::size_t at = sizeof digits;
  std::uint64_t value = now;
  do {
    digits[--at] = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value != 0 && at > 0);
  append(", at ", 5);
  append(digits + at, sizeof digits - at);
  static constexpr char kStoppedSuffix[] =
      "): this rank is the one that stopped; ending the job (--watchdog sets the limit)\n";
  static constexpr char kWaitingSuffix[] =
      "): a rank it waits for stopped, or the network to it did; ending the job (--watchdog sets the limit, twice it "
      "for a waiting rank)\n";
  if (waiting)
    append(kWaitingSuffix, sizeof kWaitingSuffix - 1);
  else
    append(kStoppedSuffix, sizeof kStoppedSuffix - 1);
  write_all(line.data(), length);
  ::_exit(kExitStalled);
}

void disarm_signal() noexcept {
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  sigemptyset(&ignore.sa_mask);
  sigaction(SIGALRM, &ignore, nullptr);
  armed.store(false);
}

}  // namespace

watchdog::watchdog(std::chrono::nanoseconds limit, const std::string& who) {
  if (armed.exchange(true)) throw std::runtime_error("one watchdog per process");
  const double seconds = std::chrono::duration<double>(limit).count();
  const auto clamp = [](int length, std::size_t size) {
    return length < 0 ? std::size_t{0} : std::min(static_cast<std::size_t>(length), size - 1);
  };
  stopped_length = clamp(std::snprintf(stopped_prefix.data(), stopped_prefix.size(),
                                       "lockstep mpi: %s stopped: no progress for %.3g s outside any wait for another "
                                       "rank (in ",
                                       who.c_str(), seconds),
                         stopped_prefix.size());
  waiting_length = clamp(std::snprintf(waiting_prefix.data(), waiting_prefix.size(),
                                       "lockstep mpi: %s made no progress for %.3g s waiting for other ranks (in ",
                                       who.c_str(), seconds * kWaitingLimits),
                         waiting_prefix.size());
  waiting_for_others.store(false, std::memory_order_relaxed);
  last_seen = progress.load(std::memory_order_relaxed);
  unchanged_checks = 0;

  struct sigaction action {};
  action.sa_handler = on_alarm;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // interrupted system calls resume; MPI's polls see EINTR and poll again
  if (sigaction(SIGALRM, &action, nullptr) != 0) {
    armed.store(false);
    throw std::runtime_error("cannot install SIGALRM");
  }
  // The timer's signal goes to this thread only (SIGEV_THREAD_ID), never to
  // another thread of the process (Open MPI's progress threads take
  // process-directed signals as readily as the main thread): the handler
  // never runs on two threads at once, and a signal pending when the
  // destructor runs is this thread's, which the destructor discards.
  sigevent event{};
  event.sigev_notify = SIGEV_THREAD_ID;
  event.sigev_signo = SIGALRM;
  event._sigev_un._tid = gettid();  // sigev_notify_thread_id in timer_create(2); glibc 2.36 names it only so
  if (timer_create(CLOCK_MONOTONIC, &event, &timer) != 0) {
    disarm_signal();
    throw std::runtime_error("cannot create the watchdog's timer");
  }
  const auto interval_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(limit / kChecksPerLimit).count();
  itimerspec period{};
  period.it_interval.tv_sec = static_cast<time_t>(interval_ns / 1'000'000'000);
  period.it_interval.tv_nsec = static_cast<long>(interval_ns % 1'000'000'000);
  period.it_value = period.it_interval;
  if (timer_settime(timer, 0, &period, nullptr) != 0) {
    timer_delete(timer);
    disarm_signal();
    throw std::runtime_error("cannot start the watchdog's timer");
  }
}

// The timer is deleted first (no signal is generated after timer_delete
// returns), then SIGALRM is ignored, which also discards one already pending
// for this thread. It stays ignored: restoring the default action instead
// would let a signal generated just before the timer went take it ("Alarm
// clock": the end of a rank that had succeeded).
watchdog::~watchdog() {
  timer_delete(timer);
  disarm_signal();
}

// relaxed, both: read by on_alarm's relaxed loads (above). Seeing the new
// count with the old phase costs nothing but a stale word in the message.
void watchdog::phase(const char* what) noexcept {
  current_phase.store(what, std::memory_order_relaxed);
  progress.fetch_add(1, std::memory_order_relaxed);
}

void watchdog::beat(std::uint64_t value) noexcept { progress.store(value, std::memory_order_relaxed); }

std::atomic<std::uint64_t>& watchdog::heartbeat() noexcept { return progress; }

std::atomic<bool>& watchdog::waiting() noexcept { return waiting_for_others; }

}  // namespace lockstep::distributed
