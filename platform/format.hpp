#pragma once
// How lockstep writes a time for a person: the one nanosecond formatter of
// the C++ side, low enough that every folder (bench/, distributed/) prints
// with it. reports/lockstep_reports has its Python twin (compare.format_ns).
#include <fmt/core.h>

#include <string>

namespace lockstep::platform {

// "12.3 ns", "4.56 us", "7.89 ms".
inline std::string format_ns(double ns) {
  if (ns >= 1e6) return fmt::format("{:.2f} ms", ns / 1e6);
  if (ns >= 1e3) return fmt::format("{:.2f} us", ns / 1e3);
  return fmt::format("{:.1f} ns", ns);
}

}  // namespace lockstep::platform
