#pragma once
// One call of an entry on a pinned team: every participant pins itself by the
// placement plan, snapshots its accounting, runs batches behind the harness
// barrier (harness.hpp: batch_gate) and snapshots again. The barrier entries
// and the RK4 entries share this; they differ only in the work a participant
// does per unit (an episode of the primitive, or one RK4 step).
#include <sched.h>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <optional>
#include <string>
#include <vector>

#include "bench/harness/run_book.hpp"
#include "platform/placement.hpp"
#include "sync/registry.hpp"
#include "platform/thread_accounting.hpp"
#include "sync/concepts.hpp"

namespace lockstep::bench {

// What one call measured, summed over the team.
struct call_result {
  batch_record batches;
  sync::sync_counters sync_totals;                  // the primitive's counters, deltas summed
  std::optional<platform::thread_counters> accounting;  // deltas summed; empty when off
  std::string failure;                              // a participant could not be pinned
};

// Per-participant slots, written only by the participant's own thread and
// read by the benchmark thread after Team::run returns (run's join orders them).
struct alignas(platform::kCacheLine) participant_slot {
  sync::participant self{};
  platform::thread_counters accounting_before{};
  platform::thread_counters accounting_after{};
  sync::sync_counters counters_before{};
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
                     bool accounting, Work& work, std::function<void()> warmed_up = {}) {
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
    std::uint64_t done = 0;
    gate.run_batches([&](std::uint64_t units) {
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
};

// Why a call stopped early, in one line, from what the primitive is and what
// it counted: "stalled: one step took 212 ms (bound 50 ms): pure-spin
// primitive with 4 threads on 2 CPUs".
std::string stall_reason(const call_result& result, const char* unit, bool pure_spin, bool may_lose_wakeups,
                         const platform::placement_plan& plan, const run_settings& settings);

// The time per unit of the median batch (probe calls).
double median_unit_ns(const batch_record& record);

// One call of an entry, the whole protocol: skip at once if this entry or too
// many of its primitive's entries stalled before; probe the batch size on the
// first call (8 batches of one unit); run the timed call, calling warmed_up()
// between its warm-up batch and its first timed batch (the team waiting: a
// baseline for what the timed batches accumulate); feed Google Benchmark the
// batch times. Returns the call's result, or nothing when the entry was
// skipped (SkipWithError, with the reason). `primitive`: the registry's facts
// about the entry's primitive (sync/registry.hpp), for the stall reasons and
// the per-primitive stall count; nullptr for an entry of no primitive.
template <class Team, class Work>
std::optional<call_result> measure_entry(benchmark::State& state, harness_state& harness, const std::string& name,
                                         const sync::primitive_info* primitive, const platform::placement_plan& plan,
                                         Team& team, std::vector<participant_slot>& slots, Work& work,
                                         bool accounting, const char* unit, std::function<void()> warmed_up = {}) {
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
    if (!times.empty()) {
      std::vector<std::int64_t> sorted = times;
      std::sort(sorted.begin(), sorted.end());
      filler = sorted[sorted.size() / 2];
    }
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
    constexpr unsigned kProbeBatches = 8;
    call_result probe = run_call(team, slots, plan, kProbeBatches, 1, settings, false, work);
    if (!probe.failure.empty()) return record_placement_failure(probe);
    if (probe.batches.stalled || probe.batches.over_budget) return record_stop(probe);
    batch_size = harness.units_per_batch.emplace(name, units_for_batch(median_unit_ns(probe.batches), settings)).first;
  }

  const auto wanted = static_cast<unsigned>(std::min<benchmark::IterationCount>(state.max_iterations, 1'000'000));
  call_result result =
      run_call(team, slots, plan, wanted, batch_size->second, settings, accounting, work, std::move(warmed_up));
  if (!result.failure.empty()) return record_placement_failure(result);
  if (result.batches.stalled || result.batches.over_budget || result.batches.batch_ns.size() < wanted)
    return record_stop(result);
  harness.measured.insert(name);

  std::size_t batch = 0;
  for (auto _ : state) {
    state.SetIterationTime(static_cast<double>(result.batches.batch_ns[batch]) * 1e-9);
    ++batch;
  }
  return result;
}

// Per-unit time of a call's timed batches, in ns.
double ns_per_unit(const call_result& result);

// Sets the accounting counters on an entry: <prefix>_per_k<unit> for
// voluntary / involuntary switches and migrations, and cross_core_csw_pct.
// Migrations unavailable: those two counters are omitted, never 0.
void set_accounting_counters(benchmark::State& state, const call_result& result, const std::string& unit);

}  // namespace lockstep::bench
