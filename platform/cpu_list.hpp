#pragma once
// The kernel's CPU list format ("0-3,8,10-11"), as sysfs and procfs write it
// (/sys/devices/system/cpu/online, isolated, nohz_full; /proc/irq/N/
// smp_affinity_list): read and written in one place. An empty text is the
// empty list; "(null)" is what some kernels print for an unset mask
// (nohz_full), also the empty list. A CPU number above kMaxCpuNumber (the
// kernel's NR_CPUS is at most 8192) is not a CPU: the list is refused rather
// than expanded.
#include <algorithm>
#include <charconv>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/core.h>

namespace lockstep::platform {

inline constexpr unsigned kMaxCpuNumber = 65535;

// The CPUs of a list, sorted, each once; nullopt when the text is not a CPU
// list (a range that runs backwards, a word, a stray comma).
inline std::optional<std::vector<unsigned>> parse_cpu_list(std::string_view text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.remove_suffix(1);
  while (!text.empty() && text.front() == ' ') text.remove_prefix(1);
  std::vector<unsigned> cpus;
  if (text.empty() || text == "(null)") return cpus;
  const auto number = [](std::string_view digits) -> std::optional<unsigned> {
    unsigned value = 0;
    const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
    if (error != std::errc() || end != digits.data() + digits.size() || digits.empty()) return std::nullopt;
    return value;
  };
  while (true) {
    const std::size_t comma = text.find(',');
    const std::string_view item = text.substr(0, comma);
    const std::size_t dash = item.find('-');
    const auto first = number(item.substr(0, dash));
    const auto last = dash == std::string_view::npos ? first : number(item.substr(dash + 1));
    if (!first || !last || *last < *first || *last > kMaxCpuNumber) return std::nullopt;
    for (unsigned cpu = *first; cpu <= *last; ++cpu) cpus.push_back(cpu);
    if (comma == std::string_view::npos) break;
    text.remove_prefix(comma + 1);
  }
  std::sort(cpus.begin(), cpus.end());
  cpus.erase(std::unique(cpus.begin(), cpus.end()), cpus.end());
  return cpus;
}

// "0-3,8,10-11" from any list (sorted and made unique first); "" for none.
inline std::string format_cpu_list(std::vector<unsigned> cpus) {
  std::sort(cpus.begin(), cpus.end());
  cpus.erase(std::unique(cpus.begin(), cpus.end()), cpus.end());
  std::string text;
  for (std::size_t at = 0; at < cpus.size();) {
    std::size_t end = at;
    while (end + 1 < cpus.size() && cpus[end + 1] == cpus[end] + 1) ++end;
    if (!text.empty()) text += ',';
    text += end == at ? fmt::format("{}", cpus[at]) : fmt::format("{}-{}", cpus[at], cpus[end]);
    at = end + 1;
  }
  return text;
}

}  // namespace lockstep::platform
