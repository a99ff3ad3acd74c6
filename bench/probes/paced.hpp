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
// word (1, paced_run_state::leave_before_period in paced.cpp); every
// participant reads it at the top of each period (2, runs_period) and leaves before period S. That is safe when no participant can
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

// An atomic fetch-min (C++26 gives std::atomic one): moves `word` to `value`
// when `value` comes first under `before` (std::less: lowers it to the
// minimum; std::greater: raises it to the maximum), and returns what `word`
// held before, so that the caller knows whether it moved it. `order` is the
// order of the read-modify-write that moves the word; the loads before it
// take the matching acquire or relaxed order. The caller's comment names the
// edge `order` pairs with. A compare-and-swap loop: it ends once the word
// is at `value` or beyond it, whoever moved it there.
template <class T, class Before = std::less<T>>
T fetch_min(std::atomic<T>& word, T value, std::memory_order order, Before before = {}) noexcept {
  const std::memory_order load = order == std::memory_order_release   ? std::memory_order_relaxed
                                 : order == std::memory_order_acq_rel ? std::memory_order_acquire
                                                                      : order;
  T held = word.load(load);
  while (before(value, held) && !word.compare_exchange_weak(held, value, order, load)) {
  }
  return held;
}

// One participant's part of a paced run, kept on its own thread.
struct paced_participant {
  explicit paced_participant(unsigned participant) : id(participant) {}
  unsigned id = 0;
  std::int64_t target_ns = 0;  // this period's target
  participant_period* row = nullptr;  // this period's row of the record, or null
  // One per participant: two periods' last participants may read at once.
  std::optional<platform::interrupt_reader> interrupts;
  bool reported_late = false;
};

// What run_paced keeps apart from the team and the step (bench/probes/paced.cpp
// holds the definitions): the samples and the record, set up before the run;
// each period's wake-up and end as a participant sees them; the agreed end (1)
// and (2); the reads of the last participant to end a period; the result.
// Every member a participant calls is called on its own thread, and writes
// only its own slots, or the shared words named with their orders.
class paced_run_state {
 public:
  // Allocates and touches the samples and the record (settings.recording),
  // and measures what one read of the counters and the interrupt tables
  // costs: all before the run.
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
  // Whether period k runs: (2), the agreed end is later.
  bool runs_period(std::size_t k) const noexcept;
  // Sleeps until period k's target and records the wake-up; a wake-up later
  // than stop_above_ns asks for the end (1).
  void wake(paced_participant& self, std::size_t k, stage_recorder* recorder);
  // After the step: records its end; the last participant to end the period
  // reads everyone's counters; a miss is counted for stop_after_misses.
  void end(paced_participant& self, std::size_t k);
  // The participant's Figure 5 counters over its run.
  void left(unsigned participant, const platform::thread_counters& delta);
  // After the team has joined: the result (main_delta: the launching thread's counters).
  paced_result result(const platform::thread_counters& main_delta);

 private:
  bool records_period(std::size_t k) const noexcept;
  void read_counters(paced_participant& self, std::size_t k);
  void leave_before_period(std::int64_t period);
  void count_miss(std::int64_t period);

  const paced_settings& settings_;
  unsigned participants_ = 0;
  std::size_t periods_ = 0;
  std::int64_t start_ns_ = 0;

  // The per-step record and what turns it into differences after the run.
  std::optional<step_record> record_;
  bool keep_record_ = false;
  std::vector<platform::cpu_interrupt_totals> interrupt_reads_;  // at the last participant's end of period k
  platform::cpu_interrupt_totals interrupt_start_;                // before its first period
  std::vector<platform::thread_step_counters> first_snapshot_;
  // Set by any participant, read after the team is joined: the join orders
  // them, so relaxed (the flags carry no data of their own).
  std::atomic<bool> schedstat_seen_{false};
  std::atomic<bool> interrupts_seen_{false};
  // How many participants have ended each period: the last one reads
  // everyone's counters and the interrupt tables, so that nobody's end
  // waits behind the reads.
  std::vector<std::atomic<unsigned>> periods_ended_;
  // Each participant's counters, opened on its own thread (/proc/thread-self
  // is the opener) before its first period; the last participant to end a
  // period reads everyone's counters through them (its periods_ended_
  // acquire orders each emplace before that read).
  std::vector<std::optional<platform::thread_counter_reader>> counter_readers_;

  // The samples: periods x participants, period-major, each participant its own slots.
  std::vector<std::int64_t> wake_;
  std::vector<std::int64_t> end_;
  std::vector<std::optional<unsigned>> cpus_;
  std::vector<platform::thread_counters> deltas_;
  std::vector<std::string> errors_;

  // The agreed end (see the header): lowered by a late wake-up or by the
  // miss that reaches stop_after_misses, read once per period by everyone.
  // No stop: never below `periods`, so the read never ends a run early.
  std::atomic<std::int64_t> leave_before_{std::numeric_limits<std::int64_t>::max()};
  std::mutex stop_mutex_;  // guards stop_: taken only on a late wake-up
  std::optional<paced_stop> stop_;
  // Stop after misses: the last period counted, and how many were. Relaxed:
  // the count only decides when to ask for the end; the end itself is
  // agreed by (1) and (2).
  std::atomic<std::int64_t> last_counted_miss_{-1};
  std::atomic<std::uint64_t> counted_misses_{0};
};

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
    for (std::size_t k = 0; state.runs_period(k); ++k) {
      state.wake(self, k, recorder);
      step_one(id, static_cast<std::uint64_t>(k));
      state.end(self, k);
    }
    if (settings.fifo_priority) {
      try {
        platform::set_current_thread_normal();  // omp_team's participant 0 is the caller
      } catch (const std::exception&) {
      }
    }
    state.left(id, platform::snapshot_current_thread() - before);
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
