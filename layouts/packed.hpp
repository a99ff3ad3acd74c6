#pragma once
// packed: the shared state and stage values in as few cache lines as
// possible — the false-sharing case (docs/design.md, Layouts).
//
// Slot-major: five arrays of n doubles one after the other, x_even, x_odd,
// k_0, k_1, k_2 (shared_slots.hpp says who writes and reads each). For the
// paper's four equations that is 160 bytes in three cache lines, and the
// values each stage publishes (one k array, 32 bytes) lie in one line written
// by all four threads: every publication invalidates every reader's copy.
// Nothing is padded; the buffer only starts on a line boundary, so that the
// count of lines is the minimum and does not depend on the allocator.
#include <cstddef>
#include <string_view>

#include "layouts/aligned_buffer.hpp"
#include "layouts/partition.hpp"
#include "layouts/shared_slots.hpp"
#include "platform/cache_line.hpp"

namespace lockstep::layouts {

// Byte offset of (slot, equation) in a packed layout of `equations` equations.
[[nodiscard]] constexpr std::size_t packed_offset(std::size_t equations, std::size_t slot,
                                                  std::size_t equation) noexcept {
  return (slot * equations + equation) * sizeof(double);
}

class packed {
 public:
  static constexpr std::string_view kName = "packed";
  static constexpr std::string_view kDescription =
      "state and stage values of every thread side by side in as few cache lines as possible (false sharing)";
  static constexpr layout_kind kKind = layout_kind::shared;
  static constexpr std::size_t kWriterIsolation = 0;  // writers share lines: what it measures

  explicit packed(const partition& blocks)
      : equations_(blocks.equations()), slots_(kSharedSlots * equations_, platform::kCacheLine) {}

  packed(const packed&) = delete;  // participants hold references into it
  packed& operator=(const packed&) = delete;

  // x_n of `equation` for step parity n & 1.
  [[nodiscard]] double& state(unsigned parity, std::size_t equation) noexcept {
    return slots_[state_slot(parity) * equations_ + equation];
  }
  // k_s of `equation`, s in 0..2.
  [[nodiscard]] double& stage(unsigned stage_index, std::size_t equation) noexcept {
    return slots_[stage_slot(stage_index) * equations_ + equation];
  }

  [[nodiscard]] std::size_t bytes() const noexcept { return slots_.size() * sizeof(double); }

 private:
  std::size_t equations_;
  aligned_buffer slots_;
};

// The proof for the paper's case (4 equations, 4 threads): 20 values, 160
// bytes, three lines; some line holds values of all four writers.
namespace packed_proof {
inline constexpr auto kOffset = [](std::size_t slot, std::size_t equation) {
  return packed_offset(4, slot, equation);
};
inline constexpr auto kOwner = [](std::size_t equation) { return owner_of(4, 4, equation, 1); };
static_assert(packed_offset(4, kSharedSlots - 1, 3) + sizeof(double) == 160,
              "packed holds the paper's 4 equations x 5 slots in 160 contiguous bytes");
static_assert(round_up(160, platform::kCacheLine) / platform::kCacheLine == 3,
              "packed: 160 bytes from a line boundary span the minimum of three lines");
static_assert(packed_offset(4, stage_slot(0), 0) / platform::kCacheLine ==
                  packed_offset(4, stage_slot(0), 3) / platform::kCacheLine,
              "packed: one stage's values of all four threads lie in one line (the false sharing it measures)");
static_assert(most_owners_in_a_block(kOffset, kOwner, 4, kSharedSlots, platform::kCacheLine, 4) == 4,
              "packed: some cache line is written by all four threads");
inline constexpr auto kChainOffset = [](std::size_t slot, std::size_t equation) {
  return packed_offset(10, slot, equation);
};
inline constexpr auto kChainOwner = [](std::size_t equation) { return owner_of(10, 2, equation, 2); };
static_assert(owner_blocks_contiguous(kOffset, kOwner, 4, kSharedSlots) &&
                  owner_blocks_contiguous(kChainOffset, kChainOwner, 10, kSharedSlots),
              "packed: each owner's block of a slot is one array (the paper's case; 5 masses on 2 threads)");
}  // namespace packed_proof

}  // namespace lockstep::layouts
