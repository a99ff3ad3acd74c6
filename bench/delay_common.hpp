#pragma once
// Shared by the delay commands (c2c, delay, falseshare, migrate): samples and
// histograms as the agreed JSON (the arithmetic is platform/stats.hpp), the
// result-file context, atomic JSON writes, CPU-list parsing and choice.
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <span>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "bench/command.hpp"
#include "platform/stats.hpp"
#include "platform/topology.hpp"
#include "bench/version.hpp"

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

namespace lockstep::bench::delay {

// A distribution as the agreed JSON object {min, p50, p99, p999, max, count};
// no samples -> every statistic null and count 0 (a missing number is said,
// never faked).
inline nlohmann::json distribution_json(const std::vector<double>& samples) {
  if (samples.empty())
    return {{"min", nullptr}, {"p50", nullptr}, {"p99", nullptr}, {"p999", nullptr}, {"max", nullptr}, {"count", 0}};
  const platform::distribution d = platform::summarize(samples);
  return {{"min", d.min}, {"p50", d.p50}, {"p99", d.p99}, {"p999", d.p999}, {"max", d.max}, {"count", d.count}};
}

// The histogram of these samples (round bucket widths covering min..max, see
// platform/stats.hpp), every sample added.
inline platform::histogram histogram_of(const std::vector<double>& samples, std::size_t max_buckets = 50) {
  platform::histogram h = platform::histogram::covering(std::span<const double>(samples), max_buckets);
  for (double sample : samples) h.add(sample);
  return h;
}

// The agreed JSON form {bucket_ns, first_ns, counts}; samples outside the
// buckets (none, for histogram_of) would be in below/above.
inline nlohmann::json histogram_json(const platform::histogram& h) {
  return {{"bucket_ns", h.bucket_ns()}, {"first_ns", h.first_ns()}, {"counts", h.counts()},
          {"below", h.below()},         {"above", h.above()}};
}

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
inline nlohmann::json result_context(const platform::topology& machine) {
  utsname names{};
  const std::string kernel = ::uname(&names) == 0 ? std::string(names.sysname) + " " + names.release : "unknown";
  std::string cpu_model = read_first_line_with("/proc/cpuinfo", "model name");
  if (cpu_model.empty()) cpu_model = "unknown";

  return {{"lockstep_version", build_info::kVersion},
          {"lockstep_schema", std::to_string(build_info::kResultSchema)},
          {"git_revision", build_info::kGitRevision},
          {"compiler", build_info::kCompiler},
          {"cxx_flags", build_info::kCxxFlags},
          {"build_type", build_info::kBuildType},
          {"cpu_model", cpu_model},
          {"hypervisor", hypervisor_name()},
          {"kernel", kernel},
          {"topology", machine.summary()},
          {"topology_packages", std::to_string(machine.packages())},
          {"topology_l3", std::to_string(machine.l3_domains())},
          {"topology_cores", std::to_string(machine.core_count())},
          {"topology_pus", std::to_string(machine.pu_count())},
          {"hwloc_version", machine.hwloc_version()}};
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

// The CPUs (OS indices, ascending) of the affinity set, one PU per core
// unless include_smt_siblings.
inline std::vector<int> usable_cpus(const platform::topology& machine, bool include_smt_siblings) {
  std::vector<int> cpus;
  std::vector<unsigned> cores_seen;
  for (unsigned cpu : machine.affinity()) {
    const unsigned core = machine.pu(cpu).core;
    if (!include_smt_siblings && std::find(cores_seen.begin(), cores_seen.end(), core) != cores_seen.end()) continue;
    cores_seen.push_back(core);
    cpus.push_back(static_cast<int>(cpu));
  }
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
