// attribute_delay on constructed records (bench/delay/attribution.hpp):
// a run of identical periods, with one cause planted in one period; the
// attribution must name that cause, its participant, CPU and stage, and a
// step's causes must add up to its excess. No clock is read.
#include <gtest/gtest.h>

#include <cstdint>
#include <numeric>
#include <string>

#include "bench/delay/attribution.hpp"
#include "bench/delay/attribution_output.hpp"
#include "bench/probes/paced.hpp"

namespace {

namespace probes = lockstep::bench::probes;
using lockstep::bench::attribute_delay;
using lockstep::bench::attribute_step;
using lockstep::bench::delay_cause;
using lockstep::bench::late_step;
using lockstep::bench::late_step_line;
using lockstep::bench::part_kind;

constexpr std::int64_t kPeriod = 1'000'000;
constexpr unsigned kParticipants = 2;
constexpr std::int64_t kPeriods = 101;
// A usual period, in ns from its target: wake-up at 10 us, each stage 5 us
// of work then 2 us in the sync; participant p runs on CPU p.
constexpr double kWake = 10'000;
constexpr double kWork = 5'000;
constexpr double kSync = 2'000;

class constructed_run {
 public:
  constructed_run() {
    run.participants = kParticipants;
    run.periods = kPeriods;
    run.wakeup_ns.assign(kPeriods * kParticipants, kWake);
    run.end_ns.assign(kPeriods * kParticipants, 0);
    probes::step_record record;
    record.participants = kParticipants;
    record.periods = kPeriods;
    record.period_ns = kPeriod;
    record.waits_for = {{1}, {0}};
    record.steps.resize(kPeriods * kParticipants);
    record.cpus = {0, 1};
    record.interrupts.assign(kPeriods * 2, 3);
    record.softirqs.assign(kPeriods * 2, 1);
    record.schedstat_available = true;
    record.interrupts_available = true;
    record.mode = probes::step_recording::every_period;
    for (std::int64_t k = 0; k < kPeriods; ++k) {
      for (unsigned p = 0; p < kParticipants; ++p) {
        probes::participant_period& row = record.at(k, p);
        row.recorded = true;
        row.counters_valid = true;
        row.wake_cpu = static_cast<std::int32_t>(p);
        row.end_cpu = static_cast<std::int32_t>(p);
        double now = kWake;
        for (unsigned s = 0; s < 4; ++s) {
          now += kWork;
          row.stages[s] = {static_cast<std::int64_t>(now), static_cast<std::int64_t>(now + kSync),
                           static_cast<std::int32_t>(p), static_cast<std::int32_t>(p)};
          now += kSync;
        }
        run.end_ns[k * kParticipants + p] = now + 500;
        row.counters.on_cpu_ns = 20'000;
        row.counters.run_queue_wait_ns = 5'000;
        row.counters.switches = 2;
        row.counters.minor_faults = 0;
        row.counters.major_faults = 0;
      }
    }
    run.record = std::move(record);
    finish();
  }

  probes::participant_period& row(std::int64_t k, unsigned p) { return run.record->at(k, p); }

  // Participant p reaches stage s `delay` ns late; everything after waits for it.
  void arrive_late(std::int64_t k, unsigned p, unsigned s, double delay) {
    const auto d = static_cast<std::int64_t>(delay);
    row(k, p).stages[s].arrival_ns += d;
    for (unsigned q = 0; q < kParticipants; ++q) {
      row(k, q).stages[s].departure_ns += d;
      for (unsigned later = s + 1; later < 4; ++later) {
        row(k, q).stages[later].arrival_ns += d;
        row(k, q).stages[later].departure_ns += d;
      }
      run.end_ns[k * kParticipants + q] += delay;
    }
    finish();
  }

  void finish() {
    run.completion_ns.assign(kPeriods, 0);
    for (std::int64_t k = 0; k < kPeriods; ++k)
      for (unsigned p = 0; p < kParticipants; ++p)
        run.completion_ns[k] = std::max(run.completion_ns[k], run.end_ns[k * kParticipants + p]);
    run.deadline_misses = 0;
  }

  probes::paced_result run;
};

double sum(const lockstep::bench::cause_split& split) { return std::accumulate(split.begin(), split.end(), 0.0); }
double of(const late_step& step, delay_cause cause) { return step.cause_ns[static_cast<std::size_t>(cause)]; }

TEST(DelayCauses, ASleepInsideAStageIsThatParticipantsCompute) {
  constructed_run built;
  built.arrive_late(50, 1, 2, 200'000);
  auto& row = built.row(50, 1);
  row.counters.switches = 2 + 1;  // the sleep; on-CPU and run-queue time as usual: the window grew
  const late_step step = attribute_step(built.run, 50);
  EXPECT_EQ(step.top, delay_cause::compute);
  EXPECT_EQ(step.kind, part_kind::compute);
  EXPECT_EQ(step.participant, 1u);
  EXPECT_EQ(step.cpu, 1u);
  EXPECT_EQ(step.stage, 2);
  EXPECT_NEAR(step.excess_ns, 200'000, 1);
  EXPECT_NEAR(of(step, delay_cause::compute), 200'000, 1);
  EXPECT_NEAR(step.lead_ns, 200'000, 1) << "it reached stage 2 200 us after the other";
  EXPECT_NEAR(sum(step.cause_ns), step.excess_ns, 1e-6);
}

TEST(DelayCauses, OnCpuTimeNoEventExplainsIsAMachineStall) {
  constructed_run built;
  built.arrive_late(60, 0, 3, 7'800'000);
  built.row(60, 0).counters.on_cpu_ns = 20'000 + 7'800'000;  // the guest says it ran
  const late_step step = attribute_step(built.run, 60);
  EXPECT_EQ(step.top, delay_cause::machine_stall);
  EXPECT_EQ(step.participant, 0u);
  EXPECT_EQ(step.cpu, 0u);
  EXPECT_EQ(step.stage, 3);
  const std::string line = late_step_line(step);
  EXPECT_NE(line.find("step 60, 7.8 ms late: participant 0 on CPU 0 reached stage 3 7.8 ms after the others"),
            std::string::npos)
      << line;
  EXPECT_NE(line.find("no switch, no fault, no interrupt: machine stall"), std::string::npos) << line;
}

TEST(DelayCauses, WaitingOnARunQueueIsRunQueueWait) {
  constructed_run built;
  built.arrive_late(70, 1, 1, 300'000);
  built.row(70, 1).counters.run_queue_wait_ns = 5'000 + 300'000;
  built.row(70, 1).counters.switches = 2 + 1;
  const late_step step = attribute_step(built.run, 70);
  EXPECT_EQ(step.top, delay_cause::run_queue_wait);
  EXPECT_EQ(step.participant, 1u);
  EXPECT_EQ(step.cpu, 1u);
  EXPECT_EQ(step.stage, 1);
}

TEST(DelayCauses, AStageBegunOnOneCpuAndEndedOnAnotherIsAMigration) {
  constructed_run built;
  built.arrive_late(80, 0, 0, 40'000);
  built.row(80, 0).stages[0].arrival_cpu = 1;  // woke on CPU 0, arrived on CPU 1
  built.row(80, 0).counters.run_queue_wait_ns = 5'000 + 10'000;
  const late_step step = attribute_step(built.run, 80);
  EXPECT_EQ(step.top, delay_cause::migration);
  EXPECT_EQ(step.participant, 0u);
  EXPECT_EQ(step.cpu, 1u) << "the CPU it arrived on";
  EXPECT_EQ(step.moved_from, 0u);
  EXPECT_NEAR(of(step, delay_cause::run_queue_wait), 0, 1) << "the move's wait is the move's";
}

TEST(DelayCauses, OnCpuTimeWithFreshFaultsIsPageFaults) {
  constructed_run built;
  built.arrive_late(90, 1, 1, 250'000);
  built.row(90, 1).counters.on_cpu_ns = 20'000 + 250'000;
  built.row(90, 1).counters.minor_faults = 256;
  const late_step step = attribute_step(built.run, 90);
  EXPECT_EQ(step.top, delay_cause::page_faults);
  EXPECT_EQ(step.participant, 1u);
  EXPECT_EQ(step.page_faults, 256);
}

TEST(DelayCauses, OnCpuTimeWithInterruptsOnItsCpuIsInterrupts) {
  constructed_run built;
  built.arrive_late(40, 1, 3, 100'000);
  built.row(40, 1).counters.on_cpu_ns = 20'000 + 100'000;
  built.run.record->interrupts[40 * 2 + 1] = 40;  // CPU 1's column
  const late_step step = attribute_step(built.run, 40);
  EXPECT_EQ(step.top, delay_cause::interrupts);
  EXPECT_EQ(step.cpu, 1u);
  EXPECT_EQ(step.interrupts, 37);
}

TEST(DelayCauses, ALateTimerWakeUpIsWakeUpLatency) {
  constructed_run built;
  for (unsigned p = 0; p < kParticipants; ++p) built.run.wakeup_ns[30 * kParticipants + p] += p == 1 ? 80'000 : 0;
  built.arrive_late(30, 1, 0, 80'000);  // its work took the usual time after the late wake-up
  // The guest's wake-up path at work: one more switch and eight more
  // interrupts on its CPU than usual, each worth up to one usual wake-up
  // (10 us): 90 us, more than the 80 us.
  built.row(30, 1).counters.switches = 2 + 1;
  built.run.record->interrupts[30 * 2 + 1] = 3 + 8;  // CPU 1's column
  const late_step step = attribute_step(built.run, 30);
  EXPECT_EQ(step.kind, part_kind::timer_wakeup);
  EXPECT_EQ(step.top, delay_cause::wakeup_latency);
  EXPECT_EQ(step.participant, 1u);
  EXPECT_DOUBLE_EQ(of(step, delay_cause::machine_stall), 0.0);
}

TEST(DelayCauses, AWakeUpLaterThanItsGuestEventsCanExplainIsMostlyAMachineStall) {
  // 25 ms late with five more switches and three more interrupts than usual:
  // eight events explain at most eight usual wake-ups (80 us); the rest is a
  // timer that fired while the vCPU did not run.
  constructed_run built;
  for (unsigned p = 0; p < kParticipants; ++p)
    built.run.wakeup_ns[30 * kParticipants + p] += p == 1 ? 25'000'000 : 0;
  built.arrive_late(30, 1, 0, 25'000'000);
  built.row(30, 1).counters.switches = 2 + 5;
  built.run.record->interrupts[30 * 2 + 1] = 3 + 3;
  const late_step step = attribute_step(built.run, 30);
  EXPECT_EQ(step.kind, part_kind::timer_wakeup);
  EXPECT_EQ(step.top, delay_cause::machine_stall);
  EXPECT_DOUBLE_EQ(of(step, delay_cause::wakeup_latency), 8 * kWake);
}

TEST(DelayCauses, ALateWakeUpNoGuestEventExplainsIsAMachineStall) {
  constructed_run built;
  for (unsigned p = 0; p < kParticipants; ++p) built.run.wakeup_ns[30 * kParticipants + p] += p == 1 ? 3'000'000 : 0;
  built.arrive_late(30, 1, 0, 3'000'000);  // slept 3 ms longer: no switch, no interrupt, no run-queue wait
  const late_step step = attribute_step(built.run, 30);
  EXPECT_EQ(step.kind, part_kind::timer_wakeup);
  EXPECT_EQ(step.top, delay_cause::machine_stall);
}

TEST(DelayCauses, TheTailTableSumsItsStepsAndNamesTheTopCause) {
  constructed_run built;
  built.arrive_late(60, 0, 3, 7'800'000);
  built.row(60, 0).counters.on_cpu_ns = 20'000 + 7'800'000;
  built.arrive_late(50, 1, 2, 200'000);
  built.row(50, 1).counters.switches = 2 + 1;
  const auto causes = attribute_delay(built.run, 5);
  ASSERT_TRUE(causes.unavailable.empty());
  ASSERT_FALSE(causes.tail.empty());
  EXPECT_EQ(causes.tail.front().label, "above p99");
  EXPECT_EQ(causes.tail.back().label, "maximum");
  EXPECT_EQ(causes.tail.back().steps, 1u);
  EXPECT_EQ(causes.tail.back().top, delay_cause::machine_stall);
  EXPECT_NEAR(causes.tail.back().explained_share, 1.0, 1e-9);
  EXPECT_NEAR(causes.tail.back().guest_share, 0.0, 1e-9) << "a machine stall is no guest event";
  ASSERT_GE(causes.worst.size(), 2u);
  EXPECT_EQ(causes.worst[0].period, 60);
  EXPECT_EQ(causes.worst[1].period, 50);
  ASSERT_TRUE(causes.misses.has_value()) << "7.8 ms is past the 1 ms deadline";
  EXPECT_EQ(causes.misses->steps, 1u);
}

TEST(DelayCauses, AStartDelayedByItsOwnOverrunInheritsItsCauses) {
  constructed_run built;
  built.arrive_late(20, 0, 3, 1'500'000);
  built.row(20, 0).counters.on_cpu_ns = 20'000 + 1'500'000;
  // Period 21 starts when period 20 ended, 0.5 ms after its target.
  for (unsigned p = 0; p < kParticipants; ++p) built.run.wakeup_ns[21 * kParticipants + p] = 530'000;
  for (unsigned p = 0; p < kParticipants; ++p)
    for (unsigned s = 0; s < 4; ++s) {
      built.row(21, p).stages[s].arrival_ns += 520'000;
      built.row(21, p).stages[s].departure_ns += 520'000;
    }
  for (unsigned p = 0; p < kParticipants; ++p) built.run.end_ns[21 * kParticipants + p] += 520'000;
  built.finish();
  const late_step step = attribute_step(built.run, 21);
  EXPECT_TRUE(step.inherited);
  EXPECT_EQ(step.top, delay_cause::machine_stall) << "period 20's cause";
}

TEST(DelayCauses, NoRecordIsSaid) {
  probes::paced_result run;
  run.completion_ns = {1, 2, 3};
  const auto causes = attribute_delay(run);
  EXPECT_FALSE(causes.unavailable.empty());
}

}  // namespace
