// The one result writer (result_file.hpp).
#include "bench/harness/result_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/core.h>

#include <array>
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

// The temporary path, for the signal handler (which may only use
// async-signal-safe calls: unlink, write, _exit).
std::array<char, 4096> g_temporary_path{};
// The signals that end a process with a temporary file in flight: an
// interrupt, a kill, a closed terminal, a closed pipe (`lockstep run | head`).
constexpr int kEndingSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGPIPE};
struct sigaction g_previous[std::size(kEndingSignals)] {};

extern "C" void remove_partial_result(int signal_number) {
  if (g_temporary_path[0] != '\0') ::unlink(g_temporary_path.data());
  static const char message[] = "\nlockstep: interrupted; no result file was written\n";
  const ssize_t ignored = ::write(STDERR_FILENO, message, sizeof message - 1);
  (void)ignored;
  ::_exit(128 + signal_number);
}

// Writes all of `text` to `fd`; false on an error (errno set).
bool write_all(int fd, std::string_view text) {
  while (!text.empty()) {
    const ssize_t written = ::write(fd, text.data(), text.size());
    if (written < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    text.remove_prefix(static_cast<std::size_t>(written));
  }
  return true;
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

atomic_result_file::atomic_result_file(std::string destination) : destination_(std::move(destination)) {
  check_result_path(destination_);
  temporary_ = temporary_for(destination_);
  if (temporary_.size() >= g_temporary_path.size())
    throw result_path_error("cannot write " + destination_ + ": the path is too long");
  const int fd = ::open(temporary_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw result_path_error(fmt::format("cannot write {}: {}", destination_, std::strerror(errno)));
  ::close(fd);
  std::memcpy(g_temporary_path.data(), temporary_.c_str(), temporary_.size() + 1);

  struct sigaction action {};
  action.sa_handler = remove_partial_result;
  sigemptyset(&action.sa_mask);
  for (std::size_t i = 0; i < std::size(kEndingSignals); ++i) ::sigaction(kEndingSignals[i], &action, &g_previous[i]);
}

atomic_result_file::~atomic_result_file() {
  for (std::size_t i = 0; i < std::size(kEndingSignals); ++i) ::sigaction(kEndingSignals[i], &g_previous[i], nullptr);
  if (!committed_) ::unlink(temporary_.c_str());
  g_temporary_path[0] = '\0';
}

void atomic_result_file::write(std::string_view text) {
  const int fd = ::open(temporary_.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  const bool written = fd >= 0 && write_all(fd, text);
  const int error = errno;
  if (fd >= 0) ::close(fd);
  if (!written) throw std::runtime_error(fmt::format("cannot write {}: {}", temporary_, std::strerror(error)));
}

void atomic_result_file::commit() {
  const int fd = ::open(temporary_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0 || ::fsync(fd) != 0) {
    const int error = errno;
    if (fd >= 0) ::close(fd);
    throw std::runtime_error(fmt::format("cannot write {}: {}", destination_, std::strerror(error)));
  }
  ::close(fd);
  // Block the signals across the rename so the handler never unlinks a file
  // that is already the destination.
  sigset_t block;
  sigset_t previous;
  sigemptyset(&block);
  for (int signal_number : kEndingSignals) sigaddset(&block, signal_number);
  ::pthread_sigmask(SIG_BLOCK, &block, &previous);
  const int renamed = std::rename(temporary_.c_str(), destination_.c_str());
  const int rename_errno = errno;
  if (renamed == 0) {
    committed_ = true;
    g_temporary_path[0] = '\0';
  }
  ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  if (renamed != 0)
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
  std::error_code ignored;  // a failure shows in check_result_path, with its reason
  fs::create_directories("results", ignored);
  return fmt::format("results/{}-{}.json", host.data(), stamp.data());
}

}  // namespace lockstep::bench
