#pragma once
// Which participant owns which equations: the contiguous equation blocks of
// the composed RK4 step (kernels/parallel_step.hpp).
//
// n equations over T participants: participant p owns the contiguous block
// [first(p), last(p)). Blocks differ in size by at most one equation, the
// larger ones first: 4 equations on 4 threads are one each (the paper's
// case), on 2 threads {x1, x2} and {x3, x4}, on 1 thread all four; an s-mass
// chain (2s equations, positions then velocities) is cut the same way.
// Every participant owns at least one equation: more participants than
// equations is not a partition (partition_error says so).
//
// The block arithmetic is constexpr so that the layouts can prove their
// offsets for the paper's case with static_assert using the same functions
// the running code uses.
#include <cstddef>
#include <stdexcept>
#include <string>

namespace lockstep::layouts {

// [first, last): the equations one participant owns.
struct equation_block {
  std::size_t first = 0;
  std::size_t last = 0;

  [[nodiscard]] constexpr std::size_t size() const noexcept { return last - first; }
  [[nodiscard]] constexpr bool contains(std::size_t equation) const noexcept {
    return equation >= first && equation < last;
  }
};

// Block of participant `participant` when `equations` are cut into
// `participants` contiguous blocks (the first equations % participants blocks
// hold one equation more).
[[nodiscard]] constexpr equation_block block_of(std::size_t equations, unsigned participants,
                                                unsigned participant) noexcept {
  const std::size_t base = equations / participants;
  const std::size_t larger = equations % participants;
  const std::size_t first = participant * base + (participant < larger ? participant : larger);
  const std::size_t size = base + (participant < larger ? 1 : 0);
  return {first, first + size};
}

// The participant whose block holds `equation`.
[[nodiscard]] constexpr unsigned owner_of(std::size_t equations, unsigned participants,
                                          std::size_t equation) noexcept {
  unsigned participant = 0;
  while (!block_of(equations, participants, participant).contains(equation)) ++participant;
  return participant;
}

// The largest block: what a channel must carry per producer and stage.
[[nodiscard]] constexpr std::size_t largest_block(std::size_t equations, unsigned participants) noexcept {
  return block_of(equations, participants, 0).size();
}

static_assert(block_of(4, 4, 3).first == 3 && block_of(4, 4, 3).size() == 1,
              "the paper's case: four threads own one equation each");
static_assert(block_of(4, 2, 0).last == 2 && block_of(4, 2, 1).first == 2,
              "two threads own {x1, x2} and {x3, x4}");
static_assert(block_of(6, 4, 0).size() == 2 && block_of(6, 4, 3).size() == 1 && block_of(6, 4, 3).last == 6,
              "uneven blocks: the larger ones first, and the last block ends at the last equation");
static_assert(owner_of(6, 4, 5) == 3 && owner_of(6, 4, 2) == 1, "owner_of inverts block_of");

// Thrown when equations cannot be cut into the asked number of blocks.
class partition_error : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// The blocks of every participant, checked once.
class partition {
 public:
  // Throws partition_error unless 1 <= participants <= equations.
  partition(std::size_t equations, unsigned participants) : equations_(equations), participants_(participants) {
    if (participants == 0) throw partition_error("a partition needs at least one participant");
    if (participants > equations)
      throw partition_error(std::to_string(participants) + " threads but only " + std::to_string(equations) +
                            " equations: every thread must own at least one equation");
  }

  [[nodiscard]] std::size_t equations() const noexcept { return equations_; }
  [[nodiscard]] unsigned participants() const noexcept { return participants_; }
  [[nodiscard]] equation_block block(unsigned participant) const noexcept {
    return block_of(equations_, participants_, participant);
  }
  [[nodiscard]] unsigned owner(std::size_t equation) const noexcept {
    return owner_of(equations_, participants_, equation);
  }
  [[nodiscard]] std::size_t largest_block() const noexcept { return layouts::largest_block(equations_, participants_); }

 private:
  std::size_t equations_;
  unsigned participants_;
};

}  // namespace lockstep::layouts
