// SCHED_FIFO and mlockall, with messages that say what is missing.
#include "platform/scheduling.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>

#include <cerrno>
#include <cstring>

#include <fmt/core.h>

namespace lockstep::platform {

namespace {

// "unlimited" or the number, for a soft resource limit.
std::string soft_limit(int resource) {
  rlimit limit{};
  if (::getrlimit(resource, &limit) != 0) return "unknown";
  if (limit.rlim_cur == RLIM_INFINITY) return "unlimited";
  return std::to_string(static_cast<unsigned long long>(limit.rlim_cur));
}

std::string errno_name(int error_number) {
  switch (error_number) {
    case EPERM: return "EPERM";
    case EINVAL: return "EINVAL";
    case ENOMEM: return "ENOMEM";
    case EAGAIN: return "EAGAIN";
    case ESRCH: return "ESRCH";
    case ENOTSUP: return "ENOTSUP";
    default: return "errno " + std::to_string(error_number);
  }
}

}  // namespace

int fifo_min_priority() noexcept { return ::sched_get_priority_min(SCHED_FIFO); }
int fifo_max_priority() noexcept { return ::sched_get_priority_max(SCHED_FIFO); }

std::string describe_fifo_failure(int error_number, int priority, const std::string& option) {
  const std::string what = fmt::format("SCHED_FIFO priority {} not permitted ({}: {})", priority,
                                       errno_name(error_number), std::strerror(error_number));
  switch (error_number) {
    case EPERM:
      return fmt::format(
          "{}: needs CAP_SYS_NICE or RLIMIT_RTPRIO >= {} (soft limit now {}); run as root, raise it with "
          "`ulimit -r {}` (see /etc/security/limits.conf), or run without {}",
          what, priority, soft_limit(RLIMIT_RTPRIO), priority, option);
    case EINVAL:
      return fmt::format("{}: the priority must be {}..{}; give one in that range, or run without {}", what,
                         fifo_min_priority(), fifo_max_priority(), option);
    default:
      return fmt::format("{}: run without {}", what, option);
  }
}

std::string describe_mlock_failure(int error_number, const std::string& option) {
  const std::string what =
      fmt::format("mlockall not permitted ({}: {})", errno_name(error_number), std::strerror(error_number));
  switch (error_number) {
    case EPERM:
      return fmt::format("{}: needs CAP_IPC_LOCK or a large enough RLIMIT_MEMLOCK (soft limit now {} bytes); "
                         "run as root, raise it with `ulimit -l unlimited`, or run without {}",
                         what, soft_limit(RLIMIT_MEMLOCK), option);
    case ENOMEM:
    case EAGAIN:
      return fmt::format("{}: the process's memory exceeds RLIMIT_MEMLOCK (soft limit now {} bytes) or the "
                         "machine's free memory; raise it with `ulimit -l unlimited` (or CAP_IPC_LOCK), or "
                         "run without {}",
                         what, soft_limit(RLIMIT_MEMLOCK), option);
    default:
      return fmt::format("{}: run without {}", what, option);
  }
}

void set_current_thread_fifo(int priority) {
  // Check the range first: the kernel's EINVAL does not say which bound.
  if (priority < fifo_min_priority() || priority > fifo_max_priority()) {
    throw scheduling_error(EINVAL, describe_fifo_failure(EINVAL, priority));
  }
  sched_param parameters{};
  parameters.sched_priority = priority;
  const int error = ::pthread_setschedparam(::pthread_self(), SCHED_FIFO, &parameters);
  if (error != 0) throw scheduling_error(error, describe_fifo_failure(error, priority));
}

void set_current_thread_normal() {
  sched_param parameters{};
  parameters.sched_priority = 0;
  const int error = ::pthread_setschedparam(::pthread_self(), SCHED_OTHER, &parameters);
  if (error != 0) {
    throw scheduling_error(error, fmt::format("cannot return to SCHED_OTHER ({})", std::strerror(error)));
  }
}

std::string current_thread_policy() {
  int policy = 0;
  sched_param parameters{};
  if (::pthread_getschedparam(::pthread_self(), &policy, &parameters) != 0) return "unknown";
  switch (policy) {
    case SCHED_OTHER: return "SCHED_OTHER";
    case SCHED_FIFO: return fmt::format("SCHED_FIFO {}", parameters.sched_priority);
    case SCHED_RR: return fmt::format("SCHED_RR {}", parameters.sched_priority);
    case SCHED_BATCH: return "SCHED_BATCH";
    case SCHED_IDLE: return "SCHED_IDLE";
    default: return fmt::format("policy {}", policy);
  }
}

void lock_all_memory() {
  if (::mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
    const int error = errno;
    throw scheduling_error(error, describe_mlock_failure(error));
  }
}

void unlock_all_memory() noexcept { ::munlockall(); }

}  // namespace lockstep::platform
