#pragma once
// The clock of every measured path: clock_gettime(CLOCK_MONOTONIC) in
// nanoseconds.
//
// Why not rdtsc: the TSC is cheaper (~10 ns against ~20 ns) but it needs a
// calibration to nanoseconds, it is only trustworthy when the CPU says
// constant_tsc + nonstop_tsc, and under a hypervisor it may be emulated or
// rescaled across live migration. CLOCK_MONOTONIC, read through the vDSO,
// already is the TSC (or kvm-clock) scaled by the kernel's calibration, never
// goes backwards, and is the clock clock_nanosleep(TIMER_ABSTIME) paces with,
// so a paced period's wake-up latency is measured on the same time base it was
// scheduled on (cyclictest does the same).
//
// Cost: one vDSO call when the clocksource is tsc or kvm-clock (about 20 to
// 30 ns on current x86 parts); a system call (about 0.5 to 1 us) when it is
// hpet or acpi_pm (measured: 22.6 ns per reading on the 2-core development
// VM, clocksource tsc, with other builds running). `clock_read_cost_ns()` measures it on this machine and
// `clocksource()` says which source the kernel uses; commands put both in
// their context so a slow clock is visible. Measure spans of at least a few
// microseconds with it, or batch many operations per reading.
#include <time.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "platform/statistics.hpp"

namespace lockstep::platform {

// Nanoseconds on CLOCK_MONOTONIC (since boot; only differences mean anything).
inline std::int64_t now_ns() noexcept {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

// The same instant as a timespec, for clock_nanosleep(CLOCK_MONOTONIC,
// TIMER_ABSTIME, ...).
inline timespec to_timespec(std::int64_t ns) noexcept {
  timespec when{};
  when.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  when.tv_nsec = static_cast<long>(ns % 1'000'000'000);
  return when;
}

// The median cost of one now_ns() call on this machine, from `rounds`
// back-to-back pairs of readings (median: robust against an interrupt).
inline double clock_read_cost_ns(int rounds = 1001) {
  std::vector<double> gaps;
  gaps.reserve(static_cast<std::size_t>(rounds));
  constexpr int kReadsPerRound = 16;  // amortises the loop and the final store
  for (int round = 0; round < rounds; ++round) {
    const std::int64_t start = now_ns();
    std::int64_t last = start;
    for (int read = 0; read < kReadsPerRound; ++read) last = now_ns();
    gaps.push_back(static_cast<double>(last - start));
  }
  return median(gaps) / kReadsPerRound;
}

// The kernel's current clocksource ("tsc", "kvm-clock", "hpet", ...), or
// "unavailable" when sysfs does not say.
inline std::string clocksource() {
  std::ifstream file("/sys/devices/system/clocksource/clocksource0/current_clocksource");
  std::string name;
  if (!(file >> name)) return "unavailable";
  return name;
}

}  // namespace lockstep::platform
