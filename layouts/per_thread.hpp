#pragma once
// per_thread: every participant keeps a private copy of the whole state and
// copies in what the others published — the paper's native model, where each
// worker first copies the shared values it reads into locals (`X1 = GX1`,
// docs/design.md, Layouts).
//
// Two kinds of storage:
//  * private copies, one per participant, each in its own allocation that
//    starts on a line boundary and fills whole lines: x[n] and k_0..k_3[n].
//    A participant computes only from its own copy and writes its own results
//    there; no other thread ever touches it.
//  * a publication board, written only by owners: per equation four slots,
//    k_0, k_1, k_2 (published at stages 0..2) and x_next (published at
//    stage 3), each owner's slots in a region of its own lines (as padded64,
//    so that per_thread measures the private copy, not false sharing). An
//    owner publishes there only the equations others read (its exports,
//    kernels/parallel_exchange.hpp): a chain cut between masses, its two
//    boundary positions.
// After every stage sync a participant copies in, from the board, the slots
// its equations read (its dependencies, nothing else) for that stage.
// One buffer per slot suffices: slot s is written at stage s and copied in
// right after the stage-s sync; its next write comes after the next stage's
// sync, by which time every consumer has copied it.
//
// With a dataflow primitive (seqlock, spsc_queue) the channel is the board:
// values travel from the owner's private copy through the channel straight
// into each consumer's private copy, and this layout's board stays unused.
#include <cstddef>
#include <string_view>
#include <vector>

#include "layouts/aligned_buffer.hpp"
#include "layouts/partition.hpp"
#include "layouts/shared_slots.hpp"
#include "platform/cache_line.hpp"

namespace lockstep::layouts {

inline constexpr std::size_t kBoardSlots = 4;        // k_0, k_1, k_2, x_next
inline constexpr std::size_t kBoardNextState = 3;    // slot index of x_next
inline constexpr std::size_t kPrivateStageValues = 4;  // k_0..k_3

// Byte offset of a board slot: each owner's region is whole lines.
[[nodiscard]] constexpr std::size_t board_region_bytes(std::size_t block_size) noexcept {
  return round_up(kBoardSlots * block_size * sizeof(double), platform::kCacheLine);
}
[[nodiscard]] constexpr std::size_t board_offset(std::size_t equations, unsigned participants, std::size_t grain,
                                                 std::size_t slot, std::size_t equation) noexcept {
  const unsigned owner = owner_of(equations, participants, equation, grain);
  const equation_block block = block_of(equations, participants, owner, grain);
  std::size_t region = 0;
  for (unsigned before = 0; before < owner; ++before)
    region += board_region_bytes(block_of(equations, participants, before, grain).size());
  return region + (slot * block.size() + (equation - block.first)) * sizeof(double);
}

class per_thread {
 public:
  static constexpr std::string_view kName = "per_thread";
  static constexpr std::string_view kDescription =
      "each thread computes from a private copy of the whole state and copies in what others published "
      "(the paper's X1 = GX1)";
  static constexpr layout_kind kKind = layout_kind::private_copy;
  // Board regions and private copies are whole lines of one writer (per_thread_proof).
  static constexpr std::size_t kWriterIsolation = platform::kCacheLine;

  explicit per_thread(const partition& blocks)
      : equations_(blocks.equations()),
        board_(board_total_bytes(blocks) / sizeof(double), platform::kCacheLine),
        board_index_(blocks.equations()),
        board_stride_(blocks.equations()) {
    for (std::size_t equation = 0; equation < equations_; ++equation) {
      const equation_block block = blocks.block(blocks.owner(equation));
      board_index_[equation] =
          board_offset(equations_, blocks.participants(), blocks.grain(), 0, equation) / sizeof(double);
      board_stride_[equation] = block.size();
    }
    copies_.reserve(blocks.participants());
    for (unsigned participant = 0; participant < blocks.participants(); ++participant)
      copies_.emplace_back((1 + kPrivateStageValues) * equations_, platform::kCacheLine);
  }

  per_thread(const per_thread&) = delete;  // participants hold references into it
  per_thread& operator=(const per_thread&) = delete;

  // The private copy of `participant`: x (n values), then k_0..k_3 (n each).
  [[nodiscard]] double* private_state(unsigned participant) noexcept { return copies_[participant].data(); }
  [[nodiscard]] double* private_stage(unsigned participant, unsigned stage_index) noexcept {
    return copies_[participant].data() + (1 + stage_index) * equations_;
  }

  // The board slot of `equation`: slot 0..2 = k_0..k_2, kBoardNextState = x_next.
  [[nodiscard]] double& board(std::size_t slot, std::size_t equation) noexcept {
    return board_[board_index_[equation] + slot * board_stride_[equation]];
  }

 private:
  static std::size_t board_total_bytes(const partition& blocks) noexcept {
    std::size_t bytes = 0;
    for (unsigned participant = 0; participant < blocks.participants(); ++participant)
      bytes += board_region_bytes(blocks.block(participant).size());
    return bytes;
  }

  std::size_t equations_;
  aligned_buffer board_;
  std::vector<std::size_t> board_index_;   // per equation: index of its k_0 slot on the board
  std::vector<std::size_t> board_stride_;  // per equation: its owner's block size (the slot stride)
  std::vector<aligned_buffer> copies_;     // one private copy per participant, each its own lines
};

namespace per_thread_proof {
template <std::size_t Equations, unsigned Participants, std::size_t Grain>
constexpr bool isolated() {
  constexpr auto offset = [](std::size_t slot, std::size_t equation) {
    return board_offset(Equations, Participants, Grain, slot, equation);
  };
  constexpr auto owner = [](std::size_t equation) { return owner_of(Equations, Participants, equation, Grain); };
  return !owners_share_a_block(offset, owner, Equations, kBoardSlots, platform::kCacheLine);
}
template <std::size_t Equations, unsigned Participants, std::size_t Grain>
constexpr bool contiguous() {
  constexpr auto offset = [](std::size_t slot, std::size_t equation) {
    return board_offset(Equations, Participants, Grain, slot, equation);
  };
  constexpr auto owner = [](std::size_t equation) { return owner_of(Equations, Participants, equation, Grain); };
  return owner_blocks_contiguous(offset, owner, Equations, kBoardSlots);
}
static_assert(contiguous<4, 2, 1>() && contiguous<10, 2, 2>(),
              "per_thread: each owner's block of a board slot is one array (private copies are whole arrays)");
static_assert(board_region_bytes(1) == platform::kCacheLine,
              "per_thread: one equation's four board slots (32 bytes) take one line of their own");
static_assert(board_offset(4, 4, 1, kBoardNextState, 2) == 2 * 64 + 3 * sizeof(double),
              "per_thread, paper's case: x_next of equation 2 is the fourth double of line 2");
static_assert(board_offset(10, 2, 2, 0, 6) == board_region_bytes(6),
              "per_thread, a 5-mass chain on 2 threads: the second owner's region starts after the first's 3 masses");
static_assert(isolated<4, 4, 1>() && isolated<4, 2, 1>() && isolated<6, 4, 1>() && isolated<10, 2, 2>() &&
                  isolated<8, 3, 2>(),
              "per_thread: no board line holds values of two writers, so only the copy-in differs from padded64");
}  // namespace per_thread_proof

}  // namespace lockstep::layouts
