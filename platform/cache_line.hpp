#pragma once
// Cache lines: the sizes lockstep pads with (compile time), and the line of
// the machine it runs on (read at run time, recorded in every result's context).
//
// Named constants, not std::hardware_destructive_interference_size: GCC 12
// warns that its value may change with -mtune, and the suite measures 64 against
// 128 bytes instead of trusting one value (docs/design.md, Layouts).
//
// The machine's line (machine_cache_line): the widest coherency_line_size
// among cpu0's data and unified caches in sysfs
// (/sys/devices/system/cpu/cpu0/cache/index*/), which the kernel fills from
// CPUID leaf 4 on x86 and from the firmware's cache description (ACPI PPTT or
// the device tree) on arm64; else sysconf(_SC_LEVEL1_DCACHE_LINESIZE) where
// glibc answers it; else kCacheLine, said to be assumed. Why sysfs first: it
// names every level (a level with wider lines than L1 makes two writers share
// a line there, so the widest is the one that decides), it needs no loaded
// topology (hwloc reads the same files on Linux), and a test can hand it a
// fixture tree (the root path). Why the widest: a layout isolates writers
// only if it does at every level.
//
// A machine whose line is wider than kCacheLine (Apple M-series: 128 bytes;
// Fujitsu A64FX: 256) keeps the compiled padding: padded64's 64-byte blocks
// and the primitives' own 64-byte-aligned words then share lines there, and
// the layouts' writer-isolation facts are false on it. That is reported
// (layouts/registry.hpp: writer_isolation_note), not padded over.
#include <cstddef>
#include <optional>
#include <string>

namespace lockstep::platform {

// The coherence unit on every x86-64 and most AArch64 parts (Arm's Neoverse and
// Cortex cores, Ampere, AWS Graviton, Nvidia Grace): the alignment of every
// word a primitive keeps apart, and padded64's stride.
inline constexpr std::size_t kCacheLine = 64;

// Adjacent-line (spatial) prefetchers on Intel cores pull lines in 128-byte
// pairs, so two writers 64 bytes apart can still interfere; 128 separates them.
inline constexpr std::size_t kPrefetchPair = 128;

static_assert((kCacheLine & (kCacheLine - 1)) == 0, "the cache line size must be a power of two");
static_assert(kPrefetchPair == 2 * kCacheLine, "a prefetch pair is two cache lines");

// The machine's cache line and where the figure came from.
struct cache_line_reading {
  std::size_t bytes = kCacheLine;
  bool from_machine = false;  // false: kCacheLine, assumed
  std::string source;         // "sysfs: ...", "sysconf(...)" or why it is assumed
};

// The widest coherency_line_size among cpu0's data and unified caches under
// `sysfs_root` (the directory that holds devices/system/cpu), or nothing when
// no such cache lists a size that is a power of two.
std::optional<std::size_t> widest_line_in_sysfs(const std::string& sysfs_root = "/sys");

// The machine's line as the header describes (sysfs, sysconf, assumed).
cache_line_reading machine_cache_line(const std::string& sysfs_root = "/sys");

}  // namespace lockstep::platform
