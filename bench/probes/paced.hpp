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
//
// The per-step record (paced_settings::recording; a team run only): for
// every period and participant, the arrival at and the departure from each
// stage's synchronisation (ns from the period's target, with the CPU read at
// each), the CPU it woke on and ended on, and its counters
// (platform/step_counters.hpp) over the window from the previous period's
// end to this one's (so a period's window holds its sleep, its wake-up and
// its step); and per CPU the interrupts and softirqs of the window between
// two reads. The last participant to end a period reads the counters of
// every participant, the interrupt tables, and its own counters again: its
// next window starts there, so that the reading lies in no window. What it
// costs on the measured path: per stage two clock reads and two
// sched_getcpu calls in the sync (stage_recorder, around the primitive's
// wait), and a CPU read after each step's end; the reads of the counters and
// tables come when nobody is stepping, outside the completion time.
// recording = alternate_blocks records every other block of periods, so
// that one run gives its cost as a pair (on against off).
// bench/delay/delay_report.hpp turns the record into causes.
#include <time.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <functional>
#include <limits>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "kernels/model_choice.hpp"
#include "kernels/rk4.hpp"
#include "platform/cache_line.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"
#include "platform/scheduling.hpp"
#include "platform/step_counters.hpp"
#include "platform/thread_accounting.hpp"

namespace lockstep::bench::probes {

// Whether a run keeps the per-step record (see the header).
enum class step_recording {
  off,
  every_period,
  alternate_blocks,  // on for recording_block_periods, off for as many, ...: the cost as a pair
};

// Called by a participant inside each stage, after its stage's work and
// before it arrives at the stage's synchronisation (its time lands in the
// participant's own part of the stage). A test hook: injected causes.
using stage_hook = std::function<void(unsigned participant, std::uint64_t period, unsigned stage)>;

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
  // The per-step record (a team run; see the header).
  step_recording recording = step_recording::off;
  std::int64_t recording_block_periods = 250;  // alternate_blocks: periods per block
  std::int64_t interrupt_every_periods = 1;    // the interrupt tables are read every N periods
  stage_hook hook;                             // empty: none
};

// The record keeps at most this many participant-periods (about 200 bytes
// each: 100 MB); a longer run keeps none and says so (step_record::not_kept).
inline constexpr std::int64_t kMaxRecordedParticipantPeriods = 500'000;

// One stage's synchronisation as one participant went through it; times in
// ns from the period's target, -1 where nothing was recorded.
struct stage_passage {
  std::int64_t arrival_ns = -1;    // entered the sync (after its stage's work)
  std::int64_t departure_ns = -1;  // left it (released)
  std::int32_t arrival_cpu = -1;
  std::int32_t departure_cpu = -1;
};

// One participant's period.
struct participant_period {
  bool recorded = false;         // false: recording was off for this period
  bool counters_valid = false;   // the window began at the previous period's end (recorded too; never period 0)
  std::int32_t wake_cpu = -1;    // read right after the wake-up
  std::int32_t end_cpu = -1;     // read right after the step's end
  std::array<stage_passage, kernels::kRk4Stages> stages{};
  // Over the window from the previous period's end to this one's (after the
  // run: a difference; during it the snapshot itself).
  platform::thread_step_counters counters;
  // The last participant to end the period: its counters again after it
  // read everyone's and the interrupt tables; its next window starts here,
  // so that the reading lies in no window (during the run only).
  std::optional<platform::thread_step_counters> resumed;
};

struct step_record {
  unsigned participants = 0;
  std::int64_t periods = 0;
  std::int64_t period_ns = 0;
  // Whose arrival each participant's departure waits for at every stage:
  // every other participant for a barrier; its producers for a channel.
  std::vector<std::vector<unsigned>> waits_for;
  // participant-major, [p * periods + k]: a participant writes a run of its
  // own, so participants never write the same cache line while they step.
  std::vector<participant_period> steps;
  // Per CPU, the interrupts and softirqs over the window that ends at the
  // last participant's step end of period k (read every interrupt_every
  // periods; -1: not read then, or unavailable): [k * cpus.size() + c].
  std::vector<unsigned> cpus;
  std::vector<std::int64_t> interrupts;
  std::vector<std::int64_t> softirqs;
  std::int64_t interrupt_every = 1;
  bool schedstat_available = false;
  bool interrupts_available = false;
  double snapshot_cost_ns = 0;        // one participant's counters, median (platform::snapshot_cost_ns)
  double interrupt_read_cost_ns = 0;  // one read of both interrupt tables
  step_recording mode = step_recording::off;
  std::int64_t block_periods = 0;     // alternate_blocks
  std::string not_kept;               // why no record was kept (too many periods), or empty

  participant_period& at(std::int64_t period, unsigned participant) noexcept {
    return steps[static_cast<std::size_t>(participant) * static_cast<std::size_t>(periods) +
                 static_cast<std::size_t>(period)];
  }
  const participant_period& at(std::int64_t period, unsigned participant) const noexcept {
    return steps[static_cast<std::size_t>(participant) * static_cast<std::size_t>(periods) +
                 static_cast<std::size_t>(period)];
  }
  // The CPU column of `cpu` in `cpus`, or empty.
  std::optional<std::size_t> cpu_column(unsigned cpu) const noexcept {
    for (std::size_t column = 0; column < cpus.size(); ++column)
      if (cpus[column] == cpu) return column;
    return std::nullopt;
  }
};

// Where the synchronisations a step makes report arrivals and departures
// (bench/probes/paced.cpp wraps the primitive so that it does). Each
// participant has a slot of its own line pair, written only by its thread.
class stage_recorder {
 public:
  explicit stage_recorder(unsigned participants, stage_hook hook = {}) : slots_(participants), hook_(std::move(hook)) {}

  // Participant p begins period k whose target is `target_ns`; `row` is
  // where its passages go (nullptr: recording off for this period).
  void begin_period(unsigned participant, std::uint64_t period, std::int64_t target_ns,
                    participant_period* row) noexcept {
    slot& mine = slots_[participant];
    mine.row = row;
    mine.period = period;
    mine.target_ns = target_ns;
    mine.stage = 0;
    mine.open = false;
  }

  // A barrier's wait: one per stage.
  void arrive(unsigned participant) { enter(participant, slots_[participant].stage); }
  void depart(unsigned participant) noexcept {
    slot& mine = slots_[participant];
    leave(mine);
    ++mine.stage;
    mine.open = false;
  }
  // A channel's publish and receives: stage `stage_in_step`; the first call
  // of a stage is the arrival, the end of each call a departure (the last
  // one stays).
  void channel_call_begins(unsigned participant, unsigned stage_in_step) {
    slot& mine = slots_[participant];
    if (!mine.open || mine.stage != stage_in_step) {
      enter(participant, stage_in_step);
      leave(mine);  // a stage with no receive leaves when it arrives
    }
  }
  void channel_call_ends(unsigned participant) noexcept { leave(slots_[participant]); }

 private:
  struct alignas(platform::kPrefetchPair) slot {
    participant_period* row = nullptr;
    std::uint64_t period = 0;
    std::int64_t target_ns = 0;
    unsigned stage = 0;
    bool open = false;  // the stage's arrival is recorded
  };

  void enter(unsigned participant, unsigned stage) {
    slot& mine = slots_[participant];
    if (hook_) hook_(participant, mine.period, stage);
    mine.stage = stage;
    mine.open = true;
    if (mine.row == nullptr || stage >= kernels::kRk4Stages) return;
    stage_passage& passage = mine.row->stages[stage];
    passage.arrival_ns = platform::now_ns() - mine.target_ns;
    passage.arrival_cpu = cpu_now();
  }
  static void leave(slot& mine) noexcept {
    if (mine.row == nullptr || mine.stage >= kernels::kRk4Stages) return;
    stage_passage& passage = mine.row->stages[mine.stage];
    passage.departure_ns = platform::now_ns() - mine.target_ns;
    passage.departure_cpu = cpu_now();
  }
  static std::int32_t cpu_now() noexcept {
    const auto cpu = platform::current_cpu();
    return cpu ? static_cast<std::int32_t>(*cpu) : -1;
  }

  std::vector<slot> slots_;
  stage_hook hook_;
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
  std::optional<step_record> record;  // with paced_settings::recording (a team run)
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

// After a run: keeps the record's first `kept` periods, turns each
// participant's snapshots into differences over its windows (a period whose
// previous period was not recorded has counters_valid false), and the
// interrupt reads into per-CPU differences between consecutive reads.
void finish_record(step_record& record, std::size_t kept,
                   const std::vector<platform::thread_step_counters>& first_snapshot,
                   const platform::cpu_interrupt_totals& interrupt_start,
                   const std::vector<platform::cpu_interrupt_totals>& interrupt_reads);

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
//   recorder      where the step's synchronisations report their passages
//                 (with settings.recording; nullptr: no per-stage times,
//                 the counters are still recorded).
template <class Team, class Prepare, class StepOne>
paced_result run_paced(Team& team, unsigned participants, const paced_settings& settings, Prepare&& prepare,
                       StepOne&& step_one, stage_recorder* recorder = nullptr) {
  const auto periods = static_cast<std::size_t>(settings.periods);
  paced_result result;
  result.participants = participants;

  // The per-step record, allocated and touched here, before the run.
  std::optional<step_record> record;
  std::vector<platform::cpu_interrupt_totals> interrupt_reads;  // at the last participant's end of period k
  platform::cpu_interrupt_totals interrupt_start;                // before its first period
  std::vector<platform::thread_step_counters> first_snapshot(participants);
  if (settings.recording != step_recording::off) {
    record.emplace();
    record->participants = participants;
    record->period_ns = settings.period_ns;
    record->mode = settings.recording;
    record->block_periods = std::max<std::int64_t>(settings.recording_block_periods, 1);
    record->interrupt_every = std::max<std::int64_t>(settings.interrupt_every_periods, 1);
    if (settings.periods * participants > kMaxRecordedParticipantPeriods) {
      record->not_kept = "the run has " + std::to_string(settings.periods * participants) +
                         " participant-periods, more than the record keeps (" +
                         std::to_string(kMaxRecordedParticipantPeriods) + ")";
    } else {
      record->periods = settings.periods;
      record->steps.resize(periods * participants);
      interrupt_reads.resize(periods);
    }
    record->snapshot_cost_ns = platform::snapshot_cost_ns(101);
    record->interrupt_read_cost_ns = platform::interrupt_read_cost_ns(11);
  }
  const bool keep_record = record && record->not_kept.empty();
  const auto records_period = [&](std::size_t k) {
    if (!keep_record) return false;
    if (settings.recording == step_recording::every_period) return true;
    return (static_cast<std::int64_t>(k) / record->block_periods) % 2 == 0;
  };
  // Set by any participant, read after the team is joined: the join orders
  // them, so relaxed (the flags carry no data of their own).
  std::atomic<bool> schedstat_seen{false};
  std::atomic<bool> interrupts_seen{false};
  // How many participants have ended each period: the last one reads
  // everyone's counters and the interrupt tables, so that nobody's end
  // waits behind the reads.
  std::vector<std::atomic<unsigned>> periods_ended(keep_record ? periods : 0);
  // Each participant's counters, opened on its own thread (/proc/thread-self
  // is the opener) before its first period; the last participant to end a
  // period reads everyone's counters through them (its periods_ended
  // acquire orders each emplace before that read).
  std::vector<std::optional<platform::thread_counter_reader>> counter_readers(keep_record ? participants : 0);
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
    // Opened on this thread (after the pin): /proc/thread-self is the opener.
    std::optional<platform::thread_counter_reader>* counters = keep_record ? &counter_readers[id] : nullptr;
    std::optional<platform::interrupt_reader> interrupts;
    if (keep_record) {
      counters->emplace();
      if ((*counters)->schedstat_available()) schedstat_seen.store(true, std::memory_order_relaxed);
      interrupts.emplace();  // one per participant: two periods' last participants may read at once
      if (interrupts->available()) interrupts_seen.store(true, std::memory_order_relaxed);
      first_snapshot[id] = (*counters)->read();
      if (id == 0 && interrupts->available()) interrupt_start = interrupts->read();
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
      participant_period* row = records_period(k) ? &record->at(static_cast<std::int64_t>(k), id) : nullptr;
      if (row != nullptr) {
        const auto cpu = platform::current_cpu();
        row->wake_cpu = cpu ? static_cast<std::int32_t>(*cpu) : -1;
      }
      if (recorder != nullptr) recorder->begin_period(id, k, target, row);
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
      if (row != nullptr) {
        // After the end was read: outside the completion time. Nothing
        // slower than a CPU read here: a participant sharing a CPU with one
        // still stepping would delay it.
        row->recorded = true;
        const auto cpu = platform::current_cpu();
        row->end_cpu = cpu ? static_cast<std::int32_t>(*cpu) : -1;
        // acq_rel: each participant's increment releases its row of this
        // period (and its reader), and the last one's acquires every
        // other's, so its reads below come after every end of the period
        // and its writes into the others' rows after theirs.
        const bool last = periods_ended[k].fetch_add(1, std::memory_order_acq_rel) + 1 == participants;
        if (last) {
          // Everyone's counters, then the interrupt tables, by the last to
          // end: nobody still stepping waits behind them. Then its own
          // again: its next window starts after the reading.
          for (unsigned other = 0; other < participants; ++other)
            record->at(static_cast<std::int64_t>(k), other).counters = counter_readers[other]->read();
          if (interrupts->available() && static_cast<std::int64_t>(k) % record->interrupt_every == 0)
            interrupt_reads[k] = interrupts->read();
          row->resumed = (*counters)->read();
        }
      }
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
  if (record) {
    if (keep_record) finish_record(*record, kept, first_snapshot, interrupt_start, interrupt_reads);
    record->schedstat_available = schedstat_seen.load(std::memory_order_relaxed);
    record->interrupts_available = interrupts_seen.load(std::memory_order_relaxed);
    result.record = std::move(record);
  }
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
