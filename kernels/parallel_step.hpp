#pragma once
// The composed parallel RK4 step: any synchronisation primitive x any layout,
// T persistent participants, each owning a contiguous block of equations
// (layouts/partition.hpp: a chain in blocks of whole masses, the paper's two
// masses one equation at a time; docs/design.md, The composed step).
//
// What one participant does per step (kernels/rk4.hpp names the arithmetic):
//
//     for stage s in 0..3:
//         the stage inputs its block reads, into its private input array:
//             those of its own block that its block reads (plan.own_reads),
//             from its own values through one pointer per slot, and those of
//             its dependencies, through the layout's accessors
//         k_s of its block = evaluate_derivatives(model, block, inputs)
//         at s = 3: x_{n+1} of its block = rk4_update(x_n, k_0..k_3)
//         publish (its exports' k_s for s < 3, x_{n+1} at s = 3: what its
//             consumers read next)
//         sync:  barrier primitives: every participant arrives and waits;
//                dataflow primitives: receive from the producers its block
//                depends on, and only those
//         copy in (per_thread with a barrier: the dependencies from the board)
//
// Four syncs per step, as in the paper (one per stage). Folding the update
// into stage 3 saves the fifth: the owner has every k it needs for its own
// update once it has computed k_3.
//
// Per-equation cost: the loops over the block are the serial step's
// (staged_rk4): one stage input per element, the model's block evaluation,
// one update per element, each over plain arrays. What the parallel step adds
// per stage is per dependency and per export (a chain cut between masses: two
// of each at most), not per equation.
//
// Determinism: every value is computed by rk4_stage_input, the model's
// derivative (evaluate_derivatives gives derivative()'s bits) and rk4_update
// from the same inputs as in staged_rk4, so every combination produces the
// serial trajectory bit for bit (tests/matrix checks it).
//
// Applicability (a trait the harness queries before instantiating):
//     applicable<Sync, Layout>()  -> {bool, reason}
//   barrier x packed/padded64/padded128/per_thread   applicable
//   channel x per_thread                             applicable
//   channel x packed/padded64/padded128              not applicable: the channel
//       carries the values in its own slots into the consumers' private copies,
//       so a shared array layout would go unused (the reason says so)
//   not_applicable_reason<Sync, Layout>(equations, threads) adds the runtime
//   condition (every thread must own at least one equation); empty = runs.
// Instantiating parallel_rk4 with a non-applicable pair is a compile error.
//
// Dataflow overrun: a producer can run several stages ahead of a consumer it
// does not itself depend on (two masses on four threads: block 1 can lead
// block 4 by three stages). The channels are built from this step's
// dependency graph and apply back-pressure before overwriting a stage a
// consumer has not received (sync/concepts.hpp, stage_channel), and every
// consumer here receives every stage of every producer it depends on, in
// order, so overrun cannot happen and back-pressure cannot deadlock (a
// producer blocked on consumer C waits for a stage C has already been given).
//
// API for the harness and tests
//
//   parallel_rk4<Sync, Layout, Model = two_mass_model, Timing = sync_timing::off>
//       step(model, dt, threads [, initial_state [, sync_args...]]);
//     Allocates and lays out everything (the partition: partition_of(model,
//     threads)); throws std::invalid_argument (layouts::partition_error) when
//     threads is 0 or more than the equations.
//   step.run(self, steps)
//     Called once per participant, each on its own thread, self.id in
//     [0, threads) (the caller launches the team with sync::team_of_t<Sync>
//     and pins it as it likes). Runs `steps` steps; may be called again for
//     more (the next call continues the trajectory). Every participant must
//     make the same calls with the same `steps`. Allocates nothing, throws
//     nothing, reads no clock unless Timing is on.
//   step.run_bounded(self, steps, deadline)
//     As run, but once the steady_clock deadline has passed the whole team
//     stops after one agreed step (a stalled combination is bounded in time);
//     returns the steps completed, the same on every participant.
//   step.state()            the state after the team joined (n values)
//   step.steps_taken()      steps completed (after the team joined)
//   step.set_sync_sample_period(n)
//                           with Timing = sampled: time the syncs of every
//                           n-th step (default kSyncTimingSampleSteps).
//   step.sync_time(p)       with Timing = on or sampled: nanoseconds participant
//                           p spent inside the stage syncs it timed, and how
//                           many it timed (sync_ns_per_stage = nanoseconds /
//                           syncs); zero with Timing = off. sync_time() sums them.
//                           Sampled also splits each timed sync into waiting
//                           for others and release (stage_sync_time below).
//   run_team(step, steps [, before])   launches a whole team (team_of<Sync>),
//                           calls before(id) on each participant's thread
//                           first (pinning), runs, joins, and returns the
//                           summed sync::sync_counters of the participants.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstddef>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "kernels/oscillator.hpp"
#include "kernels/parallel_exchange.hpp"
#include "kernels/rk4.hpp"
#include "layouts/aligned_buffer.hpp"
#include "layouts/partition.hpp"
#include "layouts/shared_slots.hpp"
#include "platform/cache_line.hpp"
#include "platform/clock.hpp"
#include "sync/concepts.hpp"
#include "sync/team.hpp"

namespace lockstep::kernels {

// Whether a participant times its stage syncs (platform::now_ns, the suite's
// clock, around each sync it times).
//   off      no clock is read on the measured path.
//   on       every stage sync: two clock reads per stage (about 40-60 ns per
//            stage where the clock is the vDSO's, platform/clock.hpp).
//   sampled  every stage sync of one step in a sampling period (default
//            kSyncTimingSampleSteps, set_sync_sample_period changes it): the
//            same mean per stage at a fraction of the clock cost, for a
//            harness that must keep the instrumentation's own cost under 2%.
enum class sync_timing { off, on, sampled };
// One step in 64: 8 clock readings (about 25 ns each on the development VM)
// per 64 steps is about 3 ns a step, 1% of the fastest 2-thread step (about
// 280 ns); one in 16 cost 4-6% there.
inline constexpr std::uint64_t kSyncTimingSampleSteps = 64;

// What a participant accumulated with sync_timing on or sampled.
//
// Sampled only, the split of a timed sync span (arrival: the clock reading
// before the barrier's arrive or the channel's receives; departure: the one
// after) at the latest arrival among the participants whose arrival its
// departure waits for (every other participant for a phase_barrier, its
// producers for a graph_channel):
//   waiting  arrival -> that latest awaited arrival, clipped to the span (0
//            when it arrived last): waiting for others;
//   release  that latest awaited arrival -> departure: what the primitive's
//            release and wake-up cost (span - waiting).
// A sync whose awaited arrivals could not all be read for its own step (a
// stamp of another sampled step: sync_clock<sampled> says when) is counted in
// unsplit_syncs and left out of the split, never guessed.
struct stage_sync_time {
  std::uint64_t nanoseconds = 0;  // inside the timed stage syncs (barrier wait or receives)
  std::uint64_t syncs = 0;        // stage syncs timed (on: 4 per step)
  std::uint64_t split_syncs = 0;          // sampled: timed syncs split into waiting and release
  std::uint64_t split_nanoseconds = 0;    // their spans (waiting + release)
  std::uint64_t waiting_nanoseconds = 0;  // of which waiting for others
  std::uint64_t unsplit_syncs = 0;        // sampled: timed syncs left out of the split

  stage_sync_time& operator+=(const stage_sync_time& other) noexcept {
    nanoseconds += other.nanoseconds;
    syncs += other.syncs;
    split_syncs += other.split_syncs;
    split_nanoseconds += other.split_nanoseconds;
    waiting_nanoseconds += other.waiting_nanoseconds;
    unsplit_syncs += other.unsplit_syncs;
    return *this;
  }
  // What was accumulated since `earlier` (the same participants, read earlier).
  [[nodiscard]] stage_sync_time since(const stage_sync_time& earlier) const noexcept {
    return {nanoseconds - earlier.nanoseconds,
            syncs - earlier.syncs,
            split_syncs - earlier.split_syncs,
            split_nanoseconds - earlier.split_nanoseconds,
            waiting_nanoseconds - earlier.waiting_nanoseconds,
            unsplit_syncs - earlier.unsplit_syncs};
  }
};

// One sync span split at the latest awaited arrival (stage_sync_time says
// what each part is). The latest awaited arrival is clipped into the span: a
// participant that arrived last waited 0; an awaited stamp read after the
// departure (a channel producer reads its clock just after its publish, so
// its consumer can leave first) counts the whole span as waiting.
struct sync_split {
  std::int64_t waiting = 0;
  std::int64_t release = 0;
};
[[nodiscard]] constexpr sync_split split_sync(std::int64_t arrival, std::int64_t departure,
                                              std::int64_t latest_awaited_arrival) noexcept {
  const std::int64_t span = std::max<std::int64_t>(departure - arrival, 0);
  const std::int64_t waiting = std::clamp<std::int64_t>(latest_awaited_arrival - arrival, 0, span);
  return {waiting, span - waiting};
}

// The mean waiting for others per stage sync over `time` (one repetition's
// accumulation, summed over the team), when enough of its timed syncs were
// split: at least kMinSplitSyncs, and no more than one timed sync in
// kMaxUnsplitShare left out (a share skipped more often could be a biased
// one: a stage whose stamps are often late). Otherwise nothing: the caller
// omits its counters rather than report a made-up figure.
inline constexpr std::uint64_t kMinSplitSyncs = 16;
inline constexpr std::uint64_t kMaxUnsplitShare = 10;  // at most 1 in 10 timed syncs unsplit
[[nodiscard]] inline std::optional<double> waiting_ns_per_stage(const stage_sync_time& time) noexcept {
  if (time.split_syncs < kMinSplitSyncs || time.unsplit_syncs * kMaxUnsplitShare > time.syncs) return std::nullopt;
  return static_cast<double>(time.waiting_nanoseconds) / static_cast<double>(time.split_syncs);
}

struct applicability {
  bool applicable;
  std::string_view reason;  // empty when applicable
};

template <class Sync, class Layout>
[[nodiscard]] constexpr applicability applicable() noexcept {
  constexpr bool barrier = sync::phase_barrier<Sync>;
  constexpr bool channel = sync::graph_channel<Sync>;
  constexpr bool private_copy = Layout::kKind == layouts::layout_kind::private_copy;
  if (barrier) return {true, {}};
  if (channel && private_copy) return {true, {}};
  if (channel)
    return {false,
            "a dataflow channel carries each producer's values in its own slots straight into the consumers' "
            "private copies, so a shared array layout would go unused; only per_thread applies"};
  return {false, "neither a phase_barrier nor a graph_channel (sync/concepts.hpp)"};
}

// Empty when Sync x Layout runs `threads` participants over `equations`;
// otherwise one line saying why not.
template <class Sync, class Layout>
[[nodiscard]] std::string not_applicable_reason(std::size_t equations, unsigned threads) {
  constexpr applicability verdict = applicable<Sync, Layout>();
  if (!verdict.applicable) return std::string(verdict.reason);
  if (threads == 0) return "at least one thread is needed";
  if (threads > equations)
    return std::to_string(threads) + " threads but " + std::to_string(equations) +
           " equations: every thread must own at least one equation";
  return {};
}

namespace detail {

template <class Sync, class Layout>
struct exchange_for {
  using type = std::conditional_t<
      sync::phase_barrier<Sync>,
      std::conditional_t<Layout::kKind == layouts::layout_kind::shared, barrier_in_place<Sync, Layout>,
                         barrier_copy_in<Sync, Layout>>,
      channel_copy_in<Sync, Layout>>;
};

// Sampled timing's arrival stamps: one participant's arrivals at the four
// stage syncs of its last two sampled steps (by the sampled step's ordinal
// parity), on a line pair of its own: written by its participant once per
// sampled step, read by the participants that wait for it at the end of that
// step. A stamp is (arrival - the step object's construction time) << kStampTagBits | the
// sampled step's ordinal modulo 2^kStampTagBits; -1 before the first.
inline constexpr unsigned kStampTagBits = 8;
inline constexpr std::int64_t kStampTagMask = (std::int64_t{1} << kStampTagBits) - 1;
struct alignas(platform::kPrefetchPair) arrival_stamps {
  std::atomic<std::int64_t> stamps[2][kRk4Stages];
  arrival_stamps() noexcept {
    for (auto& slot : stamps)
      for (auto& stamp : slot) stamp.store(-1, std::memory_order_relaxed);
  }
};

// What a participant's sampled clock reads and writes besides its own record.
struct stamp_board {
  arrival_stamps* own = nullptr;                // this participant's stamps
  const arrival_stamps* all = nullptr;          // every participant's, by id
  std::span<const unsigned> awaited;            // whose arrivals its departures wait for
  std::int64_t origin = 0;                      // the stamps' time origin
  std::uint64_t* sampled_steps = nullptr;       // its sampled steps so far: the next one's ordinal
};

// The stage-sync clock: a policy so that the step's loop has no branch on it.
template <sync_timing Timing>
struct sync_clock {
  void begin_step() noexcept {}
  void start(unsigned /*stage*/) noexcept {}
  void stop(unsigned /*stage*/, stage_sync_time& /*time*/) noexcept {}
  void end_step(stage_sync_time& /*time*/) noexcept {}
};
template <>
struct sync_clock<sync_timing::on> {
  std::int64_t started = 0;
  void begin_step() noexcept {}
  void start(unsigned /*stage*/) noexcept { started = platform::now_ns(); }
  void stop(unsigned /*stage*/, stage_sync_time& time) noexcept {
    time.nanoseconds += static_cast<std::uint64_t>(platform::now_ns() - started);
    ++time.syncs;
  }
  void end_step(stage_sync_time& /*time*/) noexcept {}
};
// Sampled: a sampled step reads the clock at each stage sync's arrival and
// departure (8 readings, as before the split), stores each arrival as a stamp
// (one relaxed store, to its own line pair) and keeps its arrivals and
// departures locally; at the end of the step, after its last sync, it reads
// the stamps of the participants it waits for, once, and splits each span at
// their latest arrival (stage_sync_time, split_sync). The cross-core reads
// thus lie outside the four stages; the other steps read no clock. Cost, on
// the overhead pair (mailbox x per_thread, 2 pinned threads, about 250 ns a
// step on the development VM): median overhead_ratio 1.015 before the split
// and 1.016 with it (18 and 12 quick runs); asking for the stamps' line in
// exclusive state when a sampled step begins (a prefetch for write) made it
// 1.035 (18 runs), so there is none.
//
// Memory ordering: (1) the stamp's store in start() and (2) its load in
// end_step() are relaxed; the primitive's release/acquire orders (1) before
// (2).
//  * phase_barrier: (1) is sequenced before the writer's arrive_and_wait of
//    that stage (release), which synchronizes-with every participant's return
//    from it (acquire); the reader's (2) follows its return from the step's
//    last stage, so every awaited stamp of that step is visible. The same
//    slot is written again only two sampled steps on, which nobody begins
//    before the reader arrives at the next step. A barrier's syncs are always
//    split.
//  * graph_channel: the span starts after the publish, so (1) is sequenced
//    after the stage's publish and before the producer's next publish
//    (release), which the consumer's receive of the next stage acquires:
//    stages 0-2 are visible at the end of the step, stage 3's not
//    necessarily.
// Each stamp carries the ordinal's low bits: a stamp of another sampled step
// (not yet written, or rewritten) is recognised, and that sync is counted in
// unsplit_syncs instead of being split with a guess.
template <>
struct sync_clock<sync_timing::sampled> {
  // Samples steps 0, period, 2 period, ...: the one division is here, once per
  // call of run; the step loop only counts down.
  sync_clock(std::uint64_t sample_period, std::uint64_t first_step, stamp_board stamps) noexcept
      : period(sample_period),
        steps_to_sample((sample_period - first_step % sample_period) % sample_period),
        board(stamps) {}
  std::uint64_t period;           // >= 1
  std::uint64_t steps_to_sample;  // steps before the next sampled one
  stamp_board board;
  std::uint64_t ordinal = 0;      // of the sampled step in progress
  bool sampling = false;
  std::int64_t arrived[kRk4Stages]{};
  std::int64_t departed[kRk4Stages]{};

  void begin_step() noexcept {
    sampling = steps_to_sample == 0;
    steps_to_sample = sampling ? period - 1 : steps_to_sample - 1;
    if (sampling) ordinal = *board.sampled_steps;
  }
  void start(unsigned stage) noexcept {
    if (!sampling) return;
    arrived[stage] = platform::now_ns();
    // (1) relaxed: ordered before (2) by the primitive (above).
    board.own->stamps[ordinal & 1U][stage].store(
        ((arrived[stage] - board.origin) << kStampTagBits) | (static_cast<std::int64_t>(ordinal) & kStampTagMask),
        std::memory_order_relaxed);
  }
  void stop(unsigned stage, stage_sync_time& time) noexcept {
    if (!sampling) return;
    departed[stage] = platform::now_ns();
    time.nanoseconds += static_cast<std::uint64_t>(departed[stage] - arrived[stage]);
    ++time.syncs;
  }
  void end_step(stage_sync_time& time) noexcept {
    if (!sampling) return;
    *board.sampled_steps = ordinal + 1;
    const std::int64_t tag = static_cast<std::int64_t>(ordinal) & kStampTagMask;
    for (unsigned stage = 0; stage < kRk4Stages; ++stage) {
      std::int64_t latest = arrived[stage];  // nobody awaited: no waiting
      bool usable = true;
      for (const unsigned other : board.awaited) {
        // (2) relaxed: see (1); the tag says whether it is this step's.
        const std::int64_t stamp = board.all[other].stamps[ordinal & 1U][stage].load(std::memory_order_relaxed);
        if (stamp < 0 || (stamp & kStampTagMask) != tag) {
          usable = false;
          break;
        }
        latest = std::max(latest, board.origin + (stamp >> kStampTagBits));
      }
      if (!usable) {
        ++time.unsplit_syncs;
        continue;
      }
      const sync_split split = split_sync(arrived[stage], departed[stage], latest);
      ++time.split_syncs;
      time.split_nanoseconds += static_cast<std::uint64_t>(split.waiting + split.release);
      time.waiting_nanoseconds += static_cast<std::uint64_t>(split.waiting);
    }
  }
};

}  // namespace detail

template <class Sync, class Layout, oscillator_model Model = two_mass_model,
          sync_timing Timing = sync_timing::off>
class parallel_rk4 {
  static_assert(applicable<Sync, Layout>().applicable,
                "this Sync x Layout is not applicable: applicable<Sync, Layout>().reason says why");

 public:
  using sync_type = Sync;
  using layout_type = Layout;
  using model_type = Model;
  static constexpr sync_timing kTiming = Timing;

  parallel_rk4(const Model& model, double dt, unsigned threads)
      : parallel_rk4(model, dt, threads, model.initial_state()) {}

  // sync_args: passed on to the primitive's constructor after the
  // participant count (barriers) or the graph and width (channels).
  template <class... SyncArgs>
  parallel_rk4(const Model& model, double dt, unsigned threads, std::span<const double> initial_state,
               SyncArgs&&... sync_args)
      : model_(model),
        coefficients_(dt),
        blocks_(partition_of(model_, threads)),
        plans_(plan_participants(model_, blocks_)),
        exchange_(blocks_, plans_, std::forward<SyncArgs>(sync_args)...),
        records_(threads),
        awaited_(threads),
        arrivals_(Timing == sync_timing::sampled ? threads : 0) {
    for (unsigned participant = 0; participant < threads; ++participant) {
      if constexpr (sync::phase_barrier<Sync>) {
        for (unsigned other = 0; other < threads; ++other)
          if (other != participant) awaited_[participant].push_back(other);
      } else {
        awaited_[participant] = plans_[participant].producers;
      }
    }
    inputs_.reserve(threads);
    for (unsigned participant = 0; participant < threads; ++participant)
      inputs_.emplace_back(model_.equations(), platform::kCacheLine);
    if (initial_state.size() != model_.equations())
      throw std::invalid_argument("the initial state must hold one value per equation");
    for (std::size_t equation = 0; equation < initial_state.size(); ++equation)
      exchange_.write_initial_state(equation, initial_state[equation]);
    // Barriers: every participant is one sync from participant 0. Channels:
    // the longest shortest path from participant 0 (breadth-first over
    // producer -> consumer edges). A participant participant 0 cannot reach
    // could lead it without bound: run_bounded then runs to the end.
    std::size_t farthest = 1;
    if constexpr (!sync::phase_barrier<Sync>) {
      std::vector<std::size_t> distance(threads, SIZE_MAX);
      std::vector<unsigned> frontier{0};
      distance[0] = 0;
      for (std::size_t head = 0; head < frontier.size(); ++head)
        for (unsigned consumer = 0; consumer < threads; ++consumer)
          if (distance[consumer] == SIZE_MAX &&
              std::binary_search(plans_[consumer].producers.begin(), plans_[consumer].producers.end(),
                                 frontier[head])) {
            distance[consumer] = distance[frontier[head]] + 1;
            frontier.push_back(consumer);
          }
      farthest = *std::max_element(distance.begin(), distance.end());
      bounded_supported_ = farthest != SIZE_MAX;
    }
    stop_margin_ = bounded_supported_ ? (farthest + kRk4Stages - 1) / kRk4Stages + 1 : 1;
  }

  parallel_rk4(const parallel_rk4&) = delete;  // participants hold references into it
  parallel_rk4& operator=(const parallel_rk4&) = delete;

  [[nodiscard]] unsigned threads() const noexcept { return blocks_.participants(); }
  [[nodiscard]] const layouts::partition& blocks() const noexcept { return blocks_; }
  [[nodiscard]] const participant_plan& plan_of(unsigned participant) const noexcept { return plans_[participant]; }

  // The work of participant self.id for `steps` steps (see the API above).
  void run(sync::participant& self, std::uint64_t steps) { (void)run_steps<false>(self, steps, {}); }

  // As run(), but the team stops early, every participant after the same
  // step, once `deadline` has passed: participant 0 reads the clock every
  // kDeadlineCheckSteps steps and, when late, names a stop step far enough
  // ahead that no participant has begun it yet (stop_margin_steps()). Returns
  // the steps this call completed (the same on every participant).
  std::uint64_t run_bounded(sync::participant& self, std::uint64_t steps,
                            std::chrono::steady_clock::time_point deadline) {
    return run_steps<true>(self, steps, deadline);
  }
  static constexpr std::uint64_t kDeadlineCheckSteps = 16;

  // Timing = sampled: time the syncs of steps 0, period, 2 period, ... from
  // the next call of run / run_bounded on (each call reads it when it starts).
  // Call it while no participant is inside run (before the team starts, or
  // from a barrier completion that the whole team waits on: that completion
  // happens-before every participant's next call). A slow step can afford a
  // short period; a fast one needs a long one to keep the clock's cost small.
  void set_sync_sample_period(std::uint64_t period) noexcept {
    sync_sample_period_ = std::max<std::uint64_t>(period, 1);
  }
  [[nodiscard]] std::uint64_t sync_sample_period() const noexcept { return sync_sample_period_; }
  // How many steps ahead of participant 0 a stop is set (see run_steps).
  [[nodiscard]] std::uint64_t stop_margin_steps() const noexcept { return stop_margin_; }

 private:
  // The step loop. Bounded = false compiles to the plain loop (no clock, no
  // stop check). Bounded = true adds, per step, one relaxed load of stop_step_
  // (a line written at most once per run) and, on participant 0 every
  // kDeadlineCheckSteps steps, one clock read.
  //
  // Stop protocol (Bounded): participant 0, at the top of step s, stores
  // S = s + stop_margin_ into stop_step_ (1); every participant, at the top of
  // each of its steps, loads it (2) and ends its run before step S.
  //  * Nobody has begun step S when (1) happens: a participant can lead
  //    participant 0 by at most d stages, d its distance from participant 0 in
  //    the producer -> consumer graph (it needs inputs that depend, through d
  //    syncs, on participant 0's), and stop_margin_ = ceil(d_max / 4) + 1 steps.
  //  * Everyone sees (1) before beginning step S: beginning step S needs the
  //    stage syncs of step S - 1, which happen-after participant 0's
  //    publications of stage 4 S - d >= 4 s + 4 - ... > its stage 4 s, which
  //    it made after (1) (barrier or channel release/acquire edges, the
  //    primitives' contracts); so (2), relaxed, reads S or a later store by
  //    coherence. Relaxed suffices: the sync edges carry the ordering.
  //  * A request is only made for S < this run's end, so every stored S is at
  //    most the step the run ends on: a later run, which starts there, treats
  //    any S <= its first step as stale.
  template <bool Bounded>
  std::uint64_t run_steps(sync::participant& self, std::uint64_t steps,
                          std::chrono::steady_clock::time_point deadline) {
    const unsigned me = self.id;
    const participant_plan& plan = plans_[me];
    const layouts::equation_block block = plan.block;
    const std::size_t size = block.size();
    // The stage inputs, by equation (only the block's reads and dependencies
    // are written and read); private to this participant.
    double* const inputs = inputs_[me].data();
    participant_record& record = records_[me];
    const std::uint64_t first_step = record.steps_taken;
    detail::sync_clock<Timing> clock = make_sync_clock(me, first_step);
    std::uint64_t end = first_step + steps;
    bool stop_requested = false;
    for (;;) {
      const std::uint64_t step = record.steps_taken;
      if constexpr (Bounded) {
        if (me == 0 && !stop_requested && bounded_supported_ && (step - first_step) % kDeadlineCheckSteps == 0 &&
            std::chrono::steady_clock::now() >= deadline && step + stop_margin_ < end) {
          // (1) relaxed: ordered for the readers by the stage syncs (above).
          stop_step_.value.store(step + stop_margin_, std::memory_order_relaxed);
          stop_requested = true;
        }
        // (2) relaxed: see (1).
        const std::uint64_t requested = stop_step_.value.load(std::memory_order_relaxed);
        if (requested > first_step && requested < end) end = requested;
      }
      if (step >= end) break;
      clock.begin_step();
      const auto parity = static_cast<unsigned>(step & 1U);
      const auto x = exchange_.states(me, parity);
      const double* const x_own = exchange_.own_states(me, parity);
      for (unsigned stage = 0; stage < kRk4Stages; ++stage) {
        // The stage inputs: y = x at stage 0 (rk4_stage_input's stage 0 is
        // x itself, bit for bit), else x + (c_s h) k_{s-1}.
        if (stage == 0) {
          for (std::size_t equation = plan.own_reads.first; equation < plan.own_reads.last; ++equation)
            inputs[equation] = x_own[equation - block.first];
          for (const std::size_t equation : plan.dependencies) inputs[equation] = x[equation];
        } else {
          const double* const k_own = exchange_.own_stage_values(me, stage - 1);
          for (std::size_t equation = plan.own_reads.first; equation < plan.own_reads.last; ++equation)
            inputs[equation] =
                rk4_stage_input(coefficients_, stage, x_own[equation - block.first], k_own[equation - block.first]);
          const auto k_previous = exchange_.stage_values(me, stage - 1);
          for (const std::size_t equation : plan.dependencies)
            inputs[equation] = rk4_stage_input(coefficients_, stage, x[equation], k_previous[equation]);
        }
        double* const k = exchange_.own_stage_values(me, stage);
        evaluate_derivatives(model_, block.first, block.last, static_cast<const double*>(inputs), k);
        if (stage == kRk4Stages - 1) {
          const double* const k0 = exchange_.own_stage_values(me, 0);
          const double* const k1 = exchange_.own_stage_values(me, 1);
          const double* const k2 = exchange_.own_stage_values(me, 2);
          double* const x_next = exchange_.own_next_states(me, parity);
          for (std::size_t element = 0; element < size; ++element)
            x_next[element] = rk4_update(coefficients_, x_own[element], k0[element], k1[element], k2[element],
                                         k[element]);
        }
        const std::uint64_t global_stage = step * kRk4Stages + stage;
        exchange_.publish(me, self, global_stage);
        clock.start(stage);
        exchange_.wait(me, self, global_stage);
        clock.stop(stage, record.sync_time);
        exchange_.copy_in(me, stage);
      }
      clock.end_step(record.sync_time);
      record.steps_taken = step + 1;
    }
    return record.steps_taken - first_step;
  }


 public:
  // After the team joined: x after steps_taken() steps.
  [[nodiscard]] std::vector<double> state() {
    const auto parity = static_cast<unsigned>(steps_taken() & 1U);
    std::vector<double> result(model_.equations());
    for (std::size_t equation = 0; equation < result.size(); ++equation)
      result[equation] = exchange_.final_state(parity, equation);
    return result;
  }

  [[nodiscard]] std::uint64_t steps_taken() const noexcept { return records_[0].steps_taken; }

  // With Timing = on or sampled: time participant p spent in the stage syncs
  // it timed (zero when off).
  [[nodiscard]] stage_sync_time sync_time(unsigned participant) const noexcept {
    return records_[participant].sync_time;
  }
  // Summed over the participants.
  [[nodiscard]] stage_sync_time sync_time() const noexcept {
    stage_sync_time total;
    for (const participant_record& record : records_) total += record.sync_time;
    return total;
  }

 private:
  // Written only by its participant's thread; a line pair of its own so that
  // the bookkeeping of one participant never shares a line (or an adjacent
  // line prefetch pair) with another's.
  struct alignas(platform::kPrefetchPair) participant_record {
    std::uint64_t steps_taken = 0;
    std::uint64_t sampled_steps = 0;  // Timing = sampled: the next sampled step's ordinal
    stage_sync_time sync_time{};
  };
  static_assert(sizeof(participant_record) % platform::kPrefetchPair == 0,
                "participant records in an array must not share a line pair");

  detail::sync_clock<Timing> make_sync_clock(unsigned participant, std::uint64_t first_step) noexcept {
    if constexpr (Timing == sync_timing::sampled) {
      return detail::sync_clock<Timing>(
          sync_sample_period_, first_step,
          detail::stamp_board{&arrivals_[participant], arrivals_.data(), awaited_[participant], stamp_origin_,
                              &records_[participant].sampled_steps});
    } else {
      return {};
    }
  }

  Model model_;
  rk4_coefficients coefficients_;
  layouts::partition blocks_;
  std::vector<participant_plan> plans_;
  typename detail::exchange_for<Sync, Layout>::type exchange_;
  std::vector<participant_record> records_;
  std::vector<layouts::aligned_buffer> inputs_;  // per participant: its stage inputs by equation (own lines)
  std::vector<std::vector<unsigned>> awaited_;  // per participant: whose arrivals its syncs wait for
  std::vector<detail::arrival_stamps> arrivals_;  // Timing = sampled: per participant (sync_clock<sampled>)
  std::int64_t stamp_origin_ = platform::now_ns();
  std::uint64_t stop_margin_ = 1;
  std::uint64_t sync_sample_period_ = kSyncTimingSampleSteps;
  bool bounded_supported_ = true;
  struct alignas(platform::kPrefetchPair) stop_line {
    std::atomic<std::uint64_t> value{0};
  } stop_step_;  // read by every participant each step of a bounded run: its own line pair
};

// Runs every participant of `step` for `steps` steps on a team of the
// primitive's own kind, calling before(id) on each participant's thread first
// (a pinning hook; the default does nothing). Returns the participants'
// summed counters. For tests, `lockstep delay` and anything that does not
// manage its own team.
struct no_hook {
  void operator()(unsigned /*participant*/) const noexcept {}
};

template <class Step, class Before = no_hook>
sync::sync_counters run_team(Step& step, std::uint64_t steps, Before&& before = {}) {
  const unsigned threads = step.threads();
  std::vector<sync::participant> participants(threads);
  for (unsigned id = 0; id < threads; ++id) participants[id].id = id;
  sync::team_of_t<typename Step::sync_type> team(threads);
  team.run([&](unsigned id) {
    before(id);
    step.run(participants[id], steps);
  });
  sync::sync_counters total;
  for (const sync::participant& participant : participants) total += participant.counters;
  return total;
}

}  // namespace lockstep::kernels
