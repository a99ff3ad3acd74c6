#pragma once
// Which participant owns which equations: the contiguous equation blocks of
// the composed RK4 step (kernels/parallel_step.hpp).
//
// n equations over T participants: participant p owns the contiguous block
// [first(p), last(p)). Blocks are cut in units of `grain` consecutive
// equations (the model's block_grain(), kernels/oscillator.hpp) whenever
// there are at least as many units as participants, and in single equations
// otherwise; blocks differ in size by at most one unit, the larger ones
// first.
//  * The paper's two masses (grain 1): 4 equations on 4 threads are one each
//    (the paper's case), on 2 threads {x1, x2} and {x3, x4}, on 3 threads
//    {x1, x2}, {x3}, {x4}, on 1 thread all four.
//  * An s-mass chain (grain 2: a mass's position and velocity, adjacent in the
//    chain's numbering) on T <= s threads: blocks of whole masses, s / T or
//    s / T + 1 each. Each participant computes its masses' positions and
//    velocities and reads, from other participants, only the position of the
//    mass just before its block and of the one just after (the velocity of
//    mass j reads positions j-1, j, j+1): its dependencies are its
//    neighbours' boundary positions, and a dataflow channel waits for its two
//    neighbours only. On s < T <= 2s threads (the chains beyond four threads
//    that model_for picks, one equation per thread) the blocks are single
//    equations as before: a mass's position and velocity may then have two
//    owners.
// Every participant owns at least one equation: more participants than
// equations is not a partition (partition_error says so).
//
// The block arithmetic is constexpr so that the layouts can prove their
// offsets with static_assert using the same functions the running code uses.
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

// Whether `equations` on `participants` are cut in units of `grain`: the
// grain divides the equations and there are at least as many units as
// participants (otherwise single equations).
[[nodiscard]] constexpr bool cut_by_grain(std::size_t equations, unsigned participants, std::size_t grain) noexcept {
  return grain > 1 && equations % grain == 0 && participants <= equations / grain;
}

// Block of participant `participant` when `equations` are cut into
// `participants` contiguous blocks of whole units of `grain` equations (the
// first units % participants blocks hold one unit more), or of single
// equations when cut_by_grain says no.
[[nodiscard]] constexpr equation_block block_of(std::size_t equations, unsigned participants, unsigned participant,
                                                std::size_t grain) noexcept {
  const std::size_t unit = cut_by_grain(equations, participants, grain) ? grain : 1;
  const std::size_t units = equations / unit;
  const std::size_t base = units / participants;
  const std::size_t larger = units % participants;
  const std::size_t first = participant * base + (participant < larger ? participant : larger);
  const std::size_t size = base + (participant < larger ? 1 : 0);
  return {first * unit, (first + size) * unit};
}

// The participant whose block holds `equation`.
[[nodiscard]] constexpr unsigned owner_of(std::size_t equations, unsigned participants, std::size_t equation,
                                          std::size_t grain) noexcept {
  unsigned participant = 0;
  while (!block_of(equations, participants, participant, grain).contains(equation)) ++participant;
  return participant;
}

// The largest block.
[[nodiscard]] constexpr std::size_t largest_block(std::size_t equations, unsigned participants,
                                                  std::size_t grain) noexcept {
  return block_of(equations, participants, 0, grain).size();
}

static_assert(block_of(4, 4, 3, 1).first == 3 && block_of(4, 4, 3, 1).size() == 1,
              "the paper's case: four threads own one equation each");
static_assert(block_of(4, 2, 0, 1).last == 2 && block_of(4, 2, 1, 1).first == 2,
              "two threads own {x1, x2} and {x3, x4}");
static_assert(block_of(6, 4, 0, 1).size() == 2 && block_of(6, 4, 3, 1).size() == 1 && block_of(6, 4, 3, 1).last == 6,
              "uneven blocks: the larger ones first, and the last block ends at the last equation");
static_assert(owner_of(6, 4, 5, 1) == 3 && owner_of(6, 4, 2, 1) == 1, "owner_of inverts block_of");
static_assert(block_of(10, 2, 0, 2).last == 6 && block_of(10, 2, 1, 2).first == 6,
              "a 5-mass chain on 2 threads: masses {1, 2, 3} and {4, 5}, never a mass cut in two");
static_assert(block_of(8, 3, 2, 2).first == 6 && block_of(8, 3, 2, 2).size() == 2,
              "a 4-mass chain on 3 threads: 2, 1 and 1 masses");
static_assert(block_of(6, 4, 2, 2).first == 4 && block_of(6, 4, 2, 2).size() == 1,
              "a 3-mass chain on 4 threads (more threads than masses): single equations");

// Thrown when equations cannot be cut into the asked number of blocks.
class partition_error : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// The blocks of every participant, checked once.
class partition {
 public:
  // Throws partition_error unless 1 <= participants <= equations and the
  // grain (1 by default: single equations) is at least 1 and divides the
  // equations.
  partition(std::size_t equations, unsigned participants, std::size_t grain = 1)
      : equations_(equations), participants_(participants), grain_(grain) {
    if (participants == 0) throw partition_error("a partition needs at least one participant");
    if (grain == 0 || equations % grain != 0)
      throw partition_error("a grain of " + std::to_string(grain) + " equations does not divide " +
                            std::to_string(equations) + " equations");
    if (participants > equations)
      throw partition_error(std::to_string(participants) + " threads but only " + std::to_string(equations) +
                            " equations: every thread must own at least one equation");
  }

  [[nodiscard]] std::size_t equations() const noexcept { return equations_; }
  [[nodiscard]] unsigned participants() const noexcept { return participants_; }
  // The model's grain (what the blocks are cut in when there are enough units).
  [[nodiscard]] std::size_t grain() const noexcept { return grain_; }
  // Whether the blocks are whole units of the grain (cut_by_grain).
  [[nodiscard]] bool by_grain() const noexcept { return cut_by_grain(equations_, participants_, grain_); }
  [[nodiscard]] equation_block block(unsigned participant) const noexcept {
    return block_of(equations_, participants_, participant, grain_);
  }
  [[nodiscard]] unsigned owner(std::size_t equation) const noexcept {
    return owner_of(equations_, participants_, equation, grain_);
  }
  [[nodiscard]] std::size_t largest_block() const noexcept {
    return layouts::largest_block(equations_, participants_, grain_);
  }

 private:
  std::size_t equations_;
  unsigned participants_;
  std::size_t grain_;
};

}  // namespace lockstep::layouts
