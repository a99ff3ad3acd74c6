// The paced engine on a stand-in step: it records one wake-up per participant
// per step and one completion per step, counts deadline misses against the
// period, re-anchors its schedule after an overrun (the periods skipped are
// counted, the team skips them together), and its Figure 5 table has one row
// per thread whose sums are the totals. No latency is asserted: where a test
// needs a step longer than its period, the step sleeps, and sleep_for sleeps
// at least that long.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <barrier>
#include <chrono>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "bench/probes/paced.hpp"
#include "kernels/model_choice.hpp"
#include "sync/team.hpp"
#include "tests/support/watchdog.hpp"

namespace {

namespace probes = lockstep::bench::probes;

TEST(PacedRun, RecordsEveryPeriodAndThread) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced run");
  constexpr unsigned kParticipants = 3;
  probes::paced_settings settings;
  settings.period_ns = 2'000'000;
  settings.periods = 10;
  settings.lead_ns = 1'000'000;
  lockstep::sync::std_thread_team team(kParticipants);
  std::atomic<int> prepared{0};
  std::atomic<int> steps{0};
  const auto run = probes::run_paced(
      team, kParticipants, settings, [&](unsigned) { prepared.fetch_add(1); },
      [&](unsigned, std::uint64_t) { steps.fetch_add(1); });
  EXPECT_EQ(prepared.load(), 3);
  // Each step is a period of the schedule, or (a step delayed past its
  // period on a busy machine) skips some: every period is one or the other.
  EXPECT_EQ(run.periods_scheduled, 10);
  EXPECT_EQ(run.periods + static_cast<std::int64_t>(run.skipped_periods), 10);
  EXPECT_EQ(steps.load(), 3 * run.periods);
  EXPECT_EQ(run.wakeup_ns.size(), 3u * static_cast<std::size_t>(run.periods));
  EXPECT_EQ(run.period_index.size(), run.wakeup_ns.size());
  EXPECT_EQ(run.completion_ns.size(), static_cast<std::size_t>(run.periods));
  // The count is of the completions above the period, whatever they were.
  EXPECT_EQ(run.deadline_misses,
            static_cast<std::uint64_t>(std::count_if(run.completion_ns.begin(), run.completion_ns.end(),
                                                     [](double completion) { return completion > 2'000'000.0; })));
  EXPECT_TRUE(run.errors.empty());
  for (double wake : run.wakeup_ns) EXPECT_GE(wake, 0.0);  // an absolute sleep never returns early
  ASSERT_EQ(run.figure5.rows().size(), 4u);
  EXPECT_EQ(run.figure5.rows()[0].thread, "main");
  EXPECT_EQ(run.figure5.rows()[1].thread, "worker 0");
  EXPECT_EQ(run.figure5.rows()[3].role, "worker");
}

// The re-anchoring arithmetic: the next step runs in the first period that
// starts at or after the step's end, never before the next period.
TEST(NextPeriod, IsTheFirstPeriodBoundaryAfterTheStepsEnd) {
  constexpr std::int64_t kPeriod = 1'000'000;
  EXPECT_EQ(probes::next_period(7, 0, kPeriod), 8);
  EXPECT_EQ(probes::next_period(7, 400'000, kPeriod), 8);
  EXPECT_EQ(probes::next_period(7, kPeriod, kPeriod), 8);  // ended as period 8 began: no overrun
  EXPECT_EQ(probes::next_period(7, kPeriod + 1, kPeriod), 9);  // overran: period 8 is skipped
  EXPECT_EQ(probes::next_period(7, 2 * kPeriod, kPeriod), 9);
  EXPECT_EQ(probes::next_period(7, 6'600'000, kPeriod), 14);  // 6.6 periods: 8..13 skipped
  EXPECT_EQ(probes::next_period(0, 15'000'000'000, kPeriod), 15'000);
  static_assert(probes::next_period(0, 2'500'000, kPeriod) == 3);
}

// A step that sleeps 0.5 ms in 0.1 ms periods: the first step overruns, the
// schedule re-anchors past the last of the 5 periods, and the run ends
// there: one step, one miss, 4 periods skipped, no backlog.
TEST(PacedRun, AnOverrunSkipsToTheNextPeriodBoundary) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced overrun");
  probes::paced_settings settings;
  settings.period_ns = 100'000;  // 0.1 ms
  settings.periods = 5;
  settings.lead_ns = 1'000'000;
  lockstep::sync::std_thread_team team(1);
  const auto run = probes::run_paced(
      team, 1, settings, [](unsigned) {},
      [](unsigned, std::uint64_t) { std::this_thread::sleep_for(std::chrono::microseconds(500)); });
  EXPECT_EQ(run.periods, 1);
  EXPECT_EQ(run.deadline_misses, 1u);
  EXPECT_EQ(run.skipped_periods, 4u);
  EXPECT_EQ(run.periods_scheduled, 5);
  ASSERT_EQ(run.completion_ns.size(), 1u);
  EXPECT_GT(run.completion_ns[0], 100'000.0);
}

// A team whose step outgrows its period (participant 1 sleeps 2.5 periods in
// every step, the others wait for it in the barrier): every step overruns,
// the team runs each step in the same period, at least 3 periods after the
// one before, and every period of the schedule is a step or a skipped one.
TEST(PacedRun, ATeamWhoseStepOutgrowsThePeriodSkipsPeriodsTogether) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced team overrun");
  constexpr unsigned kParticipants = 3;
  probes::paced_settings settings;
  settings.period_ns = 1'000'000;
  settings.periods = 30;
  settings.lead_ns = 1'000'000;
  lockstep::sync::std_thread_team team(kParticipants);
  std::array<std::atomic<int>, kParticipants> steps{};
  std::barrier<> stage(kParticipants);
  probes::paced_progress progress;
  settings.progress = &progress;
  const auto run = probes::run_paced(
      team, kParticipants, settings, [](unsigned) {},
      [&](unsigned id, std::uint64_t) {
        if (id == 1) std::this_thread::sleep_for(std::chrono::microseconds(2'500));
        steps[id].fetch_add(1);
        stage.arrive_and_wait();
      });
  ASSERT_GE(run.periods, 1);
  EXPECT_LE(run.periods, 10);  // at most one step in every 3 periods
  EXPECT_EQ(steps[0].load(), run.periods);
  EXPECT_EQ(steps[1].load(), run.periods);
  EXPECT_EQ(steps[2].load(), run.periods);
  EXPECT_EQ(run.deadline_misses, static_cast<std::uint64_t>(run.periods));
  EXPECT_EQ(run.periods_scheduled, 30);
  EXPECT_EQ(run.periods + static_cast<std::int64_t>(run.skipped_periods), 30);
  ASSERT_EQ(run.period_index.size(), static_cast<std::size_t>(run.periods) * kParticipants);
  for (std::int64_t k = 0; k < run.periods; ++k) {
    const std::int64_t period = run.period_index[static_cast<std::size_t>(k) * kParticipants];
    for (unsigned p = 1; p < kParticipants; ++p)
      EXPECT_EQ(run.period_index[static_cast<std::size_t>(k) * kParticipants + p], period) << "step " << k;
    if (k == 0) {
      EXPECT_EQ(period, 0);
    } else {
      const std::int64_t before = run.period_index[static_cast<std::size_t>(k - 1) * kParticipants];
      EXPECT_GE(period - before, 3) << "step " << k;
      // The next boundary after the previous step's end, exactly.
      EXPECT_EQ(period, probes::next_period(before, static_cast<std::int64_t>(run.completion_ns[static_cast<std::size_t>(k - 1)]),
                                            settings.period_ns))
          << "step " << k;
    }
  }
  // What the progress line reads: the whole schedule behind it, and the
  // same overruns and skipped periods as the result.
  EXPECT_EQ(progress.periods.load(), 30);
  EXPECT_EQ(progress.overran.load(), run.deadline_misses);
  EXPECT_EQ(progress.skipped.load(), run.skipped_periods);
}

TEST(PacedRun, AFailedPinIsReportedAndTheRunCompletes) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced pin failure");
  probes::paced_settings settings;
  settings.period_ns = 1'000'000;
  settings.periods = 3;
  settings.lead_ns = 1'000'000;
  lockstep::sync::std_thread_team team(2);
  const auto run = probes::run_paced(
      team, 2, settings,
      [](unsigned id) {
        if (id == 1) throw std::runtime_error("cannot pin");
      },
      [](unsigned, std::uint64_t) {});
  ASSERT_EQ(run.errors.size(), 1u);
  EXPECT_EQ(run.errors[0], "worker 1: cannot pin");
  // The run completes its schedule: every period a step or, after an
  // overrun (a loaded machine), skipped.
  EXPECT_EQ(run.completion_ns.size(), static_cast<std::size_t>(run.periods));
  EXPECT_EQ(run.periods + static_cast<std::int64_t>(run.skipped_periods), 3);
}

// --stop-above: a threshold of 0 ns makes the first wake-up late (an
// absolute sleep returns after its target); the result keeps that one period.
TEST(PacedRun, StopAboveKeepsPeriodsUpToTheLateWakeUp) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced stop");
  probes::paced_settings settings;
  settings.period_ns = 1'000'000;
  settings.periods = 50;
  settings.lead_ns = 1'000'000;
  settings.stop_above_ns = 0;
  settings.stop_margin_periods = 1;
  lockstep::sync::std_thread_team team(2);
  std::array<std::atomic<int>, 2> steps{};
  std::barrier<> stage(2);  // a team that syncs: leaving at different periods would hang it
  const auto run = probes::run_paced(
      team, 2, settings, [](unsigned) {},
      [&](unsigned id, std::uint64_t) {
        steps[id].fetch_add(1);
        stage.arrive_and_wait();
      });
  ASSERT_TRUE(run.stop.has_value());
  EXPECT_EQ(run.stop->period, 0);
  EXPECT_LT(run.stop->participant, 2u);
  EXPECT_GT(run.stop->wakeup_ns, 0);
  EXPECT_EQ(run.stop->since_start_ns, run.stop->wakeup_ns);  // period 0 starts at the start
  EXPECT_FALSE(run.stop->previous_end_ns.has_value());
  EXPECT_EQ(run.periods, 1);
  EXPECT_EQ(run.wakeup_ns.size(), 2u);
  EXPECT_EQ(run.completion_ns.size(), 1u);
  // Both left after the same period: margin 1 past the late one.
  EXPECT_EQ(steps[0].load(), steps[1].load());
  EXPECT_LT(steps[0].load(), 50);
}

// A team of three with a margin of two: the late wake-up (a threshold of 0
// makes the first one late) ends the run after one more step, for everyone.
TEST(PacedRun, StopAboveEndsATeamTogether) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced stop team");
  constexpr unsigned kParticipants = 3;
  probes::paced_settings settings;
  settings.period_ns = 2'000'000;
  settings.periods = 40;
  settings.lead_ns = 1'000'000;
  settings.stop_above_ns = 0;
  settings.stop_margin_periods = 2;
  lockstep::sync::std_thread_team team(kParticipants);
  std::array<std::atomic<int>, kParticipants> steps{};
  std::barrier<> stage(kParticipants);
  const auto run = probes::run_paced(
      team, kParticipants, settings, [](unsigned) {},
      [&](unsigned id, std::uint64_t) {
        steps[id].fetch_add(1);
        stage.arrive_and_wait();
      });
  ASSERT_TRUE(run.stop.has_value());
  EXPECT_EQ(run.stop->step, 0);
  EXPECT_EQ(run.stop->period, 0);
  EXPECT_EQ(run.periods, 1);
  EXPECT_EQ(run.wakeup_ns.size(), static_cast<std::size_t>(run.periods) * kParticipants);
  EXPECT_EQ(run.end_ns.size(), run.wakeup_ns.size());
  EXPECT_EQ(steps[0].load(), steps[1].load());
  EXPECT_EQ(steps[1].load(), steps[2].load());
  EXPECT_EQ(steps[0].load(), 2);  // the margin: one more step, together
}

// An overrun is not a late wake-up: participant 1 overruns its fifth step by
// 250 ms, and the team re-anchors (no wake-up waits out the overrun, so the
// 100 ms threshold does not end the run): the schedule's 40 periods of 2 ms
// are over by the time the overrun ends, so that step is the last.
TEST(PacedRun, AnOverrunIsNoLateWakeUp) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced overrun no stop");
  constexpr unsigned kParticipants = 3;
  probes::paced_settings settings;
  settings.period_ns = 2'000'000;
  settings.periods = 40;
  settings.lead_ns = 1'000'000;
  settings.stop_above_ns = 100'000'000;  // 100 ms
  settings.stop_margin_periods = 2;
  lockstep::sync::std_thread_team team(kParticipants);
  std::barrier<> stage(kParticipants);
  const auto run = probes::run_paced(
      team, kParticipants, settings, [](unsigned) {},
      [&](unsigned id, std::uint64_t step) {
        if (id == 1 && step == 4) std::this_thread::sleep_for(std::chrono::milliseconds(250));
        stage.arrive_and_wait();
      });
  EXPECT_FALSE(run.stop.has_value());
  ASSERT_EQ(run.periods, 5);
  EXPECT_GT(run.completion_ns[4], 250'000'000.0);
  EXPECT_EQ(run.periods_scheduled, 40);
  EXPECT_EQ(run.skipped_periods, static_cast<std::uint64_t>(40 - 5));
  for (double wake : run.wakeup_ns) EXPECT_LT(wake, 100'000'000.0);
}

// Stop after misses: a team whose step overruns from period 3 on ends soon
// after the second miss, together, and keeps every period it ran.
TEST(PacedRun, StopAfterMissesEndsATeamTogether) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced stop after misses");
  probes::paced_settings settings;
  settings.period_ns = 1'000'000;
  settings.periods = 200;
  settings.lead_ns = 1'000'000;
  settings.stop_after_misses = 2;
  settings.stop_margin_periods = 1;
  lockstep::sync::std_thread_team team(2);
  std::array<std::atomic<int>, 2> steps{};
  std::barrier<> stage(2);
  const auto run = probes::run_paced(
      team, 2, settings, [](unsigned) {},
      [&](unsigned id, std::uint64_t period) {
        if (period >= 3) std::this_thread::sleep_for(std::chrono::milliseconds(2));
        steps[id].fetch_add(1);
        stage.arrive_and_wait();
      });
  EXPECT_TRUE(run.stopped_after_misses);
  EXPECT_FALSE(run.stop.has_value());
  EXPECT_LT(run.periods, 200);
  EXPECT_GE(run.deadline_misses, 1u);
  // A miss is a period past its deadline without its step done: the step
  // that overran, and each period skipped after it (2 ms in 1 ms periods:
  // 1 + 2); the run kept every one it counted.
  EXPECT_GE(run.deadline_misses + run.skipped_periods, 2u);
  EXPECT_EQ(steps[0].load(), steps[1].load());
  EXPECT_EQ(steps[0].load(), run.periods);  // every period run is kept
  EXPECT_EQ(run.completion_ns.size(), static_cast<std::size_t>(run.periods));
}

TEST(PacedRun, WithoutAStopEveryPeriodIsKept) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced no stop");
  probes::paced_settings settings;
  settings.period_ns = 1'000'000;
  settings.periods = 5;
  settings.lead_ns = 1'000'000;
  settings.stop_above_ns = 3'600'000'000'000;  // an hour
  lockstep::sync::std_thread_team team(1);
  const auto run = probes::run_paced(team, 1, settings, [](unsigned) {}, [](unsigned, std::uint64_t) {});
  EXPECT_FALSE(run.stop.has_value());
  EXPECT_EQ(run.periods_scheduled, 5);
  EXPECT_EQ(run.periods + static_cast<std::int64_t>(run.skipped_periods), 5);
  ASSERT_EQ(run.cpus.size(), 1u);
}

// Independent participants (per CPU): each step's completion is each
// participant's own, so one that overruns misses and skips alone: its
// first step (0.5 ms in 0.1 ms periods) takes it past the schedule's 4
// periods, while the other runs its own steps.
TEST(PacedRun, IndependentParticipantsMissAlone) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced independent");
  probes::paced_settings settings;
  settings.period_ns = 100'000;
  settings.periods = 4;
  settings.lead_ns = 1'000'000;
  settings.independent = true;
  lockstep::sync::std_thread_team team(2);
  const auto run = probes::run_paced(team, 2, settings, [](unsigned) {}, [](unsigned id, std::uint64_t) {
    if (id == 1) std::this_thread::sleep_for(std::chrono::microseconds(500));
  });
  ASSERT_EQ(run.steps_run.size(), 2u);
  EXPECT_EQ(run.steps_run[1], 1);
  EXPECT_GE(run.steps_run[0], 1);
  ASSERT_EQ(run.completion_ns.size(), static_cast<std::size_t>(run.steps_run[0] + run.steps_run[1]));
  const auto slow = probes::samples_of(run, run.completion_ns, 1);
  ASSERT_EQ(slow.size(), 1u);
  EXPECT_GT(slow[0], 100'000.0);
  EXPECT_GE(run.deadline_misses, 1u);
  EXPECT_GE(run.skipped_periods, 3u);  // the slow one's periods 1..3
  EXPECT_EQ(run.periods_scheduled, 4);
  EXPECT_EQ(probes::samples_of(run, run.wakeup_ns, 0).size(), static_cast<std::size_t>(run.steps_run[0]));
  EXPECT_EQ(probes::samples_of(run, run.period_index, 1), (std::vector<std::int64_t>{0}));
}

// samples_of on a result made by hand: a team's samples are step-major, an
// independent run's participant-major with steps_run each.
TEST(PacedRun, SamplesOfTakesOneParticipantsSteps) {
  probes::paced_result team;
  team.participants = 2;
  team.wakeup_ns = {0, 1, 10, 11, 20, 21};
  EXPECT_EQ(probes::samples_of(team, team.wakeup_ns, 1), (std::vector<double>{1, 11, 21}));
  probes::paced_result apart;
  apart.participants = 2;
  apart.independent = true;
  apart.steps_run = {1, 3};
  apart.wakeup_ns = {5, 0, 1, 2};
  EXPECT_EQ(probes::samples_of(apart, apart.wakeup_ns, 0), (std::vector<double>{5}));
  EXPECT_EQ(probes::samples_of(apart, apart.wakeup_ns, 1), (std::vector<double>{0, 1, 2}));
}

TEST(PacedRun, ParticipantSamplesTakesEveryNth) {
  const std::vector<double> samples{0, 1, 2, 10, 11, 12};
  EXPECT_EQ(probes::participant_samples(samples, 3, 1), (std::vector<double>{1, 11}));
  EXPECT_EQ(probes::participant_samples(samples, 3, 2), (std::vector<double>{2, 12}));
}

// The per-CPU probe: one participant per CPU given, each pinned there.
TEST(PacedStep, PerCpuRunsOneParticipantPerCpu) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "paced per cpu");
  const unsigned cpu = lockstep::platform::current_cpu().value_or(0);
  std::vector<unsigned> cpus{cpu};
  probes::paced_step_settings settings;
  settings.sync = "std_barrier";
  settings.layout = "padded64";
  settings.pacing.period_ns = 1'000'000;
  settings.pacing.periods = 5;
  settings.pacing.lead_ns = 1'000'000;
  const auto run = probes::run_paced_per_cpu(settings, cpus);
  EXPECT_EQ(run.participants, 1u);
  EXPECT_EQ(run.periods_scheduled, 5);
  ASSERT_EQ(run.cpus.size(), 1u);
  ASSERT_TRUE(run.cpus[0].has_value());
  if (run.errors.empty()) {
    EXPECT_EQ(*run.cpus[0], cpu);
  }
  EXPECT_EQ(run.completion_ns.size(), static_cast<std::size_t>(run.periods));
}

TEST(PacedStep, PerCpuRefusesATeamOfItsOwn) {
  EXPECT_NE(probes::paced_per_cpu_problem("omp_barrier", "padded64"), "");
  EXPECT_EQ(probes::paced_per_cpu_problem("futex_spin", "padded64"), "");
  EXPECT_NE(probes::paced_per_cpu_problem("nope", "padded64").find("unknown primitive"), std::string::npos);
}

// The team's stop on a real step: the dataflow step (seqlock, 4
// participants) leaves together as the barrier step does (no hang).
TEST(PacedStep, StopAboveEndsTheComposedStep) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "paced step stop");
  for (const char* sync : {"std_barrier", "seqlock"}) {
    probes::paced_step_settings settings;
    settings.sync = sync;
    settings.layout = "per_thread";
    settings.threads = 4;
    settings.pacing.period_ns = 1'000'000;
    settings.pacing.periods = 30;
    settings.pacing.lead_ns = 1'000'000;
    settings.pacing.stop_above_ns = 0;  // the first wake-up is late
    const lockstep::platform::topology machine = lockstep::platform::topology::this_machine();
    const auto plan = lockstep::platform::plan_placement(machine, lockstep::platform::placement::none, 4);
    const auto run = probes::run_paced_step(settings, plan);
    ASSERT_TRUE(run.stop.has_value()) << sync;
    EXPECT_EQ(run.periods, 1) << sync;
    EXPECT_EQ(run.wakeup_ns.size(), 4u) << sync;
  }
}

// Beyond four participants the team paces a chain (kernels::model_for); a
// chain too small for the team is refused with the counts.
TEST(PacedStep, ProblemAsksTheModelForItsEquations) {
  EXPECT_EQ(probes::paced_step_problem("std_barrier", "padded64", 8, lockstep::kernels::model_for(8)), "");
  EXPECT_NE(probes::paced_step_problem("std_barrier", "padded64", 8, {}).find("8 threads but 4 equations"),
            std::string::npos);
  const std::string too_small =
      probes::paced_step_problem("std_barrier", "padded64", 8, lockstep::kernels::model_for(8, 3));
  EXPECT_NE(too_small.find("8 threads but 6 equations"), std::string::npos) << too_small;
  EXPECT_NE(too_small.find("a chain of 3 masses"), std::string::npos) << too_small;
}

// A chain's step, barrier and dataflow, stops together at the first late
// wake-up as the two-mass step does (the dataflow graph of a chain is longer
// than the two-mass one: the margin comes from it).
TEST(PacedStep, ChainStepOfSixParticipantsStopsTogether) {
  lockstep::testing::watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "paced chain stop");
  constexpr unsigned kThreads = 6;
  for (const char* sync : {"std_barrier", "seqlock"}) {
    probes::paced_step_settings settings;
    settings.sync = sync;
    settings.layout = "per_thread";
    settings.threads = kThreads;
    settings.model = lockstep::kernels::model_for(kThreads);
    ASSERT_TRUE(settings.model.is_chain());
    settings.pacing.period_ns = 1'000'000;
    settings.pacing.periods = 30;
    settings.pacing.lead_ns = 1'000'000;
    settings.pacing.stop_above_ns = 0;  // the first wake-up is late
    const lockstep::platform::topology machine = lockstep::platform::topology::this_machine();
    const auto plan = lockstep::platform::plan_placement(machine, lockstep::platform::placement::none, kThreads);
    const auto run = probes::run_paced_step(settings, plan);
    EXPECT_EQ(run.participants, kThreads) << sync;
    ASSERT_TRUE(run.stop.has_value()) << sync;
    EXPECT_EQ(run.periods, 1) << sync;
    EXPECT_EQ(run.wakeup_ns.size(), kThreads) << sync;
  }
}

TEST(Figure5Table, TotalsAreTheSumsOfTheRows) {
  lockstep::platform::figure5_table table;
  lockstep::platform::thread_counters main_thread{1, 1, 1};
  lockstep::platform::thread_counters worker_a{100, 20, 6};
  lockstep::platform::thread_counters worker_b{30, 0, 0};
  table.add("main", "main", main_thread);
  table.add("worker 0", "worker", worker_a);
  table.add("worker 1", "worker", worker_b);
  const auto totals = table.totals();
  EXPECT_EQ(totals.total_csw, 2 + 120 + 30);
  ASSERT_TRUE(totals.cross_core_csw.has_value());
  EXPECT_EQ(*totals.cross_core_csw, 1 + 6 + 0);
  ASSERT_TRUE(totals.pct.has_value());
  EXPECT_DOUBLE_EQ(*totals.pct, 100.0 * 7.0 / 152.0);  // from the sums, not the mean of the rows
  EXPECT_DOUBLE_EQ(*table.rows()[1].pct, 5.0);
}

}  // namespace
