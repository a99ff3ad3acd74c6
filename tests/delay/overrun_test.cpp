// The overrun named first (bench/delay/delay_report.hpp: overrun_of,
// overrun_line) on runs made by hand and scheduled as the paced run
// schedules them (bench/probes/paced.hpp, next_period): a step that does not
// fit its period, steps that overran now and then, none; the first line of
// the result in the text, and the result file's "overrun". No clock is read.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "bench/delay/delay_report.hpp"
#include "bench/probes/delay.hpp"
#include "bench/probes/paced.hpp"
#include "platform/topology.hpp"

namespace {

namespace probes = lockstep::bench::probes;
using lockstep::bench::overrun_of;

constexpr std::int64_t kPeriod = 1'000'000;

// One participant whose steps complete `completions` ns after their
// period's start, over a schedule of `periods` periods of 1 ms: each step in
// the period next_period gives after the one before, until the schedule ends.
probes::paced_result scheduled_run(const std::vector<double>& completions, std::int64_t periods) {
  probes::paced_result run;
  run.participants = 1;
  run.cpus = {0U};
  std::int64_t period = 0;
  for (std::size_t k = 0; period < periods; ++k) {
    const double completion = completions[k % completions.size()];
    run.period_index.push_back(period);
    run.wakeup_ns.push_back(20'000);
    run.end_ns.push_back(completion);
    run.completion_ns.push_back(completion);
    if (completion > static_cast<double>(kPeriod)) ++run.deadline_misses;
    period = probes::next_period(period, static_cast<std::int64_t>(completion), kPeriod);
  }
  run.periods = static_cast<std::int64_t>(run.completion_ns.size());
  run.steps_run = {run.periods};
  run.periods_scheduled = std::min(period, periods);
  run.skipped_periods = static_cast<std::uint64_t>(run.periods_scheduled - run.periods);
  run.skipped_by_participant = {run.skipped_periods};
  return run;
}

probes::delay_measurement measured_with(probes::paced_result run) {
  probes::delay_measurement measured;
  measured.settings.period_ns = kPeriod;
  measured.settings.periods = 100;
  measured.settings.duration_ns = 100 * kPeriod;
  measured.settings.threads = 1;
  measured.name = "rk4/sync:std_barrier/layout:padded64/pin:compact/threads:1";
  measured.period_ns = kPeriod;
  measured.pinned = std::move(run);
  return measured;
}

// The lines of the run's result: from the one after "result" on.
std::vector<std::string> result_lines(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> lines;
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (inside) lines.push_back(line);
    if (line == "result") inside = true;
  }
  return lines;
}

// 6.6 ms steps in 1 ms periods: every step overruns, the schedule runs one
// in every 7 periods (0, 7, ..., 98): 15 steps, 85 periods skipped.
TEST(Overrun, AStepThatDoesNotFitItsPeriodIsTheFirstLineOfTheResult) {
  const auto measured = measured_with(scheduled_run({6'600'000}, 100));
  ASSERT_EQ(measured.pinned.periods, 15);
  ASSERT_EQ(measured.pinned.skipped_periods, 85u);
  const auto overrun = overrun_of(measured.pinned, kPeriod);
  ASSERT_TRUE(overrun.has_value());
  EXPECT_TRUE(overrun->step_exceeds_period);
  EXPECT_EQ(overrun->overran, 15u);
  EXPECT_EQ(overrun->periods, 100);
  const auto analysis = lockstep::bench::analyse_delay(measured);
  const std::string text = lockstep::bench::delay_text(measured, analysis, false);
  EXPECT_EQ(text.rfind(measured.name + ": 100 periods of 1000 us", 0), 0U) << text;
  const auto lines = result_lines(text);
  ASSERT_FALSE(lines.empty()) << text;
  EXPECT_EQ(lines[0].rfind("overrun: the step does not fit the period: its completion p50 is 6600.0 us against a "
                           "period of 1000 us (6.6 periods); 15 of 15 steps overran, and 85 of the 100 periods were "
                           "skipped (after an overrun the next step waits for the next period boundary",
                           0),
            0U)
      << lines[0];
  EXPECT_NE(text.find("deadline misses: 15 of 15 steps, and 85 periods skipped after them (deadline = period = 1000 us)"),
            std::string::npos)
      << text;
}

// Two steps in a hundred overran (2.5 ms): the step fits, and the line says
// how many overran, the longest, and the periods skipped after them.
TEST(Overrun, StepsThatOverranNowAndThenAreCounted) {
  std::vector<double> completions(50, 300'000);
  completions[10] = 2'500'000;
  const auto measured = measured_with(scheduled_run(completions, 100));
  const auto overrun = overrun_of(measured.pinned, kPeriod);
  ASSERT_TRUE(overrun.has_value());
  EXPECT_FALSE(overrun->step_exceeds_period);
  EXPECT_EQ(overrun->overran, 2u);  // steps 10 and 60
  EXPECT_EQ(overrun->skipped_periods, 4u);
  const auto lines = result_lines(lockstep::bench::delay_text(measured, lockstep::bench::analyse_delay(measured), false));
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines[0].rfind("overrun: 2 of 96 steps overran the 1000 us period (the longest completed 2500.0 us after "
                           "its period's start); 4 of the 100 periods were skipped",
                           0),
            0U)
      << lines[0];
}

// No step overran: no overrun line, the result opens with its table as it
// always has, and the file's overrun is null.
TEST(Overrun, NoneLeavesTheResultAsItWas) {
  const auto measured = measured_with(scheduled_run({300'000}, 100));
  EXPECT_FALSE(overrun_of(measured.pinned, kPeriod).has_value());
  const auto analysis = lockstep::bench::analyse_delay(measured);
  const auto lines = result_lines(lockstep::bench::delay_text(measured, analysis, false));
  ASSERT_GE(lines.size(), 4U);
  EXPECT_EQ(lines[0].rfind("us ", 0), 0U) << lines[0];
  EXPECT_EQ(lines[1].rfind("wake-up latency ", 0), 0U) << lines[1];
  EXPECT_EQ(lines[2].rfind("completion (deadline) ", 0), 0U) << lines[2];
  EXPECT_EQ(lines[3], "deadline misses: 0 of 100 (deadline = period = 1000 us)");
  const auto document =
      lockstep::bench::delay_json(measured, analysis, lockstep::platform::topology::this_machine());
  EXPECT_TRUE(document["overrun"].is_null());
  EXPECT_EQ(document["skipped_periods"], 0);
  EXPECT_EQ(document["periods_scheduled"], 100);
}

// The result file holds the same figures and the line.
TEST(Overrun, TheResultFileHoldsTheFiguresAndTheLine) {
  const auto measured = measured_with(scheduled_run({6'600'000}, 100));
  const auto analysis = lockstep::bench::analyse_delay(measured);
  const auto document =
      lockstep::bench::delay_json(measured, analysis, lockstep::platform::topology::this_machine());
  const auto& overrun = document["overrun"];
  ASSERT_TRUE(overrun.is_object());
  EXPECT_EQ(overrun["steps"], 15);
  EXPECT_EQ(overrun["overran"], 15);
  EXPECT_EQ(overrun["skipped_periods"], 85);
  EXPECT_EQ(overrun["periods"], 100);
  EXPECT_EQ(overrun["period_ns"], kPeriod);
  EXPECT_EQ(overrun["completion_p50_ns"], 6'600'000.0);
  EXPECT_EQ(overrun["step_exceeds_period"], true);
  EXPECT_EQ(overrun["line"], lockstep::bench::overrun_line(*overrun_of(measured.pinned, kPeriod)));
  EXPECT_EQ(document["periods_measured"], 15);
  EXPECT_EQ(document["periods_scheduled"], 100);
  EXPECT_EQ(document["skipped_periods"], 85);
}

// Independent participants (--per-cpu) keep a schedule each: the counts add
// theirs up, and the line says so.
TEST(Overrun, IndependentParticipantsCountTheirOwnSchedules) {
  probes::paced_result run = scheduled_run({6'600'000}, 100);
  run.participants = 2;
  run.independent = true;
  run.cpus = {0U, 1U};
  const std::size_t steps = run.completion_ns.size();
  for (std::size_t k = 0; k < steps; ++k) {  // participant-major: the second's steps after the first's
    run.wakeup_ns.push_back(run.wakeup_ns[k]);
    run.end_ns.push_back(run.end_ns[k]);
    run.completion_ns.push_back(run.completion_ns[k]);
    run.period_index.push_back(run.period_index[k]);
  }
  run.deadline_misses *= 2;
  run.steps_run = {run.periods, run.periods};
  run.skipped_by_participant = {run.skipped_periods, run.skipped_periods};
  run.skipped_periods *= 2;
  const auto overrun = overrun_of(run, kPeriod);
  ASSERT_TRUE(overrun.has_value());
  EXPECT_EQ(overrun->schedules, 2U);
  EXPECT_EQ(overrun->steps, 30);
  EXPECT_EQ(overrun->periods, 200);
  EXPECT_NE(lockstep::bench::overrun_line(*overrun).find("170 of the 200 periods of the 2 participants' own schedules "
                                                         "were skipped"),
            std::string::npos)
      << lockstep::bench::overrun_line(*overrun);
}

}  // namespace
