// The machine's cache line (cache_line.hpp).
#include "platform/cache_line.hpp"

#include <unistd.h>

#include <fmt/core.h>

#include <filesystem>
#include <fstream>
#include <system_error>

namespace lockstep::platform {

namespace {

bool power_of_two(std::size_t value) { return value != 0 && (value & (value - 1)) == 0; }

}  // namespace

std::optional<std::size_t> widest_line_in_sysfs(const std::string& sysfs_root) {
  const std::filesystem::path caches = std::filesystem::path(sysfs_root) / "devices/system/cpu/cpu0/cache";
  std::error_code error;
  std::optional<std::size_t> widest;
  for (const auto& entry : std::filesystem::directory_iterator(caches, error)) {
    if (entry.path().filename().string().rfind("index", 0) != 0) continue;
    std::ifstream type_file(entry.path() / "type");
    std::string type;
    if (!(type_file >> type) || (type != "Data" && type != "Unified")) continue;
    std::ifstream size_file(entry.path() / "coherency_line_size");
    std::size_t bytes = 0;
    if (!(size_file >> bytes) || !power_of_two(bytes)) continue;
    if (!widest || bytes > *widest) widest = bytes;
  }
  return widest;
}

cache_line_reading machine_cache_line(const std::string& sysfs_root) {
  cache_line_reading reading;
  if (const auto widest = widest_line_in_sysfs(sysfs_root)) {
    reading.bytes = *widest;
    reading.from_machine = true;
    reading.source = "sysfs: the widest coherency_line_size of cpu0's data and unified caches";
    return reading;
  }
  const long level_one = ::sysconf(_SC_LEVEL1_DCACHE_LINESIZE);
  if (level_one > 0 && power_of_two(static_cast<std::size_t>(level_one))) {
    reading.bytes = static_cast<std::size_t>(level_one);
    reading.from_machine = true;
    reading.source = "sysconf(_SC_LEVEL1_DCACHE_LINESIZE) (sysfs lists no cache line)";
    return reading;
  }
  reading.source = fmt::format("assumed {} bytes: neither sysfs nor sysconf gives a line size", kCacheLine);
  return reading;
}

}  // namespace lockstep::platform
