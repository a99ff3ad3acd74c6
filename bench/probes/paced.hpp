#pragma once
// The paced run of `lockstep delay`: a team of participants computes one step
// per period, each period started with an absolute clock_nanosleep, the way
// cyclictest paces its threads; the paper's "simple benchmark for determining
// delay in multi-core systems", with distributions instead of one number.
//
// Per period k (start = first period's start, target_k = start + k * period),
// every participant p:
//   sleeps with clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, target_k),
//   reads the clock:            wake-up latency = now - target_k
//                               (cyclictest's measure, on its clock),
//   runs one step (step_one(p, k): its share of the RK4 step, syncs included),
//   reads the clock again:      end_p.
// The period's completion time is max_p end_p - target_k, against the
// deadline target_k + period: a period whose step ends later is a deadline
// miss. A period that overran makes the next sleep return at once; its late
// start is then counted as that period's wake-up latency, as cyclictest does.
//
// Every participant sleeps on its own (no hand-off from a pacer thread), so a
// wake-up latency is the kernel's and the scheduler's alone, and a pinned
// single participant is measured exactly as `cyclictest -t1 -a CPU`.
//
// Per thread, the paper's Figure 5 counters (platform/thread_accounting.hpp):
// context switches and the share that crossed cores, from the run's start to
// its end, for each participant and for the thread that launched the team.
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "platform/clock.hpp"
#include "platform/placement.hpp"
#include "platform/scheduling.hpp"
#include "platform/thread_accounting.hpp"

namespace lockstep::bench::probes {

struct paced_settings {
  std::int64_t period_ns = 1'000'000;
  std::int64_t periods = 1000;
  std::optional<int> fifo_priority;  // SCHED_FIFO for every participant when set
  // The first period starts this long after the team is launched, so that
  // every participant has started, pinned itself and gone to sleep before it.
  std::int64_t lead_ns = 20'000'000;
};

struct paced_result {
  std::vector<double> wakeup_ns;      // periods x participants, every wake-up
  std::vector<double> completion_ns;  // one per period
  std::uint64_t deadline_misses = 0;
  platform::figure5_table figure5;    // "main" first, then "worker <id>"
  std::vector<std::string> errors;    // a participant that could not pin or go FIFO (it still ran)
};

// Sleeps until the absolute CLOCK_MONOTONIC time `target_ns` (restarted after
// a signal: an interrupted sleep must not end a period early).
inline void sleep_until(std::int64_t target_ns) noexcept {
  const timespec target = platform::to_timespec(target_ns);
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &target, nullptr) == EINTR) {
  }
}

// Runs `settings.periods` paced periods on `team` (sync::std_thread_team or
// sync::omp_team: team.run(body) calls body(id) for every participant).
//   prepare(id)   on participant id's thread first: pinning (may throw; the
//                 error is reported and the participant runs where it is,
//                 since leaving the team would strand the others in a sync);
//   step_one(id, k)  participant id's share of the step of period k (must
//                 not throw).
// Throws nothing itself; FIFO failures land in errors too, so check the
// permission before (platform::set_current_thread_fifo on the caller).
template <class Team, class Prepare, class StepOne>
paced_result run_paced(Team& team, unsigned participants, const paced_settings& settings, Prepare&& prepare,
                       StepOne&& step_one) {
  const auto periods = static_cast<std::size_t>(settings.periods);
  paced_result result;
  std::vector<std::int64_t> wake(periods * participants, 0);
  std::vector<std::int64_t> end(periods * participants, 0);
  std::vector<platform::thread_counters> deltas(participants);
  std::vector<std::string> errors(participants);

  const platform::thread_counters main_before = platform::snapshot_current_thread();
  const std::int64_t start = platform::now_ns() + settings.lead_ns;
  // Everything written before team.run happens-before every body, and every
  // body happens-before run returns (sync/team.hpp): the plain vectors need
  // no atomics, each participant writes only its own slots.
  team.run([&](unsigned id) {
    const platform::thread_counters before = platform::snapshot_current_thread();
    try {
      prepare(id);
      if (settings.fifo_priority) platform::set_current_thread_fifo(*settings.fifo_priority);
    } catch (const std::exception& e) {
      errors[id] = e.what();
    }
    for (std::size_t k = 0; k < periods; ++k) {
      const std::int64_t target = start + static_cast<std::int64_t>(k) * settings.period_ns;
      sleep_until(target);
      wake[k * participants + id] = platform::now_ns() - target;
      step_one(id, static_cast<std::uint64_t>(k));
      end[k * participants + id] = platform::now_ns() - target;
    }
    if (settings.fifo_priority) {
      try {
        platform::set_current_thread_normal();  // omp_team's participant 0 is the caller
      } catch (const std::exception&) {
      }
    }
    deltas[id] = platform::snapshot_current_thread() - before;
  });
  const platform::thread_counters main_delta = platform::snapshot_current_thread() - main_before;

  result.wakeup_ns.reserve(wake.size());
  for (std::int64_t ns : wake) result.wakeup_ns.push_back(static_cast<double>(ns));
  result.completion_ns.reserve(periods);
  for (std::size_t k = 0; k < periods; ++k) {
    const auto first = end.begin() + static_cast<std::ptrdiff_t>(k * participants);
    const std::int64_t completion = *std::max_element(first, first + participants);
    result.completion_ns.push_back(static_cast<double>(completion));
    if (completion > settings.period_ns) ++result.deadline_misses;
  }
  result.figure5.add("main", "main", main_delta);
  for (unsigned id = 0; id < participants; ++id) result.figure5.add("worker " + std::to_string(id), "worker", deltas[id]);
  for (unsigned id = 0; id < participants; ++id)
    if (!errors[id].empty()) result.errors.push_back("worker " + std::to_string(id) + ": " + errors[id]);
  return result;
}

// The paced RK4 step of `lockstep delay`: one sync x layout, `threads`
// participants placed by `plan`, paced by `settings`.
struct paced_step_settings {
  std::string sync;    // a name from sync/registry.hpp
  std::string layout;  // a name from layouts/registry.hpp
  unsigned threads = 4;
  paced_settings pacing;
};

// Why these settings cannot run, in one line ("unknown primitive 'x' (valid:
// ...)", "... does not run: <reason>"), or empty when they can. Checked by
// run_paced_step too; call it first to reject bad input before measuring.
std::string paced_step_problem(const std::string& sync, const std::string& layout, unsigned threads);

// Runs the paced step; throws std::invalid_argument with
// paced_step_problem's line when the settings cannot run. Moves a migrate
// plan's participants inside the period they are due in, so that the move's
// cost lands in that period's completion time.
paced_result run_paced_step(const paced_step_settings& settings, const platform::placement_plan& plan);

}  // namespace lockstep::bench::probes
