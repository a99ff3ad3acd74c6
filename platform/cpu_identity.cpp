// The CPU's name (cpu_identity.hpp).
#include "platform/cpu_identity.hpp"

#include <fmt/core.h>

#include <array>
#include <charconv>
#include <cstdint>
#include <fstream>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

namespace lockstep::platform {

namespace {

struct implementer_name {
  unsigned implementer;
  std::string_view name;
};
struct core_name {
  unsigned implementer;
  unsigned part;
  std::string_view name;
};

// MIDR_EL1's implementer codes and part numbers, from the Linux kernel's
// arch/arm64/include/asm/cputype.h (ARM_CPU_IMP_*, *_CPU_PART_*), but Neoverse
// E1 (0xd4a, from Arm's Neoverse E1 technical reference manual). Qualcomm's
// Kryo 5XX and later report Arm's part numbers (the kernel's notes there),
// and so do the cloud parts built on Arm's cores (the header lists them).
constexpr std::array kImplementers{
    implementer_name{0x41, "Arm"},      implementer_name{0x42, "Broadcom"},  implementer_name{0x43, "Cavium"},
    implementer_name{0x46, "Fujitsu"},  implementer_name{0x48, "HiSilicon"}, implementer_name{0x4e, "Nvidia"},
    implementer_name{0x50, "APM"},      implementer_name{0x51, "Qualcomm"},  implementer_name{0x61, "Apple"},
    implementer_name{0x6d, "Microsoft"}, implementer_name{0xc0, "Ampere"},
};

constexpr std::array kCores{
    core_name{0x41, 0xd03, "Cortex-A53"},     core_name{0x41, 0xd04, "Cortex-A35"},
    core_name{0x41, 0xd05, "Cortex-A55"},     core_name{0x41, 0xd07, "Cortex-A57"},
    core_name{0x41, 0xd08, "Cortex-A72"},     core_name{0x41, 0xd09, "Cortex-A73"},
    core_name{0x41, 0xd0a, "Cortex-A75"},     core_name{0x41, 0xd0b, "Cortex-A76"},
    core_name{0x41, 0xd0c, "Neoverse N1"},    core_name{0x41, 0xd0d, "Cortex-A77"},
    core_name{0x41, 0xd0e, "Cortex-A76AE"},   core_name{0x41, 0xd40, "Neoverse V1"},
    core_name{0x41, 0xd41, "Cortex-A78"},     core_name{0x41, 0xd42, "Cortex-A78AE"},
    core_name{0x41, 0xd44, "Cortex-X1"},      core_name{0x41, 0xd46, "Cortex-A510"},
    core_name{0x41, 0xd47, "Cortex-A710"},    core_name{0x41, 0xd48, "Cortex-X2"},
    core_name{0x41, 0xd49, "Neoverse N2"},    core_name{0x41, 0xd4a, "Neoverse E1"},
    core_name{0x41, 0xd4b, "Cortex-A78C"},    core_name{0x41, 0xd4c, "Cortex-X1C"},
    core_name{0x41, 0xd4d, "Cortex-A715"},    core_name{0x41, 0xd4e, "Cortex-X3"},
    core_name{0x41, 0xd4f, "Neoverse V2"},    core_name{0x41, 0xd80, "Cortex-A520"},
    core_name{0x41, 0xd81, "Cortex-A720"},    core_name{0x41, 0xd82, "Cortex-X4"},
    core_name{0x41, 0xd84, "Neoverse V3"},    core_name{0x41, 0xd85, "Cortex-X925"},
    core_name{0x41, 0xd87, "Cortex-A725"},    core_name{0x41, 0xd8e, "Neoverse N3"},
    core_name{0x42, 0x100, "Brahma-B53"},     core_name{0x42, 0x516, "Vulcan"},
    core_name{0x43, 0x0a1, "ThunderX"},       core_name{0x43, 0x0a2, "ThunderX 81XX"},
    core_name{0x43, 0x0a3, "ThunderX 83XX"},  core_name{0x43, 0x0af, "ThunderX2"},
    core_name{0x43, 0x0b1, "OcteonTX2 98XX"}, core_name{0x43, 0x0b2, "OcteonTX2 96XX"},
    core_name{0x43, 0x0b3, "OcteonTX2 95XX"}, core_name{0x43, 0x0b4, "OcteonTX2 95XXN"},
    core_name{0x43, 0x0b5, "OcteonTX2 95XXMM"}, core_name{0x43, 0x0b6, "OcteonTX2 95XXO"},
    core_name{0x46, 0x001, "A64FX"},          core_name{0x48, 0xd01, "TSV110 (Kunpeng 920)"},
    core_name{0x48, 0xd02, "HIP09"},          core_name{0x48, 0xd06, "HIP12"},
    core_name{0x4e, 0x003, "Denver"},         core_name{0x4e, 0x004, "Carmel"},
    core_name{0x50, 0x000, "X-Gene"},         core_name{0x51, 0x001, "Oryon X1"},
    core_name{0x51, 0x200, "Kryo"},           core_name{0x51, 0x800, "Kryo 2XX Gold or Falkor V1"},
    core_name{0x51, 0x801, "Kryo 2XX Silver"}, core_name{0x51, 0x802, "Kryo 3XX Gold"},
    core_name{0x51, 0x803, "Kryo 3XX Silver"}, core_name{0x51, 0x804, "Kryo 4XX Gold"},
    core_name{0x51, 0x805, "Kryo 4XX Silver"}, core_name{0x51, 0xc00, "Falkor"},
    core_name{0x61, 0x022, "M1 Icestorm"},    core_name{0x61, 0x023, "M1 Firestorm"},
    core_name{0x61, 0x024, "M1 Pro Icestorm"}, core_name{0x61, 0x025, "M1 Pro Firestorm"},
    core_name{0x61, 0x028, "M1 Max Icestorm"}, core_name{0x61, 0x029, "M1 Max Firestorm"},
    core_name{0x61, 0x032, "M2 Blizzard"},    core_name{0x61, 0x033, "M2 Avalanche"},
    core_name{0x61, 0x034, "M2 Pro Blizzard"}, core_name{0x61, 0x035, "M2 Pro Avalanche"},
    core_name{0x61, 0x038, "M2 Max Blizzard"}, core_name{0x61, 0x039, "M2 Max Avalanche"},
    core_name{0x6d, 0xd49, "Azure Cobalt 100"}, core_name{0xc0, 0xac3, "Ampere-1"},
    core_name{0xc0, 0xac4, "Ampere-1A"},
};

// "  CPU part\t: 0xd0c" -> ("CPU part", "0xd0c"); nothing without a colon.
std::optional<std::pair<std::string_view, std::string_view>> split_field(std::string_view line) {
  const std::size_t colon = line.find(':');
  if (colon == std::string_view::npos) return std::nullopt;
  const auto trim = [](std::string_view text) {
    const std::size_t first = text.find_first_not_of(" \t");
    if (first == std::string_view::npos) return std::string_view();
    const std::size_t last = text.find_last_not_of(" \t\r");
    return text.substr(first, last - first + 1);
  };
  return std::pair{trim(line.substr(0, colon)), trim(line.substr(colon + 1))};
}

// "0x41" (or "41") as a number; nothing when it is not hexadecimal.
std::optional<unsigned> hexadecimal(std::string_view text) {
  if (text.rfind("0x", 0) == 0 || text.rfind("0X", 0) == 0) text.remove_prefix(2);
  unsigned value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value, 16);
  if (error != std::errc() || end != text.data() + text.size() || text.empty()) return std::nullopt;
  return value;
}

struct core_kind {
  unsigned implementer;
  unsigned part;
  unsigned cpus;
};

// Each CPU's (implementer, part), grouped by kind in the order kinds appear.
std::vector<core_kind> arm_core_kinds(std::string_view cpuinfo) {
  constexpr unsigned kUnread = ~0u;  // no implementer (or part) read for this CPU: neither is 32 bits wide
  std::vector<core_kind> kinds;
  unsigned implementer = kUnread;
  std::istringstream lines{std::string(cpuinfo)};
  std::string line;
  while (std::getline(lines, line)) {
    const auto field = split_field(line);
    if (!field) continue;
    if (field->first == "processor") implementer = kUnread;
    if (field->first == "CPU implementer") implementer = hexadecimal(field->second).value_or(kUnread);
    if (field->first != "CPU part" || implementer == kUnread) continue;
    const unsigned part = hexadecimal(field->second).value_or(kUnread);
    if (part == kUnread) continue;
    bool counted = false;
    for (core_kind& kind : kinds)
      if (kind.implementer == implementer && kind.part == part) {
        ++kind.cpus;
        counted = true;
      }
    if (!counted) kinds.push_back({implementer, part, 1});
    implementer = kUnread;
  }
  return kinds;
}

std::optional<std::string> model_name(std::string_view cpuinfo) {
  std::istringstream lines{std::string(cpuinfo)};
  std::string line;
  while (std::getline(lines, line)) {
    const auto field = split_field(line);
    if (field && field->first == "model name" && !field->second.empty()) return std::string(field->second);
  }
  return std::nullopt;
}

}  // namespace

std::string arm_core_name(unsigned implementer, unsigned part) {
  for (const core_name& core : kCores)
    if (core.implementer == implementer && core.part == part)
      for (const implementer_name& maker : kImplementers)
        if (maker.implementer == implementer) return fmt::format("{} {}", maker.name, core.name);
  return fmt::format("implementer {:#04x} part {:#05x}", implementer, part);
}

std::string cpu_model_of_cpuinfo(std::string_view cpuinfo) {
  const std::vector<core_kind> kinds = arm_core_kinds(cpuinfo);
  if (kinds.size() == 1) return arm_core_name(kinds.front().implementer, kinds.front().part);
  if (kinds.size() > 1) {
    std::string names;
    for (const core_kind& kind : kinds)
      names += fmt::format("{}{} x {}", names.empty() ? "" : " + ", kind.cpus, arm_core_name(kind.implementer, kind.part));
    return names;
  }
  return model_name(cpuinfo).value_or("unavailable");
}

std::string cpu_model() {
  std::ifstream file("/proc/cpuinfo");
  if (!file) return "unavailable";
  std::ostringstream text;
  text << file.rdbuf();
  return cpu_model_of_cpuinfo(text.str());
}

}  // namespace lockstep::platform
