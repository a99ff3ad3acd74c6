// Idle states (idle_states.hpp): the cpuidle names and the PM QoS hold.
#include "platform/idle_states.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>

namespace lockstep::platform {
namespace {

std::string first_word_of(const char* path) {
  std::ifstream file(path);
  std::string word;
  if (!(file >> word)) return "unavailable";
  return word;
}

}  // namespace

std::string cpuidle_driver() { return first_word_of("/sys/devices/system/cpu/cpuidle/current_driver"); }

std::string cpuidle_governor() { return first_word_of("/sys/devices/system/cpu/cpuidle/current_governor"); }

dma_latency_hold::dma_latency_hold(std::int32_t latency_us, const std::string& path)
    : requested_us_(latency_us), path_(path) {
  // Read and write, as cyclictest opens it: reading back says what is in force.
  const int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) {
    problem_ = std::string("open: ") + std::strerror(errno);
    return;
  }
  // The binary form (exactly 4 bytes); any other length is parsed as text.
  if (::write(fd, &latency_us, sizeof latency_us) != static_cast<ssize_t>(sizeof latency_us)) {
    problem_ = std::string("write: ") + std::strerror(errno);
    ::close(fd);
    return;
  }
  fd_ = fd;
  std::int32_t in_force = 0;
  if (::pread(fd, &in_force, sizeof in_force, 0) == static_cast<ssize_t>(sizeof in_force)) in_force_us_ = in_force;
}

dma_latency_hold::~dma_latency_hold() {
  if (fd_ >= 0) ::close(fd_);
}

}  // namespace lockstep::platform
