// The composed step's contract beyond bitwise determinism: who depends on
// whom, applicability, the bounded run's agreed stop, the sync-time
// instrumentation, and constructor arguments reaching the primitive.
#include <algorithm>
#include <atomic>
#include <barrier>
#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "sync/registry.hpp"
#include "tests/matrix/matrix_cases.hpp"
#include "tests/support/faulty_primitives.hpp"

namespace lockstep::testing::matrix {
namespace {

using std::chrono::steady_clock;

TEST(StepPlan, ThePapersFourThreadsWaitOnlyForTheirDependencies) {
  kernels::parallel_rk4<sync::seqlock, layouts::per_thread> step(kernels::two_mass_model{}, kStepSize, 4);
  // D1 <- x3, D2 <- x4, D3 <- x1, x2, D4 <- x1, x2.
  EXPECT_EQ(step.plan_of(0).producers, (std::vector<unsigned>{2}));
  EXPECT_EQ(step.plan_of(1).producers, (std::vector<unsigned>{3}));
  EXPECT_EQ(step.plan_of(2).producers, (std::vector<unsigned>{0, 1}));
  EXPECT_EQ(step.plan_of(3).producers, (std::vector<unsigned>{0, 1}));
  for (unsigned participant = 0; participant < 4; ++participant) EXPECT_TRUE(step.plan_of(participant).has_consumers);
  // From participant 0: 2 and 3 read it (one stage), 1 reads 3 (two stages).
  // The farthest is 2 stages: a stop is set ceil(2 / 4) + 1 = 2 steps ahead.
  EXPECT_EQ(step.stop_margin_steps(), 2U);
}

TEST(StepPlan, TwoThreadsOwnPositionsAndVelocities) {
  kernels::parallel_rk4<sync::std_barrier, layouts::padded64> step(kernels::two_mass_model{}, kStepSize, 2);
  EXPECT_EQ(step.plan_of(0).dependencies, (std::vector<std::size_t>{2, 3}));
  EXPECT_EQ(step.plan_of(1).dependencies, (std::vector<std::size_t>{0, 1}));
  EXPECT_EQ(step.plan_of(0).producers, (std::vector<unsigned>{1}));
}

// The paper's split stays one equation at a time on 1..4 threads: the same
// blocks as before chains were cut between masses, and every block's values
// go whole to the others (each is read by another thread).
TEST(StepPlan, ThePapersSplitIsOneEquationAtATime) {
  const kernels::two_mass_model model;
  const std::vector<std::vector<std::size_t>> firsts{{0}, {0, 2}, {0, 2, 3}, {0, 1, 2, 3}};
  for (unsigned threads = 1; threads <= 4; ++threads) {
    const layouts::partition blocks = kernels::partition_of(model, threads);
    const std::vector<kernels::participant_plan> plans = kernels::plan_participants(model, blocks);
    for (unsigned participant = 0; participant < threads; ++participant) {
      const kernels::participant_plan& plan = plans[participant];
      EXPECT_EQ(plan.block.first, firsts[threads - 1][participant]) << threads << " threads";
      if (threads == 1) {
        EXPECT_EQ(plan.own_reads.first, 0U);
        EXPECT_EQ(plan.own_reads.last, 4U);
        EXPECT_TRUE(plan.exports.empty());
        EXPECT_FALSE(plan.has_consumers);
        continue;
      }
      EXPECT_EQ(plan.own_reads.size(), 0U) << "on 2..4 threads every equation reads only other threads' values";
      std::vector<std::size_t> whole_block;
      for (std::size_t equation = plan.block.first; equation < plan.block.last; ++equation)
        whole_block.push_back(equation);
      EXPECT_EQ(plan.exports, whole_block) << threads << " threads, participant " << participant;
      EXPECT_TRUE(plan.exports_contiguous);
    }
  }
}

// A chain on T <= S threads: blocks of whole masses (sizes differing by one
// mass at most, the larger first), every equation owned once, each block
// reading only the positions just outside it, from its neighbours only, and
// giving them only its two boundary positions.
TEST(StepPlan, AChainIsCutBetweenMassesAndReadsOnlyItsNeighboursBoundaries) {
  for (const std::size_t masses : {1U, 2U, 3U, 5U, 8U, 33U, 4096U})
    for (unsigned threads = 1; threads <= std::min<std::size_t>(masses, 6); ++threads) {
      const kernels::chain_model chain(kernels::chain_params::uniform(masses));
      const layouts::partition blocks = kernels::partition_of(chain, threads);
      ASSERT_TRUE(blocks.by_grain()) << masses << " masses on " << threads;
      const std::vector<kernels::participant_plan> plans = kernels::plan_participants(chain, blocks);
      std::vector<unsigned> owners(chain.equations(), threads);
      std::size_t next = 0;
      for (unsigned participant = 0; participant < threads; ++participant) {
        const std::string where = std::to_string(masses) + " masses, participant " + std::to_string(participant) +
                                  " of " + std::to_string(threads);
        const kernels::participant_plan& plan = plans[participant];
        const layouts::equation_block block = plan.block;
        EXPECT_EQ(block.first, next) << where;
        next = block.last;
        EXPECT_EQ(block.first % 2, 0U) << where << ": the block starts on a position";
        EXPECT_EQ(block.size() % 2, 0U) << where << ": whole masses";
        const std::size_t block_masses = block.size() / 2;
        EXPECT_TRUE(block_masses == masses / threads || block_masses == masses / threads + 1) << where;
        EXPECT_EQ(block_masses == masses / threads + 1, participant < masses % threads) << where << ": larger first";
        for (std::size_t equation = block.first; equation < block.last; ++equation) {
          EXPECT_EQ(owners[equation], threads) << "equation " << equation << " owned twice";
          owners[equation] = participant;
        }
        // Its dependencies: the position before its first mass and after its last.
        std::vector<std::size_t> boundaries;
        std::vector<unsigned> neighbours;
        std::vector<std::size_t> exports;
        if (participant > 0) {
          boundaries.push_back(block.first - 2);
          neighbours.push_back(participant - 1);
          exports.push_back(block.first);
        }
        if (participant + 1 < threads) {
          boundaries.push_back(block.last);
          neighbours.push_back(participant + 1);
          if (exports.empty() || exports.back() != block.last - 2) exports.push_back(block.last - 2);
        }
        EXPECT_EQ(plan.dependencies, boundaries) << where;
        EXPECT_EQ(plan.producers, neighbours) << where;
        EXPECT_EQ(plan.exports, exports) << where;
        EXPECT_EQ(plan.has_consumers, threads > 1) << where;
        EXPECT_EQ(plan.own_reads.first, block.first) << where << ": its equations read all of its block";
        EXPECT_EQ(plan.own_reads.last, block.last) << where;
      }
      EXPECT_EQ(next, chain.equations());
      EXPECT_EQ(std::count(owners.begin(), owners.end(), threads), 0) << "an equation nobody owns";
    }
}

// S < T <= 2S (the chains beyond four threads, one equation each): single
// equations, every one owned once; a participant still waits only for the
// owners of the masses next to its own.
TEST(StepPlan, MoreThreadsThanMassesSplitsEquations) {
  for (const std::size_t masses : {2U, 3U, 4U, 8U})
    for (unsigned threads = static_cast<unsigned>(masses) + 1; threads <= 2 * masses; ++threads) {
      const kernels::chain_model chain(kernels::chain_params::uniform(masses));
      const layouts::partition blocks = kernels::partition_of(chain, threads);
      EXPECT_FALSE(blocks.by_grain());
      const std::vector<kernels::participant_plan> plans = kernels::plan_participants(chain, blocks);
      std::size_t next = 0;
      for (unsigned participant = 0; participant < threads; ++participant) {
        const kernels::participant_plan& plan = plans[participant];
        EXPECT_EQ(plan.block.first, next);
        EXPECT_GE(plan.block.size(), 1U);
        EXPECT_LE(plan.block.size(), 2U);
        next = plan.block.last;
        for (const unsigned producer : plan.producers) {
          const std::size_t own_mass = plan.block.first / 2;
          const std::size_t their_first = blocks.block(producer).first / 2;
          const std::size_t their_last = (blocks.block(producer).last - 1) / 2;
          EXPECT_TRUE(their_last + 1 >= own_mass && their_first <= (plan.block.last - 1) / 2 + 1)
              << masses << " masses on " << threads << ": participant " << participant << " waits for "
              << producer << ", which owns no mass next to its own";
        }
      }
      EXPECT_EQ(next, chain.equations());
    }
}

TEST(Applicability, ChannelsNeedPrivateCopiesAndSayWhy) {
  static_assert(kernels::applicable<sync::std_barrier, layouts::packed>().applicable);
  static_assert(kernels::applicable<sync::std_barrier, layouts::per_thread>().applicable);
  static_assert(kernels::applicable<sync::seqlock, layouts::per_thread>().applicable);
  static_assert(!kernels::applicable<sync::spsc_queue, layouts::padded128>().applicable);
  EXPECT_NE(std::string(kernels::applicable<sync::seqlock, layouts::packed>().reason).find("per_thread"),
            std::string::npos);
}

TEST(Applicability, MoreThreadsThanEquationsIsNotApplicableWithAReason) {
  EXPECT_EQ((kernels::not_applicable_reason<sync::std_barrier, layouts::packed>(4, 4)), "");
  EXPECT_NE((kernels::not_applicable_reason<sync::std_barrier, layouts::packed>(4, 8))
                .find("every thread must own at least one equation"),
            std::string::npos);
  EXPECT_THROW((kernels::parallel_rk4<sync::std_barrier, layouts::packed>(kernels::two_mass_model{}, kStepSize, 8)),
               layouts::partition_error);
}

TEST(Construction, RejectsAWrongInitialStateAndStep) {
  const std::vector<double> three{1.0, 2.0, 3.0};
  EXPECT_THROW((kernels::parallel_rk4<sync::std_barrier, layouts::packed>(kernels::two_mass_model{}, kStepSize, 2,
                                                                           three)),
               std::invalid_argument);
  EXPECT_THROW((kernels::parallel_rk4<sync::std_barrier, layouts::packed>(kernels::two_mass_model{}, -1.0, 2)),
               std::invalid_argument);
}

// A deadline already passed: participant 0 asks at step 0 to stop before
// step stop_margin_steps(); every participant stops there, and the state is
// the serial one after that many steps. A later run ignores the old request.
template <class Sync, class Layout>
void expect_agreed_stop(unsigned threads) {
  const watchdog guard(std::chrono::milliseconds(30'000 * kSlowdown), "bounded run did not stop");
  const kernels::two_mass_model model;
  kernels::parallel_rk4<Sync, Layout> step(model, kStepSize, threads);
  std::vector<sync::participant> participants(threads);
  for (unsigned id = 0; id < threads; ++id) participants[id].id = id;
  std::vector<std::uint64_t> completed(threads, 0);
  sync::team_of_t<Sync> team(threads);
  team.run([&](unsigned id) { completed[id] = step.run_bounded(participants[id], 1000, steady_clock::now()); });
  const std::uint64_t margin = step.stop_margin_steps();
  for (unsigned id = 0; id < threads; ++id) EXPECT_EQ(completed[id], margin) << "participant " << id;
  EXPECT_EQ(step.steps_taken(), margin);

  team.run([&](unsigned id) {
    completed[id] = step.run_bounded(participants[id], 40, steady_clock::now() + std::chrono::hours(1));
  });
  for (unsigned id = 0; id < threads; ++id) EXPECT_EQ(completed[id], 40U) << "a stale stop must not end a new run";

  kernels::staged_rk4<kernels::two_mass_model> serial(model, kStepSize);
  serial.run(margin + 40);
  EXPECT_EQ(first_difference(step.state(), serial.state()), "");
}

TEST(RunBounded, BarrierTeamStopsTogether) { expect_agreed_stop<sync::std_barrier, layouts::padded64>(4); }
TEST(RunBounded, ChannelTeamStopsTogether) { expect_agreed_stop<sync::seqlock, layouts::per_thread>(4); }
TEST(RunBounded, QueueTeamStopsTogether) { expect_agreed_stop<sync::spsc_queue, layouts::per_thread>(2); }

TEST(RunBounded, ALateDeadlineRunsEveryStep) {
  const watchdog guard(std::chrono::milliseconds(30'000 * kSlowdown));
  kernels::parallel_rk4<sync::futex_spin, layouts::packed> step(kernels::two_mass_model{}, kStepSize, 2);
  std::vector<sync::participant> participants(2);
  participants[1].id = 1;
  std::vector<std::uint64_t> completed(2, 0);
  sync::std_thread_team team(2);
  team.run([&](unsigned id) {
    completed[id] = step.run_bounded(participants[id], 100, steady_clock::now() + std::chrono::hours(1));
  });
  EXPECT_EQ(completed, (std::vector<std::uint64_t>{100, 100}));
}

// Timing on: one timed sync per stage per participant, the same trajectory.
TEST(SyncTiming, OnCountsEveryStageSyncAndKeepsTheTrajectory) {
  expect_bitwise_serial<sync::std_barrier, layouts::padded64, kernels::two_mass_model, kernels::sync_timing::on>(
      kernels::two_mass_model{}, 4, placement::none, 60);
  expect_bitwise_serial<sync::seqlock, layouts::per_thread, kernels::two_mass_model, kernels::sync_timing::on>(
      kernels::two_mass_model{}, 4, placement::none, 60);
}

TEST(SyncTiming, SampledTimesOneStepPerPeriod) {
  expect_bitwise_serial<sync::futex_spin, layouts::packed, kernels::two_mass_model, kernels::sync_timing::sampled>(
      kernels::two_mass_model{}, 2, placement::none, 100);
  expect_bitwise_serial<sync::spsc_queue, layouts::per_thread, kernels::two_mass_model,
                        kernels::sync_timing::sampled>(kernels::two_mass_model{}, 4, placement::none, 100);
}

// A shorter sampling period, set between two calls (as the harness sets it
// between its warm-up and timed batches), applies from the next call on:
// steps 0..9 at the default period time step 0; steps 10..19 at period 3
// time steps 12, 15, 18.
TEST(SyncTiming, SamplePeriodAppliesFromTheNextCall) {
  const watchdog guard(std::chrono::milliseconds(30'000 * kSlowdown), "sampled-timing team did not finish");
  kernels::parallel_rk4<sync::futex_spin, layouts::padded64, kernels::two_mass_model, kernels::sync_timing::sampled>
      step(kernels::two_mass_model{}, kStepSize, 2);
  EXPECT_EQ(step.sync_sample_period(), kernels::kSyncTimingSampleSteps);
  kernels::run_team(step, 10);
  EXPECT_EQ(step.sync_time(0).syncs, kernels::kRk4Stages * 1);
  step.set_sync_sample_period(3);
  kernels::run_team(step, 10);
  for (unsigned participant = 0; participant < 2; ++participant)
    EXPECT_EQ(step.sync_time(participant).syncs, kernels::kRk4Stages * 4) << "participant " << participant;
  step.set_sync_sample_period(0);  // clamped: every step
  EXPECT_EQ(step.sync_sample_period(), 1U);
}

TEST(SyncTiming, OffReadsNoClockAndReportsZero) {
  const watchdog guard(std::chrono::milliseconds(30'000 * kSlowdown));
  kernels::parallel_rk4<sync::std_barrier, layouts::packed> step(kernels::two_mass_model{}, kStepSize, 2);
  kernels::run_team(step, 20);
  EXPECT_EQ(step.sync_time().syncs, 0U);
  EXPECT_EQ(step.sync_time().nanoseconds, 0U);
}

// What a primitive's constructor received, and on which thread each
// participant arrived first: written by the primitive, read after the team
// joined.
struct construction_record {
  unsigned participants = 0;
  std::size_t width = 0;  // channels: doubles per stage
  std::chrono::milliseconds timeout{0};
  std::vector<std::thread::id> arrived_on;  // barriers: per participant
};

// Where a primitive built without a record writes (never read).
construction_record& unread() {
  static construction_record nobody_reads;
  return nobody_reads;
}

// std::barrier, recording its constructor's arguments (the participants, then
// what the step was given after the initial state) and its participants'
// threads.
class recording_barrier {
 public:
  static constexpr std::string_view kName = "recording_barrier";
  static constexpr std::string_view kDescription = "test-only: std::barrier that records its construction";
  static constexpr sync::primitive_kind kKind = sync::primitive_kind::barrier;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = false;
  static constexpr bool kSpinsLong = false;
  static constexpr bool kVisibleToTsan = true;

  // (The defaults make it a phase_barrier: constructible from the count.)
  explicit recording_barrier(unsigned participants, std::chrono::milliseconds timeout = {},
                             construction_record* record = &unread())
      : barrier_(static_cast<std::ptrdiff_t>(participants)), record_(record) {
    record_->participants = participants;
    record_->timeout = timeout;
    record_->arrived_on.assign(participants, std::thread::id{});
  }

  void arrive_and_wait(sync::participant& self) {
    // Each participant writes only its own entry; the team's join orders it
    // before the test reads it.
    if (record_->arrived_on[self.id] == std::thread::id{}) record_->arrived_on[self.id] = std::this_thread::get_id();
    barrier_.arrive_and_wait();
  }

 private:
  std::barrier<> barrier_;
  construction_record* record_;
};

// The fault-free test channel (tests/support/faulty_primitives.hpp), recording
// its constructor's arguments (the graph and width, then what the step was
// given after the initial state).
class recording_channel : public faulty::stage_channel<faulty::channel_fault::none> {
 public:
  static constexpr std::string_view kName = "recording_channel";

  // (The defaults make it a graph_channel: constructible from the graph and width.)
  recording_channel(const sync::dependency_graph& graph, std::size_t width, std::chrono::milliseconds timeout = {},
                    construction_record* record = &unread())
      : stage_channel(graph, width) {
    record->participants = graph.participants();
    record->width = width;
    record->timeout = timeout;
  }
};

// Extra constructor arguments (here a timeout and a record) reach the
// primitive, after the participant count for a barrier and after the graph
// and width for a channel; the step still runs bitwise serial on it.
TEST(SyncArguments, ReachThePrimitive) {
  const watchdog guard(std::chrono::milliseconds(60'000 * kSlowdown));
  const kernels::two_mass_model model;
  kernels::staged_rk4<kernels::two_mass_model> serial(model, kStepSize);
  serial.run(30);

  construction_record barrier_record;
  kernels::parallel_rk4<recording_barrier, layouts::padded64> on_barrier(
      model, kStepSize, 4, model.initial_state(), std::chrono::milliseconds(50), &barrier_record);
  EXPECT_EQ(barrier_record.participants, 4U);
  EXPECT_EQ(barrier_record.timeout, std::chrono::milliseconds(50));
  kernels::run_team(on_barrier, 30);
  EXPECT_EQ(first_difference(on_barrier.state(), serial.state()), "");

  construction_record channel_record;
  kernels::parallel_rk4<recording_channel, layouts::per_thread> on_channel(
      model, kStepSize, 2, model.initial_state(), std::chrono::milliseconds(70), &channel_record);
  EXPECT_EQ(channel_record.participants, 2U);
  EXPECT_EQ(channel_record.width, 2U) << "two threads on four equations: blocks of two";
  EXPECT_EQ(channel_record.timeout, std::chrono::milliseconds(70));
  kernels::run_team(on_channel, 30);
  EXPECT_EQ(first_difference(on_channel.state(), serial.state()), "");
}

// The hook runs once per participant, on the thread that then runs that
// participant's steps (the one its first arrival comes from), one thread each.
TEST(RunTeam, CallsTheHookOncePerParticipantOnItsThread) {
  const watchdog guard(std::chrono::milliseconds(30'000 * kSlowdown));
  construction_record record;
  kernels::parallel_rk4<recording_barrier, layouts::per_thread> step(
      kernels::two_mass_model{}, kStepSize, 4, kernels::two_mass_model{}.initial_state(), std::chrono::milliseconds(0),
      &record);
  struct hook_call {
    unsigned calls = 0;
    std::thread::id thread;
  };
  std::vector<hook_call> hooked(4);  // each participant writes its own entry; read after the join
  kernels::run_team(step, 5, [&](unsigned participant) {
    ++hooked[participant].calls;
    hooked[participant].thread = std::this_thread::get_id();
  });
  EXPECT_EQ(step.steps_taken(), 5U);
  for (unsigned participant = 0; participant < 4; ++participant) {
    EXPECT_EQ(hooked[participant].calls, 1U) << "participant " << participant;
    EXPECT_EQ(hooked[participant].thread, record.arrived_on[participant]) << "participant " << participant;
    for (unsigned other = 0; other < participant; ++other)
      EXPECT_NE(hooked[participant].thread, hooked[other].thread) << participant << " and " << other;
  }
}

}  // namespace
}  // namespace lockstep::testing::matrix
