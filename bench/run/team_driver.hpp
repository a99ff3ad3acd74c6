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
    if (accounting) slot.accounting_before = platform::snapshot_current_thread();
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
    if (accounting) slot.accounting_after = platform::snapshot_current_thread();
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
class block_runner {
 public:
  virtual ~block_runner() = default;
  // The timed batch's time per unit, or empty when the block stalled, ran
  // out of its budget, or the team could not be placed.
  virtual std::optional<double> run_block(std::uint64_t units) = 0;
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

 private:
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
std::string stall_reason(const call_result& result, const char* unit, bool pure_spin, bool may_lose_wakeups,
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
//   side of its ratio from (reports/lockstep_reports/compare.py); so the two
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
// One call of an entry, the whole protocol: skip at once if this entry or too
// many of its primitive's entries stalled before; probe the batch size on the
// first call (8 batches of one unit); run the timed call, calling
// warmed_up(units per timed batch) between its warm-up batch and its first
// timed batch (the team waiting: a baseline for what the timed batches
// accumulate); feed Google Benchmark the
// timed batches as its iterations (per unit, as above). Returns the call's
// result, or nothing when the entry was skipped (SkipWithError, with the
// reason). `primitive`: the registry's facts about the entry's primitive
// (sync/registry.hpp), for the stall reasons and the per-primitive stall
// count; nullptr for an entry of no primitive.
template <class Team, class Work>
std::optional<call_result> measure_entry(benchmark::State& state, harness_state& harness, const std::string& name,
                                         const sync::primitive_info* primitive, const platform::placement_plan& plan,
                                         Team& team, std::vector<participant_slot>& slots, Work& work,
                                         bool accounting, const char* unit,
                                         std::function<void(std::uint64_t)> warmed_up = {}) {
  const run_settings& settings = harness.settings;
  const auto skip = [&](const std::string& reason) {
    state.SkipWithError(reason.c_str());
    return std::optional<call_result>{};
  };
  // Google Benchmark requires every repetition of an entry to report the same
  // iteration count (it aborts otherwise), and a skipped call reports none.
  // So once a repetition of this entry was measured, a later call that stops
  // early still walks all its iterations, then is flagged as an error, which
  // keeps it out of the aggregates; its times are not a measurement.
  // Google Benchmark 1.7.1 also computes an entry's aggregates from its first
  // repetition's statistics list, which it leaves uninitialised when that
  // repetition was flagged (google/benchmark#1406): a flagged first
  // repetition followed by two measured ones read a wild pointer and crashed
  // the run (exit 139). A call flagged while Google Benchmark still sizes the
  // first repetition becomes that repetition, so no later call may measure:
  // once a call of an entry stopped, every later call of it stops too, and
  // either every repetition is flagged or the first one was measured.
  const bool measured_before = harness.measured.count(name) > 0;
  const auto flag_measured_entry = [&](const call_result& result, const std::string& reason) {
    std::vector<std::int64_t> times = result.batches.batch_ns;
    std::int64_t filler = result.batches.slowest_unit_ns * static_cast<std::int64_t>(result.batches.units_per_batch);
    if (!times.empty())
      filler = std::llround(platform::median(std::vector<double>(times.begin(), times.end())));
    std::size_t batch = 0;
    for (auto _ : state) {
      state.SetIterationTime(static_cast<double>(batch < times.size() ? times[batch] : filler) * 1e-9);
      ++batch;
    }
    const std::string message = reason + " (this repetition stopped after " + std::to_string(times.size()) + " of " +
                                std::to_string(batch) + " batches; its times are not a measurement)";
    state.SkipWithError(message.c_str());
    return std::optional<call_result>{};
  };

  const std::string stall_key =
      (primitive != nullptr ? std::string(primitive->name) : name) + " threads:" + std::to_string(plan.threads);
  if (const auto known = harness.stalled.find(name); known != harness.stalled.end()) {
    if (measured_before) return flag_measured_entry(call_result{}, "an earlier call stopped: " + known->second);
    return skip(known->second);
  }
  if (!measured_before && primitive != nullptr) {
    const unsigned stalls = harness.stalls_of_sync[stall_key];
    if (stalls >= harness.stalls_before_skipping_sync) {
      const std::string reason =
          "skipped: " + stall_key + " already stalled in " + std::to_string(stalls) + " entries of this run";
      harness.stalled[name] = reason;
      return skip(reason);
    }
  }
  // A stall (one unit beyond the bound) says something about the primitive;
  // running out of the call's budget only about this call.
  const auto record_stop = [&](const call_result& result) {
    std::string reason = stall_reason(result, unit, primitive != nullptr && primitive->pure_spin,
                                      primitive != nullptr && primitive->may_lose_wakeups, plan, settings);
    harness.stalled[name] = reason;
    if (measured_before) return flag_measured_entry(result, reason);
    if (result.batches.stalled && primitive != nullptr) ++harness.stalls_of_sync[stall_key];
    return skip(reason);
  };
  const auto record_placement_failure = [&](const call_result& result) {
    const std::string reason = "cannot place the team: " + result.failure;
    harness.stalled[name] = reason;
    if (measured_before) return flag_measured_entry(result, reason);
    return skip(reason);
  };

  auto batch_size = harness.units_per_batch.find(name);
  if (batch_size == harness.units_per_batch.end()) {
    // The first probe (8 batches of one unit) can land on a slow moment, or
    // weigh the harness barrier's own cost (a sleeping team's wake-up) in
    // its unit, and settle on batches far shorter than the target: the
    // entry's figure is then mostly the harness's. So the size is checked
    // by batches of the size it chose, and grown by what they fell short,
    // up to kRegrowths times; batches still under a quarter of the target
    // are flagged (harness.short_batches), not hidden. The median, not the
    // fastest batch: sized from the fastest, an entry whose steps run at two
    // speeds (win_event) took batches many times the target, and the default
    // run twice as long. The timed call below catches what a slow probe
    // still gets wrong.
    //
    // A unit that alone outlasts the target makes a batch of one unit
    // whatever the probe says, so a first batch of one unit that does is
    // the whole probe: an oversubscribed pure spinner (tens of ms a step)
    // spent about eleven units, most of a second, on a probe whose answer
    // was known after one; collapsed entries took half of the quick run.
    constexpr unsigned kProbeBatches = 8;
    constexpr unsigned kCheckBatches = 3;
    constexpr int kRegrowths = 3;
    call_result first = run_call(team, slots, plan, 1, 1, settings, false, work);
    if (!first.failure.empty()) return record_placement_failure(first);
    if (first.batches.stalled || first.batches.over_budget) return record_stop(first);
    const bool slow_unit = median_unit_ns(first.batches) >= static_cast<double>(settings.target_batch_ns);
    call_result probe = slow_unit ? std::move(first) : run_call(team, slots, plan, kProbeBatches, 1, settings, false, work);
    if (!probe.failure.empty()) return record_placement_failure(probe);
    if (probe.batches.stalled || probe.batches.over_budget) return record_stop(probe);
    std::uint64_t units = units_for_batch(median_unit_ns(probe.batches), settings);
    bool short_batch = false;
    for (int regrowth = 0; regrowth <= kRegrowths && !slow_unit; ++regrowth) {
      call_result check = run_call(team, slots, plan, kCheckBatches, units, settings, false, work);
      if (!check.failure.empty()) return record_placement_failure(check);
      if (check.batches.stalled || check.batches.over_budget) return record_stop(check);
      const double batch_ns = median_unit_ns(check.batches) * static_cast<double>(units);
      short_batch = batch_ns < static_cast<double>(settings.target_batch_ns) / 4.0;
      if (batch_ns >= static_cast<double>(settings.target_batch_ns) / 2.0 || units >= kMaxUnitsPerBatch) break;
      units = units_for_batch(median_unit_ns(check.batches), settings);
    }
    if (short_batch) harness.short_batches.insert(name);
    batch_size = harness.units_per_batch.emplace(name, units).first;
  }

  const auto wanted = static_cast<unsigned>(std::min<benchmark::IterationCount>(state.max_iterations, 1'000'000));
  // The size can still be wrong by orders of magnitude: an unpinned team's
  // probe and checks, while the scheduler still places its new threads on
  // one CPU, took 10-100x a step and settled on ~20 steps per batch instead
  // of ~30,000; every later call and every paired block of the entry then
  // read 1.4-2.4x slow (mailbox's 2-thread bare step at pin:none, in 2 of 8
  // processes). A timed call whose median batch is under kShortBatch of the
  // target is re-sized from its own median and run again, before Google
  // Benchmark sees it, up to kResizes times; a re-size only grows the batch
  // (at least doubling it) and keeps the call within a quarter of its budget.
  constexpr double kShortBatch = 1.0 / 8.0;
  constexpr int kResizes = 2;
  call_result result;
  long pace_before = 0;
  long pace_after = 0;
  for (int resize = 0;; ++resize) {
    pace_before = pace_reading_before(harness);
    result = run_call(team, slots, plan, wanted, batch_size->second, settings, accounting, work, warmed_up);
    pace_after = pace_reading_after(harness);
    if (!result.failure.empty()) return record_placement_failure(result);
    if (result.batches.stalled || result.batches.over_budget || result.batches.batch_ns.size() < wanted)
      return record_stop(result);
    const double unit_ns = median_unit_ns(result.batches);
    const double target = static_cast<double>(settings.target_batch_ns);
    const double batch_ns = unit_ns * static_cast<double>(result.batches.units_per_batch);
    if (batch_ns >= target / 4.0) harness.short_batches.erase(name);
    if (resize == kResizes || unit_ns <= 0.0 || batch_ns >= target * kShortBatch) break;
    const double affordable = static_cast<double>(settings.call_budget_ns) / 4.0 / (unit_ns * wanted);
    const auto units = std::min(units_for_batch(unit_ns, settings),
                                static_cast<std::uint64_t>(std::min(affordable, double(kMaxUnitsPerBatch))));
    if (units < 2 * batch_size->second) break;
    batch_size->second = units;
  }
  harness.measured.insert(name);
  set_pace_counters(state, harness, pace_before, pace_after);
  if (harness.short_batches.count(name) > 0) state.counters["short_batches"] = 1.0;

  // A batch's time (see above): Google Benchmark sizes the next repetition's
  // iterations by it; the JSON reporter writes it per unit.
  const double units = static_cast<double>(result.batches.units_per_batch);
  std::size_t batch = 0;
  for (auto _ : state) {
    state.SetIterationTime(static_cast<double>(result.batches.batch_ns[batch]) * 1e-9);
    ++batch;
  }
  const std::string unit_name(unit);
  state.counters[unit_name + "s_per_batch"] = units;
  const double units_timed = static_cast<double>(result.batches.batch_ns.size()) * units;
  if (result.lead_cpu_ns >= 0)
    state.counters["cpu_ns_per_" + unit_name] = static_cast<double>(result.lead_cpu_ns) / units_timed;
  if (result.team_cpu_ns >= 0)
    state.counters["team_cpu_ns_per_" + unit_name] = static_cast<double>(result.team_cpu_ns) / units_timed;
  return result;
}

// Per-unit time of a call's timed batches, in ns.
double ns_per_unit(const call_result& result);

template <class Team, class Subject, class Work>
std::optional<double> team_block_runner<Team, Subject, Work>::run_block(std::uint64_t units) {
  affinity_guard restore_caller;  // omp_team runs participant 0 on the calling thread
  auto share = [this](sync::participant& self, std::uint64_t count) { work_(*subject_, self, count); };
  const call_result result = run_call(team_, slots_, plan_, 1, units, settings_, false, share);
  if (!result.failure.empty() || result.batches.stalled || result.batches.over_budget ||
      result.batches.batch_ns.empty())
    return std::nullopt;
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
void set_accounting_counters(benchmark::State& state, const call_result& result, const std::string& unit);

}  // namespace lockstep::bench
