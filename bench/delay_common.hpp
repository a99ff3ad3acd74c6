#pragma once
// Shared by the delay commands (c2c, delay, falseshare, migrate): summaries of
// samples, the latency histogram, the result-file context, atomic JSON
// writes, CPU-list parsing.
//
// Percentiles here are nearest-rank: the p-quantile of n sorted samples is the
// sample at rank ceil(p * n) (1-based), so every reported value is a value
// that was measured, never an interpolation between two.
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "bench/command.hpp"
#include "bench/delay_topology.hpp"
#include "bench/version.hpp"

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

namespace lockstep::bench::delay {

// Nearest-rank percentile of sorted samples; p in [0, 1]. Empty input: NaN.
inline double percentile_sorted(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return std::nan("");
  const double rank = std::ceil(p * static_cast<double>(sorted.size()));
  const std::size_t index = rank < 1.0 ? 0 : static_cast<std::size_t>(rank) - 1;
  return sorted[std::min(index, sorted.size() - 1)];
}

struct summary {
  double min = 0;
  double p50 = 0;
  double p99 = 0;
  double p999 = 0;
  double max = 0;
  std::size_t count = 0;
};

inline summary summarize(std::vector<double> samples) {
  summary s;
  s.count = samples.size();
  if (samples.empty()) {
    s.min = s.p50 = s.p99 = s.p999 = s.max = std::nan("");
    return s;
  }
  std::sort(samples.begin(), samples.end());
  s.min = samples.front();
  s.max = samples.back();
  s.p50 = percentile_sorted(samples, 0.50);
  s.p99 = percentile_sorted(samples, 0.99);
  s.p999 = percentile_sorted(samples, 0.999);
  return s;
}

// NaN (no samples) becomes JSON null: a missing number is said, never faked.
inline nlohmann::json number_or_null(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

inline nlohmann::json to_json(const summary& s) {
  return {{"min", number_or_null(s.min)},   {"p50", number_or_null(s.p50)}, {"p99", number_or_null(s.p99)},
          {"p999", number_or_null(s.p999)}, {"max", number_or_null(s.max)}, {"count", s.count}};
}

// A histogram of non-negative nanosecond values with equal buckets
// [first + i * width, first + (i + 1) * width) that cover every sample: the
// width is the smallest 1-2-5 step (at least 1 ns) that fits min..max into
// at most max_buckets buckets.
struct histogram {
  std::int64_t bucket_ns = 1;
  std::int64_t first_ns = 0;
  std::vector<std::uint64_t> counts;

  static histogram of(const std::vector<double>& samples, std::size_t max_buckets = 60) {
    histogram h;
    if (samples.empty()) return h;
    const auto [lowest, highest] = std::minmax_element(samples.begin(), samples.end());
    const auto low = static_cast<std::int64_t>(std::floor(*lowest));
    const auto high = static_cast<std::int64_t>(std::floor(*highest));
    std::int64_t width = 1;
    for (std::int64_t decade = 1;; decade *= 10) {
      bool found = false;
      for (std::int64_t step : {1, 2, 5}) {
        width = step * decade;
        const std::int64_t first = low / width * width;
        if (static_cast<std::size_t>((high - first) / width + 1) <= max_buckets) {
          found = true;
          break;
        }
      }
      if (found) break;
    }
    h.bucket_ns = width;
    h.first_ns = low / width * width;
    h.counts.assign(static_cast<std::size_t>((high - h.first_ns) / width + 1), 0);
    for (double value : samples) {
      const auto v = static_cast<std::int64_t>(std::floor(value));
      ++h.counts[static_cast<std::size_t>((v - h.first_ns) / width)];
    }
    return h;
  }

  std::uint64_t total() const {
    std::uint64_t sum = 0;
    for (auto c : counts) sum += c;
    return sum;
  }

  nlohmann::json to_json() const { return {{"bucket_ns", bucket_ns}, {"first_ns", first_ns}, {"counts", counts}}; }

  // One line per bucket from the first to the last non-empty one, with a bar
  // scaled to the fullest bucket (a log scale would hide nothing but mislead).
  std::string text(int bar_width = 50) const {
    std::string out;
    std::uint64_t fullest = 0;
    for (auto c : counts) fullest = std::max(fullest, c);
    for (std::size_t i = 0; i < counts.size(); ++i) {
      const std::int64_t from = first_ns + static_cast<std::int64_t>(i) * bucket_ns;
      const int bar = fullest == 0 ? 0
                                   : static_cast<int>(std::ceil(static_cast<double>(counts[i]) * bar_width /
                                                                static_cast<double>(fullest)));
      out += fmt::format("  {:>10} .. {:<10} {:>9}  {}\n", from, from + bucket_ns, counts[i], std::string(static_cast<std::size_t>(bar), '#'));
    }
    return out;
  }
};

// Writes text to `path` atomically: a temporary file in the same directory,
// flushed and closed, then renamed over the target. A reader sees the old
// file or the whole new one. Throws usage_error when the directory is not
// writable (bad input: the user named the file).
inline void write_file_atomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw cli::usage_error("cannot write '" + path + "': the directory does not exist or is not writable");
    out << text;
    out.flush();
    if (!out) {
      std::remove(temporary.c_str());
      throw cli::usage_error("cannot write '" + path + "'");
    }
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const int error = errno;
    std::remove(temporary.c_str());
    throw cli::usage_error("cannot rename the result into '" + path + "': " + std::generic_category().message(error));
  }
}

// Fails early (before minutes of measurement) when the result file cannot be
// created where the user asked.
inline void check_writable(const std::string& path) {
  if (path.empty()) return;
  const std::string probe = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(probe, std::ios::binary | std::ios::trunc);
    if (!out) throw cli::usage_error("cannot write '" + path + "': the directory does not exist or is not writable");
  }
  std::remove(probe.c_str());
}

inline std::string read_first_line_with(const std::string& file, const std::string& key) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key, 0) == 0) {
      const auto colon = line.find(':');
      if (colon == std::string::npos) return {};
      auto value = line.substr(colon + 1);
      value.erase(0, value.find_first_not_of(" \t"));
      return value;
    }
  }
  return {};
}

// The hypervisor's vendor (CPUID leaf 0x40000000) or "none".
inline std::string hypervisor_name() {
#if defined(__x86_64__) || defined(__i386__)
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  if (__get_cpuid(1, &eax, &ebx, &ecx, &edx) == 0 || (ecx & (1u << 31)) == 0) return "none";
  __cpuid(0x40000000, eax, ebx, ecx, edx);
  char vendor[13] = {};
  std::memcpy(vendor + 0, &ebx, 4);
  std::memcpy(vendor + 4, &ecx, 4);
  std::memcpy(vendor + 8, &edx, 4);
  std::string name(vendor);
  if (name == "KVMKVMKVM") return "KVM";
  if (name == "Microsoft Hv") return "Hyper-V";
  if (name == "VMwareVMware") return "VMware";
  if (name == "XenVMMXenVMM") return "Xen";
  if (name == "TCGTCGTCGTCG") return "QEMU (TCG)";
  return name.empty() ? "unknown" : name;
#else
  return "unknown";
#endif
}

// The agreed context keys this command can know (all values strings).
inline nlohmann::json result_context(const topology_view& topology) {
  utsname names{};
  const std::string kernel = ::uname(&names) == 0 ? std::string(names.sysname) + " " + names.release : "unknown";
  std::string cpu_model = read_first_line_with("/proc/cpuinfo", "model name");
  if (cpu_model.empty()) cpu_model = "unknown";
  const topology_summary shape = topology.summary();
  return {{"lockstep_version", build_info::kVersion},
          {"lockstep_schema", std::to_string(build_info::kResultSchema)},
          {"git_revision", build_info::kGitRevision},
          {"compiler", build_info::kCompiler},
          {"cxx_flags", build_info::kCxxFlags},
          {"build_type", build_info::kBuildType},
          {"cpu_model", cpu_model},
          {"hypervisor", hypervisor_name()},
          {"kernel", kernel},
          {"topology", shape.text()},
          {"topology_packages", std::to_string(shape.packages)},
          {"topology_l3", std::to_string(shape.l3)},
          {"topology_cores", std::to_string(shape.cores)},
          {"topology_pus", std::to_string(shape.pus)},
          {"hwloc_version", hwloc_version_string()}};
}

// Parses "0,2,4-7" into CPU numbers (ascending, no duplicates); throws
// usage_error naming the bad piece.
inline std::vector<int> parse_cpu_list(const std::string& text, const std::string& option) {
  std::vector<int> cpus;
  std::stringstream pieces(text);
  std::string piece;
  auto number = [&](const std::string& digits) {
    if (digits.empty() || digits.size() > 6 || digits.find_first_not_of("0123456789") != std::string::npos)
      throw cli::usage_error(option + ": '" + piece + "' is not a CPU number or range (example: 0,2,4-7)");
    return std::stoi(digits);
  };
  while (std::getline(pieces, piece, ',')) {
    const auto dash = piece.find('-');
    if (dash == std::string::npos) {
      cpus.push_back(number(piece));
    } else {
      const int from = number(piece.substr(0, dash));
      const int to = number(piece.substr(dash + 1));
      if (to < from) throw cli::usage_error(option + ": range '" + piece + "' runs backwards");
      for (int cpu = from; cpu <= to; ++cpu) cpus.push_back(cpu);
    }
  }
  if (cpus.empty()) throw cli::usage_error(option + ": empty CPU list (example: 0,2,4-7)");
  std::sort(cpus.begin(), cpus.end());
  cpus.erase(std::unique(cpus.begin(), cpus.end()), cpus.end());
  return cpus;
}

// Keeps only the requested CPUs; every requested CPU must be usable.
inline std::vector<int> restrict_to(const std::vector<int>& usable, const std::vector<int>& requested,
                                    const std::string& option) {
  for (int cpu : requested)
    if (std::find(usable.begin(), usable.end(), cpu) == usable.end())
      throw cli::usage_error(option + ": CPU " + std::to_string(cpu) +
                             " is not usable here (offline, outside this process's affinity, or an SMT sibling "
                             "skipped without --smt)");
  return requested;
}

}  // namespace lockstep::bench::delay
