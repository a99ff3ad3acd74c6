// The end-of-run summary (harness_summary.hpp).
#include "bench/harness/summary.hpp"

#include "bench/harness/derived_figures.hpp"
#include "layouts/registry.hpp"

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

struct measured {
  const captured_entry* entry;
  double median;
};

// Entries of one kind that measured the counter, with its median.
std::vector<measured> measured_of(const run_book& book, const std::string& kind, const std::string& counter) {
  std::vector<measured> found;
  for (const auto& entry : book.entries()) {
    if (entry.field("kind") != kind || !entry.error.empty()) continue;
    if (const auto median = entry.median(counter)) found.push_back({&entry, *median});
  }
  return found;
}

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

void false_sharing(std::string& out, const std::vector<measured>& steps) {
  // (sync, pin, threads) -> layout -> median
  std::map<std::tuple<std::string, std::string, std::string>, std::map<std::string, double>> groups;
  for (const auto& step : steps)
    groups[{step.entry->field("sync"), step.entry->field("pin"), step.entry->field("threads")}]
          [step.entry->field("layout")] = step.median;
  out += "\nBest and worst layout per primitive (false-sharing penalty = a layout whose writers share lines / the "
         "best one that isolates them):\n";
  for (const auto& [key, layouts] : groups) {
    const auto& [sync, pin, threads] = key;
    const auto best = std::min_element(layouts.begin(), layouts.end(),
                                       [](const auto& a, const auto& b) { return a.second < b.second; });
    const auto worst = std::max_element(layouts.begin(), layouts.end(),
                                        [](const auto& a, const auto& b) { return a.second < b.second; });
    std::optional<std::pair<std::string, double>> best_isolated;
    std::optional<std::pair<std::string, double>> sharing;
    for (const auto& [layout, median] : layouts) {
      if (writers_isolated(layout) && (!best_isolated || median < best_isolated->second)) best_isolated = {layout, median};
      if (writers_share_lines(layout) && !sharing) sharing = {layout, median};
    }
    std::string penalty = "false-sharing penalty: -";
    if (sharing && best_isolated)
      penalty = fmt::format("{}/{}: {:.2f}x", sharing->first, best_isolated->first,
                            sharing->second / best_isolated->second);
    out += fmt::format("  {:<20} pin:{:<8} threads:{:<3} best {} {}, worst {} {}, {}\n", sync, pin, threads,
                       best->first, format_ns(best->second), worst->first, format_ns(worst->second), penalty);
  }
}

void migration(std::string& out, const std::vector<measured>& steps) {
  // (sync, layout, threads) -> pin -> median
  std::map<std::tuple<std::string, std::string, std::string>, std::map<std::string, double>> groups;
  for (const auto& step : steps)
    groups[{step.entry->field("sync"), step.entry->field("layout"), step.entry->field("threads")}]
          [step.entry->field("pin")] = step.median;
  // Per (sync, threads): the layout that is best pinned (compact).
  std::map<std::pair<std::string, std::string>, std::pair<std::string, double>> best_pinned;
  for (const auto& [key, pins] : groups) {
    const auto& [sync, layout, threads] = key;
    const auto compact = pins.find("compact");
    if (compact == pins.end() || pins.find("none") == pins.end()) continue;
    auto& best = best_pinned[{sync, threads}];
    if (best.first.empty() || compact->second < best.second) best = {layout, compact->second};
  }
  out += "\nPinned against unpinned (migration penalty = pin:none / pin:compact, each primitive's best pinned "
         "layout):\n";
  if (best_pinned.empty()) out += "  (needs both pin:none and pin:compact in the run)\n";
  for (const auto& [key, best] : best_pinned) {
    const auto& pins = groups[{key.first, best.first, key.second}];
    const double none = pins.at("none");
    out += fmt::format("  {:<20} threads:{:<3} layout:{:<10} none {}, compact {}, none/compact {:.2f}x\n", key.first,
                       key.second, best.first, format_ns(none), format_ns(best.second), none / best.second);
  }
}

// Each primitive against the best other primitive at each placement and
// thread count: both on their best layout (the lowest median over layouts),
// ratio = this primitive / the best other (below 1: it leads the group).
void against_best_other(std::string& out, const std::vector<measured>& entries, const char* what, const char* unit) {
  // (pin, threads) -> sync -> its best entry
  std::map<std::pair<std::string, std::string>, std::map<std::string, measured>> groups;
  for (const auto& item : entries) {
    auto& best = groups[{item.entry->field("pin"), item.entry->field("threads")}];
    const auto found = best.find(item.entry->field("sync"));
    if (found == best.end() || item.median < found->second.median) best.insert_or_assign(item.entry->field("sync"), item);
  }
  out += fmt::format("\nEach primitive against the best other primitive ({}; best layout each; ratio < 1: it leads):\n",
                     what);
  bool any = false;
  for (const auto& [key, best] : groups) {
    if (best.size() < 2) continue;
    any = true;
    std::vector<measured> ranked;
    for (const auto& [sync, item] : best) ranked.push_back(item);
    std::sort(ranked.begin(), ranked.end(), [](const measured& a, const measured& b) { return a.median < b.median; });
    out += fmt::format("  pin:{} threads:{}\n", key.first, key.second);
    for (std::size_t i = 0; i < ranked.size(); ++i) {
      const measured& other = ranked[i == 0 ? 1 : 0];
      const std::string layout = ranked[i].entry->field("layout");
      out += fmt::format("    {:<20} {:>11}{} {:<12} vs best other {:<20} {:>6.2f}x\n", ranked[i].entry->field("sync"),
                         format_ns(ranked[i].median), unit, layout.empty() ? "" : "(" + layout + ")",
                         other.entry->field("sync"), ranked[i].median / other.median);
    }
  }
  if (!any) out += "  (needs two primitives at one placement and thread count)\n";
}

}  // namespace

std::string oversubscribed_note(const run_book& book, unsigned cpus) {
  std::set<std::string> thread_counts;
  std::size_t count = 0;
  for (const auto& entry : book.entries()) {
    if (const auto flag = entry.median("oversubscribed"); flag && *flag > 0.5) {
      ++count;
      thread_counts.insert("threads:" + entry.field("threads"));
    }
  }
  if (count == 0) return "none: every measured entry had a CPU per thread";
  std::string counts;
  for (const auto& threads : thread_counts) counts += (counts.empty() ? "" : ", ") + threads;
  return fmt::format("{} entries ran oversubscribed (more threads than the {} CPUs of the affinity set: {})", count,
                     cpus, counts);
}

std::string render_summary(const run_book& book, const std::string& result_path) {
  std::string out;
  std::size_t skipped = 0;
  for (const auto& entry : book.entries()) skipped += entry.error.empty() ? 0 : 1;
  out += fmt::format("lockstep run: {} entries measured, {} skipped, {} not applicable; results in {}\n",
                     book.entries().size() - skipped, skipped, book.not_applicable.size(), result_path);

  out += "\nIn-run calibration: ";
  out += book.c2c_one_way_ns() ? "core-to-core one-way " + format_ns(*book.c2c_one_way_ns()) : "c2c unavailable";
  if (const captured_entry* c2c = book.find(entry_spec{entry_kind::c2c, {}, {}, platform::placement::compact, 2}.name());
      c2c != nullptr && book.c2c_one_way_ns()) {
    if (const auto range = c2c->range("one_way_ns"))
      out += fmt::format(" (repetitions {}..{})", format_ns(range->first), format_ns(range->second));
  }
  out += book.serial_step_ns() ? ", serial RK4 step " + format_ns(*book.serial_step_ns()) : ", serial step unavailable";
  out += fmt::format(", clock reading {} (taken off each timed sync)", format_ns(book.clock_read_ns));
  out += "\n";

  std::vector<measured> steps = measured_of(book, "rk4", "ns_per_step");
  steps.erase(std::remove_if(steps.begin(), steps.end(),
                             [](const measured& step) { return step.entry->field("variant") == "serial"; }),
              steps.end());
  std::sort(steps.begin(), steps.end(), [](const measured& a, const measured& b) { return a.median < b.median; });
  if (!steps.empty()) {
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
                         entry.name, entry.median("oversubscribed").value_or(0.0) > 0.5 ? "  [oversubscribed]" : "");
    }
    false_sharing(out, steps);
    migration(out, steps);
    against_best_other(out, steps, "RK4 step time", "/step");

    // The best stage sync at 2 threads pinned, against the one-way
    // core-to-core latency: the latency measured in the same call
    // (vs_c2c_paired) where the entry has it, and the run's calibration
    // (vs_c2c) for reference.
    bool header = false;
    for (const char* ratio_name : {"vs_c2c_paired", "vs_c2c"}) {
      std::optional<std::pair<const captured_entry*, double>> best_c2c;
      for (const auto& step : steps) {
        if (step.entry->field("threads") != "2" || step.entry->field("pin") != "compact") continue;
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

  std::vector<measured> episodes = measured_of(book, "barrier", "ns_per_episode");
  if (!episodes.empty()) {
    std::sort(episodes.begin(), episodes.end(), [](const measured& a, const measured& b) {
      return std::tuple(a.entry->field("threads"), a.entry->field("pin"), a.median) <
             std::tuple(b.entry->field("threads"), b.entry->field("pin"), b.median);
    });
    out += "\nBare primitives, median time per episode:\n";
    for (const auto& episode : episodes)
      out += fmt::format("  {:>11} {:>8}  futex waits/episode {:>6}  timeouts {:>3}  {}{}\n", format_ns(episode.median),
                         spread_of(*episode.entry, "ns_per_episode"),
                         // absent: the primitive cannot count them (registry.hpp: counts_futex_waits)
                         optional_number(*episode.entry, "futex_waits_per_episode", "{:.3f}", "unavailable"),
                         optional_number(*episode.entry, "timeouts", "{:.0f}"), episode.entry->name,
                         episode.entry->median("oversubscribed").value_or(0.0) > 0.5 ? "  [oversubscribed]" : "");
    against_best_other(out, episodes, "bare episodes", "/episode");
  }

  // The harness's own cost: the overhead pair.
  std::optional<double> with_accounting;
  std::optional<double> without_accounting;
  std::string overhead_name;
  for (const auto& entry : book.entries()) {
    if (entry.field("kind") != "overhead" || !entry.error.empty()) continue;
    (entry.field("accounting") == "on" ? with_accounting : without_accounting) = entry.median("ns_per_step");
    overhead_name = entry.name.substr(entry.name.find("/sync:") + 1);
  }
  // Paired in each repetition of the "on" side (rk4_benchmarks.cpp): the
  // figure to read. The entries' own medians follow, for reference.
  bool paired_shown = false;
  for (const auto& entry : book.entries()) {
    if (entry.field("kind") != "overhead" || entry.field("accounting") != "on" || !entry.error.empty()) continue;
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

  std::vector<std::string> oversubscribed;
  for (const auto& entry : book.entries())
    if (entry.error.empty() && entry.median("oversubscribed").value_or(0.0) > 0.5) oversubscribed.push_back(entry.name);
  out += fmt::format("\nRan oversubscribed (more threads than CPUs): {}\n",
                     oversubscribed.empty() ? std::string("none") : std::to_string(oversubscribed.size()) + " entries");
  for (const auto& name : oversubscribed) out += "  " + name + "\n";

  if (!book.not_applicable.empty()) {
    out += fmt::format("\nNot applicable ({}):\n", book.not_applicable.size());
    for (const auto& skipped_entry : book.not_applicable)
      out += "  " + skipped_entry.name + ": " + skipped_entry.reason + "\n";
  }
  if (skipped > 0) {
    out += fmt::format("\nStalled or skipped ({}):\n", skipped);
    for (const auto& entry : book.entries())
      if (!entry.error.empty()) out += "  " + entry.name + ": " + entry.error + "\n";
  }
  for (const auto& note : book.notes) out += "\nNote: " + note + "\n";
  return out;
}

}  // namespace lockstep::bench
