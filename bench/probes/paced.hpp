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
// Two shapes of run:
//  * a team (run_paced_step): the participants share one step and sync
//    inside it, the paper's model (4 participants by default); beyond four
//    participants the step is an s-mass chain's (kernels/model_choice.hpp);
//  * per CPU (run_paced_per_cpu): one participant pinned to each CPU, each
//    computing a two-mass step of its own (no one to wait for), as
//    `cyclictest -S` runs one thread per CPU. Its completion time and
//    deadline are then per participant.
//
// Stop on a threshold (paced_settings::stop_above_ns, cyclictest's -b): the
// first wake-up later than the threshold ends the run. Participants of a team
// must agree on the last period, or one would wait forever in a sync for a
// participant that has left. The late participant p, at period k, before it
// begins that period's step, stores S = k + stop_margin_periods into a shared
// word (1, in run_paced); every participant reads it at the top of each
// period (2) and leaves before period S. That is safe when no participant can
// finish period S - 1 without a publication p makes in period k or later:
// then nobody has begun S when (1) happens, and everybody sees (1) before it
// would begin S (the sync's release/acquire edges order (1) before the read).
// In the composed step a participant q finishes a step only after its four
// stage syncs; a publication by p reaches q through d(p, q) syncs (d: the
// distance in the producer -> consumer graph; 1 for a barrier), one stage
// each, so q's end of period k + m - 1 needs p's period-k publications when
// 4 m >= d: stop_margin_periods = max(1, ceil(d_max / 4)), which
// run_paced_step computes from the step's graph. Per-CPU participants share
// nothing and stop on their own. Either way the result keeps periods 0..k
// (every participant ran them): the late wake-up is the last sample.
//
// Stop after misses (paced_settings::stop_after_misses, for the period
// search: once a trial has failed, running it on cannot change its verdict):
// a participant whose step ends after its period's deadline has seen that
// period miss (the period's completion is the latest end); the first to
// record a period counts it (a high-water mark of counted periods, so a
// period is counted at most once; one reported out of order may go
// uncounted, which only delays the stop). When the count reaches the limit
// after period k's step, that participant stores S = k + 1 + margin before
// its next publication, the same protocol as above from period k + 1; the
// result keeps the S periods every participant ran.
//
// Per thread, the paper's Figure 5 counters (platform/thread_accounting.hpp):
// context switches and the share that crossed cores, from the run's start to
// its end, for each participant and for the thread that launched the team.
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <limits>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "kernels/model_choice.hpp"
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
  // End the run at the first wake-up later than this (see above).
  std::optional<std::int64_t> stop_above_ns;
  // How many periods after the late one the team leaves (see above); 0: the
  // participants cannot agree on an early end, so they run every period and
  // only the result stops at the late one.
  std::int64_t stop_margin_periods = 1;
  // Per-CPU runs: every participant is its own deadline (end_p > period is a
  // miss of p); a team: the period's latest end is the one deadline.
  bool independent = false;
  // End the run once this many periods have missed their deadline (a team
  // only; see above). Empty: run every period.
  std::optional<std::uint64_t> stop_after_misses;
};

// The first wake-up later than stop_above_ns, and what the step was doing.
struct paced_stop {
  std::int64_t period = 0;          // index of the late period (0-based)
  unsigned participant = 0;         // who woke late
  std::optional<unsigned> cpu;      // the CPU it woke on
  std::int64_t wakeup_ns = 0;       // how late it woke
  std::int64_t since_start_ns = 0;  // from the first period's start to that wake-up
  // The same participant's step in the period before: how long after that
  // period's start it ended (empty for period 0).
  std::optional<std::int64_t> previous_end_ns;
};

struct paced_result {
  unsigned participants = 0;
  std::int64_t periods = 0;           // periods kept: all, or up to and including a stop
  std::vector<double> wakeup_ns;      // periods x participants, period-major: [k * participants + p]
  std::vector<double> end_ns;         // each participant's step end from its period's start, same order
  // A team: one per period, the latest end. Independent participants: the
  // same as end_ns (each its own deadline).
  std::vector<double> completion_ns;
  std::uint64_t deadline_misses = 0;  // completion_ns above the period
  std::vector<std::optional<unsigned>> cpus;  // where each participant woke for its first period
  std::optional<paced_stop> stop;
  bool stopped_after_misses = false;  // stop_after_misses ended the run early
  platform::figure5_table figure5;    // "main" first, then "worker <id>"
  std::vector<std::string> errors;    // a participant that could not pin or go FIFO (it still ran)
};

// One participant's samples out of a period-major vector (wakeup_ns, end_ns).
inline std::vector<double> participant_samples(const std::vector<double>& samples, unsigned participants,
                                               unsigned participant) {
  std::vector<double> mine;
  if (participants == 0) return mine;
  mine.reserve(samples.size() / participants);
  for (std::size_t index = participant; index < samples.size(); index += participants) mine.push_back(samples[index]);
  return mine;
}

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
  result.participants = participants;
  std::vector<std::int64_t> wake(periods * participants, 0);
  std::vector<std::int64_t> end(periods * participants, 0);
  std::vector<std::optional<unsigned>> cpus(participants);
  std::vector<platform::thread_counters> deltas(participants);
  std::vector<std::string> errors(participants);

  // The agreed end (see the header): lowered by a late wake-up or by the
  // miss that reaches stop_after_misses, read once per period by everyone.
  // No stop: never below `periods`, so the read never ends a run early.
  std::atomic<std::int64_t> leave_before{std::numeric_limits<std::int64_t>::max()};
  // Lowers the agreed end to `period` (never raises it).
  const auto leave_before_period = [&leave_before](std::int64_t period) {
    std::int64_t agreed = leave_before.load(std::memory_order_relaxed);
    // (1) relaxed, sequenced before this participant's next publication: see
    // (2). The minimum wins when two participants ask at once.
    while (period < agreed &&
           !leave_before.compare_exchange_weak(agreed, period, std::memory_order_relaxed, std::memory_order_relaxed)) {
    }
  };
  std::mutex stop_mutex;  // guards `stop`: taken only on a late wake-up
  std::optional<paced_stop> stop;
  // Stop after misses: the last period counted, and how many were. Relaxed:
  // the count only decides when to ask for the end; the end itself is
  // agreed by (1) and (2).
  std::atomic<std::int64_t> last_counted_miss{-1};
  std::atomic<std::uint64_t> counted_misses{0};

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
    bool reported_late = false;
    for (std::size_t k = 0; k < periods; ++k) {
      // (2) relaxed: a team's sync edges order (1) before this read (header);
      // independent participants only need to see it eventually.
      if (static_cast<std::int64_t>(k) >= leave_before.load(std::memory_order_relaxed)) break;
      const std::int64_t target = start + static_cast<std::int64_t>(k) * settings.period_ns;
      sleep_until(target);
      const std::int64_t latency = platform::now_ns() - target;
      wake[k * participants + id] = latency;
      if (k == 0) cpus[id] = platform::current_cpu();
      if (settings.stop_above_ns && latency > *settings.stop_above_ns && !reported_late) {
        reported_late = true;
        const std::lock_guard lock(stop_mutex);
        if (!stop || stop->period > static_cast<std::int64_t>(k)) {
          stop = paced_stop{static_cast<std::int64_t>(k),
                            id,
                            platform::current_cpu(),
                            latency,
                            static_cast<std::int64_t>(k) * settings.period_ns + latency,
                            k == 0 ? std::nullopt : std::optional<std::int64_t>(end[(k - 1) * participants + id])};
          if (settings.stop_margin_periods > 0)
            leave_before_period(static_cast<std::int64_t>(k) + settings.stop_margin_periods);
        }
      }
      step_one(id, static_cast<std::uint64_t>(k));
      const std::int64_t ended = platform::now_ns() - target;
      end[k * participants + id] = ended;
      if (settings.stop_after_misses && settings.stop_margin_periods > 0 && ended > settings.period_ns) {
        const auto period = static_cast<std::int64_t>(k);
        std::int64_t counted = last_counted_miss.load(std::memory_order_relaxed);
        while (counted < period && !last_counted_miss.compare_exchange_weak(counted, period, std::memory_order_relaxed,
                                                                            std::memory_order_relaxed)) {
        }
        if (counted < period &&
            counted_misses.fetch_add(1, std::memory_order_relaxed) + 1 >= *settings.stop_after_misses)
          leave_before_period(period + 1 + settings.stop_margin_periods);
      }
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

  const std::int64_t agreed_end = leave_before.load(std::memory_order_relaxed);  // the team has joined
  std::size_t kept = periods;
  if (stop) {
    kept = static_cast<std::size_t>(stop->period) + 1;
  } else if (agreed_end < static_cast<std::int64_t>(periods)) {
    kept = static_cast<std::size_t>(agreed_end);
    result.stopped_after_misses = true;
  }
  result.periods = static_cast<std::int64_t>(kept);
  result.stop = stop;
  result.cpus = cpus;
  result.wakeup_ns.reserve(kept * participants);
  result.end_ns.reserve(kept * participants);
  for (std::size_t index = 0; index < kept * participants; ++index) {
    result.wakeup_ns.push_back(static_cast<double>(wake[index]));
    result.end_ns.push_back(static_cast<double>(end[index]));
  }
  if (settings.independent) {
    result.completion_ns = result.end_ns;
  } else {
    result.completion_ns.reserve(kept);
    for (std::size_t k = 0; k < kept; ++k) {
      const auto first = end.begin() + static_cast<std::ptrdiff_t>(k * participants);
      result.completion_ns.push_back(static_cast<double>(*std::max_element(first, first + participants)));
    }
  }
  for (double completion : result.completion_ns)
    if (completion > static_cast<double>(settings.period_ns)) ++result.deadline_misses;
  result.figure5.add("main", "main", main_delta);
  for (unsigned id = 0; id < participants; ++id) result.figure5.add("worker " + std::to_string(id), "worker", deltas[id]);
  for (unsigned id = 0; id < participants; ++id)
    if (!errors[id].empty()) result.errors.push_back("worker " + std::to_string(id) + ": " + errors[id]);
  return result;
}

// The paced RK4 step of `lockstep delay`: one sync x layout, `threads`
// participants placed by `plan` integrating `model`, paced by `settings`.
struct paced_step_settings {
  std::string sync;    // a name from sync/registry.hpp
  std::string layout;  // a name from layouts/registry.hpp
  unsigned threads = 4;
  // Which oscillator the team integrates: kernels::model_for(threads,
  // --masses) decides; the default is the paper's two-mass system.
  kernels::model_choice model;
  paced_settings pacing;  // stop_margin_periods and independent are set by the runs below
};

// Why these settings cannot run, in one line ("unknown primitive 'x' (valid:
// ...)", "... does not run: <reason>", e.g. more threads than the model has
// equations), or empty when they can. Checked by run_paced_step too; call it
// first to reject bad input before measuring.
std::string paced_step_problem(const std::string& sync, const std::string& layout, unsigned threads,
                               const kernels::model_choice& model);

// Runs the paced step; throws std::invalid_argument with
// paced_step_problem's line when the settings cannot run. Moves a migrate
// plan's participants inside the period they are due in, so that the move's
// cost lands in that period's completion time.
paced_result run_paced_step(const paced_step_settings& settings, const platform::placement_plan& plan);

// Why the per-CPU run cannot use this sync and layout (each CPU's thread runs
// a one-participant step on a plain thread; a primitive that needs a team of
// its own, such as OpenMP's, cannot), or empty.
std::string paced_per_cpu_problem(const std::string& sync, const std::string& layout);

// One participant pinned to each of `cpus` (OS indices), each computing its
// own one-participant step of settings.sync x settings.layout on the paper's
// two-mass system, like cyclictest's one thread per CPU (settings.threads and
// settings.model are ignored). Participant i runs on cpus[i]. Throws
// std::invalid_argument with paced_per_cpu_problem's line.
paced_result run_paced_per_cpu(const paced_step_settings& settings, std::span<const unsigned> cpus);

}  // namespace lockstep::bench::probes
