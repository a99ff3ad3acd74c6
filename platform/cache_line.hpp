#pragma once
// Cache-line constants used for every padding decision in lockstep.
//
// Named constants, not std::hardware_destructive_interference_size: GCC 12
// warns that its value may change with -mtune, and the suite measures 64 against
// 128 bytes instead of trusting one value (docs/design.md, Layouts).
#include <cstddef>

namespace lockstep::platform {

// The coherence unit on every x86-64 and most AArch64 parts.
inline constexpr std::size_t kCacheLine = 64;

// Adjacent-line (spatial) prefetchers on Intel cores pull lines in 128-byte
// pairs, so two writers 64 bytes apart can still interfere; 128 separates them.
inline constexpr std::size_t kPrefetchPair = 128;

static_assert((kCacheLine & (kCacheLine - 1)) == 0, "the cache line size must be a power of two");
static_assert(kPrefetchPair == 2 * kCacheLine, "a prefetch pair is two cache lines");

}  // namespace lockstep::platform
