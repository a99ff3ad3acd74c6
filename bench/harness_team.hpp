#pragma once
// One call of an entry on a pinned team: every participant pins itself by the
// placement plan, snapshots its accounting, runs batches behind the harness
// barrier (harness.hpp: batch_gate) and snapshots again. The barrier entries
// and the RK4 entries share this; they differ only in the work a participant
// does per unit (an episode of the primitive, or one RK4 step).
#include <sched.h>

#include <benchmark/benchmark.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bench/harness.hpp"
#include "platform/placement.hpp"
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
template <class Team, class Work>
call_result run_call(Team& team, std::vector<participant_slot>& slots, const platform::placement_plan& plan,
                     unsigned timed_batches, std::uint64_t units_per_batch, const run_settings& settings,
                     bool accounting, Work& work) {
  batch_clock clock(timed_batches, units_per_batch, settings);
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

// Why a call stopped early, in one line, from what the primitive is and what
// it counted: "stalled: one step took 212 ms (bound 50 ms): pure-spin
// primitive with 4 threads on 2 CPUs".
std::string stall_reason(const call_result& result, const char* unit, bool pure_spin, bool may_lose_wakeups,
                         const platform::placement_plan& plan, const run_settings& settings);

// The time per unit of the median batch (probe calls).
double median_unit_ns(const batch_record& record);

// Sets the accounting counters on an entry: <prefix>_per_k<unit> for
// voluntary / involuntary switches and migrations, and cross_core_csw_pct.
// Migrations unavailable: those two counters are omitted, never 0.
void set_accounting_counters(benchmark::State& state, const call_result& result, const std::string& unit);

}  // namespace lockstep::bench
