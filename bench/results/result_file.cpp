// The one result writer (result_file.hpp).
#include "bench/results/result_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/core.h>

#include <array>
#include <atomic>
#include <iterator>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>

namespace lockstep::bench {

namespace {

namespace fs = std::filesystem;

std::string directory_of(const std::string& destination) {
  const fs::path parent = fs::path(destination).parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

std::string temporary_for(const std::string& destination) {
  return destination + ".partial-" + std::to_string(::getpid());
}

// What the signal handler knows. It may only use async-signal-safe calls
// (unlink, rmdir, write, nanosleep, _exit) and lock-free atomics, so the
// paths sit in fixed arrays and the file's state in one atomic word.
std::array<char, 4096> g_temporary_path{};
std::array<char, 4096> g_destination_path{};
std::array<char, 4096> g_made_directory{};  // empty: the file made no directory

// The life of the one result file in flight. Transitions:
//   idle -> writing      the constructor, before the handlers are installed;
//   writing -> renaming  commit(), by compare-exchange, with the signals
//                        blocked on the committing thread;
//   renaming -> committed or writing   commit(), after rename() answered;
//   any -> idle          the destructor, after the handlers are restored.
// (1) The release stores of commit() pair with the acquire loads (2) of a
// handler on another thread: a handler that reads `committed` also sees the
// rename done, one that reads `writing` after `renaming` sees it failed.
enum file_state : int { idle, writing, renaming, committed };
std::atomic<int> g_state{idle};
static_assert(std::atomic<int>::is_always_lock_free, "the handler reads the state: it must not hide a lock");
// Set by the first handler to run; a second signal on another thread waits
// for the first one's _exit instead of printing a second line.
std::atomic<bool> g_ending{false};

// The signals that end a process with a temporary file in flight: an
// interrupt, a kill, a closed terminal, a closed pipe (`lockstep run | head`).
constexpr int kEndingSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGPIPE};
struct sigaction g_previous[std::size(kEndingSignals)] {};
// Whether the handler was installed for kEndingSignals[i]: not where the
// process inherited the signal as ignored (nohup's SIGHUP; a background job's
// SIGINT), which stays ignored.
bool g_installed[std::size(kEndingSignals)] {};

void say(const char* text) {
  const ssize_t ignored = ::write(STDERR_FILENO, text, std::strlen(text));
  (void)ignored;
}

extern "C" void end_on_signal(int signal_number) {
  if (g_ending.exchange(true)) {
    for (;;) ::pause();  // another thread is ending the process
  }
  // (2) Pairs with (1). A rename under way on another thread (the committing
  // thread blocks these signals for itself, so it is never this one): wait
  // for its outcome, a system call's time.
  int state = g_state.load(std::memory_order_acquire);
  while (state == renaming) {
    const timespec nap{0, 100'000};
    ::nanosleep(&nap, nullptr);
    state = g_state.load(std::memory_order_acquire);
  }
  if (state == committed) {
    say("\nlockstep: interrupted; the result file ");
    say(g_destination_path.data());
    say(" was written\n");
  } else {
    if (g_temporary_path[0] != '\0') ::unlink(g_temporary_path.data());
    if (g_made_directory[0] != '\0') ::rmdir(g_made_directory.data());  // only when empty
    say("\nlockstep: interrupted; no result file was written\n");
  }
  ::_exit(128 + signal_number);
}

}  // namespace

void check_result_path(const std::string& destination) {
  if (destination.empty()) throw result_path_error("the result file name is empty");
  const std::string directory = directory_of(destination);
  struct stat info {};
  if (::stat(directory.c_str(), &info) != 0)
    throw result_path_error(fmt::format("cannot write {}: the directory {} does not exist", destination, directory));
  if (!S_ISDIR(info.st_mode))
    throw result_path_error(fmt::format("cannot write {}: {} is not a directory", destination, directory));
  if (::stat(destination.c_str(), &info) == 0 && S_ISDIR(info.st_mode))
    throw result_path_error(fmt::format("cannot write {}: it is a directory", destination));
  // Where the temporary file will go: creating it is the only real test
  // (permissions, read-only mounts, /proc and /sys refuse here).
  const std::string probe = temporary_for(destination);
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0)
    throw result_path_error(fmt::format("cannot write {}: {}", destination, std::strerror(errno)));
  ::close(fd);
  ::unlink(probe.c_str());
}

atomic_result_file::atomic_result_file(std::string destination, make_directory directory)
    : destination_(std::move(destination)) {
  // One level, and only a missing one: a directory that exists is not ours
  // to remove.
  if (directory == make_directory::when_missing && ::mkdir(directory_of(destination_).c_str(), 0777) == 0)
    made_directory_ = directory_of(destination_);
  try {
    check_result_path(destination_);
    temporary_ = temporary_for(destination_);
    if (temporary_.size() >= g_temporary_path.size() || destination_.size() >= g_destination_path.size() ||
        made_directory_.size() >= g_made_directory.size())
      throw result_path_error("cannot write " + destination_ + ": the path is too long");
    // Exclusive and not through a link: a name planted since the probe (a
    // symlink to somebody's file) makes this fail instead of writing there.
    descriptor_ = ::open(temporary_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (descriptor_ < 0)
      throw result_path_error(fmt::format("cannot write {}: {}", destination_, std::strerror(errno)));
  } catch (...) {
    if (!made_directory_.empty()) ::rmdir(made_directory_.c_str());
    throw;
  }
  through_descriptor_ = fmt::format("/proc/self/fd/{}", descriptor_);
  if (::access(through_descriptor_.c_str(), W_OK) != 0) through_descriptor_ = temporary_;
  std::memcpy(g_temporary_path.data(), temporary_.c_str(), temporary_.size() + 1);
  std::memcpy(g_destination_path.data(), destination_.c_str(), destination_.size() + 1);
  std::memcpy(g_made_directory.data(), made_directory_.c_str(), made_directory_.size() + 1);
  g_ending.store(false, std::memory_order_relaxed);  // no handler runs yet: none is installed
  g_state.store(writing, std::memory_order_release);  // (1)

  struct sigaction action {};
  action.sa_handler = end_on_signal;
  sigemptyset(&action.sa_mask);
  for (int signal_number : kEndingSignals) sigaddset(&action.sa_mask, signal_number);
  for (std::size_t i = 0; i < std::size(kEndingSignals); ++i) {
    ::sigaction(kEndingSignals[i], nullptr, &g_previous[i]);
    g_installed[i] = g_previous[i].sa_handler != SIG_IGN;
    if (g_installed[i]) ::sigaction(kEndingSignals[i], &action, nullptr);
  }
}

atomic_result_file::~atomic_result_file() {
  if (!committed_) ::unlink(temporary_.c_str());
  if (!committed_ && !made_directory_.empty()) ::rmdir(made_directory_.c_str());  // only when empty
  for (std::size_t i = 0; i < std::size(kEndingSignals); ++i)
    if (g_installed[i]) ::sigaction(kEndingSignals[i], &g_previous[i], nullptr);
  g_state.store(idle, std::memory_order_release);  // (1)
  g_temporary_path[0] = '\0';
  g_made_directory[0] = '\0';
  if (descriptor_ >= 0) ::close(descriptor_);
}

void atomic_result_file::write(std::string_view text) {
  bool written = ::ftruncate(descriptor_, 0) == 0;
  for (off_t offset = 0; written && !text.empty();) {
    const ssize_t count = ::pwrite(descriptor_, text.data(), text.size(), offset);
    if (count < 0) {
      if (errno == EINTR) continue;
      written = false;
      break;
    }
    text.remove_prefix(static_cast<std::size_t>(count));
    offset += count;
  }
  if (!written) throw std::runtime_error(fmt::format("cannot write {}: {}", temporary_, std::strerror(errno)));
}

void atomic_result_file::commit() {
  if (::fsync(descriptor_) != 0)
    throw std::runtime_error(fmt::format("cannot write {}: {}", destination_, std::strerror(errno)));
  // The name must still hold this file: a name replaced since (by a link to
  // another file) would otherwise be what the rename publishes.
  struct stat opened {};
  struct stat named {};
  if (::fstat(descriptor_, &opened) != 0 || ::lstat(temporary_.c_str(), &named) != 0 ||
      opened.st_dev != named.st_dev || opened.st_ino != named.st_ino)
    throw std::runtime_error(fmt::format("cannot write {}: the temporary file {} was replaced while it was written",
                                         destination_, temporary_));
  // This thread takes none of the ending signals across the rename; a
  // handler on another thread waits for the outcome (end_on_signal).
  sigset_t block;
  sigset_t previous;
  sigemptyset(&block);
  for (int signal_number : kEndingSignals) sigaddset(&block, signal_number);
  ::pthread_sigmask(SIG_BLOCK, &block, &previous);
  int expected = writing;
  // (1) on success, as the stores below: a handler that reads `renaming`
  // waits for the outcome this thread stores after the rename.
  if (!g_state.compare_exchange_strong(expected, renaming, std::memory_order_acq_rel)) {
    // Unreachable while this object lives: only commit() leaves `writing`,
    // and a handler never changes the state.
    ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
    throw std::logic_error("atomic_result_file::commit: the file is not being written");
  }
  const int renamed = std::rename(temporary_.c_str(), destination_.c_str());
  const int rename_errno = errno;
  committed_ = renamed == 0;
  g_state.store(committed_ ? committed : writing, std::memory_order_release);  // (1)
  ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  if (!committed_)
    throw std::runtime_error(fmt::format("cannot rename {} to {}: {}", temporary_, destination_,
                                         std::strerror(rename_errno)));
}

void write_result_file(const std::string& destination, std::string_view text) {
  atomic_result_file file(destination);
  file.write(text);
  file.commit();
}

std::string default_result_path() {
  std::array<char, 256> host{};
  if (::gethostname(host.data(), host.size() - 1) != 0) std::strcpy(host.data(), "unknown-host");
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  ::gmtime_r(&now, &utc);
  std::array<char, 32> stamp{};
  std::strftime(stamp.data(), stamp.size(), "%Y%m%dT%H%M%SZ", &utc);
  return fmt::format("results/{}-{}.json", host.data(), stamp.data());
}

}  // namespace lockstep::bench
