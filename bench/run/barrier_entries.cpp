// The bare barrier entries (barrier_entries.hpp).
#include "bench/run/barrier_entries.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>

#include "sync/registry.hpp"

namespace lockstep::bench {

namespace {

template <class Primitive>
void barrier_entry(benchmark::State& state, harness_state& harness, const entry_spec spec) {
  using episode_barrier = sync::as_barrier_t<Primitive>;
  using team_type = sync::team_of_t<episode_barrier>;
  constexpr sync::primitive_info info = sync::info_of<Primitive>();

  affinity_guard restore_caller;  // omp_team pins the benchmark thread as participant 0
  const platform::placement_plan plan = platform::plan_placement(*harness.machine, spec.pin, spec.threads);
  episode_barrier barrier(spec.threads);
  team_type team(spec.threads);
  std::vector<participant_slot> slots(spec.threads);
  auto episodes = [&barrier](sync::participant& self, std::uint64_t count) {
    for (std::uint64_t episode = 0; episode < count; ++episode) barrier.arrive_and_wait(self);
  };
  entry_call call{state, harness, spec.name(), sync::find_primitive(info.name), plan, harness.settings.accounting,
                  spec.unit(), {}};
  const auto result = measure_entry(call, team_call_runner(team, slots, plan, harness.settings, episodes));
  if (!result) return;

  const double episodes_run = static_cast<double>(std::max<std::uint64_t>(result->batches.units_run, 1));
  state.counters["ns_per_episode"] = ns_per_unit(*result);
  // The library barriers hide their futex calls, yields and spins alike: unavailable, so omitted.
  if constexpr (info.counts_futex_waits) {
    state.counters["futex_waits_per_episode"] = static_cast<double>(result->sync_totals.futex_waits) / episodes_run;
    state.counters["futex_wakes_per_episode"] = static_cast<double>(result->sync_totals.futex_wakes) / episodes_run;
    state.counters["yields_per_episode"] = static_cast<double>(result->sync_totals.yields) / episodes_run;
    state.counters["spins_exhausted_per_episode"] =
        static_cast<double>(result->sync_totals.spins_exhausted) / episodes_run;
  }
  state.counters["timeouts"] = static_cast<double>(result->sync_totals.timeouts);
  state.counters["oversubscribed"] = plan.oversubscribed ? 1.0 : 0.0;
  set_accounting_counters(state, *result, spec.unit());
}

}  // namespace

std::vector<entry_spec> register_barrier_benchmarks(const run_selection& selection, harness_state& harness) {
  std::vector<entry_spec> registered;
  sync::for_each_primitive([&]<class Primitive>() {
    const std::string name(Primitive::kName);
    if (std::find(selection.syncs.begin(), selection.syncs.end(), name) == selection.syncs.end()) return;
    for (unsigned threads : selection.threads) {
      if (threads < 2) continue;  // one participant never waits: an episode of nothing
      for (platform::placement pin : selection.pins) {
        const entry_spec spec = entry_spec::barrier_episode(name, pin, threads);
        auto* entry = benchmark::RegisterBenchmark(spec.name().c_str(), [&harness, spec](benchmark::State& state) {
          barrier_entry<Primitive>(state, harness, spec);
        });
        constexpr sync::primitive_info info = sync::info_of<Primitive>();
        size_entry(*entry, &info, threads, harness);
        entry->UseManualTime()->Unit(benchmark::kNanosecond);
        registered.push_back(spec);
        // The entry's side of a paired comparison (paired_blocks.hpp).
        using episode_barrier = sync::as_barrier_t<Primitive>;
        harness.block_runners[spec.name()] =
            block_runner_of<sync::team_of_t<episode_barrier>, episode_barrier>(
                harness, pin, threads,
                [](episode_barrier& barrier, sync::participant& self, std::uint64_t count) {
                  for (std::uint64_t episode = 0; episode < count; ++episode) barrier.arrive_and_wait(self);
                },
                threads);
      }
    }
  });
  return registered;
}

}  // namespace lockstep::bench
