// The end-of-run summary (summary.hpp).
#include "bench/run/scaling.hpp"
#include "bench/run/summary.hpp"

#include "bench/run/derived_sections.hpp"

#include "bench/results/derived_figures.hpp"
#include "bench/run/paired_blocks.hpp"
#include "bench/run/ranking.hpp"
#include "platform/statistics.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

namespace lockstep::bench {

namespace {

// The short summary's ranking: this many combinations per group.
constexpr std::size_t kShortRankingPerGroup = 3;

std::string spread_of(const captured_entry& entry, const std::string& counter) {
  const auto median = entry.median(counter);
  const auto range = entry.range(counter);
  if (!median || !range || *median <= 0.0) return "-";
  // The half-range relative to the median: what a re-run may move it by.
  return fmt::format("+-{:.1f}%", (range->second - range->first) / 2.0 / *median * 100.0);
}

std::string optional_number(const captured_entry& entry, const std::string& counter, const char* format_spec,
                            const char* absent = "-") {
  const auto value = entry.median(counter);
  if (!value) return absent;
  return fmt::format(fmt::runtime(format_spec), *value);
}

// The CPUs a step kept busy: the team's CPU time per step over the step's
// wall time (both medians over the repetitions). A team that spins while it
// waits reads near its thread count; one that sleeps, less.
std::string cpus_busy(const captured_entry& entry) {
  const auto cpu = entry.median(fmt::format("team_cpu_ns_per_{}", to_string(entry.spec.unit())));
  const auto wall = entry.median_time();
  if (!cpu || !wall || !(*wall > 0.0)) return "-";
  return fmt::format("{:.1f}", *cpu / *wall);
}

// "  [oversubscribed] [straddles a pace change] [short batches]"
std::string entry_flags(const captured_entry& entry) {
  std::string flags;
  if (entry.median("oversubscribed").value_or(0.0) > 0.5) flags += "  [oversubscribed]";
  if (entry.pace_medians().straddling > 0) flags += "  [straddles a pace change]";
  if (entry.median("short_batches").value_or(0.0) > 0.5) flags += "  [short batches: the harness barrier weighs in]";
  return flags;
}

// Entries whose repetitions ran in more than one pace mode: their median in each.
void per_mode_medians(std::string& out, const run_book& book, const std::optional<pace_modes>& run_pace) {
  const std::vector<entry_in_modes> several = entries_in_several_modes(book);
  if (several.empty() || !run_pace) return;
  std::string lines;
  for (const entry_in_modes& entry : several) {
    std::string cells;
    for (const pace_mode_time& mode : entry.times.modes) {
      if (static_cast<std::size_t>(mode.mode) >= run_pace->modes.size()) continue;
      const pace_mode& pace = run_pace->modes[static_cast<std::size_t>(mode.mode)];
      cells += fmt::format("{}{} {}: {} (x{})", cells.empty() ? "" : ", ", run_pace->has_c2c ? "c2c" : "serial",
                           format_ns(run_pace->has_c2c ? pace.c2c_ns : pace.serial_ns), format_ns(mode.median),
                           mode.repetitions);
    }
    lines += fmt::format("  {:<62} {}\n", entry.entry->name, cells);
  }
  out += fmt::format("\nMedian per pace mode ({} entries ran in more than one mode; repetitions that straddle a "
                     "change left out):\n",
                     several.size());
  out += lines;
}

// One comparison's line: the paired ratio with its interval and verdict, or,
// when it was not measured as a pair, the ratio of the two medians (marked).
std::string comparison_figure(const run_book& book, const comparison& what) {
  const auto pair = std::find_if(book.pairs.begin(), book.pairs.end(), [&](const paired_result& measured_pair) {
    return measured_pair.what.a == what.a && measured_pair.what.b == what.b;
  });
  if (pair != book.pairs.end() && pair->failure.empty() && !pair->ratios.empty()) {
    std::size_t straddling = 0;
    for (int mode : pair->modes) straddling += mode < 0 ? 1 : 0;
    return fmt::format("{:.2f}x [{:.2f}, {:.2f}] {:<12} ({} pairs{}{})", pair->estimate.median, pair->estimate.low,
                       pair->estimate.high, to_string(pair->verdict), pair->ratios.size(),
                       pair->budget_cut ? ", cut by the time budget: slow blocks" : "",
                       straddling > 0 ? fmt::format(", {} straddling a pace change", straddling) : "");
  }
  const captured_entry* a = book.find(what.a);
  const captured_entry* b = book.find(what.b);
  const double median_a = a != nullptr ? a->median_time().value_or(0.0) : 0.0;
  const double median_b = b != nullptr ? b->median_time().value_or(0.0) : 0.0;
  std::string why = pair != book.pairs.end() ? pair->failure : std::string("not measured as a pair");
  if (!(median_a > 0.0) || !(median_b > 0.0)) return why;
  return fmt::format("{:.2f}x (medians, unpaired: no interval; {})", median_a / median_b, why);
}

std::string median_of(const run_book& book, const std::string& name) {
  const captured_entry* entry = book.find(name);
  const auto median = entry != nullptr ? entry->median_time() : std::nullopt;
  return median ? format_ns(*median) : "-";
}

void comparisons_of(std::string& out, const run_book& book, const std::vector<comparison>& plan,
                    comparison_kind kind) {
  std::string last_group;
  for (const comparison& what : plan) {
    if (what.kind != kind) continue;
    const captured_entry* a = book.find(what.a);
    const captured_entry* b = book.find(what.b);
    if (a == nullptr || b == nullptr) continue;
    switch (kind) {
      case comparison_kind::false_sharing:
        out += fmt::format("  {:<44} {}/{} ({} / {}): {}\n", what.group, a->spec.layout, b->spec.layout,
                           median_of(book, what.a), median_of(book, what.b), comparison_figure(book, what));
        break;
      case comparison_kind::migration:
        out += fmt::format("  {:<44} none {} / compact {}: {}\n", what.group, median_of(book, what.a),
                           median_of(book, what.b), comparison_figure(book, what));
        break;
      case comparison_kind::crossover:  // the sweep's own section (crossover.hpp), not the run's plan
        break;
      case comparison_kind::against_best_other:
        if (what.group == last_group) break;
        last_group = what.group;
        out += "  " + what.group + "\n";
        // One measurement per unordered pair: the leader's line is its pair
        // with the runner-up read the other way round.
        for (const best_other_view& view : against_best_other_views(book, what.group)) {
          const captured_entry* entry = view.entry;
          const captured_entry* other = view.other;
          out += fmt::format("    {:<20} {:>11} {:<13} vs {:<20} {:.2f}x [{:.2f}, {:.2f}] {:<12} ({} pairs{}{})\n",
                             entry->spec.sync, median_of(book, entry->name),
                             entry->spec.layout.empty() ? std::string() : fmt::format("({})", entry->spec.layout),
                             other->spec.sync, view.estimate.median, view.estimate.low, view.estimate.high,
                             to_string(view.verdict), view.pair->ratios.size(),
                             view.inverted ? ", the runner-up's pair inverted" : "",
                             view.pair->budget_cut ? ", cut by the time budget: slow blocks" : "");
        }
        break;
    }
  }
}

// The short ranking: the fastest few combinations of each model, thread
// count and placement.
void short_ranking(std::string& out, const run_book& book, std::size_t per_group) {
  const std::vector<ranked_group> groups = rank_groups(book, entry_kind::rk4);
  if (groups.empty()) return;
  out += fmt::format("\nFastest {} per thread count and placement (median step, spread over repetitions, stage "
                     "sync in core-to-core transfers, CPUs the team kept busy):\n",
                     per_group);
  for (const ranked_group& group : groups) {
    out += fmt::format("  {}threads:{} pin:{}\n", group.model.is_chain() ? "model:" + group.model.name() + " " : "",
                       group.threads, platform::to_string(group.pin));
    for (std::size_t index = 0; index < group.entries.size() && index < per_group; ++index) {
      const measured_entry& step = group.entries[index];
      const captured_entry& entry = *step.entry;
      out += fmt::format("    {:>11} {:>8} {:>6} {:>4} CPU  {} + {}{}\n", format_ns(step.median),
                         spread_of(entry, "ns_per_step"), optional_number(entry, "vs_c2c", "{:.2f}"), cpus_busy(entry),
                         entry.spec.sync, entry.spec.layout, entry_flags(entry));
    }
  }
}

}  // namespace

std::string oversubscribed_note(const run_book& book, unsigned cpus) {
  std::set<unsigned> thread_counts;  // in numeric order
  std::size_t count = 0;
  for (const auto& entry : book.entries()) {
    if (const auto flag = entry.median("oversubscribed"); flag && *flag > 0.5) {
      ++count;
      thread_counts.insert(entry.spec.threads);
    }
  }
  if (count == 0) return "none: every measured entry had a CPU per thread";
  std::string counts;
  for (const unsigned threads : thread_counts) counts += fmt::format("{}threads:{}", counts.empty() ? "" : ", ", threads);
  return fmt::format("{} entries ran oversubscribed (more threads than the {} CPUs of the affinity set: {})", count,
                     cpus, counts);
}

namespace {

// The first lines: what was measured, the in-run calibrations and the pace.
void calibration_lines(std::string& out, const run_book& book, const std::optional<pace_modes>& pace,
                       const std::string& result_path, std::size_t skipped) {
  std::size_t partly_stopped = 0;
  for (const auto& entry : book.entries()) partly_stopped += entry.stopped_repetitions > 0 ? 1 : 0;
  out += fmt::format("lockstep run: {} entries measured{}, {} skipped, {} not applicable; results in {}\n",
                     book.entries().size() - skipped,
                     partly_stopped == 0 ? std::string()
                                         : fmt::format(" ({} of them lost repetitions to a stop)", partly_stopped),
                     skipped, book.not_applicable.size(), result_path);
  out += "\nIn-run calibration: ";
  out += book.c2c_one_way_ns() ? "core-to-core one-way " + format_ns(*book.c2c_one_way_ns()) : "c2c unavailable";
  if (const captured_entry* c2c = book.find(entry_spec::c2c_calibration().name());
      c2c != nullptr && book.c2c_one_way_ns()) {
    if (const auto range = c2c->range("one_way_ns"))
      out += fmt::format(" (repetitions {}..{})", format_ns(range->first), format_ns(range->second));
  }
  out += book.serial_step_ns() ? ", serial RK4 step " + format_ns(*book.serial_step_ns()) : ", serial step unavailable";
  out += fmt::format(", clock reading {} (taken off each timed sync)", format_ns(book.clock_read_ns));
  out += "\n";
  if (pace) {
    out += fmt::format("Pace of the machine ({} readings around the entries and pairs): {}\n", pace->mode_of.size(),
                       pace->summary());
  }
}

// The best stage sync at 2 threads pinned, against the one-way core-to-core
// latency: the latency measured in the same call (vs_c2c_paired) where the
// entry has it, and the run's calibration (vs_c2c) for reference.
void best_stage_sync_lines(std::string& out, const std::vector<measured_entry>& steps) {
  bool header = false;
  for (const char* ratio_name : {"vs_c2c_paired", "vs_c2c"}) {
    std::optional<std::pair<const captured_entry*, double>> best_c2c;
    for (const auto& step : steps) {
      if (step.entry->spec.threads != 2 || step.entry->spec.pin != platform::placement::compact) continue;
      if (const auto ratio = step.entry->median(ratio_name); ratio && (!best_c2c || *ratio < best_c2c->second))
        best_c2c = {step.entry, *ratio};
    }
    if (!best_c2c) continue;
    const bool paired = std::string_view(ratio_name) == "vs_c2c_paired";
    const auto latency = best_c2c->first->median("c2c_paired_ns");
    out += fmt::format(
        "{}{} {:.2f} ({}; {})\n",
        header ? "  against the run's calibration: " : "\nBest stage sync at threads:2 pin:compact: ",
        ratio_name, best_c2c->second, best_c2c->first->name,
        paired && latency ? fmt::format("one-way latency in the same calls {}", format_ns(*latency))
                          : "the run's calibration");
    header = true;
  }
}

// Every RK4 entry ranked by its median step, then the best stage sync.
void step_ranking(std::string& out, const run_book& book) {
  std::vector<measured_entry> steps = measured_of(book, entry_kind::rk4);
  std::sort(steps.begin(), steps.end(), [](const measured_entry& a, const measured_entry& b) { return a.median < b.median; });
  if (steps.empty()) return;
  out += "\nRK4 step, ranked by median step time (spread: half the min..max range over repetitions):\n";
  out += fmt::format("  {:>4} {:>11} {:>8} {:>9} {:>11} {:>7}  {}\n", "rank", "step", "spread", "vs_serial",
                     "sync/stage", "vs_c2c", "combination");
  std::size_t rank = 0;
  for (const auto& step : steps) {
    const captured_entry& entry = *step.entry;
    const auto sync_stage = entry.median("sync_ns_per_stage");
    out += fmt::format("  {:>4} {:>11} {:>8} {:>9} {:>11} {:>7}  {}{}\n", ++rank, format_ns(step.median),
                       spread_of(entry, "ns_per_step"), optional_number(entry, "vs_serial", "{:.2f}"),
                       sync_stage ? format_ns(*sync_stage) : "-", optional_number(entry, "vs_c2c", "{:.2f}"),
                       entry.name, entry_flags(entry));
  }
  best_stage_sync_lines(out, steps);
}

// The bare primitives' episodes, by thread count, placement and median.
void episode_table(std::string& out, const run_book& book) {
  const std::vector<ranked_group> groups = rank_groups(book, entry_kind::barrier);
  if (groups.empty()) return;
  out += "\nBare primitives, median time per episode:\n";
  for (const ranked_group& group : groups)
    for (const measured_entry& episode : group.entries)
      out += fmt::format("  {:>11} {:>8}  futex waits/episode {:>6}  timeouts {:>3}  {}{}\n",
                         format_ns(episode.median), spread_of(*episode.entry, "ns_per_episode"),
                         // absent: the primitive cannot count them (registry.hpp: counts_futex_waits)
                         optional_number(*episode.entry, "futex_waits_per_episode", "{:.3f}", "unavailable"),
                         optional_number(*episode.entry, "timeouts", "{:.0f}"), episode.entry->name,
                         entry_flags(*episode.entry));
}

// Every ratio the summary prints, paired (paired_blocks.hpp).
void paired_ratio_tables(std::string& out, const run_book& book) {
  const std::vector<comparison> plan = plan_comparisons(book);
  out += fmt::format(
      "\nPaired ratios: each measured as alternating blocks of its two sides (A B, B A, ...), one pair per round "
      "of all comparisons (so its pairs spread over the pairing phase), the median ratio "
      "over pairs with its {:.0f} % bootstrap interval, against the noise band of {:.0f} % "
      "(platform/statistics.hpp): \"penalty\" / \"gain\" when the whole interval lies above / below the band, "
      "\"within noise\" when it lies wholly inside, \"unsure\" when it straddles an edge of the band.\n",
      100.0 * kConfidence, 100.0 * book.noise);
  out += "\nFalse-sharing penalty per primitive (a layout whose writers share lines / the best one that isolates "
         "them):\n";
  comparisons_of(out, book, plan, comparison_kind::false_sharing);
  out += "\nMigration penalty (pin:none / pin:compact, each primitive's best pinned layout):\n";
  comparisons_of(out, book, plan, comparison_kind::migration);
  out += "\nEach primitive against the best other primitive (best layout each; ratio < 1 and \"gain\": it leads):\n";
  comparisons_of(out, book, plan, comparison_kind::against_best_other);
}

// The harness's own cost: the overhead pair.
void overhead_lines(std::string& out, const run_book& book) {
  std::optional<double> with_accounting;
  std::optional<double> without_accounting;
  std::string overhead_name;
  for (const auto& entry : book.entries()) {
    if (entry.spec.kind != entry_kind::overhead || !entry.error.empty()) continue;
    (entry.spec.accounting ? with_accounting : without_accounting) = entry.median_time();
    overhead_name = fmt::format("sync:{}/layout:{}/pin:{}/threads:{}", entry.spec.sync, entry.spec.layout,
                                platform::to_string(entry.spec.pin), entry.spec.threads);
  }
  // Paired in each repetition of the "on" side (rk4_entries.cpp): the
  // figure to read. The entries' own medians follow, for reference.
  bool paired_shown = false;
  for (const auto& entry : book.entries()) {
    if (entry.spec.kind != entry_kind::overhead || !entry.spec.accounting || !entry.error.empty()) continue;
    const auto paired = entry.median("overhead_ratio");
    const auto range = entry.range("overhead_ratio");
    if (!paired || !range) continue;
    out += fmt::format(
        "\nHarness overhead ({}): accounting and instrumentation on / off, paired in each of {} repetitions: "
        "median {:.3f}x (range {:.3f}..{:.3f})\n",
        overhead_name, entry.repetitions.size(), *paired, range->first, range->second);
    paired_shown = true;
  }
  if (with_accounting && without_accounting)
    out += fmt::format("{}the two entries' medians, measured one after the other: on {} / off {} = {:.3f}x\n",
                       paired_shown ? "  " : "\nHarness overhead (" + overhead_name + "), ",
                       format_ns(*with_accounting), format_ns(*without_accounting),
                       *with_accounting / *without_accounting);
}

// What was left out and why: oversubscribed, collapsed, not applicable,
// stalled or skipped entries, and the run's notes.
void left_out_lines(std::string& out, const run_book& book, std::size_t skipped) {
  out += "\nRan oversubscribed (more threads than CPUs): " + oversubscribed_note(book, book.cpus) + "\n";
  if (!book.collapsed.empty()) {
    out += fmt::format("Collapsed ({}: oversubscribed and at least {:.0f}x the best of their kind and thread count; "
                       "out of the rankings and pairs above):\n",
                       book.collapsed.size(), kCollapseFactor);
    for (const captured_entry* entry : collapsed_entries(book))
      out += fmt::format("  {:<62} {}\n", entry->name, median_of(book, entry->name));
  }
  if (!book.not_applicable.empty()) {
    std::map<std::string, std::vector<std::string>> by_reason;
    for (const auto& skipped_entry : book.not_applicable) by_reason[skipped_entry.reason].push_back(skipped_entry.name);
    out += fmt::format("\nNot applicable ({}):\n", book.not_applicable.size());
    for (const auto& [reason, names] : by_reason) out += fmt::format("  {} entries: {}\n", names.size(), reason);
  }
  if (skipped > 0) {
    out += fmt::format("\nStalled or skipped ({}):\n", skipped);
    for (const auto& entry : book.entries())
      if (!entry.error.empty()) out += "  " + entry.name + ": " + entry.error + "\n";
  }
  bool header = false;
  for (const auto& entry : book.entries()) {
    if (entry.stopped_repetitions == 0) continue;
    if (!header) out += "\nRepetitions stopped (the entries' figures are the other repetitions'):\n";
    header = true;
    out += fmt::format("  {}: {} of {}: {}\n", entry.name, entry.stopped_repetitions,
                       entry.stopped_repetitions + entry.repetitions.size(), entry.stop_reason);
  }
  for (const auto& note : book.notes) out += "\nNote: " + note + "\n";
}

}  // namespace

std::string render_summary(const run_result& result, const std::string& result_path, bool verbose) {
  const run_book& book = result.book;
  std::string out;
  std::size_t skipped = 0;
  for (const auto& entry : book.entries()) skipped += entry.error.empty() ? 0 : 1;
  calibration_lines(out, book, result.pace, result_path, skipped);
  if (!verbose) {
    if (book.scaling) out += render_scaling(scaling_of(book));  // the sweep's own answer
    short_ranking(out, book, kShortRankingPerGroup);
    out += '\n';
    out += answer_text(result.answer);
    return out;
  }
  step_ranking(out, book);
  episode_table(out, book);
  paired_ratio_tables(out, book);
  overhead_lines(out, book);
  if (book.scaling) out += render_scaling(scaling_of(book));
  per_mode_medians(out, book, result.pace);
  left_out_lines(out, book, skipped);
  out += '\n';
  out += answer_text(result.answer);
  return out;
}

}  // namespace lockstep::bench
