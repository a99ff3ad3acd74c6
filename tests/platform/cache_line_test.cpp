// The machine's cache line (platform/cache_line.hpp) from sysfs trees built
// here: the widest line of cpu0's data and unified caches decides; an
// instruction cache, a missing tree and unreadable sizes do not.
#include "platform/cache_line.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/scratch_directory.hpp"

namespace {

using lockstep::platform::machine_cache_line;
using lockstep::platform::widest_line_in_sysfs;
using lockstep::testing::scratch_directory;

// Writes cpu0's cache `index` under `root`, as the kernel lists it.
void add_cache(const std::filesystem::path& root, int index, const std::string& type, const std::string& line) {
  const std::filesystem::path directory = root / "devices/system/cpu/cpu0/cache" / ("index" + std::to_string(index));
  std::filesystem::create_directories(directory);
  std::ofstream(directory / "type") << type << "\n";
  std::ofstream(directory / "coherency_line_size") << line << "\n";
}

TEST(CacheLine, AnX86MachineHas64ByteLines) {
  scratch_directory root("lockstep-cache-line");
  add_cache(root.path(), 0, "Data", "64");
  add_cache(root.path(), 1, "Instruction", "64");
  add_cache(root.path(), 2, "Unified", "64");
  add_cache(root.path(), 3, "Unified", "64");
  EXPECT_EQ(widest_line_in_sysfs(root.path().string()), 64U);
  const auto reading = machine_cache_line(root.path().string());
  EXPECT_EQ(reading.bytes, 64U);
  EXPECT_TRUE(reading.from_machine);
  EXPECT_NE(reading.source.find("sysfs"), std::string::npos) << reading.source;
}

// Apple M-series: 128-byte lines, wider than padded64's stride.
TEST(CacheLine, A128ByteLineIsRead) {
  scratch_directory root("lockstep-cache-line");
  add_cache(root.path(), 0, "Data", "128");
  add_cache(root.path(), 1, "Instruction", "128");
  add_cache(root.path(), 2, "Unified", "128");
  EXPECT_EQ(machine_cache_line(root.path().string()).bytes, 128U);
}

TEST(CacheLine, TheWidestDataOrUnifiedLevelDecides) {
  scratch_directory root("lockstep-cache-line");
  add_cache(root.path(), 0, "Data", "64");
  add_cache(root.path(), 1, "Instruction", "256");  // not where writers' data lives
  add_cache(root.path(), 2, "Unified", "128");
  EXPECT_EQ(widest_line_in_sysfs(root.path().string()), 128U);
}

TEST(CacheLine, SizesThatAreNotPowersOfTwoAreIgnored) {
  scratch_directory root("lockstep-cache-line");
  add_cache(root.path(), 0, "Data", "0");
  add_cache(root.path(), 1, "Unified", "96");
  add_cache(root.path(), 2, "Unified", "lots");
  EXPECT_FALSE(widest_line_in_sysfs(root.path().string()).has_value());
}

// No sysfs tree: sysconf answers, or kCacheLine is assumed and said to be.
TEST(CacheLine, WithoutSysfsTheLineComesFromSysconfOrIsAssumed) {
  scratch_directory root("lockstep-cache-line");
  EXPECT_FALSE(widest_line_in_sysfs(root.path().string()).has_value());
  const auto reading = machine_cache_line(root.path().string());
  EXPECT_EQ(reading.bytes & (reading.bytes - 1), 0U) << reading.bytes;
  if (reading.from_machine) {
    EXPECT_NE(reading.source.find("sysconf"), std::string::npos) << reading.source;
  } else {
    EXPECT_EQ(reading.bytes, lockstep::platform::kCacheLine);
    EXPECT_NE(reading.source.find("assumed"), std::string::npos) << reading.source;
  }
}

}  // namespace
