// The crossover sweep (crossover_sweep.hpp).
#include "bench/run/crossover_sweep.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <map>
#include <optional>

#include "bench/run/ranking.hpp"
#include "bench/run/rk4_entries.hpp"
#include "bench/run/run_plan.hpp"
#include "kernels/rk4.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"
#include "platform/statistics.hpp"
#include "sync/registry.hpp"

namespace lockstep::bench {

namespace {

// A comparison's own bound within the sweep: far above what its pairs take
// (48 pairs of two 4 ms blocks, a step of about a millisecond at the largest
// size: about 2 s); the sweep's budget is what bounds the whole.
constexpr std::int64_t kComparisonBudgetNs = 20'000'000'000;
// A probe block this long sizes a side's blocks (its time per unit).
constexpr double kProbeBlockNs = 200'000.0;
// A pair of blocks costs this many times its two timed blocks (warm-up
// batches, the teams' start, the probes): run_plan.cpp's kPairOverBlocks.
constexpr double kPairOverBlocks = 5.0;

// The units of a side's block: from a probe block of growing size, as
// units_for_batch sizes an entry's batch (block_units then scales it to the
// block). One unit when the probe stalls (the pair will say so).
std::uint64_t probe_units(const block_runner_factory& factory, const run_settings& settings) {
  const std::unique_ptr<block_runner> runner = factory();
  std::uint64_t units = 1;
  for (;;) {
    const std::optional<double> unit_ns = runner->run_block(units);
    if (!unit_ns || !(*unit_ns > 0.0)) return 1;
    if (*unit_ns * static_cast<double>(units) >= kProbeBlockNs || units >= kMaxUnitsPerBatch / 8)
      return units_for_batch(*unit_ns, settings);
    units *= 8;
  }
}

std::optional<double> median_of(const std::vector<double>& values) {
  std::vector<double> kept;
  for (const double value : values)
    if (value > 0.0) kept.push_back(value);
  if (kept.empty()) return std::nullopt;
  return platform::median(kept);
}

// A point of a series (stage_sync_ns: the model's, when the run measured
// it) or of a ceiling (none: no model).
crossover_sweep_point point_of(const paired_result& pair, unsigned threads, std::size_t masses, bool oversubscribed,
                               const std::optional<double>& stage_sync_ns) {
  crossover_sweep_point point;
  point.masses = masses;
  point.threads = threads;
  point.oversubscribed = oversubscribed;
  point.failure = pair.failure;
  point.pairs = pair.ratios.size();
  point.pairs_set_aside = pair.set_aside.size();
  if (point.failure.empty() && pair.ratios.empty())
    point.failure = "every pair set aside: another process took a CPU";
  if (!point.failure.empty()) return point;
  point.speedup = pair.estimate;
  point.verdict = pair.verdict;
  point.serial_ns = median_of(pair.unit_ns_a).value_or(0.0);
  point.parallel_ns = median_of(pair.unit_ns_b).value_or(0.0);
  point.cpus_busy = median_of(pair.cpus_busy_b);
  if (stage_sync_ns)
    point.model_ns = point.serial_ns / static_cast<double>(threads) + kernels::kRk4Stages * *stage_sync_ns;
  return point;
}

// The ceilings of every thread count with a series measured at this size
// (`measured`: the series' indices), their sides built and their pairs added
// to `plan` after the series'; returns their indices in sweep.ceilings, in
// the plan's order.
std::vector<std::size_t> plan_ceilings(harness_state& harness, const crossover_sweep& sweep,
                                       const std::vector<std::size_t>& measured, std::size_t masses,
                                       const std::string& serial_name, std::vector<comparison>& plan) {
  const std::size_t cpus = harness.machine->affinity().size();
  std::vector<std::size_t> planned;
  for (std::size_t index = 0; index < sweep.ceilings.size(); ++index) {
    const crossover_ceiling& ceiling = sweep.ceilings[index];
    const bool wanted = std::any_of(measured.begin(), measured.end(), [&](std::size_t series) {
      return sweep.series[series].threads == ceiling.threads;
    });
    if (!wanted) continue;
    block_runner_factory factory =
        chain_split_runner(harness, ceiling.pin, ceiling.threads, masses, ceiling.threads <= cpus);
    if (!factory) continue;
    // The ceiling's side is no entry of the run: this key names it among the
    // harness's block runners only.
    const std::string name = fmt::format("crossover/model:chain{}/blocks_at_once/pin:{}/threads:{}", masses,
                                         platform::to_string(ceiling.pin), ceiling.threads);
    harness.units_per_batch[name] = probe_units(factory, harness.settings);
    harness.block_runners[name] = std::move(factory);
    plan.push_back({comparison_kind::crossover,
                    fmt::format("ceiling pin:{} threads:{} masses:{}", platform::to_string(ceiling.pin),
                                ceiling.threads, masses),
                    serial_name, name});
    planned.push_back(index);
  }
  return planned;
}

}  // namespace

bool interval_too_wide(const paired_result& pair) {
  return pair.failure.empty() && !pair.ratios.empty() && pair.estimate.median > 0.0 &&
         (pair.estimate.high - pair.estimate.low) / pair.estimate.median > kCrossoverWideShare;
}

void add_batch(paired_result& into, const paired_result& more, double noise) {
  const auto append = [](auto& to, const auto& from) { to.insert(to.end(), from.begin(), from.end()); };
  append(into.ratios, more.ratios);
  append(into.readings, more.readings);
  append(into.modes, more.modes);
  append(into.set_aside, more.set_aside);
  append(into.unit_ns_a, more.unit_ns_a);
  append(into.unit_ns_b, more.unit_ns_b);
  append(into.cpus_busy_a, more.cpus_busy_a);
  append(into.cpus_busy_b, more.cpus_busy_b);
  into.budget_cut = into.budget_cut || more.budget_cut;
  into.estimate = bootstrap_median(into.ratios);
  into.verdict = verdict_of(into.estimate, noise);
}

std::vector<crossover_series> plan_crossover_series(const run_book& book, const std::vector<answer_choice>& choices) {
  const std::vector<ranked_group> ranked = rank_groups(book, entry_kind::rk4);
  std::map<unsigned, std::vector<const answer_choice*>> by_threads;
  for (const auto& choice : choices)
    if (choice.threads > 1) by_threads[choice.threads].push_back(&choice);
  std::vector<crossover_series> planned;
  for (const auto& [threads, here] : by_threads) {
    const auto compact_choice = std::find_if(here.begin(), here.end(), [&](const answer_choice* choice) {
      return choice->pin == platform::placement::compact;
    });
    const answer_choice& chosen = compact_choice != here.end() ? **compact_choice : *here.front();
    const auto stage_sync_of = [&](crossover_series& series, const std::string& entry) {
      series.stage_sync_entry = entry;
      if (const captured_entry* found = book.find(entry)) series.stage_sync_ns = found->median("sync_ns_per_stage");
    };
    crossover_series leader;
    leader.threads = threads;
    leader.pin = chosen.pin;
    leader.sync = chosen.sync;
    leader.layout = chosen.layout;
    stage_sync_of(leader, chosen.entry);
    planned.push_back(leader);
    // A rival the matrix could not tell from the choice leads too: a tie at
    // the matrix's model size says nothing about which pays off at others
    // (on the AMD guest, seqlock and ck_dissemination, tied at 2 masses,
    // crossed at 102 [93, 114] and 219 [156, 292] masses in one run).
    if (chosen.tied && chosen.runner_up && chosen.runner_up->sync != sync::kBaselinePrimitive) {
      crossover_series tied = leader;
      tied.sync = chosen.runner_up->sync;
      tied.layout = chosen.runner_up->layout;
      tied.stage_sync_ns.reset();
      stage_sync_of(tied, chosen.runner_up->entry);
      planned.push_back(tied);
    }
    if (chosen.sync == sync::kBaselinePrimitive) continue;
    // The baseline on its best layout here: its first in the choice's group of the ranking.
    const auto group = std::find_if(ranked.begin(), ranked.end(), [&](const ranked_group& one) {
      return one.threads == threads && one.model == chosen.model && one.pin == chosen.pin;
    });
    if (group == ranked.end()) continue;
    const auto best = std::find_if(group->entries.begin(), group->entries.end(), [](const measured_entry& step) {
      return step.entry->spec.sync == sync::kBaselinePrimitive;
    });
    if (best == group->entries.end()) continue;
    crossover_series baseline = leader;
    baseline.leader = false;
    baseline.sync = best->entry->spec.sync;
    baseline.layout = best->entry->spec.layout;
    baseline.stage_sync_ns.reset();
    stage_sync_of(baseline, best->entry->name);
    planned.push_back(baseline);
  }
  return planned;
}

double estimate_crossover_s(std::size_t series, std::size_t ceilings, const crossover_settings& settings) {
  std::size_t sizes = 0;
  for (std::size_t masses = kCrossoverFirstMasses; masses <= settings.max_masses; masses *= 2) ++sizes;
  const double per_point_ns = kPairOverBlocks * 2.0 * static_cast<double>(settings.block_ns) * settings.pairs;
  const double all_ns = static_cast<double>((series + ceilings) * sizes) * per_point_ns;
  return std::min(all_ns, static_cast<double>(settings.budget_ns)) / 1e9;
}

namespace {

// A sweep under way: where it measures, how, which series are still going,
// how many points in a row each cleared 1, and since when.
struct sweep_state {
  harness_state& harness;
  const crossover_settings& settings;
  pairing_settings pairing;
  std::size_t cpus = 0;
  std::int64_t start_ns = 0;
  std::vector<bool> going;
  std::vector<unsigned> clear_in_a_row;

  [[nodiscard]] bool over_budget() const { return platform::now_ns() - start_ns > settings.budget_ns; }
  [[nodiscard]] double elapsed_s() const { return static_cast<double>(platform::now_ns() - start_ns) / 1e9; }
};

// The sweep as asked, its points empty: one ceiling per thread count, at its
// series' placement (they share it).
crossover_sweep empty_sweep(std::vector<crossover_series> series, const crossover_settings& settings) {
  crossover_sweep sweep;
  sweep.budget_ns = settings.budget_ns;
  sweep.max_masses = settings.max_masses;
  sweep.pairs = settings.pairs;
  sweep.block_ns = settings.block_ns;
  sweep.series = std::move(series);
  for (const auto& one : sweep.series)
    if (std::none_of(sweep.ceilings.begin(), sweep.ceilings.end(),
                     [&](const crossover_ceiling& ceiling) { return ceiling.threads == one.threads; }))
      sweep.ceilings.push_back({one.threads, one.pin, {}});
  return sweep;
}

// Whether the sweep measures `masses`: not when every series stopped, past
// the largest size, or past the budget (each series still going then says so).
bool sweep_goes_on(const sweep_state& state, crossover_sweep& sweep, std::size_t masses) {
  if (std::find(state.going.begin(), state.going.end(), true) == state.going.end()) {
    sweep.stop_reason = "every series stopped";
    return false;
  }
  const char* reason = masses > state.settings.max_masses ? "largest_size" : state.over_budget() ? "budget" : nullptr;
  if (reason == nullptr) return true;
  for (std::size_t index = 0; index < state.going.size(); ++index)
    if (state.going[index]) sweep.series[index].stop_reason = reason;
  sweep.stop_reason = reason;
  return false;
}

// The comparisons of every series still going at `masses` (its parallel
// step against the chain's serial step), their sides built; returns the
// series' indices, in the plan's order.
std::vector<std::size_t> plan_series(sweep_state& state, const crossover_sweep& sweep, std::size_t masses,
                                     const std::string& serial_name, std::vector<comparison>& plan) {
  harness_state& harness = state.harness;
  std::vector<std::size_t> which;
  for (std::size_t index = 0; index < sweep.series.size(); ++index) {
    if (!state.going[index]) continue;
    const crossover_series& one = sweep.series[index];
    const bool oversubscribed = one.threads > state.cpus;
    block_runner_factory factory =
        chain_step_runner(harness, one.sync, one.layout, one.pin, one.threads, masses, !oversubscribed);
    if (!factory) continue;  // too few masses for the threads at this size: the next one
    const std::string name =
        entry_spec::parallel_step(one.sync, one.layout, one.pin, one.threads, kernels::model_choice{masses}).name();
    harness.units_per_batch[name] = probe_units(factory, harness.settings);
    harness.block_runners[name] = std::move(factory);
    plan.push_back({comparison_kind::crossover,
                    fmt::format("crossover sync:{} layout:{} pin:{} threads:{} masses:{}", one.sync, one.layout,
                                platform::to_string(one.pin), one.threads, masses),
                    serial_name, name});
    which.push_back(index);
  }
  return which;
}

// The plan's pairs, added to the book's after `before`. A comparison whose
// interval came out wide takes another batch of pairs, up to
// kCrossoverMoreBatches, while the budget lasts: the rule reads the
// interval's width, never its place, and the estimate is over every pair.
void measure_size(const sweep_state& state, const std::vector<comparison>& plan, std::size_t before) {
  std::vector<paired_result>& pairs = state.harness.book->pairs;
  measure_pairs(state.harness, plan, state.pairing, {});
  for (unsigned batch = 0; batch < kCrossoverMoreBatches && pairs.size() == before + plan.size(); ++batch) {
    if (state.over_budget()) break;
    std::vector<comparison> again;
    std::vector<std::size_t> where;
    for (std::size_t item = 0; item < plan.size(); ++item)
      if (interval_too_wide(pairs[before + item])) {
        again.push_back(plan[item]);
        where.push_back(before + item);
      }
    if (again.empty()) break;
    const std::size_t added = pairs.size();
    measure_pairs(state.harness, again, state.pairing, {});
    for (std::size_t item = 0; item < where.size() && added + item < pairs.size(); ++item)
      if (pairs[added + item].failure.empty()) add_batch(pairs[where[item]], pairs[added + item], state.settings.noise);
    pairs.erase(pairs.begin() + static_cast<std::ptrdiff_t>(added), pairs.end());
  }
}

// The points of one size, from the pairs after `before` (the series' first,
// then the ceilings'): a series that failed or confirmed its crossover stops.
void record_size(sweep_state& state, crossover_sweep& sweep, const std::vector<std::size_t>& which,
                 const std::vector<std::size_t>& ceilings_here, std::size_t before, std::size_t masses) {
  const std::vector<paired_result>& pairs = state.harness.book->pairs;
  for (std::size_t item = 0; item < which.size() && before + item < pairs.size(); ++item) {
    const std::size_t index = which[item];
    crossover_series& one = sweep.series[index];
    crossover_sweep_point point =
        point_of(pairs[before + item], one.threads, masses, one.threads > state.cpus, one.stage_sync_ns);
    if (!point.failure.empty() && point.pairs_set_aside == 0) {
      one.stop_reason = "failed: " + point.failure;
      state.going[index] = false;
    }
    unsigned& clear = state.clear_in_a_row[index];
    clear = point.measured() && point.speedup.low > 1.0 ? clear + 1 : 0;
    one.points.push_back(std::move(point));
    if (state.going[index] && clear >= kCrossoverClearPoints && masses >= state.settings.through_masses) {
      one.stop_reason = "confirmed";
      state.going[index] = false;
    }
  }
  for (std::size_t item = 0; item < ceilings_here.size() && before + which.size() + item < pairs.size(); ++item) {
    crossover_ceiling& ceiling = sweep.ceilings[ceilings_here[item]];
    ceiling.points.push_back(point_of(pairs[before + which.size() + item], ceiling.threads, masses,
                                      ceiling.threads > state.cpus, std::nullopt));
  }
}

}  // namespace

crossover_sweep sweep_crossovers(harness_state& harness, std::vector<crossover_series> series,
                                 const crossover_settings& settings,
                                 const std::function<void(std::size_t, double)>& progress) {
  crossover_sweep sweep = empty_sweep(std::move(series), settings);
  sweep_state state{harness, settings, {}, harness.machine->affinity().size(), platform::now_ns(),
                    std::vector<bool>(sweep.series.size(), true), std::vector<unsigned>(sweep.series.size(), 0)};
  state.pairing.pairs = settings.pairs;
  state.pairing.block_ns = settings.block_ns;
  state.pairing.noise = settings.noise;
  state.pairing.budget_ns = kComparisonBudgetNs;
  // The sweep's pairs take no pace readings: each pair's two blocks share the
  // pace, and the pace trace is the matrix's.
  pace_probe* const pace = harness.pace;
  harness.pace = nullptr;
  for (std::size_t masses = kCrossoverFirstMasses; sweep_goes_on(state, sweep, masses); masses *= 2) {
    const std::string serial_name = entry_spec::serial_step(kernels::model_choice{masses}).name();
    std::vector<comparison> plan;
    const std::vector<std::size_t> which = plan_series(state, sweep, masses, serial_name, plan);
    if (plan.empty()) continue;
    const std::vector<std::size_t> ceilings_here = plan_ceilings(harness, sweep, which, masses, serial_name, plan);
    harness.block_runners[serial_name] = chain_serial_runner(masses);
    harness.units_per_batch[serial_name] = probe_units(harness.block_runners[serial_name], harness.settings);
    std::vector<paired_result>& pairs = harness.book->pairs;
    const std::size_t before = pairs.size();
    measure_size(state, plan, before);
    record_size(state, sweep, which, ceilings_here, before, masses);
    // The sweep's pairs are its own section, not the run's lockstep_pairs.
    pairs.erase(pairs.begin() + static_cast<std::ptrdiff_t>(before), pairs.end());
    if (progress) progress(masses, state.elapsed_s());
  }
  harness.pace = pace;
  for (auto& one : sweep.series) one.crossover = find_crossover(crossover_points(one));
  sweep.spent_s = state.elapsed_s();
  return sweep;
}

}  // namespace lockstep::bench
