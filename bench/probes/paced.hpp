#pragma once
// The paced run of `lockstep delay`: a team of participants computes one step
// per period, each period started with an absolute clock_nanosleep, the way
// cyclictest paces its threads; the paper's "simple benchmark for determining
// delay in multi-core systems", with distributions instead of one number.
//
// The schedule: period j starts at target_j = start + j * period, for j in
// 0..periods-1. Step k (0, 1, ...) runs in a period j_k (j_0 = 0); in it
// every participant p:
//   sleeps with clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, target_j),
//   reads the clock:            wake-up latency = now - target_j
//                               (cyclictest's measure, on its clock),
//   runs one step (step_one(p, k): its share of the RK4 step, syncs included),
//   reads the clock again:      end_p.
// The step's completion time is max_p end_p - target_j, against the deadline
// target_j + period: a step that ends later overran its period, a deadline
// miss. The next step runs in the first period that starts at or after the
// step's end, and never before the next one:
//   j_(k+1) = j_k + max(1, ceil(completion / period))      (next_period)
// and the periods between are skipped (counted: paced_result::skipped_periods).
// That is how a real-time loop re-anchors after an overrun (cyclictest moves
// its next wake-up past `now` the same way): a wake-up latency is always of
// its own period, never the backlog of a schedule that fell behind, and a run
// of `periods` periods lasts their length whatever its steps take. The run
// ends when the next period would be the `periods`-th or later.
//
// A team agrees on each j_k: after its step, each participant counts itself
// ended (steps_ended, acq_rel: (3) in paced.cpp); the last to end reads every
// end of the step, decides j_(k+1) from the latest and stores it (4); the
// others sleep until the period after their own end (its start is never
// later than the decided one's: the decision takes the latest end), read the
// decision (5), and sleep on to it when it is later. One that finds no
// decision yet (the last participant has not ended: its step overran, or it
// was preempted between its end and its count) waits for it (an atomic wait
// that the decision's notify ends); its wake-up latency stays the one it
// read after its sleep. So every participant runs step k in period j_k, and
// none begins step k + 1 before all have ended step k. Independent (per-CPU)
// participants decide alone, each from its own end.
//
// Every participant sleeps on its own (no hand-off from a pacer thread), so a
// wake-up latency is the kernel's and the scheduler's alone, and a pinned
// single participant is measured exactly as `cyclictest -t1 -a CPU`. Each
// shared word below is indexed by step, and "period" in the settings' names
// is the schedule's.
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
// must agree on the last step, or one would wait forever in a sync for a
// participant that has left. The late participant p, at step k, before it
// begins that step, stores S = k + stop_margin_periods into a shared word
// (1, paced_run_state::leave_before in paced.cpp); every participant reads
// it at the top of each step (2, runs_step) and leaves before step S. That
// is safe when no participant can finish step S - 1 without a publication p
// makes in step k or later: then nobody has begun S when (1) happens, and
// everybody sees (1) before it would begin S (the sync's release/acquire
// edges order (1) before the read). In the composed step a participant q
// finishes a step only after its four stage syncs; a publication by p
// reaches q through d(p, q) syncs (d: the distance in the producer ->
// consumer graph; 1 for a barrier), one stage each, so q's end of step
// k + m - 1 needs p's step-k publications when 4 m >= d: stop_margin_periods
// = max(1, ceil(d_max / 4)), which run_paced_step computes from the step's
// graph. Per-CPU participants share nothing and stop on their own; there S
// is a period of the schedule (the late one's + 1), since each runs its
// steps in periods of its own. Either way the result keeps the steps up to
// the late one (every participant ran them): the late wake-up is the last
// sample.
//
// Stop after misses (paced_settings::stop_after_misses, for the period
// search: once a trial has failed, running it on cannot change its verdict;
// a team only): a miss is a period whose deadline passed without its step
// done, so a step that overran counts one, and each period it made the
// schedule skip one more. The last participant to end step k, who decides
// j_(k+1), counts them (each step once, by one participant). When the count
// reaches the limit, it stores S = k + 1 + margin before its next
// publication, the same protocol as above from step k + 1; the result keeps
// the S steps every participant ran.
//
// Per thread, the paper's Figure 5 counters (platform/thread_accounting.hpp):
// context switches and the share that crossed cores, from the run's start to
// its end, for each participant and for the thread that launched the team.
//
// The per-step record (paced_settings::recording; a team run only): for
// every step and participant, the arrival at and the departure from each
// stage's synchronisation (ns from the step's target, with the CPU read at
// each), the CPU it woke on and ended on, and its counters
// (platform/step_counters.hpp) over the window from the previous step's
// end to this one's (so a step's window holds its sleep, its wake-up and
// the step); and per CPU the interrupts and softirqs of the window between
// two reads. The last participant to end a step reads the counters of
// every participant, the interrupt tables, and its own counters again: its
// next window starts there, so that the reading lies in no window. What it
// costs on the measured path: per stage two clock reads and two
// sched_getcpu calls in the sync (stage_recorder, around the primitive's
// wait), and a CPU read after each step's end; the reads of the counters and
// tables come when nobody is stepping, outside the completion time.
// recording = alternate_blocks records every other block of steps, so
// that one run gives its cost as a pair (on against off).
// bench/delay/attribution.hpp turns the record into causes.
#include <time.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <exception>
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

// How far a run is, for a progress line written by another thread while it
// goes on. Relaxed, each word: a figure of its own, read on its own; nothing
// else is read on its strength.
struct paced_progress {
  std::atomic<std::int64_t> periods{0};    // periods of the schedule behind the run (before its latest step's)
  std::atomic<std::uint64_t> overran{0};   // steps that overran their period
  std::atomic<std::uint64_t> skipped{0};   // periods skipped after them
};

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
  paced_progress* progress = nullptr;          // where the run says how far it is (null: nowhere)
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
  std::int64_t period = 0;          // the late step's period of the schedule (0-based)
  std::int64_t step = 0;            // and its index among the participant's steps
  unsigned participant = 0;         // who woke late
  std::optional<unsigned> cpu;      // the CPU it woke on
  std::int64_t wakeup_ns = 0;       // how late it woke
  std::int64_t since_start_ns = 0;  // from the first period's start to that wake-up
  // The same participant's step before: how long after its own period's
  // start it ended (empty for the first step).
  std::optional<std::int64_t> previous_end_ns;
};

struct paced_result {
  unsigned participants = 0;
  // Steps kept: a team's, every step run or up to and including a stop;
  // independent participants: the most any one kept (steps_run has each).
  std::int64_t periods = 0;
  // The samples. A team: steps x participants, step-major, [k * participants
  // + p]. Independent participants, who may run different numbers of steps:
  // participant-major, participant p's steps_run[p] one after another.
  // samples_of takes one participant's either way.
  std::vector<double> wakeup_ns;
  std::vector<double> end_ns;         // each participant's step end from its period's start, same order
  std::vector<std::int64_t> period_index;  // the period of the schedule each sample's step ran in, same order
  // A team: one per step, the latest end. Independent participants: the
  // same as end_ns (each its own deadline).
  std::vector<double> completion_ns;
  std::uint64_t deadline_misses = 0;  // completion_ns above the period: the steps that overran
  bool independent = false;
  std::vector<std::int64_t> steps_run;  // per participant, the steps kept
  // The periods of the schedule the kept steps span, from period 0 to the
  // one the next step would have run in (a run to its end: all of them), and
  // how many of them no step ran in: after an overrun the schedule re-anchors
  // at the next period boundary (see the header). Independent participants:
  // the longest span, and the skipped periods of all of them.
  std::int64_t periods_scheduled = 0;
  std::uint64_t skipped_periods = 0;
  std::vector<std::uint64_t> skipped_by_participant;  // each one's (a team: the same for all)
  std::vector<std::optional<unsigned>> cpus;  // where each participant woke for its first period
  std::optional<paced_stop> stop;
  bool stopped_after_misses = false;  // stop_after_misses ended the run early
  platform::figure5_table figure5;    // "main" first, then "worker <id>"
  std::vector<std::string> errors;    // a participant that could not pin or go FIFO (it still ran)
  std::optional<step_record> record;  // with paced_settings::recording (a team run)
};

// One participant's samples out of a step-major vector (a team's wakeup_ns, end_ns).
template <class T>
std::vector<T> participant_samples(const std::vector<T>& samples, unsigned participants, unsigned participant) {
  std::vector<T> mine;
  if (participants == 0) return mine;
  mine.reserve(samples.size() / participants);
  for (std::size_t index = participant; index < samples.size(); index += participants) mine.push_back(samples[index]);
  return mine;
}

// Participant p's samples of `run` (its wakeup_ns, end_ns, period_index, or
// an independent run's completion_ns), in the order of its steps.
template <class T>
std::vector<T> samples_of(const paced_result& run, const std::vector<T>& samples, unsigned participant) {
  if (!run.independent) return participant_samples(samples, run.participants, participant);
  std::size_t first = 0;
  for (unsigned before = 0; before < participant && before < run.steps_run.size(); ++before)
    first += static_cast<std::size_t>(run.steps_run[before]);
  if (participant >= run.steps_run.size() || first >= samples.size()) return {};
  const std::size_t last = std::min(samples.size(), first + static_cast<std::size_t>(run.steps_run[participant]));
  return std::vector<T>(samples.begin() + static_cast<std::ptrdiff_t>(first),
                        samples.begin() + static_cast<std::ptrdiff_t>(last));
}

// The period of the schedule the next step runs in, after a step that ran in
// `period` and completed `completion_ns` after that period's start: the
// first period that starts at or after the step's end, and never before the
// next one (the periods between are skipped). See the header.
constexpr std::int64_t next_period(std::int64_t period, std::int64_t completion_ns, std::int64_t period_ns) noexcept {
  if (completion_ns <= period_ns) return period + 1;
  return period + (completion_ns + period_ns - 1) / period_ns;
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

// An atomic fetch-min (C++26 gives std::atomic one): lowers `word` to
// `value` when `value` is below it, and returns what `word` held before, so
// that the caller knows whether it lowered it. `order` is the order of the
// read-modify-write that lowers the word; the loads before it take the
// matching acquire or relaxed order. The caller's comment names the edge
// `order` pairs with. A compare-and-swap loop: it ends once the word is at
// `value` or below, whoever lowered it there.
template <class T>
T fetch_min(std::atomic<T>& word, T value, std::memory_order order) noexcept {
  const std::memory_order load = order == std::memory_order_release   ? std::memory_order_relaxed
                                 : order == std::memory_order_acq_rel ? std::memory_order_acquire
                                                                      : order;
  T held = word.load(load);
  while (value < held && !word.compare_exchange_weak(held, value, order, load)) {
  }
  return held;
}

// One participant's part of a paced run, kept on its own thread.
struct paced_participant {
  explicit paced_participant(unsigned participant) : id(participant) {}
  unsigned id = 0;
  std::int64_t period = 0;     // the period of the schedule its current step runs in
  std::int64_t target_ns = 0;  // that period's start
  std::int64_t woke_ns = 0;    // when its sleep to it returned
  std::int64_t ended_ns = 0;   // its current step's end, from target_ns
  participant_period* row = nullptr;  // this step's row of the record, or null
  // One per participant: two steps' last participants may read at once.
  std::optional<platform::interrupt_reader> interrupts;
  bool reported_late = false;
  std::int64_t steps = 0;  // steps it ran
};

// What run_paced keeps apart from the team and the step (bench/probes/paced.cpp
// holds the definitions): the samples and the record, set up before the run;
// the schedule a team agrees on, step by step (3), (4), (5); each step's
// wake-up and end as a participant sees them; the agreed end (1) and (2);
// the reads of the last participant to end a step; the result. Every member
// a participant calls is called on its own thread, and writes only its own
// slots, or the shared words named with their orders.
class paced_run_state {
 public:
  // Allocates and touches the samples, the schedule's words and the record
  // (settings.recording), and measures what one read of the counters and the
  // interrupt tables costs: all before the run.
  paced_run_state(unsigned participants, const paced_settings& settings);
  paced_run_state(const paced_run_state&) = delete;
  paced_run_state& operator=(const paced_run_state&) = delete;

  // The first period starts settings.lead_ns from now.
  void start() noexcept;
  // A participant that could not pin or go FIFO (it still runs).
  void failed(unsigned participant, std::string what);
  // On the participant's thread, after its prepare: its counters and its
  // interrupt reader are opened there (/proc/thread-self is the opener).
  void open(paced_participant& self);
  // Whether step k runs, and if so the participant asleep until its period:
  // false once the team agreed to leave (2) or the schedule has no period
  // left for it. Records the wake-up; a wake-up later than stop_above_ns
  // asks for the end (1).
  bool wake(paced_participant& self, std::size_t k, stage_recorder* recorder);
  // After the step: records its end; the last participant to end the step
  // decides the next period (4) and reads everyone's counters.
  void end(paced_participant& self, std::size_t k);
  // The participant's Figure 5 counters over its run.
  void left(const paced_participant& self, const platform::thread_counters& delta);
  // After the team has joined: the result (main_delta: the launching thread's counters).
  paced_result result(const platform::thread_counters& main_delta);

 private:
  bool runs_step(std::size_t k) const noexcept;
  std::optional<std::int64_t> next_team_period(paced_participant& self, std::size_t k);
  std::int64_t decided_period(std::size_t step);
  void sleep_to(paced_participant& self, std::int64_t period);
  void record_wake(paced_participant& self, std::size_t k, stage_recorder* recorder);
  void check_late(paced_participant& self, std::size_t k, std::int64_t latency);
  void decide(paced_participant& self, std::size_t k);
  void count(const paced_participant& self, std::size_t k, std::int64_t next, std::int64_t completion_ns);
  bool records_step(std::size_t k) const noexcept;
  void read_counters(paced_participant& self, std::size_t k);
  void leave_before(std::int64_t index);
  void keep_team_samples(paced_result& result);
  void keep_independent_samples(paced_result& result);

  const paced_settings& settings_;
  unsigned participants_ = 0;
  std::size_t periods_ = 0;  // of the schedule; no participant runs more steps
  std::int64_t start_ns_ = 0;

  // The per-step record and what turns it into differences after the run.
  bool keep_record_ = false;
  std::optional<step_record> record_;
  std::vector<platform::cpu_interrupt_totals> interrupt_reads_;  // at the last participant's end of step k
  platform::cpu_interrupt_totals interrupt_start_;                // before its first step
  std::vector<platform::thread_step_counters> first_snapshot_;
  // Set by any participant, read after the team is joined: the join orders
  // them, so relaxed (the flags carry no data of their own).
  std::atomic<bool> schedstat_seen_{false};
  std::atomic<bool> interrupts_seen_{false};
  // Each participant's counters, opened on its own thread (/proc/thread-self
  // is the opener) before its first step; the last participant to end a
  // step reads everyone's counters through them (its steps_ended_ acquire
  // orders each emplace before that read).
  std::vector<std::optional<platform::thread_counter_reader>> counter_readers_;

  // The schedule a team agrees on (the header, and (3) to (5) in paced.cpp):
  // per step, how many participants have ended it, and the period the next
  // step runs in (0 until the last to end it decides).
  std::vector<std::atomic<unsigned>> steps_ended_;
  std::vector<std::atomic<std::int64_t>> next_period_;

  // The samples: steps x participants, step-major, each participant its own
  // slots (independent participants' own next period too).
  std::vector<std::int64_t> wake_;
  std::vector<std::int64_t> end_;
  std::vector<std::int64_t> period_;
  std::vector<std::int64_t> own_next_;
  std::vector<std::int64_t> steps_;
  std::vector<std::optional<unsigned>> cpus_;
  std::vector<platform::thread_counters> deltas_;
  std::vector<std::string> errors_;

  // The agreed end (see the header): a step of a team, a period of the
  // schedule for independent participants; lowered by a late wake-up or by
  // the miss that reaches stop_after_misses, read once per step by everyone.
  // No stop: never below `periods`, so the read never ends a run early.
  std::atomic<std::int64_t> leave_before_{std::numeric_limits<std::int64_t>::max()};
  std::mutex stop_mutex_;  // guards stop_: taken only on a late wake-up
  std::optional<paced_stop> stop_;
  // Stop after misses: how many periods missed so far, counted by each
  // step's decider. Relaxed: the count only decides when to ask for the
  // end; the end itself is agreed by (1) and (2).
  std::atomic<std::uint64_t> counted_misses_{0};
};

// Runs paced steps on `team` (sync::std_thread_team or sync::omp_team:
// team.run(body) calls body(id) for every participant) over the
// `settings.periods` periods of the schedule (see the header).
//   prepare(id)   on participant id's thread first: pinning (may throw; the
//                 error is reported and the participant runs where it is,
//                 since leaving the team would strand the others in a sync);
//   step_one(id, k)  participant id's share of step k (must not throw).
// Throws nothing itself; FIFO failures land in errors too, so check the
// permission before (platform::set_current_thread_fifo on the caller).
//   recorder      where the step's synchronisations report their passages
//                 (with settings.recording; nullptr: no per-stage times,
//                 the counters are still recorded).
template <class Team, class Prepare, class StepOne>
paced_result run_paced(Team& team, unsigned participants, const paced_settings& settings, Prepare&& prepare,
                       StepOne&& step_one, stage_recorder* recorder = nullptr) {
  paced_run_state state(participants, settings);
  const platform::thread_counters main_before = platform::snapshot_current_thread();
  state.start();
  // Everything written before team.run happens-before every body, and every
  // body happens-before run returns (sync/team.hpp): the state's plain
  // vectors need no atomics, each participant writes only its own slots.
  team.run([&](unsigned id) {
    const platform::thread_counters before = platform::snapshot_current_thread();
    try {
      prepare(id);
      if (settings.fifo_priority) platform::set_current_thread_fifo(*settings.fifo_priority);
    } catch (const std::exception& e) {
      state.failed(id, e.what());
    }
    paced_participant self(id);
    state.open(self);
    for (std::size_t k = 0; state.wake(self, k, recorder); ++k) {
      step_one(id, static_cast<std::uint64_t>(k));
      state.end(self, k);
    }
    if (settings.fifo_priority) {
      try {
        platform::set_current_thread_normal();  // omp_team's participant 0 is the caller
      } catch (const std::exception&) {
      }
    }
    state.left(self, platform::snapshot_current_thread() - before);
  });
  return state.result(platform::snapshot_current_thread() - main_before);
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
