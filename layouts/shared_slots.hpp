#pragma once
// What the shared-memory layouts hold, and the contract every layout meets.
//
// The composed RK4 step (kernels/parallel_step.hpp) publishes, per equation i
// owned by a participant, and per step n:
//
//   stage values   k_{0,i}, k_{1,i}, k_{2,i}   written at stages 0..2 by the owner,
//                                              read at the next stage by the
//                                              participants whose equations read i
//   state          x_{n+1,i}                   written at stage 3 by the owner (the
//                                              update needs only its own k), read
//                                              from stage 0 of step n+1 on
//   k_{3,i} is never read by another participant and stays private.
//
// Two kinds of layout (layout_kind):
//
//  * shared (packed, padded64, padded128): the five slots below ARE the state.
//    Every participant reads its operands in place, its own and its
//    dependencies', and writes its results there. The state is double-buffered
//    by step parity: at stage 3 of step n the owner writes x_{n+1,i} while
//    consumers may still read x_{n,i} for their own stage-3 input; the other
//    buffer was last read at stage 3 of step n-1, before the stage-3 sync of
//    step n-1, so no read and write of one slot are ever unordered.
//    A stage slot k_{s,i} is written at stage s and read at stage s+1 of the
//    same step; the next write (stage s of step n+1) comes after the stage-s+1
//    sync of step n.
//
//  * private_copy (per_thread): every participant keeps a private copy of the
//    whole state and of k_0..k_3, and copies in what the others published
//    (the paper's `X1 = GX1`). See per_thread.hpp.
//
// Every layout keeps, in each slot, one owner's block of equations as one
// array: consecutive equations of a block at consecutive doubles
// (owner_blocks_contiguous below, proved by each layout's static_asserts and
// checked at run time by tests/matrix/layouts_test.cpp). The step reads and
// writes its own block through one pointer per slot, with no per-equation
// lookup (kernels/parallel_exchange.hpp); only the few values it reads from
// other owners go through the per-equation accessors.
#include <cstddef>
#include <string_view>

namespace lockstep::layouts {

enum class layout_kind { shared, private_copy };

// The slots one equation has in a shared layout, in the order of their index.
enum shared_slot : std::size_t {
  kStateEven = 0,  // x_n for even n
  kStateOdd = 1,   // x_n for odd n
  kStage0 = 2,     // k_0 (the first stage value); k_1 and k_2 follow
};
inline constexpr std::size_t kSharedStageSlots = 3;  // k_0, k_1, k_2 (k_3 stays private)
inline constexpr std::size_t kSharedSlots = 2 + kSharedStageSlots;

// Slot index of x_n: step parity picks the buffer.
[[nodiscard]] constexpr std::size_t state_slot(unsigned parity) noexcept { return kStateEven + (parity & 1U); }
// Slot index of k_s, s in 0..2.
[[nodiscard]] constexpr std::size_t stage_slot(unsigned stage) noexcept { return kStage0 + stage; }

// True when two different owners have a value in the same `unit`-byte block
// of a layout whose byte offset of (slot, equation) is `offset(slot, equation)`.
// Constexpr: the layouts run it in static_assert over the paper's case with
// the same offset function their accessors use.
template <class Offset, class Owner>
[[nodiscard]] constexpr bool owners_share_a_block(Offset offset, Owner owner, std::size_t equations,
                                                  std::size_t slots, std::size_t unit) {
  for (std::size_t a = 0; a < equations; ++a)
    for (std::size_t b = 0; b < equations; ++b) {
      if (owner(a) == owner(b)) continue;
      for (std::size_t slot_a = 0; slot_a < slots; ++slot_a)
        for (std::size_t slot_b = 0; slot_b < slots; ++slot_b)
          if (offset(slot_a, a) / unit == offset(slot_b, b) / unit) return true;
    }
  return false;
}

// True when, in every slot, each equation that has the same owner as the
// equation before it lies one double after that one: one owner's block of a
// slot is one array, in equation order.
template <class Offset, class Owner>
[[nodiscard]] constexpr bool owner_blocks_contiguous(Offset offset, Owner owner, std::size_t equations,
                                                     std::size_t slots) {
  for (std::size_t slot = 0; slot < slots; ++slot)
    for (std::size_t equation = 1; equation < equations; ++equation)
      if (owner(equation) == owner(equation - 1) &&
          offset(slot, equation) != offset(slot, equation - 1) + sizeof(double))
        return false;
  return true;
}

// The most owners that have a value in one `unit`-byte block.
template <class Offset, class Owner>
[[nodiscard]] constexpr unsigned most_owners_in_a_block(Offset offset, Owner owner, std::size_t equations,
                                                        std::size_t slots, std::size_t unit,
                                                        unsigned participants) {
  unsigned most = 0;
  std::size_t last_block = 0;
  for (std::size_t slot = 0; slot < slots; ++slot)
    for (std::size_t equation = 0; equation < equations; ++equation)
      if (offset(slot, equation) / unit > last_block) last_block = offset(slot, equation) / unit;
  for (std::size_t block = 0; block <= last_block; ++block) {
    unsigned owners = 0;
    for (unsigned participant = 0; participant < participants; ++participant) {
      bool present = false;
      for (std::size_t slot = 0; slot < slots; ++slot)
        for (std::size_t equation = 0; equation < equations; ++equation)
          if (owner(equation) == participant && offset(slot, equation) / unit == block) present = true;
      if (present) ++owners;
    }
    if (owners > most) most = owners;
  }
  return most;
}

}  // namespace lockstep::layouts
