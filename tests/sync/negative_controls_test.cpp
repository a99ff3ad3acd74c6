// The conformance oracle (conformance.hpp) against primitives with a known
// fault (tests/support/faulty_primitives.hpp): each faulty one must fail, and
// the test names the check that catches it; the same primitive without its
// fault must pass, so that the failure is the fault's. A check removed from
// the oracle, or weakened so that it no longer sees the fault, fails one of
// these tests.
//
// Which check catches which fault:
//  * a barrier that releases at N - 1 arrivals: the phase invariant's arrival
//    count (its first check; the record check would catch it next);
//  * a channel that publishes a stage's flag before its values, or reads the
//    values of another stage: channel_barrier's own check of the token it
//    receives (sync/channel_barrier.hpp), which ends the process. The phase
//    invariant alone cannot see either: both still order the arrivals.
// Not under the sanitizers: the faults are data races by design.
#include <gtest/gtest-spi.h>

#include "tests/support/faulty_primitives.hpp"
#include "tests/sync/conformance.hpp"

namespace lockstep::sync::testing {
namespace {

using lockstep::testing::faulty::barrier_fault;
using lockstep::testing::faulty::channel_fault;
using lockstep::testing::faulty::counting_barrier;
using lockstep::testing::faulty::stage_channel;

// EXPECT_NONFATAL_FAILURE and EXPECT_DEATH take a statement that names no
// local variable: the scenarios are functions.
void four_participants_early_release() {
  run_conformance<counting_barrier<barrier_fault::early_release>>({.participants = 4});
}
void four_participants_flag_before_data() {
  run_conformance<stage_channel<channel_fault::flag_before_data>>({.participants = 4});
}
void four_participants_stage_swap() {
  run_conformance<stage_channel<channel_fault::stage_swap>>({.participants = 4});
}

TEST(ConformancePositiveControl, TheFaultFreeBarrierPasses) {
  run_conformance<counting_barrier<barrier_fault::none>>({.participants = 4});
  run_conformance<counting_barrier<barrier_fault::none>>({.participants = 8, .delay = delays::random});
}

TEST(ConformancePositiveControl, TheFaultFreeChannelPasses) {
  run_conformance<stage_channel<channel_fault::none>>({.participants = 4});
  run_conformance<stage_channel<channel_fault::none>>({.participants = 8, .delay = delays::random});
}

TEST(ConformanceNegativeControl, ReleaseAtNMinusOneArrivalsFailsTheArrivalCount) {
  EXPECT_NONFATAL_FAILURE(four_participants_early_release(), "before every participant arrived (arrival count)");
}

TEST(ConformanceNegativeControl, FlagBeforeDataFailsChannelBarriersTokenCheck) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(four_participants_flag_before_data(), "channel_barrier<flag_before_data>: phase 0 received nan");
}

TEST(ConformanceNegativeControl, ASwappedStageFailsChannelBarriersTokenCheck) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(four_participants_stage_swap(), "channel_barrier<stage_swap>: phase 0 received (nan|1) from producer");
}

}  // namespace
}  // namespace lockstep::sync::testing
