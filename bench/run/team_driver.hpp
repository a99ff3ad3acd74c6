#pragma once
// One call of an entry on a pinned team: every participant pins itself by the
// placement plan, snapshots its accounting, runs batches behind the harness
// barrier (run_book.hpp: batch_gate) and snapshots again. The barrier entries
// and the RK4 entries share this; they differ only in the work a participant
// does per unit (an episode of the primitive, or one RK4 step).
#include <sched.h>
#include <time.h>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "bench/run/run_book.hpp"
#include "platform/placement.hpp"
#include "platform/statistics.hpp"
#include "platform/step_counters.hpp"
#include "sync/registry.hpp"
#include "platform/thread_accounting.hpp"
#include "sync/concepts.hpp"

namespace lockstep::bench {

// The calling thread's CPU time (user and system), ns. CLOCK_THREAD_CPUTIME_ID
// is a system call, not a vDSO read: a participant takes two per call.
inline std::int64_t thread_cpu_ns() noexcept {
  timespec now{};
  if (::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now) != 0) return -1;
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

// What one call measured, summed over the team.
struct call_result {
  batch_record batches;
  sync::sync_counters sync_totals;                  // the primitive's counters, deltas summed
  std::optional<platform::thread_counters> accounting;  // deltas summed; empty when off
  std::string failure;                              // a participant could not be pinned
  // Participant 0's thread CPU time over the timed batches: from the start of
  // its first timed batch to its return from the barrier that ends the last
  // one. -1 when no timed batch ran or the clock could not be read.
  std::int64_t lead_cpu_ns = -1;
  // The same summed over every participant: the CPU the team burned for the
  // timed batches (a spinning participant burns its CPU while it waits, a
  // sleeping one does not). -1 when any participant's clock is missing.
  std::int64_t team_cpu_ns = -1;
  // With accounting: the time the team's threads waited on a run queue
  // (runnable, not running: schedstat) from before the warm-up batch to after
  // the last timed one, summed; empty when a thread's schedstat is unreadable.
  std::optional<std::int64_t> run_queue_wait_ns;
};

// Per-participant slots, written only by the participant's own thread and
// read by the benchmark thread after Team::run returns (run's join orders them).
struct alignas(platform::kCacheLine) participant_slot {
  sync::participant self{};
  platform::thread_counters accounting_before{};
  platform::thread_counters accounting_after{};
  sync::sync_counters counters_before{};
  std::int64_t timed_cpu_start_ns = -1;  // thread_cpu_ns() as its first timed batch starts
  std::int64_t timed_cpu_end_ns = -1;    // and after the last batch's barrier
  std::int64_t run_queue_wait_ns = -1;   // with accounting: over the call; -1 unreadable
  std::string failure;
};

// Runs one call: `timed_batches` batches of `units_per_batch` units after one
// warm-up batch, every participant calling work(self, units). `work` must make
// every participant run the same number of units (the primitive's phases must
// match). A `migrate` plan re-pins each participant at the plan's step
// boundaries, inside the timed region: that cost is what it prices.
// `warmed_up` runs once, between the warm-up and the first timed batch, with
// the whole team waiting (batch_clock says what it may do).
template <class Team, class Work>
call_result run_call(Team& team, std::vector<participant_slot>& slots, const platform::placement_plan& plan,
                     unsigned timed_batches, std::uint64_t units_per_batch, const run_settings& settings,
                     bool accounting, Work& work, std::function<void(std::uint64_t)> warmed_up = {}) {
  batch_clock clock(timed_batches, units_per_batch, settings, std::move(warmed_up));
  batch_gate gate(static_cast<unsigned>(slots.size()), clock);
  team.run([&](unsigned id) {
    participant_slot& slot = slots[id];
    slot.self.id = id;
    slot.failure.clear();
    try {
      platform::pin_current_thread(plan, id, 0);
    } catch (const std::exception& error) {
      // Still take part: the others would wait for this participant forever.
      slot.failure = error.what();
    }
    std::optional<platform::thread_counter_reader> schedstat;
    std::optional<std::int64_t> waited_before;
    if (accounting) {
      slot.accounting_before = platform::snapshot_current_thread();
      waited_before = schedstat.emplace().read().run_queue_wait_ns;
    }
    slot.counters_before = slot.self.counters;
    slot.timed_cpu_start_ns = -1;
    std::uint64_t done = 0;
    unsigned batches_started = 0;
    gate.run_batches([&](std::uint64_t units) {
      // The first batch is the warm-up (batch_clock): the CPU clock starts with the second.
      if (++batches_started == 2) slot.timed_cpu_start_ns = thread_cpu_ns();
      if (plan.kind != platform::placement::migrate || plan.migrate_every_steps == 0) {
        work(slot.self, units);
        done += units;
        return;
      }
      while (units > 0) {
        const std::uint64_t boundary = (done / plan.migrate_every_steps + 1) * plan.migrate_every_steps;
        const std::uint64_t chunk = std::min(units, boundary - done);
        work(slot.self, chunk);
        done += chunk;
        units -= chunk;
        if (plan.moves_at(done)) {
          try {
            platform::pin_current_thread(plan, id, done);
          } catch (const std::exception& error) {
            slot.failure = error.what();
          }
        }
      }
    });
    slot.timed_cpu_end_ns = thread_cpu_ns();
    slot.run_queue_wait_ns = -1;
    if (accounting) {
      if (const auto waited_after = schedstat->read().run_queue_wait_ns; waited_before && waited_after)
        slot.run_queue_wait_ns = *waited_after - *waited_before;
      slot.accounting_after = platform::snapshot_current_thread();
    }
  });

  call_result result;
  result.batches = clock.record();
  if (accounting) result.accounting = platform::thread_counters{0, 0, std::int64_t{0}};
  for (const participant_slot& slot : slots) {
    sync::sync_counters delta = slot.self.counters;
    delta.futex_waits -= slot.counters_before.futex_waits;
    delta.futex_wakes -= slot.counters_before.futex_wakes;
    delta.yields -= slot.counters_before.yields;
    delta.spins_exhausted -= slot.counters_before.spins_exhausted;
    delta.timeouts -= slot.counters_before.timeouts;
    result.sync_totals += delta;
    if (accounting) *result.accounting += slot.accounting_after - slot.accounting_before;
    if (result.failure.empty() && !slot.failure.empty()) result.failure = slot.failure;
  }
  if (accounting) {
    std::int64_t waited = 0;
    for (const participant_slot& slot : slots) waited = slot.run_queue_wait_ns < 0 || waited < 0 ? -1 : waited + slot.run_queue_wait_ns;
    if (waited >= 0) result.run_queue_wait_ns = waited;
  }
  const participant_slot& lead = slots.front();
  if (!result.batches.batch_ns.empty() && lead.timed_cpu_start_ns >= 0 &&
      lead.timed_cpu_end_ns >= lead.timed_cpu_start_ns)
    result.lead_cpu_ns = lead.timed_cpu_end_ns - lead.timed_cpu_start_ns;
  if (result.lead_cpu_ns >= 0) {
    std::int64_t team_cpu = 0;
    for (const participant_slot& slot : slots) {
      if (slot.timed_cpu_start_ns < 0 || slot.timed_cpu_end_ns < slot.timed_cpu_start_ns) {
        team_cpu = -1;
        break;
      }
      team_cpu += slot.timed_cpu_end_ns - slot.timed_cpu_start_ns;
    }
    result.team_cpu_ns = team_cpu;
  }
  return result;
}

// Restores the calling thread's affinity when it leaves scope: omp_team runs
// participant 0 on the caller (Google Benchmark's thread), which pins it.
class affinity_guard {
 public:
  affinity_guard() noexcept { saved_ok_ = ::sched_getaffinity(0, sizeof saved_, &saved_) == 0; }
  ~affinity_guard() {
    if (saved_ok_) ::sched_setaffinity(0, sizeof saved_, &saved_);
  }
  affinity_guard(const affinity_guard&) = delete;  // restores once
  affinity_guard& operator=(const affinity_guard&) = delete;

 private:
  cpu_set_t saved_{};
  bool saved_ok_ = false;
};

// One side of a paired comparison (paired_blocks.hpp): an entry's
// combination, built once, ready to run short blocks on demand. A block is
// one call (run_call): a warm-up batch and one timed batch of `units` units,
// without accounting or instrumentation (a pair compares the bare costs).
// What a block saw of the machine, from a runner with accounting on (the
// crossover sweep's): whether its threads kept their CPUs.
struct block_facts {
  // Involuntary context switches of its threads over the block (warm-up and
  // timed batch).
  std::int64_t involuntary_switches = 0;
  // Over the same span, the time its threads waited on a run queue, summed
  // (schedstat; empty when unreadable), and the span's wall time: with no
  // more threads than CPUs, a wait is another process holding a CPU.
  std::optional<std::int64_t> run_queue_wait_ns;
  std::int64_t block_ns = 0;
  // The threads' CPU time over the timed batch / its wall time (the run's
  // cpus_busy per entry): empty when a thread's CPU clock could not be read.
  std::optional<double> cpus_busy;
};

class block_runner {
 public:
  virtual ~block_runner() = default;
  // The timed batch's time per unit, or empty when the block stalled, ran
  // out of its budget, or the team could not be placed.
  virtual std::optional<double> run_block(std::uint64_t units) = 0;
  // On: every block snapshots its threads' context switches (outside the
  // timed batch) and last_facts says what the last block saw. Off (the
  // default, the matrix's pairs): no facts.
  virtual void set_accounting(bool on) { (void)on; }
  [[nodiscard]] virtual std::optional<block_facts> last_facts() const { return std::nullopt; }
};
using block_runner_factory = std::function<std::unique_ptr<block_runner>()>;

// A block_runner over a team that runs `Subject` (the composed step, or a
// bare barrier): `work(subject, self, units)` is one participant's share.
template <class Team, class Subject, class Work>
class team_block_runner final : public block_runner {
 public:
  team_block_runner(const run_settings& settings, platform::placement_plan plan, std::unique_ptr<Subject> subject,
                    Work work)
      : settings_(settings),
        plan_(std::move(plan)),
        subject_(std::move(subject)),
        work_(std::move(work)),
        team_(plan_.threads),
        slots_(plan_.threads) {}

  std::optional<double> run_block(std::uint64_t units) override;
  void set_accounting(bool on) override { accounting_ = on; }
  [[nodiscard]] std::optional<block_facts> last_facts() const override { return facts_; }

 private:
  bool accounting_ = false;
  std::optional<block_facts> facts_;
  const run_settings& settings_;
  platform::placement_plan plan_;
  std::unique_ptr<Subject> subject_;
  Work work_;
  Team team_;
  std::vector<participant_slot> slots_;
};

class pace_probe;

// The run-wide state every entry function shares: the machine, the settings,
// the run book, and what earlier calls learned (batch sizes from each entry's
// probe, primitives that already stalled).
struct harness_state {
  const platform::topology* machine = nullptr;
  run_settings settings;
  run_book* book = nullptr;
  std::map<std::string, std::uint64_t> units_per_batch;  // entry name -> from its probe
  std::map<std::string, std::string> stalled;            // entry name -> reason
  std::map<std::string, unsigned> stalls_of_sync;        // "sync threads:T" -> stalled entries so far
  std::set<std::string> measured;                        // entries with a repetition measured
  // After this many stalled entries of one primitive at one thread count, its
  // remaining entries at that count are skipped at once (each stall costs up
  // to the stall bound or a 1000 ms timeout; the verdict is already known).
  unsigned stalls_before_skipping_sync = 3;
  // Readings of the machine's pace around every repetition (pace.hpp); null: none taken.
  pace_probe* pace = nullptr;
  // Called after every call of an entry (with pace_reading_after): the
  // run's progress line (reporters.hpp: progress_reporter::tick). May be empty.
  std::function<void()> after_call;
  // Entry name -> how to build one side of a paired comparison of it.
  std::map<std::string, block_runner_factory> block_runners;
  // Entries whose batches stayed shorter than a quarter of the target after
  // re-probing: the harness barrier weighs in their figure (the summary says so).
  std::set<std::string> short_batches;
};

// How many repetitions and timed batches an entry gets (Google Benchmark's
// Repetitions and Iterations): the run's timed_batches (run_book.hpp), and
// the run's repetitions, except where collapse is foreseen.
//
// Collapse measured briefly: a pure spinner (sync/registry.hpp: pure_spin)
// with more threads than the CPUs of the affinity set waits for a scheduler
// quantum at every stage, so its step takes tens of milliseconds, where the
// others' take microseconds, and every repetition costs tens of units of
// that (ck_*'s entries at threads:4 took 13.6 s of the 42 s quick run on the
// 2-vCPU development VM). One repetition of a few batches shows it; the
// summary then reports such an entry as collapsed (paired_blocks.hpp:
// find_collapsed) when it does collapse, and ranks it as usual, with one
// repetition, when it does not. `primitive`: nullptr for an entry of none.
inline constexpr int kBriefRepetitions = 1;
inline constexpr unsigned kBriefBatches = 3;
void size_entry(benchmark::internal::Benchmark& entry, const sync::primitive_info* primitive, unsigned threads,
                const harness_state& harness);

// Takes a pace reading around a call (pace.hpp: the reading after the
// previous call when it is fresh, else a new one; always a new one after)
// when the harness has a probe; returns its index in the trace, or -1.
inline constexpr std::string_view kPaceBeforeCounter = "pace_reading_before";
inline constexpr std::string_view kPaceAfterCounter = "pace_reading_after";
long pace_reading_before(harness_state& harness);
long pace_reading_after(harness_state& harness);
// Sets pace_c2c_ns, pace_serial_ns and the reading indices (pace_reading_before,
// pace_reading_after: replaced by pace_mode after the run) on a repetition.
void set_pace_counters(benchmark::State& state, const harness_state& harness, long before, long after);

// Why a call stopped early, in one line, from what the primitive is and what
// it counted: "stalled: one step took 212 ms (bound 50 ms): pure-spin
// primitive with 4 threads on 2 CPUs".
std::string stall_reason(const call_result& result, std::string_view unit, bool pure_spin, bool may_lose_wakeups,
                         const platform::placement_plan& plan, const run_settings& settings);

// The time per unit of the median batch (probe calls, and the timed call's
// re-size).
double median_unit_ns(const batch_record& record);

// What a team entry (rk4/, overhead/, barrier/) gives Google Benchmark, so
// that its JSON reads as any Google Benchmark file does and Google Benchmark's
// own tools/compare.py compares what `lockstep compare` compares:
// - one iteration is one timed batch of units (RK4 steps, or episodes of a
//   bare barrier), and its manual time (SetIterationTime) is the batch's
//   time: Google Benchmark decides how many iterations a repetition runs from
//   the time an iteration takes, and a time per unit would make it ask for a
//   batch's worth of units too many (a quick run's entry ran out of its call
//   budget). result_json_reporter (reporters.hpp) then writes real_time per
//   unit: a repetition's real_time is its ns_per_step (ns_per_episode)
//   counter, the time per unit over its timed batches;
// - Google Benchmark's median aggregate of real_time is then the median of
//   the repetitions' ns_per_<unit>, the figure `lockstep compare` builds each
//   side of its ratio from (reports/lockstep_reports/compare/compare.py); so the two
//   tools' ratios of the medians agree by construction;
// - cpu_time is participant 0's thread CPU time per unit over the timed
//   batches (call_result::lead_cpu_ns), written as the counter
//   cpu_ns_per_<unit> and put in place of Google Benchmark's own cpu_time by
//   result_json_reporter (reporters.hpp): Google Benchmark's thread only
//   replays the batch times here, so its own CPU time measures nothing;
// - the batch size stays a counter: <unit>s_per_batch.
// The result file's context says so (lockstep_timing) from lockstep_schema 2
// on; in files of schema 1, real_time and cpu_time were per batch.
//
// One call of the team (run_call over an entry's team, slots, plan and work,
// bound by team_call_runner): timed batches of units, with or without
// accounting, the warm-up hook between the warm-up and the first timed batch.
using call_runner = std::function<call_result(unsigned timed_batches, std::uint64_t units_per_batch,
                                              bool accounting, std::function<void(std::uint64_t)> warmed_up)>;

template <class Team, class Work>
call_runner team_call_runner(Team& team, std::vector<participant_slot>& slots, const platform::placement_plan& plan,
                             const run_settings& settings, Work& work) {
  return [&team, &slots, &plan, &settings, &work](unsigned timed_batches, std::uint64_t units_per_batch,
                                                  bool accounting, std::function<void(std::uint64_t)> warmed_up) {
    return run_call(team, slots, plan, timed_batches, units_per_batch, settings, accounting, work,
                    std::move(warmed_up));
  };
}

// What one call of an entry is: which entry, its primitive's facts
// (sync/registry.hpp; nullptr for an entry of no primitive: the stall
// reasons and the per-primitive stall count use them), its placement, and
// how its timed call runs.
struct entry_call {
  benchmark::State& state;
  harness_state& harness;
  std::string name;
  const sync::primitive_info* primitive = nullptr;
  const platform::placement_plan& plan;
  bool accounting = true;     // the timed call's accounting and instrumentation
  entry_unit unit = entry_unit::step;  // the counters' names (the entry's spec says which)
  // Runs between the timed call's warm-up batch and its first timed batch,
  // with the units per timed batch (the team waiting: a baseline for what the
  // timed batches accumulate). May be empty.
  std::function<void(std::uint64_t)> warmed_up;
};

// One call of an entry, the whole protocol: skip at once if this entry or too
// many of its primitive's entries stalled before; probe the batch size on the
// first call (8 batches of one unit, then checks); run the timed call
// (re-sized when its batches came out far too short); feed Google Benchmark
// the timed batches as its iterations (per unit, as above). Returns the
// call's result, or nothing when the entry was skipped (SkipWithError, with
// the reason). Not a template: every entry's source calls this one
// definition (team_driver.cpp) through its call_runner.
std::optional<call_result> measure_entry(entry_call& call, const call_runner& run);

// Per-unit time of a call's timed batches, in ns.
double ns_per_unit(const call_result& result);

template <class Team, class Subject, class Work>
std::optional<double> team_block_runner<Team, Subject, Work>::run_block(std::uint64_t units) {
  affinity_guard restore_caller;  // omp_team runs participant 0 on the calling thread
  auto share = [this](sync::participant& self, std::uint64_t count) { work_(*subject_, self, count); };
  const std::int64_t block_start_ns = platform::now_ns();
  const call_result result = run_call(team_, slots_, plan_, 1, units, settings_, accounting_, share);
  facts_.reset();
  if (!result.failure.empty() || result.batches.stalled || result.batches.over_budget ||
      result.batches.batch_ns.empty())
    return std::nullopt;
  if (result.accounting) {
    block_facts facts{result.accounting->involuntary_switches, result.run_queue_wait_ns,
                      platform::now_ns() - block_start_ns, std::nullopt};
    if (result.team_cpu_ns >= 0 && result.batches.batch_ns.front() > 0)
      facts.cpus_busy =
          static_cast<double>(result.team_cpu_ns) / static_cast<double>(result.batches.batch_ns.front());
    facts_ = facts;
  }
  return ns_per_unit(result);
}

// The factory of an entry's block runner: a fresh Subject(args...) per runner.
template <class Team, class Subject, class Work, class... Args>
block_runner_factory block_runner_of(const harness_state& harness, platform::placement plan_kind, unsigned threads,
                                     Work work, Args... args) {
  return [&harness, plan_kind, threads, work, args...]() -> std::unique_ptr<block_runner> {
    return std::make_unique<team_block_runner<Team, Subject, Work>>(
        harness.settings, platform::plan_placement(*harness.machine, plan_kind, threads),
        std::make_unique<Subject>(args...), work);
  };
}

// Sets the accounting counters on an entry: <prefix>_per_k<unit> for
// voluntary / involuntary switches and migrations, and cross_core_csw_pct.
// Migrations unavailable: those two counters are omitted, never 0.
void set_accounting_counters(benchmark::State& state, const call_result& result, entry_unit unit);

}  // namespace lockstep::bench
