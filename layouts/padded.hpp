#pragma once
// padded64, padded128: what each thread writes sits in blocks of its own
// (docs/design.md, Layouts).
//
// The names are strides, fixed at compile time and proved below: padded64's
// blocks are 64 bytes, padded128's 128, whatever the machine. Each keeps
// writers on lines of their own only where the machine's cache line is no
// wider than its stride (64 bytes on x86-64 and most AArch64 parts; 128 on
// Apple M-series, 256 on Fujitsu A64FX): kWriterIsolation states the stride,
// and a run compares it with the line it reads from the machine
// (platform::machine_cache_line; layouts/registry.hpp: writer_isolation_note)
// and says so where a layout's isolation does not hold.
//
// Each participant owns one region that starts on a `Pad`-byte boundary and
// fills whole `Pad`-byte blocks; inside it, its equations' five slots
// (shared_slots.hpp) slot-major: x_even[b], x_odd[b], k_0[b], k_1[b], k_2[b]
// for its b equations. No block holds values of two writers, so a
// publication invalidates only the lines its readers need.
//   padded64  = padded<kPadded64Stride>:  64-byte blocks, one 64-byte line per writer at least.
//   padded128 = padded<kPadded128Stride>: 128-byte blocks: whole 64-byte line pairs, because
//               the adjacent-line prefetcher pulls 64-byte lines in pairs and can
//               make two writers 64 bytes apart interfere anyway.
// The strides are the named constants of platform/cache_line.hpp (kCacheLine,
// kPrefetchPair), never std::hardware_destructive_interference_size (see there why).
//
// Access costs one table lookup (the region of the equation's owner) more
// than packed; the tables are written once and only read afterwards.
#include <cstddef>
#include <string_view>
#include <vector>

#include "layouts/aligned_buffer.hpp"
#include "layouts/partition.hpp"
#include "layouts/shared_slots.hpp"
#include "platform/cache_line.hpp"

namespace lockstep::layouts {

// The padded layouts' strides, by the names the layouts carry.
inline constexpr std::size_t kPadded64Stride = platform::kCacheLine;
inline constexpr std::size_t kPadded128Stride = platform::kPrefetchPair;
static_assert(kPadded64Stride == 64, "padded64's blocks are 64 bytes: the name says so");
static_assert(kPadded128Stride == 128, "padded128's blocks are 128 bytes: the name says so");

// Bytes of the region of a participant that owns `block_size` equations.
[[nodiscard]] constexpr std::size_t padded_region_bytes(std::size_t block_size, std::size_t pad) noexcept {
  return round_up(kSharedSlots * block_size * sizeof(double), pad);
}

// Byte offset of the region of `participant`.
[[nodiscard]] constexpr std::size_t padded_region_offset(std::size_t equations, unsigned participants,
                                                         std::size_t grain, std::size_t pad,
                                                         unsigned participant) noexcept {
  std::size_t offset = 0;
  for (unsigned before = 0; before < participant; ++before)
    offset += padded_region_bytes(block_of(equations, participants, before, grain).size(), pad);
  return offset;
}

// Byte offset of (slot, equation).
[[nodiscard]] constexpr std::size_t padded_offset(std::size_t equations, unsigned participants, std::size_t grain,
                                                  std::size_t pad, std::size_t slot, std::size_t equation) noexcept {
  const unsigned owner = owner_of(equations, participants, equation, grain);
  const equation_block block = block_of(equations, participants, owner, grain);
  return padded_region_offset(equations, participants, grain, pad, owner) +
         (slot * block.size() + (equation - block.first)) * sizeof(double);
}

template <std::size_t Pad>
class padded {
  static_assert(Pad == kPadded64Stride || Pad == kPadded128Stride,
                "padded is measured at the two named strides, 64 and 128 bytes (platform/cache_line.hpp)");
  static_assert(Pad % sizeof(double) == 0, "a region must hold whole doubles");

 public:
  static constexpr std::size_t kPad = Pad;
  static constexpr std::string_view kName = Pad == kPadded64Stride ? "padded64" : "padded128";
  static constexpr std::string_view kDescription =
      Pad == kPadded64Stride
          ? "what each thread writes on cache lines of its own (64-byte blocks)"
          : "what each thread writes on 128-byte line pairs of its own (adjacent-line prefetch)";
  static constexpr layout_kind kKind = layout_kind::shared;
  // Proved below (padded_proof); isolates writers where the line is at most Pad.
  static constexpr std::size_t kWriterIsolation = Pad;

  explicit padded(const partition& blocks)
      : slots_(padded_region_offset(blocks.equations(), blocks.participants(), blocks.grain(), Pad,
                                    blocks.participants()) /
                   sizeof(double),
               Pad),
        region_(blocks.equations()),
        block_size_(blocks.equations()) {
    for (std::size_t equation = 0; equation < blocks.equations(); ++equation) {
      const unsigned owner = blocks.owner(equation);
      const equation_block block = blocks.block(owner);
      region_[equation] =
          padded_region_offset(blocks.equations(), blocks.participants(), blocks.grain(), Pad, owner) /
              sizeof(double) +
          (equation - block.first);
      block_size_[equation] = block.size();
    }
  }

  padded(const padded&) = delete;  // participants hold references into it
  padded& operator=(const padded&) = delete;

  [[nodiscard]] double& state(unsigned parity, std::size_t equation) noexcept {
    return slots_[region_[equation] + state_slot(parity) * block_size_[equation]];
  }
  [[nodiscard]] double& stage(unsigned stage_index, std::size_t equation) noexcept {
    return slots_[region_[equation] + stage_slot(stage_index) * block_size_[equation]];
  }

  [[nodiscard]] std::size_t bytes() const noexcept { return slots_.size() * sizeof(double); }

 private:
  aligned_buffer slots_;
  std::vector<std::size_t> region_;      // per equation: index of its slot 0 (owner's region + place in block)
  std::vector<std::size_t> block_size_;  // per equation: its owner's block size (the slot stride)
};

using padded64 = padded<kPadded64Stride>;
using padded128 = padded<kPadded128Stride>;
static_assert(padded64::kWriterIsolation == 64 && padded128::kWriterIsolation == 128,
              "each padded layout states its stride as its writer isolation");

// Proofs, with the offset function the constructor uses: no block of Pad
// bytes holds values of two owners, for the paper's case (4 equations on 4
// and 2 threads) and an uneven chain (6 equations on 4 threads).
namespace padded_proof {
template <std::size_t Equations, unsigned Participants, std::size_t Grain, std::size_t Pad>
constexpr bool isolated() {
  constexpr auto offset = [](std::size_t slot, std::size_t equation) {
    return padded_offset(Equations, Participants, Grain, Pad, slot, equation);
  };
  constexpr auto owner = [](std::size_t equation) { return owner_of(Equations, Participants, equation, Grain); };
  return !owners_share_a_block(offset, owner, Equations, kSharedSlots, Pad);
}
template <std::size_t Equations, unsigned Participants, std::size_t Grain, std::size_t Pad>
constexpr bool contiguous() {
  constexpr auto offset = [](std::size_t slot, std::size_t equation) {
    return padded_offset(Equations, Participants, Grain, Pad, slot, equation);
  };
  constexpr auto owner = [](std::size_t equation) { return owner_of(Equations, Participants, equation, Grain); };
  return owner_blocks_contiguous(offset, owner, Equations, kSharedSlots);
}
static_assert(padded_region_bytes(1, kPadded64Stride) == 64,
              "padded64: one equation's five slots (40 bytes) round up to one line");
static_assert(padded_region_bytes(2, kPadded64Stride) == 128,
              "padded64: two equations' ten slots (80 bytes) round up to two lines");
static_assert(padded_region_bytes(1, kPadded128Stride) == 128,
              "padded128: one equation's slots take a whole line pair");
static_assert(padded_region_offset(4, 4, 1, kPadded64Stride, 3) == 3 * 64,
              "padded64, paper's case: thread p's region starts on line p");
static_assert(padded_offset(4, 4, 1, kPadded128Stride, stage_slot(2), 1) == 128 + 4 * sizeof(double),
              "padded128: k_2 of equation 1 is the fifth double of the second line pair");
static_assert(padded_offset(10, 2, 2, kPadded64Stride, stage_slot(0), 7) ==
                  padded_region_bytes(6, kPadded64Stride) + (stage_slot(0) * 4 + 1) * sizeof(double),
              "padded64, a 5-mass chain on 2 threads: k_0 of equation 7 (mass 4's velocity) is its owner's second");
static_assert(isolated<4, 4, 1, kPadded64Stride>(), "padded64: no line holds two writers (4 on 4)");
static_assert(isolated<4, 2, 1, kPadded64Stride>(), "padded64: no line holds two writers (4 on 2)");
static_assert(isolated<6, 4, 1, kPadded64Stride>(), "padded64: no line holds two writers (6 on 4)");
static_assert(isolated<10, 2, 2, kPadded64Stride>(), "padded64: no line holds two writers (5 masses on 2)");
static_assert(isolated<4, 4, 1, kPadded128Stride>(), "padded128: no line pair holds two writers (4 on 4)");
static_assert(isolated<6, 4, 1, kPadded128Stride>(), "padded128: no line pair holds two writers (6 on 4)");
static_assert(isolated<8, 3, 2, kPadded128Stride>(), "padded128: no line pair holds two writers (4 masses on 3)");
static_assert(contiguous<4, 2, 1, kPadded64Stride>() && contiguous<6, 4, 1, kPadded128Stride>() &&
                  contiguous<10, 2, 2, kPadded64Stride>(),
              "padded: each owner's block of a slot is one array");
}  // namespace padded_proof

}  // namespace lockstep::layouts
