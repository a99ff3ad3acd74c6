// Planning and measuring the paired comparisons (paired_blocks.hpp).
#include "bench/run/paired_blocks.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <numeric>
#include <random>
#include <tuple>

#include "bench/run/pace.hpp"
#include "layouts/registry.hpp"
#include "platform/clock.hpp"

namespace lockstep::bench {

namespace {

// A reading taken at the end of the pair just before is this pair's reading
// before: no time passes between them.
constexpr std::int64_t kFreshReadingNs = 1'000'000;
constexpr std::uint64_t kRoundOrderSeed = 0x9a17'04de;
// A side whose threads waited on a run queue for more than this share of its
// block (warm-up and timed batch) had a CPU taken by another thread: a
// kernel worker's few microseconds stay below it, a competing process's
// timeslice (milliseconds) does not.
constexpr double kCpuTakenShare = 0.01;


// From the layout registry: a shared layout whose writers share lines (the
// false-sharing case), and a shared layout that gives each writer its own
// aligned block (the padded cases).
bool writers_share_lines(const std::string& layout) {
  const layouts::layout_info* info = layouts::find_layout(layout);
  return info != nullptr && info->kind == layouts::layout_kind::shared && info->writer_isolation == 0;
}
bool writers_isolated(const std::string& layout) {
  const layouts::layout_info* info = layouts::find_layout(layout);
  return info != nullptr && info->kind == layouts::layout_kind::shared && info->writer_isolation > 0;
}

void plan_false_sharing(std::vector<comparison>& plan, const std::vector<measured_entry>& steps) {
  // (sync, pin, threads) -> the sharing entry and the best isolating one
  std::map<std::tuple<std::string, std::string_view, unsigned>,
           std::pair<std::optional<measured_entry>, std::optional<measured_entry>>>
      groups;
  for (const auto& step : steps) {
    const entry_spec& spec = step.entry->spec;
    auto& [sharing, isolated] = groups[{spec.sync, platform::to_string(spec.pin), spec.threads}];
    if (writers_share_lines(spec.layout) && !sharing) sharing = step;
    if (writers_isolated(spec.layout) && (!isolated || step.median < isolated->median)) isolated = step;
  }
  for (const auto& [key, sides] : groups) {
    if (!sides.first || !sides.second) continue;
    const auto& [sync, pin, threads] = key;
    plan.push_back({comparison_kind::false_sharing, fmt::format("sync:{} pin:{} threads:{}", sync, pin, threads),
                    sides.first->entry->name, sides.second->entry->name});
  }
}

void plan_migration(std::vector<comparison>& plan, const std::vector<measured_entry>& steps) {
  // (sync, threads) -> layout -> pin -> entry
  std::map<std::pair<std::string, unsigned>, std::map<std::string, std::map<platform::placement, measured_entry>>>
      groups;
  for (const auto& step : steps) {
    const entry_spec& spec = step.entry->spec;
    groups[{spec.sync, spec.threads}][spec.layout].insert_or_assign(spec.pin, step);
  }
  for (const auto& [key, layouts] : groups) {
    std::optional<std::pair<measured_entry, measured_entry>> best;  // (none, compact) on the best pinned layout
    for (const auto& [layout, pins] : layouts) {
      const auto compact = pins.find(platform::placement::compact);
      const auto none = pins.find(platform::placement::none);
      if (compact == pins.end() || none == pins.end()) continue;
      // A penalty of migration needs migrations: an unpinned entry the OS
      // left in place (or one that did not count) prices nothing.
      if (!(none->second.entry->median("migrations_per_kstep").value_or(0.0) > 0.0)) continue;
      if (!best || compact->second.median < best->second.median) best = {none->second, compact->second};
    }
    if (!best) continue;
    plan.push_back({comparison_kind::migration,
                    fmt::format("sync:{} threads:{} layout:{}", key.first, key.second,
                                best->second.entry->spec.layout),
                    best->first.entry->name, best->second.entry->name});
  }
}

// Per placement and thread count (placements first, as the summary prints
// them), every other primitive's best entry against the leader's.
void plan_against_best_other(std::vector<comparison>& plan, std::vector<ranked_group> ranked, entry_kind kind) {
  std::stable_sort(ranked.begin(), ranked.end(), [](const ranked_group& a, const ranked_group& b) {
    return platform::to_string(a.pin) < platform::to_string(b.pin);
  });
  for (const ranked_group& group : ranked) {
    // Each primitive's best entry: its first in the group, which is fastest first.
    std::vector<measured_entry> best;
    for (const measured_entry& item : group.entries)
      if (std::none_of(best.begin(), best.end(),
                       [&](const measured_entry& seen) { return seen.entry->spec.sync == item.entry->spec.sync; }))
        best.push_back(item);
    if (best.size() < 2) continue;
    // Every other primitive against the leader; the leader against the
    // runner-up would be the runner-up's pair again, measured a second
    // time, and two measurements of one comparison can disagree.
    for (std::size_t index = 1; index < best.size(); ++index)
      plan.push_back({comparison_kind::against_best_other, against_best_other_group(kind, group.pin, group.threads),
                      best[index].entry->name, best[0].entry->name});
  }
}

// A block of about block_ns from the entry's batch size (sized for
// settings.target_batch_ns); at least one unit.
std::uint64_t block_units(const harness_state& harness, const std::string& name, std::int64_t block_ns) {
  const auto found = harness.units_per_batch.find(name);
  const double units = found == harness.units_per_batch.end() ? 1.0 : static_cast<double>(found->second);
  const double scaled =
      std::round(units * static_cast<double>(block_ns) / static_cast<double>(harness.settings.target_batch_ns));
  return static_cast<std::uint64_t>(std::clamp(scaled, 1.0, static_cast<double>(kMaxUnitsPerBatch)));
}

// One comparison while its pairs are being taken: both sides built once, and
// what the pairs so far gave.
struct comparison_in_progress {
  paired_result result;
  std::unique_ptr<block_runner> side_a;
  std::unique_ptr<block_runner> side_b;
  std::uint64_t units_a = 1;
  std::uint64_t units_b = 1;
  std::vector<double> block_ms;
  std::int64_t spent_ns = 0;  // time in this comparison's pairs so far
  bool finished = false;
};

comparison_in_progress start_comparison(harness_state& harness, const comparison& what,
                                        const pairing_settings& settings) {
  comparison_in_progress progress;
  progress.result.what = what;
  const auto factory_a = harness.block_runners.find(what.a);
  const auto factory_b = harness.block_runners.find(what.b);
  if (factory_a == harness.block_runners.end() || factory_b == harness.block_runners.end()) {
    progress.result.failure = "not measured as a pair: no block runner for a side";
    progress.finished = true;
    return progress;
  }
  progress.side_a = factory_a->second();
  progress.side_b = factory_b->second();
  progress.units_a = block_units(harness, what.a, settings.block_ns);
  progress.units_b = block_units(harness, what.b, settings.block_ns);
  return progress;
}

// Pair number `pair` of one comparison: a pace reading before (shared with
// the pair just before it, whichever comparison that was) and after, block A
// and block B, in the order A B on even pairs and B A on odd ones.
void take_pair(harness_state& harness, comparison_in_progress& progress, unsigned pair) {
  paired_result& result = progress.result;
  const auto& what = result.what;
  if (harness.pace != nullptr) result.readings.push_back(harness.pace->latest_or_take(kFreshReadingNs));
  const std::int64_t start_ns = platform::now_ns();
  std::optional<double> a;
  std::optional<double> b;
  if (pair % 2 == 0) {
    a = progress.side_a->run_block(progress.units_a);
    b = progress.side_b->run_block(progress.units_b);
  } else {
    b = progress.side_b->run_block(progress.units_b);
    a = progress.side_a->run_block(progress.units_a);
  }
  progress.spent_ns += platform::now_ns() - start_ns;
  if (harness.pace != nullptr) result.readings.push_back(harness.pace->take());
  if (!a || !b || !(*a > 0.0) || !(*b > 0.0)) {
    result.failure = fmt::format("not measured as a pair: a block of {} stalled", !a ? what.a : what.b);
    result.ratios.clear();
    result.readings.clear();
    progress.finished = true;
    return;
  }
  // Sides that say what their blocks saw: a pair in which another process
  // took a side's CPU is set aside, not averaged in.
  const auto facts_a = progress.side_a->last_facts();
  const auto facts_b = progress.side_b->last_facts();
  const auto preempted = [](const std::optional<block_facts>& facts) {
    if (!facts) return false;
    if (facts->run_queue_wait_ns)
      return static_cast<double>(*facts->run_queue_wait_ns) > kCpuTakenShare * static_cast<double>(facts->block_ns);
    return facts->involuntary_switches > 0;  // no schedstat: any preemption
  };
  if (preempted(facts_a) || preempted(facts_b)) {
    result.set_aside.push_back(*a / *b);
    if (harness.pace != nullptr) result.readings.resize(result.readings.size() - 2);
    return;
  }
  result.unit_ns_a.push_back(*a);
  result.unit_ns_b.push_back(*b);
  result.cpus_busy_a.push_back(facts_a && facts_a->cpus_busy ? *facts_a->cpus_busy : 0.0);
  result.cpus_busy_b.push_back(facts_b && facts_b->cpus_busy ? *facts_b->cpus_busy : 0.0);
  result.ratios.push_back(*a / *b);
  progress.block_ms.push_back(*a * static_cast<double>(progress.units_a) * 1e-6);
  progress.block_ms.push_back(*b * static_cast<double>(progress.units_b) * 1e-6);
}

paired_result finish_comparison(comparison_in_progress& progress, const pairing_settings& settings) {
  paired_result result = std::move(progress.result);
  if (!progress.block_ms.empty()) result.block_ms = platform::median(progress.block_ms);
  if (result.failure.empty()) {
    result.estimate = bootstrap_median(result.ratios);
    result.verdict = verdict_of(result.estimate, settings.noise);
  }
  return result;
}

}  // namespace

std::set<std::string> find_collapsed(const run_book& book) {
  // (kind, model, threads) -> the best median of the group
  using group_key = std::tuple<entry_kind, std::size_t, unsigned>;
  const auto key_of = [](const captured_entry& entry) {
    return group_key{entry.spec.kind, entry.spec.model.masses, entry.spec.threads};
  };
  const auto time_of = [](const captured_entry& entry) { return entry.median_time(); };
  const auto counts = [](const captured_entry& entry) {
    return (entry.spec.kind == entry_kind::rk4 || entry.spec.kind == entry_kind::barrier) && entry.error.empty();
  };
  std::map<group_key, double> best;
  for (const auto& entry : book.entries()) {
    if (!counts(entry)) continue;
    if (const auto time = time_of(entry); time && *time > 0.0) {
      const auto [found, inserted] = best.try_emplace(key_of(entry), *time);
      if (!inserted) found->second = std::min(found->second, *time);
    }
  }
  std::set<std::string> collapsed;
  for (const auto& entry : book.entries()) {
    if (!counts(entry) || entry.median("oversubscribed").value_or(0.0) < 0.5) continue;
    const auto time = time_of(entry);
    const auto group_best = best.find(key_of(entry));
    if (time && group_best != best.end() && *time >= kCollapseFactor * group_best->second)
      collapsed.insert(entry.name);
  }
  return collapsed;
}

std::string against_best_other_group(entry_kind kind, platform::placement pin, unsigned threads) {
  return fmt::format("{} pin:{} threads:{}", kind == entry_kind::barrier ? "bare episode" : "RK4 step",
                     platform::to_string(pin), threads);
}

std::vector<best_other_view> against_best_other_views(const run_book& book, const std::string& group) {
  std::vector<best_other_view> views;
  const paired_result* runner_up = nullptr;
  for (const paired_result& pair : book.pairs) {
    if (pair.what.kind != comparison_kind::against_best_other || pair.what.group != group) continue;
    if (!pair.failure.empty() || pair.ratios.empty()) continue;
    const captured_entry* a = book.find(pair.what.a);
    const captured_entry* b = book.find(pair.what.b);
    if (a == nullptr || b == nullptr) continue;
    views.push_back({a, b, &pair, false, pair.estimate, pair.verdict});
    if (runner_up == nullptr) runner_up = &pair;  // the plan's order: the runner-up's pair first
  }
  if (runner_up != nullptr)
    views.insert(views.begin(), best_other_view{views.front().other, views.front().entry, runner_up, true,
                                                inverse(runner_up->estimate), inverse(runner_up->verdict)});
  return views;
}

std::vector<comparison> plan_comparisons(const run_book& book) {
  std::vector<comparison> plan;
  const std::vector<measured_entry> steps = measured_of(book, entry_kind::rk4);
  plan_false_sharing(plan, steps);
  plan_migration(plan, steps);
  plan_against_best_other(plan, rank_groups(book, entry_kind::rk4), entry_kind::rk4);
  plan_against_best_other(plan, rank_groups(book, entry_kind::barrier), entry_kind::barrier);
  return plan;
}

void measure_pairs(harness_state& harness, const std::vector<comparison>& plan, const pairing_settings& settings,
                   const std::function<void(std::size_t, std::size_t)>& progress) {
  harness.book->noise = settings.noise;
  if (settings.pairs == 0) return;
  std::vector<comparison_in_progress> running;
  running.reserve(plan.size());
  for (const comparison& what : plan) running.push_back(start_comparison(harness, what, settings));
  // Rounds: each round takes one pair of every comparison still running, in
  // an order shuffled per round (seeded: a run can be repeated), so that a
  // comparison's pairs lie spread over the whole pairing phase, not within
  // the tenth of a second its pairs would take back to back.
  std::vector<std::size_t> order(running.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::mt19937_64 shuffle(kRoundOrderSeed);
  for (unsigned pair = 0; pair < settings.pairs; ++pair) {
    std::shuffle(order.begin(), order.end(), shuffle);
    for (const std::size_t index : order) {
      comparison_in_progress& item = running[index];
      if (item.finished) continue;
      if (pair >= kMinPairs && item.spent_ns > settings.budget_ns) {
        item.result.budget_cut = true;
        item.finished = true;
        continue;
      }
      take_pair(harness, item, pair);
    }
    if (progress) progress(pair + 1, settings.pairs);
  }
  for (auto& item : running) harness.book->pairs.push_back(finish_comparison(item, settings));
}

void assign_pace_modes(run_book& book, const pace_modes& modes) {
  book.for_each_repetition([&](std::map<std::string, double>& repetition) {
    const auto before = repetition.find(std::string(kPaceBeforeCounter));
    const auto after = repetition.find(std::string(kPaceAfterCounter));
    if (before == repetition.end() || after == repetition.end()) return;
    repetition["pace_mode"] = agreed_mode(modes, static_cast<std::size_t>(before->second),
                                          static_cast<std::size_t>(after->second));
    repetition.erase(std::string(kPaceBeforeCounter));
    repetition.erase(std::string(kPaceAfterCounter));
  });
  for (paired_result& pair : book.pairs) {
    pair.modes.clear();
    for (std::size_t index = 0; 2 * index + 1 < pair.readings.size() && index < pair.ratios.size(); ++index)
      pair.modes.push_back(agreed_mode(modes, pair.readings[2 * index], pair.readings[2 * index + 1]));
  }
}

void write_pace_and_pairs(nlohmann::json& result, const run_book& book, const pace_probe* probe,
                          const pace_modes& modes) {
  if (probe != nullptr) result["lockstep_pace"] = pace_json(*probe, modes);
  nlohmann::json pairs = nlohmann::json::array();
  for (const paired_result& pair : book.pairs) {
    if (!pair.failure.empty() || pair.ratios.empty()) continue;
    pairs.push_back({{"comparison", to_string(pair.what.kind)},
                     {"group", pair.what.group},
                     {"a", pair.what.a},
                     {"b", pair.what.b},
                     {"ratios", pair.ratios},
                     {"modes", pair.modes},
                     {"median", pair.estimate.median},
                     {"ci_low", pair.estimate.low},
                     {"ci_high", pair.estimate.high},
                     {"confidence", kConfidence},
                     // what recomputes the interval from the ratios (platform/statistics.hpp's draw rule)
                     {"resamples", kBootstrapResamples},
                     {"seed", kBootstrapSeed},
                     {"noise", book.noise},
                     {"verdict", to_string(pair.verdict)},
                     {"block_ms", pair.block_ms},
                     {"budget_cut", pair.budget_cut}});
  }
  result["lockstep_pairs"] = pairs;
}

}  // namespace lockstep::bench
