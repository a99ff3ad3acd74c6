// The layouts at run time: every slot has its own address, the blocks the
// static_asserts promise hold for the sizes the matrix runs (not only the
// paper's case), and owners never share a block where a layout says so.
#include <cstdint>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "layouts/layouts.hpp"

namespace lockstep::layouts {
namespace {

std::uintptr_t address(const double& value) { return reinterpret_cast<std::uintptr_t>(&value); }

// Every (slot, equation) of a shared layout: its address and its owner.
struct placed {
  std::uintptr_t address;
  unsigned owner;
};

template <class Layout>
std::vector<placed> shared_slots_of(Layout& layout, const partition& blocks) {
  std::vector<placed> result;
  for (std::size_t equation = 0; equation < blocks.equations(); ++equation) {
    const unsigned owner = blocks.owner(equation);
    result.push_back({address(layout.state(0, equation)), owner});
    result.push_back({address(layout.state(1, equation)), owner});
    for (unsigned stage = 0; stage < kSharedStageSlots; ++stage)
      result.push_back({address(layout.stage(stage, equation)), owner});
  }
  return result;
}

bool owners_share(const std::vector<placed>& slots, std::size_t unit) {
  for (const placed& a : slots)
    for (const placed& b : slots)
      if (a.owner != b.owner && a.address / unit == b.address / unit) return true;
  return false;
}

std::size_t distinct(const std::vector<placed>& slots) {
  std::set<std::uintptr_t> addresses;
  for (const placed& slot : slots) addresses.insert(slot.address);
  return addresses.size();
}

struct shape {
  std::size_t equations;
  unsigned participants;
};
constexpr shape kShapes[] = {{4, 1}, {4, 2}, {4, 4}, {6, 4}, {10, 3}, {16, 4}};

TEST(Partition, BlocksCoverEveryEquationOnceInOrder) {
  for (const shape& each : kShapes) {
    const partition blocks(each.equations, each.participants);
    std::size_t next = 0;
    for (unsigned participant = 0; participant < each.participants; ++participant) {
      const equation_block block = blocks.block(participant);
      EXPECT_EQ(block.first, next);
      EXPECT_GE(block.size(), 1U);
      EXPECT_LE(block.size(), blocks.largest_block());
      for (std::size_t equation = block.first; equation < block.last; ++equation)
        EXPECT_EQ(blocks.owner(equation), participant);
      next = block.last;
    }
    EXPECT_EQ(next, each.equations);
  }
}

TEST(Partition, RejectsMoreThreadsThanEquationsWithAReason) {
  EXPECT_THROW(partition(4, 0), partition_error);
  try {
    partition(4, 5);
    FAIL() << "5 threads over 4 equations must be rejected";
  } catch (const partition_error& error) {
    EXPECT_NE(std::string(error.what()).find("every thread must own at least one equation"), std::string::npos);
  }
}

TEST(Packed, EverySlotDistinctAndContiguous) {
  for (const shape& each : kShapes) {
    const partition blocks(each.equations, each.participants);
    packed layout(blocks);
    const auto slots = shared_slots_of(layout, blocks);
    EXPECT_EQ(distinct(slots), kSharedSlots * each.equations);
    EXPECT_EQ(layout.bytes(), kSharedSlots * each.equations * sizeof(double)) << "packed has no padding";
    EXPECT_EQ(address(layout.state(0, 0)) % platform::kCacheLine, 0U) << "packed starts on a line boundary";
  }
}

template <class Layout>
void expect_isolated_blocks() {
  for (const shape& each : kShapes) {
    const partition blocks(each.equations, each.participants);
    Layout layout(blocks);
    const auto slots = shared_slots_of(layout, blocks);
    EXPECT_EQ(distinct(slots), kSharedSlots * each.equations);
    EXPECT_FALSE(owners_share(slots, Layout::kPad))
        << Layout::kName << ": two writers share a " << Layout::kPad << "-byte block with " << each.equations
        << " equations on " << each.participants << " threads";
    EXPECT_EQ(address(layout.state(0, 0)) % Layout::kPad, 0U);
  }
}

TEST(Padded64, NoLineHoldsTwoWriters) { expect_isolated_blocks<padded64>(); }
TEST(Padded128, NoLinePairHoldsTwoWriters) { expect_isolated_blocks<padded128>(); }

TEST(PerThread, PrivateCopiesAndBoardAreSeparate) {
  for (const shape& each : kShapes) {
    const partition blocks(each.equations, each.participants);
    per_thread layout(blocks);
    std::vector<placed> board;
    for (std::size_t equation = 0; equation < each.equations; ++equation)
      for (std::size_t slot = 0; slot < kBoardSlots; ++slot)
        board.push_back({address(layout.board(slot, equation)), blocks.owner(equation)});
    EXPECT_EQ(distinct(board), kBoardSlots * each.equations);
    EXPECT_FALSE(owners_share(board, platform::kCacheLine)) << "board lines are one writer's each";
    // Private copies: each participant's x and k_0..k_3 on lines no one else has.
    std::vector<placed> copies;
    for (unsigned participant = 0; participant < each.participants; ++participant) {
      for (std::size_t equation = 0; equation < each.equations; ++equation) {
        copies.push_back({address(layout.private_state(participant)[equation]), participant});
        for (unsigned stage = 0; stage < kPrivateStageValues; ++stage)
          copies.push_back({address(layout.private_stage(participant, stage)[equation]), participant});
      }
    }
    EXPECT_EQ(distinct(copies), (1 + kPrivateStageValues) * each.equations * each.participants);
    EXPECT_FALSE(owners_share(copies, platform::kCacheLine)) << "private copies never share a line";
    for (const placed& copy : copies)
      for (const placed& slot : board)
        EXPECT_NE(copy.address / platform::kCacheLine, slot.address / platform::kCacheLine)
            << "a private copy shares a line with the board";
  }
}

}  // namespace
}  // namespace lockstep::layouts
