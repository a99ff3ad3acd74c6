#pragma once
// Idle states, as a paced real-time run must control and report them.
//
// Between two periods a paced thread sleeps; an idle CPU then enters an idle
// state (C-state, or a hypervisor's halt), and the deeper the state the longer
// the wake-up takes. cyclictest therefore holds /dev/cpu_dma_latency open with
// 0 written for its whole run (Linux PM QoS: "no idle state whose exit latency
// exceeds 0 us"), unless told otherwise (--latency=US, --default-system).
// Results taken with and without that hold differ by 2x on this project's VM,
// so `lockstep delay` does the same and records what was in force.
//
// The PM QoS contract (Documentation/power/pm_qos_interface.rst): a process
// writes a 32-bit value (binary, native endianness) to the open file; the
// request lasts while the file stays open and is dropped when it is closed.
// Reading the file returns the value currently in force (the minimum over
// every open request, from any process), which may be lower than ours.
//
// cpuidle: /sys/devices/system/cpu/cpuidle/current_driver and
// current_governor name the idle driver ("intel_idle", "acpi_idle",
// "haltpoll", "none") and the governor ("menu", "teo", "haltpoll").
#include <cstdint>
#include <optional>
#include <string>

namespace lockstep::platform {

// The kernel's PM QoS file for CPU wake-up latency.
inline constexpr const char* kDmaLatencyPath = "/dev/cpu_dma_latency";

// "haltpoll", or "unavailable" when sysfs does not say (no cpuidle, a container).
std::string cpuidle_driver();
std::string cpuidle_governor();

// Holds a PM QoS CPU latency request for as long as it lives. Never throws
// for a file that cannot be opened or written: a run goes on without the
// hold, and held() / problem() say what happened.
class dma_latency_hold {
 public:
  // Opens `path` for writing and writes `latency_us` as a 32-bit value. On
  // failure nothing stays open and problem() says why in a few words
  // ("open: Permission denied").
  dma_latency_hold(std::int32_t latency_us, const std::string& path = kDmaLatencyPath);
  ~dma_latency_hold();  // closes the file: the request ends
  dma_latency_hold(const dma_latency_hold&) = delete;  // owns the file descriptor
  dma_latency_hold& operator=(const dma_latency_hold&) = delete;

  bool held() const noexcept { return fd_ >= 0; }
  std::int32_t requested_us() const noexcept { return requested_us_; }
  const std::string& path() const noexcept { return path_; }
  const std::string& problem() const noexcept { return problem_; }
  // The value in force read back right after the write (every process's
  // requests combined), when the file could be read; empty otherwise.
  std::optional<std::int32_t> in_force_us() const noexcept { return in_force_us_; }

 private:
  std::int32_t requested_us_;
  std::string path_;
  int fd_ = -1;
  std::string problem_;
  std::optional<std::int32_t> in_force_us_;
};

}  // namespace lockstep::platform
