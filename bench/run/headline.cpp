// The answer of a run (headline.hpp).
#include "bench/run/headline.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "bench/run/paired_blocks.hpp"
#include "bench/run/run_book.hpp"
#include "platform/format.hpp"
#include "sync/registry.hpp"

namespace lockstep::bench {

namespace {

// A name list for one line: "a, b, c" or "a, b and 4 more".
std::string short_list(const std::vector<std::string>& names, std::size_t shown = 4) {
  std::string text;
  for (std::size_t index = 0; index < names.size() && index < shown; ++index)
    text += (index == 0 ? "" : ", ") + names[index];
  if (names.size() > shown) text += fmt::format(" and {} more", names.size() - shown);
  return text;
}

// A line cut to the headline's width at a word, marked; the whole text
// stays where it came from (lockstep run --verbose, the report's tables).
constexpr std::size_t kLineWidth = 120;
std::string fitted(std::string line) {
  if (line.size() <= kLineWidth) return line;
  const std::size_t cut = line.rfind(' ', kLineWidth - 4);
  line.resize(cut == std::string::npos ? kLineWidth - 4 : cut);
  return line + " ...";
}

std::string ratio_text(const ratio_estimate& estimate, ratio_verdict verdict) {
  return fmt::format("{:.2f}x [{:.2f}, {:.2f}] {}", estimate.median, estimate.low, estimate.high, to_string(verdict));
}

std::string model_words(const std::string& model) { return model.empty() ? std::string() : "model:" + model + " "; }

// The against_best_other group name of rk4 entries (paired_blocks.cpp).
std::string step_group(const std::string& pin, unsigned threads) {
  return fmt::format("RK4 step pin:{} threads:{}", pin, threads);
}

std::optional<headline_rival> rival_from(const best_other_view& view, const run_book& book) {
  const captured_entry* other = book.find(view.entry);
  if (other == nullptr) return std::nullopt;
  return headline_rival{view.entry, other->field("sync"), view.estimate, view.verdict};
}

std::vector<headline_choice> choose(const run_book& book) {
  // (model, threads, pin) -> the entries that count, fastest first
  using group_key = std::tuple<std::string, unsigned, std::string>;
  std::map<group_key, std::vector<measured_entry>> groups;
  for (const measured_entry& step : measured_of(book, "rk4", "ns_per_step")) {
    const captured_entry& entry = *step.entry;
    groups[{entry.field("model"), static_cast<unsigned>(std::stoul(entry.field("threads"))), entry.field("pin")}]
        .push_back(step);
  }
  std::vector<headline_choice> choices;
  for (auto& [key, steps] : groups) {
    std::sort(steps.begin(), steps.end(), [](const measured_entry& a, const measured_entry& b) { return a.median < b.median; });
    const auto& [model, threads, pin] = key;
    const captured_entry* chosen = steps.front().entry;
    headline_choice choice;
    choice.model = model;
    choice.threads = threads;
    choice.pin = pin;
    choice.median_leader = chosen->name;
    choice.basis = "medians";
    // Each primitive against the leader, paired (the leader's view is the
    // inverse of its pair with the runner-up).
    const std::vector<best_other_view> views = against_best_other_views(book, step_group(pin, threads));
    const best_other_view* leader_view = nullptr;
    for (const auto& view : views)
      if (view.entry == chosen->name) leader_view = &view;
    if (leader_view != nullptr) {
      choice.basis = "paired";
      if (leader_view->verdict == ratio_verdict::penalty) {
        // The runner-up is faster, side by side: it goes first, and the
        // median leader becomes its rival (leader / runner-up).
        chosen = book.find(leader_view->other);
        choice.runner_up = headline_rival{leader_view->entry, book.find(leader_view->entry)->field("sync"),
                                          leader_view->estimate, leader_view->verdict};
      } else {
        const captured_entry* other = book.find(leader_view->other);
        if (other != nullptr)
          choice.runner_up = headline_rival{leader_view->other, other->field("sync"), inverse(leader_view->estimate),
                                            inverse(leader_view->verdict)};
      }
    }
    choice.entry = chosen->name;
    choice.sync = chosen->field("sync");
    choice.layout = chosen->field("layout");
    choice.ns_per_step = chosen->median("ns_per_step").value_or(0.0);
    if (const auto range = chosen->range("ns_per_step"); range && choice.ns_per_step > 0.0)
      choice.spread_pct = (range->second - range->first) / 2.0 / choice.ns_per_step * 100.0;
    for (const auto& [mode, values] : chosen->by_pace_mode("ns_per_step")) {
      if (mode < 0) choice.straddles_pace_change = true;
      else ++choice.paces;
    }
    choice.vs_c2c = chosen->median("vs_c2c");
    if (const auto cpu = chosen->median("team_cpu_ns_per_step"); cpu && choice.ns_per_step > 0.0)
      choice.cpus_busy = *cpu / choice.ns_per_step;
    choice.oversubscribed = chosen->median("oversubscribed").value_or(0.0) > 0.5;
    // std::barrier, the C++20 baseline, against the choice: its own pair
    // is against the median leader, which is the choice unless overturned.
    for (const auto& view : views) {
      const captured_entry* entry = book.find(view.entry);
      if (entry == nullptr || entry->field("sync") != sync::kBaselinePrimitive || view.entry == choice.entry) continue;
      if (view.other == choice.entry) choice.baseline = rival_from(view, book);
    }
    choices.push_back(std::move(choice));
  }
  std::stable_sort(choices.begin(), choices.end(), [](const headline_choice& a, const headline_choice& b) {
    return std::tie(a.threads, a.model) < std::tie(b.threads, b.model);
  });
  return choices;
}

// "+-4.2 %", and where the spread comes from when the machine changed pace
// under the repetitions (lockstep run --verbose splits them: "Median per pace
// mode").
std::string spread_words(const headline_choice& choice) {
  std::string words = fmt::format("+-{:.1f} %", choice.spread_pct);
  if (choice.paces >= 2) return words + fmt::format(" over {} paces", choice.paces);
  if (choice.straddles_pace_change) return words + ", straddles a pace change";
  return words;
}

void choice_lines(std::vector<std::string>& lines, const headline_choice& choice, unsigned cpus) {
  std::string first = fmt::format("  {}threads:{} pin:{:<8} {} + {}: {} a step ({})", model_words(choice.model),
                                  choice.threads, choice.pin, choice.sync, choice.layout, format_ns(choice.ns_per_step),
                                  spread_words(choice));
  if (choice.cpus_busy) first += fmt::format(", {:.1f} CPUs busy", *choice.cpus_busy);
  if (choice.oversubscribed) first += fmt::format(" ({} threads on {} CPUs)", choice.threads, cpus);
  lines.push_back(first);
  // The details, packed into lines of the headline's width at their seams.
  std::vector<std::string> details;
  if (choice.vs_c2c) details.push_back(fmt::format("sync {:.2f} c2c transfers a stage", *choice.vs_c2c));
  if (choice.runner_up) {
    const bool overturned = choice.median_leader != choice.entry;
    details.push_back(overturned ? fmt::format("first by median {} takes {} side by side", choice.runner_up->sync,
                                               ratio_text(choice.runner_up->estimate, choice.runner_up->verdict))
                                 : fmt::format("next {} takes {}", choice.runner_up->sync,
                                               ratio_text(choice.runner_up->estimate, choice.runner_up->verdict)));
  } else if (choice.basis == "medians") {
    details.push_back("no paired comparison (--pairs 0): ranked by medians only");
  }
  if (choice.baseline)
    details.push_back(
        fmt::format("{} takes {}", choice.baseline->sync, ratio_text(choice.baseline->estimate, choice.baseline->verdict)));
  const std::string indent = "      ";
  std::string line;
  for (const auto& detail : details) {
    if (!line.empty() && line.size() + 2 + detail.size() > kLineWidth) {
      lines.push_back(line);
      line.clear();
    }
    line += line.empty() ? indent + detail : "; " + detail;
  }
  if (!line.empty()) lines.push_back(line);
}

void false_sharing_lines(std::vector<std::string>& lines, const run_book& book, const known_answers& probes) {
  if (probes.false_sharing) {
    const false_sharing_probe& probe = *probes.false_sharing;
    lines.push_back(fmt::format("False sharing: two writers {} B apart (one line) against {} B apart take {} a write "
                                "(probe on CPUs {}, {} pairs)",
                                probe.sharing_stride, probe.apart_stride, ratio_text(probe.estimate, probe.verdict),
                                probe.cpus, probe.pairs));
  } else {
    lines.push_back("False sharing: probe unavailable (" + probes.false_sharing_unavailable + ")");
  }
  std::size_t compared = 0;
  std::vector<std::pair<double, std::string>> penalties;
  for (const paired_result& pair : book.pairs) {
    if (pair.what.kind != comparison_kind::false_sharing || !pair.failure.empty() || pair.ratios.empty()) continue;
    ++compared;
    if (pair.verdict == ratio_verdict::penalty) penalties.emplace_back(pair.estimate.median, pair.what.group);
  }
  if (compared == 0) {
    lines.push_back("  in the step: not compared (a layout whose writers share lines and one that isolates them "
                    "were not both measured, or --pairs 0)");
    return;
  }
  std::sort(penalties.rbegin(), penalties.rend());
  lines.push_back(fmt::format("  in the step: {} of {} primitive/placement/thread groups showed a penalty{}", penalties.size(),
                              compared,
                              penalties.empty() ? std::string()
                                                : fmt::format(" (most {:.2f}x: {})", penalties.front().first,
                                                              penalties.front().second)));
}

void migration_lines(std::vector<std::string>& lines, const run_book& book, const known_answers& probes) {
  if (probes.migration) {
    const migration_probe& probe = *probes.migration;
    lines.push_back(fmt::format("Migration: one forced move takes {} (p50), refilling {} KiB {} more (probe, CPUs {}, "
                                "{} moves)",
                                format_ns(probe.move.p50), probe.bytes / 1024, format_ns(probe.refill.p50), probe.cpus,
                                probe.move.count));
  } else {
    lines.push_back("Migration: probe unavailable (" + probes.migration_unavailable + ")");
  }
  std::size_t unpinned = 0;
  std::size_t migrated = 0;
  for (const measured_entry& step : measured_of(book, "rk4", "ns_per_step")) {
    if (step.entry->field("pin") != "none") continue;
    const auto migrations = step.entry->median("migrations_per_kstep");
    if (!migrations) continue;
    ++unpinned;
    migrated += *migrations > 0.0 ? 1 : 0;
  }
  std::size_t compared = 0;
  std::size_t penalties = 0;
  for (const paired_result& pair : book.pairs) {
    if (pair.what.kind != comparison_kind::migration || !pair.failure.empty() || pair.ratios.empty()) continue;
    ++compared;
    penalties += pair.verdict == ratio_verdict::penalty ? 1 : 0;
  }
  if (unpinned == 0) {
    lines.push_back("  in the step: no unpinned entry counted its migrations (pin:none not run, or --no-accounting)");
  } else if (migrated == 0) {
    lines.push_back(fmt::format("  in the step: the OS migrated none of the {} pin:none entries, so no step "
                                "migration penalty was measured",
                                unpinned));
  } else {
    lines.push_back(fmt::format("  in the step: {} of {} pin:none entries migrated; against pin:compact {} of {} "
                                "showed a penalty",
                                migrated, unpinned, penalties, compared));
  }
}

void left_out_lines(std::vector<std::string>& lines, const run_book& book) {
  if (!book.collapsed.empty()) {
    std::vector<std::string> syncs;
    std::set<std::string> threads;
    double fastest = 0.0;
    double slowest = 0.0;
    for (const std::string& name : book.collapsed) {
      const captured_entry* entry = book.find(name);
      if (entry == nullptr) continue;
      if (std::find(syncs.begin(), syncs.end(), entry->field("sync")) == syncs.end()) syncs.push_back(entry->field("sync"));
      threads.insert("threads:" + entry->field("threads"));
      const auto time = entry->median(entry->field("kind") == "barrier" ? "ns_per_episode" : "ns_per_step");
      if (!time) continue;
      fastest = fastest == 0.0 ? *time : std::min(fastest, *time);
      slowest = std::max(slowest, *time);
    }
    std::vector<std::string> thread_list(threads.begin(), threads.end());
    lines.push_back(fitted(fmt::format("Collapsed when threads outnumber CPUs ({} entries at {}, {}..{} a step or "
                                       "episode, left out of rankings): {}",
                                       book.collapsed.size(), short_list(thread_list), format_ns(fastest),
                                       format_ns(slowest), short_list(syncs, 5))));
  }
  std::map<std::string, std::size_t> reasons;
  for (const auto& skipped : book.not_applicable) ++reasons[skipped.reason];
  for (const auto& [reason, count] : reasons) lines.push_back(fitted(fmt::format("Not applicable ({}): {}", count, reason)));
  std::size_t stalled = 0;
  for (const auto& entry : book.entries()) stalled += entry.error.empty() ? 0 : 1;
  if (stalled > 0) lines.push_back(fmt::format("Stalled or skipped: {} entries (lockstep run --verbose lists them)", stalled));
}

}  // namespace

run_headline make_headline(const run_book& book, const known_answers& probes, unsigned cpus,
                           const std::string& result_path) {
  run_headline headline;
  headline.choices = choose(book);
  headline.collapsed.assign(book.collapsed.begin(), book.collapsed.end());
  headline.probes = probes;
  std::vector<std::string> choices;
  if (headline.choices.empty()) choices.push_back("  no RK4 step was measured without error: nothing to recommend");
  for (const auto& choice : headline.choices) choice_lines(choices, choice, cpus);
  std::vector<std::string> rest;
  false_sharing_lines(rest, book, probes);
  migration_lines(rest, book, probes);
  if (book.pace) rest.push_back("Pace: " + book.pace->summary());
  left_out_lines(rest, book);
  rest.push_back(fmt::format("Results: {} (every table: lockstep run --verbose, or the report)", result_path));
  const std::string stem =
      result_path.size() > 5 && result_path.ends_with(".json") ? result_path.substr(0, result_path.size() - 5) : result_path;
  rest.push_back(fmt::format("Report: lockstep report {} --out {}-report; compare: lockstep compare {} OTHER.json",
                             result_path, stem, result_path));
  // A matrix of many thread counts keeps its first choices within the
  // headline's lines and leaves the others to the report.
  const std::size_t room = kHeadlineLines - 1 - std::min(rest.size(), kHeadlineLines - 3);
  if (choices.size() > room) {
    const std::size_t left = choices.size() - (room - 1);
    choices.resize(room - 1);
    choices.push_back(fmt::format("  ({} more lines of choices: lockstep run --verbose, or the report)", left));
  }
  std::vector<std::string>& lines = headline.lines;
  lines.push_back(fmt::format("The answer on this machine (ratios paired side by side: median [95 % interval], "
                              "noise band {:.0f} %):",
                              100.0 * book.noise));
  lines.insert(lines.end(), choices.begin(), choices.end());
  lines.insert(lines.end(), rest.begin(), rest.end());
  if (lines.size() > kHeadlineLines) lines.resize(kHeadlineLines);
  return headline;
}

std::string headline_text(const run_headline& headline) {
  std::string text;
  for (const auto& line : headline.lines) text += line + "\n";
  return text;
}

nlohmann::json headline_json(const run_headline& headline) {
  const auto estimate_json = [](const ratio_estimate& estimate, ratio_verdict verdict) {
    return nlohmann::json{{"median", estimate.median},
                          {"ci_low", estimate.low},
                          {"ci_high", estimate.high},
                          {"verdict", to_string(verdict)}};
  };
  const auto rival_json = [&](const std::optional<headline_rival>& rival) -> nlohmann::json {
    if (!rival) return nullptr;
    nlohmann::json json = estimate_json(rival->estimate, rival->verdict);
    json["entry"] = rival->entry;
    json["sync"] = rival->sync;
    return json;
  };
  nlohmann::json recommendations = nlohmann::json::array();
  for (const auto& choice : headline.choices) {
    recommendations.push_back({{"model", choice.model},
                               {"threads", choice.threads},
                               {"pin", choice.pin},
                               {"entry", choice.entry},
                               {"sync", choice.sync},
                               {"layout", choice.layout},
                               {"ns_per_step", choice.ns_per_step},
                               {"spread_pct", choice.spread_pct},
                               {"paces", choice.paces},
                               {"straddles_pace_change", choice.straddles_pace_change},
                               {"vs_c2c", choice.vs_c2c ? nlohmann::json(*choice.vs_c2c) : nlohmann::json(nullptr)},
                               {"cpus_busy", choice.cpus_busy ? nlohmann::json(*choice.cpus_busy) : nlohmann::json(nullptr)},
                               {"oversubscribed", choice.oversubscribed},
                               {"basis", choice.basis},
                               {"median_leader", choice.median_leader},
                               {"runner_up", rival_json(choice.runner_up)},
                               {"baseline", rival_json(choice.baseline)}});
  }
  nlohmann::json false_sharing = nullptr;
  if (const auto& probe = headline.probes.false_sharing) {
    false_sharing = estimate_json(probe->estimate, probe->verdict);
    false_sharing["cpus"] = probe->cpus;
    false_sharing["sharing_stride_bytes"] = probe->sharing_stride;
    false_sharing["apart_stride_bytes"] = probe->apart_stride;
    false_sharing["pairs"] = probe->pairs;
  }
  nlohmann::json migration = nullptr;
  if (const auto& probe = headline.probes.migration) {
    migration = {{"cpus", probe->cpus},
                 {"bytes", probe->bytes},
                 {"moves", probe->move.count},
                 {"move_p50_ns", probe->move.p50},
                 {"refill_p50_ns", probe->refill.p50}};
  }
  return {{"lines", headline.lines},
          {"recommendations", recommendations},
          {"collapsed", headline.collapsed},
          {"false_sharing_probe", false_sharing},
          {"false_sharing_probe_unavailable", headline.probes.false_sharing_unavailable},
          {"migration_probe", migration},
          {"migration_probe_unavailable", headline.probes.migration_unavailable}};
}

}  // namespace lockstep::bench
