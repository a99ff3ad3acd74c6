// The sampled stage-sync clock's split of each timed sync into waiting for
// others and release (kernels/parallel_step.hpp: stage_sync_time, split_sync,
// sync_clock<sampled>, waiting_ns_per_stage). Event-level facts only, never a
// timing: who waited for whom when one participant is made late, that the
// parts add up to the span, which syncs the memory ordering guarantees to be
// split, and that no figure comes out of too few samples.
#include <gtest/gtest.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <thread>
#include <vector>

#include "kernels/oscillator.hpp"
#include "kernels/parallel_step.hpp"
#include "layouts/padded.hpp"
#include "layouts/per_thread.hpp"
#include "sync/futex_spin.hpp"
#include "sync/seqlock.hpp"
#include "sync/std_barrier.hpp"
#include "tests/support/watchdog.hpp"

namespace lockstep::testing {
namespace {

constexpr double kStepSize = 1e-3;

// The paper's two masses, with equation 0 made late: its derivative sleeps
// first, so the participant that owns it (participant 0) arrives at every
// stage sync about `delay` after the others.
struct late_equation_model {
  kernels::two_mass_model masses{};
  std::chrono::microseconds delay{2000};

  [[nodiscard]] static constexpr std::size_t equations() noexcept { return kernels::two_mass_model::equations(); }
  [[nodiscard]] static constexpr std::size_t block_grain() noexcept { return kernels::two_mass_model::block_grain(); }
  template <kernels::stage_values Values>
  [[nodiscard]] double derivative(std::size_t equation, const Values& y) const {
    if (equation == 0) std::this_thread::sleep_for(delay);
    return masses.derivative(equation, y);
  }
  [[nodiscard]] static kernels::dependency_set dependencies(std::size_t equation) noexcept {
    return kernels::two_mass_model::dependencies(equation);
  }
  [[nodiscard]] std::vector<double> initial_state() const { return masses.initial_state(); }
  [[nodiscard]] double energy(std::span<const double> state) const noexcept { return masses.energy(state); }
};
static_assert(kernels::oscillator_model<late_equation_model>);

template <class Sync, class Layout>
using sampled_step = kernels::parallel_rk4<Sync, Layout, late_equation_model, kernels::sync_timing::sampled>;

TEST(SplitSync, ALastArrivalWaitedForNobody) {
  const kernels::sync_split split = kernels::split_sync(1000, 1300, 900);
  EXPECT_EQ(split.waiting, 0);
  EXPECT_EQ(split.release, 300);
}

TEST(SplitSync, AnEarlyArrivalWaitsUntilTheLatestAwaitedOne) {
  const kernels::sync_split split = kernels::split_sync(1000, 1300, 1250);
  EXPECT_EQ(split.waiting, 250);
  EXPECT_EQ(split.release, 50);
}

TEST(SplitSync, AnAwaitedStampAfterTheDepartureIsClippedToTheSpan) {
  const kernels::sync_split split = kernels::split_sync(1000, 1300, 1400);
  EXPECT_EQ(split.waiting, 300);
  EXPECT_EQ(split.release, 0);
}

TEST(SplitSync, WaitingAndReleaseAlwaysAddUpToTheSpan) {
  for (const std::int64_t latest : {0, 999, 1000, 1001, 1150, 1299, 1300, 1301, 5000}) {
    const kernels::sync_split split = kernels::split_sync(1000, 1300, latest);
    EXPECT_EQ(split.waiting + split.release, 300) << "latest awaited arrival " << latest;
    EXPECT_GE(split.waiting, 0);
    EXPECT_GE(split.release, 0);
  }
}

TEST(WaitingPerStage, NoFigureWithoutEnoughSplitSyncs) {
  EXPECT_FALSE(kernels::waiting_ns_per_stage(kernels::stage_sync_time{}).has_value());
  kernels::stage_sync_time few{};
  few.syncs = few.split_syncs = kernels::kMinSplitSyncs - 1;
  few.nanoseconds = few.split_nanoseconds = 1000;
  few.waiting_nanoseconds = 500;
  EXPECT_FALSE(kernels::waiting_ns_per_stage(few).has_value());
}

TEST(WaitingPerStage, NoFigureWhenTooManySyncsWereLeftUnsplit) {
  kernels::stage_sync_time skipped{};
  skipped.split_syncs = 80;
  skipped.unsplit_syncs = 20;
  skipped.syncs = 100;
  skipped.waiting_nanoseconds = 8000;
  EXPECT_FALSE(kernels::waiting_ns_per_stage(skipped).has_value());
  skipped.split_syncs = 90;
  skipped.unsplit_syncs = 10;
  ASSERT_TRUE(kernels::waiting_ns_per_stage(skipped).has_value());
  EXPECT_DOUBLE_EQ(*kernels::waiting_ns_per_stage(skipped), 8000.0 / 90.0);
}

TEST(StageSyncTime, SinceSubtractsEveryField) {
  kernels::stage_sync_time earlier{10, 2, 1, 9, 4, 1};
  kernels::stage_sync_time later = earlier;
  later += kernels::stage_sync_time{100, 8, 7, 90, 40, 1};
  const kernels::stage_sync_time delta = later.since(earlier);
  EXPECT_EQ(delta.nanoseconds, 100U);
  EXPECT_EQ(delta.syncs, 8U);
  EXPECT_EQ(delta.split_syncs, 7U);
  EXPECT_EQ(delta.split_nanoseconds, 90U);
  EXPECT_EQ(delta.waiting_nanoseconds, 40U);
  EXPECT_EQ(delta.unsplit_syncs, 1U);
}

// A barrier: every participant waits for every other. Participant 0 is late
// at every stage, so the others wait for it and it waits for nobody much.
// The barrier orders every stamp of a step before every departure of its
// last stage, so every timed sync is split and the split spans are the
// timed spans.
template <class Barrier>
void expect_others_wait_for_the_late_one(unsigned threads) {
  const watchdog guard(std::chrono::milliseconds(60'000 * kSlowdown), "a late-participant team did not finish");
  sampled_step<Barrier, layouts::padded64> step(late_equation_model{}, kStepSize, threads);
  step.set_sync_sample_period(1);  // every step sampled
  constexpr std::uint64_t kSteps = 6;
  kernels::run_team(step, kSteps);
  for (unsigned participant = 0; participant < threads; ++participant) {
    const kernels::stage_sync_time time = step.sync_time(participant);
    EXPECT_EQ(time.syncs, kSteps * kernels::kRk4Stages) << "participant " << participant;
    EXPECT_EQ(time.split_syncs, time.syncs) << "participant " << participant << ": a barrier's syncs are all split";
    EXPECT_EQ(time.unsplit_syncs, 0U) << "participant " << participant;
    EXPECT_EQ(time.split_nanoseconds, time.nanoseconds) << "participant " << participant;
    EXPECT_LE(time.waiting_nanoseconds, time.split_nanoseconds) << "participant " << participant;
  }
  const std::uint64_t late_waiting = step.sync_time(0).waiting_nanoseconds;
  for (unsigned participant = 1; participant < threads; ++participant)
    EXPECT_GT(step.sync_time(participant).waiting_nanoseconds, late_waiting)
        << "participant " << participant << " should have waited longer for participant 0 than 0 for anyone";
}

TEST(SampledSplit, TwoOnABarrierWaitForTheLateOne) { expect_others_wait_for_the_late_one<sync::futex_spin>(2); }
TEST(SampledSplit, FourOnABarrierWaitForTheLateOne) { expect_others_wait_for_the_late_one<sync::std_barrier>(4); }

// The sampled step's ordinal carries over from one call of run to the next
// (the harness's warm-up and timed batches), with a period that changes
// between them: the participants' stamps still match.
TEST(SampledSplit, TheOrdinalCarriesOverBetweenCalls) {
  const watchdog guard(std::chrono::milliseconds(60'000 * kSlowdown), "a sampled team did not finish");
  kernels::parallel_rk4<sync::futex_spin, layouts::padded64, kernels::two_mass_model, kernels::sync_timing::sampled>
      step(kernels::two_mass_model{}, kStepSize, 2);
  step.set_sync_sample_period(2);
  kernels::run_team(step, 7);  // samples steps 0, 2, 4, 6
  step.set_sync_sample_period(3);
  kernels::run_team(step, 8);  // samples steps 9, 12
  for (unsigned participant = 0; participant < 2; ++participant) {
    const kernels::stage_sync_time time = step.sync_time(participant);
    EXPECT_EQ(time.syncs, 6U * kernels::kRk4Stages) << "participant " << participant;
    EXPECT_EQ(time.split_syncs, time.syncs) << "participant " << participant;
  }
}

// A channel: participant 1 of two waits only for its producer, participant
// 0, which is late. A producer's stamps of stages 0-2 are ordered before its
// consumer's end of step by its next publish; stage 3's may be read too early
// and is then left unsplit, counted, never guessed.
TEST(SampledSplit, AChannelConsumerWaitsForItsLateProducer) {
  const watchdog guard(std::chrono::milliseconds(60'000 * kSlowdown), "a late-producer team did not finish");
  sampled_step<sync::seqlock, layouts::per_thread> step(late_equation_model{}, kStepSize, 2);
  ASSERT_EQ(step.plan_of(1).producers, (std::vector<unsigned>{0}));
  step.set_sync_sample_period(1);
  constexpr std::uint64_t kSteps = 6;
  kernels::run_team(step, kSteps);
  for (unsigned participant = 0; participant < 2; ++participant) {
    const kernels::stage_sync_time time = step.sync_time(participant);
    EXPECT_EQ(time.syncs, kSteps * kernels::kRk4Stages) << "participant " << participant;
    EXPECT_EQ(time.split_syncs + time.unsplit_syncs, time.syncs) << "participant " << participant;
    EXPECT_GE(time.split_syncs, kSteps * (kernels::kRk4Stages - 1)) << "participant " << participant;
    EXPECT_LE(time.waiting_nanoseconds, time.split_nanoseconds) << "participant " << participant;
  }
  EXPECT_GT(step.sync_time(1).waiting_nanoseconds, step.sync_time(0).waiting_nanoseconds);
}

TEST(SampledSplit, OffAndOnSplitNothing) {
  const watchdog guard(std::chrono::milliseconds(60'000 * kSlowdown), "an unsampled team did not finish");
  kernels::parallel_rk4<sync::futex_spin, layouts::padded64> off(kernels::two_mass_model{}, kStepSize, 2);
  kernels::run_team(off, 10);
  EXPECT_EQ(off.sync_time().split_syncs + off.sync_time().unsplit_syncs, 0U);
  kernels::parallel_rk4<sync::futex_spin, layouts::padded64, kernels::two_mass_model, kernels::sync_timing::on> on(
      kernels::two_mass_model{}, kStepSize, 2);
  kernels::run_team(on, 10);
  EXPECT_EQ(on.sync_time().syncs, 2U * 10U * kernels::kRk4Stages);
  EXPECT_EQ(on.sync_time().split_syncs + on.sync_time().unsplit_syncs, 0U);
  EXPECT_FALSE(kernels::waiting_ns_per_stage(on.sync_time()).has_value());
}

}  // namespace
}  // namespace lockstep::testing
