// The bitwise oracle (matrix_cases.hpp, expect_bitwise_serial) against
// primitives with a known fault (tests/support/faulty_primitives.hpp): the
// composed RK4 step on each faulty one must leave the serial trajectory, and
// the oracle must say so; on the same primitive without its fault it must
// stay bitwise serial, so that the failure is the fault's.
//
// What each fault does to the step, and what catches it (the oracle's one
// check: the state after a segment equals the serial staged RK4's bit for bit):
//  * a barrier that releases at N - 1 arrivals (packed, in place; per_thread,
//    copied in): the others compute stage 2 from the last participant's k_1
//    before it has written it;
//  * a channel that publishes a stage's flag before its values: every
//    consumer reads values two stages old (NaN at first);
//  * a channel whose consumer reads the other slot of its ring: the values of
//    the neighbouring stage.
// Not under the sanitizers: the faults are data races by design.
#include <gtest/gtest-spi.h>

#include "layouts/packed.hpp"
#include "layouts/per_thread.hpp"
#include "tests/matrix/matrix_cases.hpp"
#include "tests/support/faulty_primitives.hpp"

namespace lockstep::testing::matrix {
namespace {

using faulty::barrier_fault;
using faulty::channel_fault;
using faulty::counting_barrier;
using faulty::stage_channel;

// 30 steps: the segments are 1, 10 and 19 steps, each checked.
constexpr std::uint64_t kSteps = 30;

template <class Sync, class Layout>
void two_mass_on(unsigned threads) {
  expect_bitwise_serial<Sync, Layout>(kernels::two_mass_model{}, threads, placement::none, kSteps);
}

// EXPECT_FATAL_FAILURE takes a statement that names no local variable.
void early_release_packed() { two_mass_on<counting_barrier<barrier_fault::early_release>, layouts::packed>(2); }
void early_release_per_thread() {
  two_mass_on<counting_barrier<barrier_fault::early_release>, layouts::per_thread>(4);
}
void flag_before_data() { two_mass_on<stage_channel<channel_fault::flag_before_data>, layouts::per_thread>(2); }
void stage_swap() { two_mass_on<stage_channel<channel_fault::stage_swap>, layouts::per_thread>(4); }

constexpr const char* kCaught = "after 1 steps the trajectory is not bitwise serial";

TEST(BitwisePositiveControl, TheFaultFreePrimitivesStayBitwiseSerial) {
  two_mass_on<counting_barrier<barrier_fault::none>, layouts::packed>(2);
  two_mass_on<counting_barrier<barrier_fault::none>, layouts::per_thread>(4);
  two_mass_on<stage_channel<channel_fault::none>, layouts::per_thread>(2);
  two_mass_on<stage_channel<channel_fault::none>, layouts::per_thread>(4);
}

TEST(BitwiseNegativeControl, ReleaseAtNMinusOneArrivalsLeavesTheSerialTrajectory) {
  EXPECT_FATAL_FAILURE(early_release_packed(), kCaught);
  EXPECT_FATAL_FAILURE(early_release_per_thread(), kCaught);
}

TEST(BitwiseNegativeControl, FlagBeforeDataLeavesTheSerialTrajectory) {
  EXPECT_FATAL_FAILURE(flag_before_data(), kCaught);
}

TEST(BitwiseNegativeControl, ASwappedStageLeavesTheSerialTrajectory) { EXPECT_FATAL_FAILURE(stage_swap(), kCaught); }

}  // namespace
}  // namespace lockstep::testing::matrix
