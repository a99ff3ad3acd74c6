// The answer of a run (answer.hpp).
#include "bench/run/answer.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "bench/probe_reports/falseshare_report.hpp"
#include "bench/probes/falseshare.hpp"
#include "bench/run/crossover.hpp"
#include "bench/run/pace.hpp"
#include "bench/run/paired_blocks.hpp"
#include "bench/run/ranking.hpp"
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

// The terminal's width for the answer: answer_text wraps longer lines at
// a word (a line in the result file and the report stays whole).
constexpr std::size_t kLineWidth = 120;

// The verdict of a rival's step over the choice's, in words about the rival.
std::string rival_verdict_words(ratio_verdict verdict) {
  switch (verdict) {
    case ratio_verdict::penalty: return "slower";
    case ratio_verdict::gain: return "faster";
    case ratio_verdict::within_noise: return "within noise: a tie";
    case ratio_verdict::unsure: break;
  }
  return "unsure: the pairs cannot tell them apart";
}

// A rival against the choice, saying what the ratio divides: "seqlock: its
// step is 1.17x this one [1.07, 1.25], slower" (`spelled_out`), or, after
// one that was, "std_barrier: 11.45x [5.98, 25.34], slower".
std::string rival_text(const answer_rival& rival, bool spelled_out) {
  return fmt::format("{}: {}{:.2f}x {}[{:.2f}, {:.2f}], {}", rival.sync, spelled_out ? "its step is " : "",
                     rival.estimate.median, spelled_out ? "this one " : "", rival.estimate.low, rival.estimate.high,
                     rival_verdict_words(rival.verdict));
}

std::string model_words(const kernels::model_choice& model) {
  return model.is_chain() ? "model:" + model.name() + " " : std::string();
}

answer_rival rival_from(const best_other_view& view) {
  return answer_rival{view.entry->name, view.entry->spec.sync, view.entry->spec.layout, view.estimate, view.verdict};
}

}  // namespace

std::vector<answer_choice> choose_combinations(const run_book& book) {
  std::vector<answer_choice> choices;
  for (const ranked_group& group : rank_groups(book, entry_kind::rk4)) {
    const captured_entry* chosen = group.entries.front().entry;
    answer_choice choice;
    choice.model = group.model;
    choice.threads = group.threads;
    choice.pin = group.pin;
    choice.median_leader = chosen->name;
    choice.basis = "medians";
    // Each primitive against the leader, paired (the leader's view is the
    // inverse of its pair with the runner-up).
    const std::vector<best_other_view> views =
        against_best_other_views(book, against_best_other_group(entry_kind::rk4, group.pin, group.threads));
    const best_other_view* leader_view = nullptr;
    for (const auto& view : views)
      if (view.entry == chosen) leader_view = &view;
    if (leader_view != nullptr) {
      choice.basis = "paired";
      // leader_view->estimate is the median leader's step over the
      // runner-up's, side by side. The pair's side goes first: the runner-up
      // when the whole interval lies above 1 (it was faster in the pairs,
      // however the medians fell), else the leader. The other is the rival,
      // its ratio its step over the choice's.
      const captured_entry* other = leader_view->other;
      if (leader_view->estimate.low > 1.0) {
        chosen = other;
        choice.runner_up = rival_from(*leader_view);
      } else {
        choice.runner_up = answer_rival{other->name, other->spec.sync, other->spec.layout,
                                        inverse(leader_view->estimate), inverse(leader_view->verdict)};
      }
      // Only a rival slower beyond the noise band leaves one winner; within
      // noise or unsure, the pair cannot tell them apart.
      choice.tied = choice.runner_up && choice.runner_up->verdict != ratio_verdict::penalty;
    }
    choice.entry = chosen->name;
    choice.sync = chosen->spec.sync;
    choice.layout = chosen->spec.layout;
    choice.ns_per_step = chosen->median("ns_per_step").value_or(0.0);
    choice.fastest_ns = choice.slowest_ns = choice.ns_per_step;
    if (const auto range = chosen->range("ns_per_step"); range && choice.ns_per_step > 0.0) {
      choice.fastest_ns = range->first;
      choice.slowest_ns = range->second;
    }
    const pace_mode_times times = chosen->pace_medians();
    choice.paces = times.modes.size();
    choice.straddles_pace_change = times.straddling > 0;
    choice.vs_c2c = chosen->median("vs_c2c");
    if (const auto cpu = chosen->median("team_cpu_ns_per_step"); cpu && choice.ns_per_step > 0.0)
      choice.cpus_busy = *cpu / choice.ns_per_step;
    choice.oversubscribed = chosen->median("oversubscribed").value_or(0.0) > 0.5;
    // std::barrier, the C++20 baseline, against the choice: its own pair
    // is against the median leader, which is the choice unless overturned.
    for (const auto& view : views) {
      if (view.entry->spec.sync != sync::kBaselinePrimitive || view.entry == chosen) continue;
      if (view.other == chosen) choice.baseline = rival_from(view);
    }
    choices.push_back(std::move(choice));
  }
  return choices;  // in the ranking's order: threads, model, placement
}

namespace {

// "+-4.2 %", and where the spread comes from when the machine changed pace
// under the repetitions (lockstep run --verbose splits them: "Median per pace
// mode"): then the figure itself is uncertain, and the line says so.
std::string spread_words(const answer_choice& choice) {
  std::string words = fmt::format("+-{:.1f} %", choice.spread_pct());
  if (choice.paces >= 2) return words + fmt::format(" over {} paces of the machine: uncertain", choice.paces);
  if (choice.straddles_pace_change) return words + ", straddles a pace change";
  return words;
}

void choice_lines(std::vector<std::string>& lines, const answer_choice& choice, unsigned cpus) {
  const std::string chosen = choice.sync + " + " + choice.layout;
  std::string named = chosen;
  if (choice.tied && choice.runner_up) {
    named = fmt::format("{} or {} + {} (tied)", chosen, choice.runner_up->sync, choice.runner_up->layout);
  }
  std::string first = fmt::format("  {}threads:{} pin:{:<8} {}: {} a step ({})", model_words(choice.model),
                                  choice.threads, platform::to_string(choice.pin), named, format_ns(choice.ns_per_step),
                                  spread_words(choice));
  if (choice.cpus_busy) first += fmt::format(", {:.1f} CPUs busy", *choice.cpus_busy);
  if (choice.oversubscribed) first += fmt::format(" ({} threads on {} CPUs)", choice.threads, cpus);
  lines.push_back(first);
  std::vector<std::string> details;
  if (choice.runner_up) {
    const bool overturned = choice.median_leader != choice.entry;
    details.push_back((overturned && !choice.tied ? "first by median, slower side by side, " : "next ") +
                      rival_text(*choice.runner_up, true));
  } else if (choice.basis == "medians") {
    details.push_back("no paired comparison (--pairs 0): ranked by medians only");
  }
  if (choice.baseline && !(choice.runner_up && choice.runner_up->entry == choice.baseline->entry))
    details.push_back("the C++20 baseline " + rival_text(*choice.baseline, !choice.runner_up));
  if (choice.vs_c2c) details.push_back(fmt::format("stage sync {:.2f} core-to-core transfers", *choice.vs_c2c));
  std::string line;
  for (const auto& detail : details) line += (line.empty() ? "      " : "; ") + detail;
  if (!line.empty()) lines.push_back(line);
}

// The answer first: the run's fastest choice, and the parallel step against
// the serial step of the same model.
std::optional<best_choice> best_of(const run_book& book, const std::vector<answer_choice>& choices) {
  const answer_choice* best = nullptr;
  for (const auto& choice : choices) {
    if (best != nullptr && choice.model != best->model) continue;  // the first model (the paper's sorts first)
    if (best == nullptr || choice.ns_per_step < best->ns_per_step) best = &choice;
  }
  if (best == nullptr) return std::nullopt;
  best_choice found{best->model, best->threads, best->pin, best->entry, best->ns_per_step, {}, {}, {}};
  // The repetitions themselves, not the median -+ half their range: the
  // range of a choice with one slow repetition lies mostly above its median.
  for (const auto& choice : choices) {
    if (&choice == best || choice.model != best->model) continue;
    if (choice.fastest_ns <= best->slowest_ns)
      found.level.push_back({choice.threads, choice.pin, choice.entry, choice.ns_per_step});
  }
  std::sort(found.level.begin(), found.level.end(),
            [](const tied_choice& a, const tied_choice& b) { return a.ns_per_step < b.ns_per_step; });
  found.serial_ns_per_step = book.serial_step_ns(best->model);
  if (const captured_entry* entry = book.find(best->entry)) found.vs_serial = entry->median("vs_serial");
  return found;
}

std::string best_line(const best_choice& best) {
  std::string line = fmt::format("Best here: {}threads:{} pin:{}, {} a step", model_words(best.model), best.threads,
                                 platform::to_string(best.pin), format_ns(best.ns_per_step));
  if (!best.level.empty()) {
    std::vector<std::string> others;
    for (const auto& other : best.level)
      others.push_back(fmt::format("threads:{} pin:{} ({})", other.threads, platform::to_string(other.pin),
                                   format_ns(other.ns_per_step)));
    line += fmt::format(", tied with {}: their repetitions overlap and no pair compared them",
                        fmt::join(others, " and "));
  }
  if (!best.serial_ns_per_step || !best.vs_serial) return line + "; the serial step was not measured";
  line += fmt::format("; the serial step of the same model takes {}", format_ns(*best.serial_ns_per_step));
  const double ratio = *best.vs_serial;
  if (ratio >= 1.0)
    return line + fmt::format(": the parallel step costs {:.1f}x the serial one (medians), so synchronisation "
                              "dominates this model here: step it serially",
                              ratio);
  return line + fmt::format(": the parallel step is {:.2f}x faster than the serial one (medians)", 1.0 / ratio);
}

// What false sharing costs here, per access pattern (the probe beside the
// matrix, worded as lockstep falseshare words it: falseshare_answer_of), which
// patterns the step's layouts exercise, and what the step's own groups showed.
// Each line whole: answer_text wraps it for the terminal.
void false_sharing_lines(std::vector<std::string>& lines, const run_book& book, const known_answers& answers) {
  std::vector<pattern_figure> figures;
  std::vector<std::string> unmeasured;
  std::size_t fewest_pairs = 0;
  std::size_t most_pairs = 0;
  for (std::size_t index = 0; index < probes::all_access_patterns.size(); ++index) {
    const auto probe = std::find_if(answers.false_sharing.begin(), answers.false_sharing.end(), [&](const auto& measured) {
      return probes::find_access_pattern(measured.pattern) == index;
    });
    if (probe == answers.false_sharing.end()) {
      unmeasured.emplace_back(probes::all_access_patterns[index].words);
      continue;
    }
    figures.push_back({index, probe->estimate, probe->verdict});
    fewest_pairs = figures.size() == 1 ? probe->pairs : std::min(fewest_pairs, probe->pairs);
    most_pairs = std::max(most_pairs, probe->pairs);
  }
  if (figures.empty()) {
    lines.push_back(fmt::format("False sharing: probe unavailable ({})", answers.false_sharing_unavailable.empty()
                                                                            ? std::string("no pattern was paired")
                                                                            : answers.false_sharing_unavailable));
  } else {
    const false_sharing_probe& first = answers.false_sharing.front();
    const std::string pairs = fewest_pairs == most_pairs ? fmt::format("{} pairs", most_pairs)
                                                         : fmt::format("{}-{} pairs", fewest_pairs, most_pairs);
    lines.push_back(fmt::format("False sharing, one line against apart (words {} B against {} B apart, per access; "
                                "CPUs {}{}, {}):",
                                first.sharing_stride, first.apart_stride, first.cpus,
                                answers.false_sharing_relation.empty()
                                    ? std::string()
                                    : fmt::format(", {}", answers.false_sharing_relation),
                                pairs));
    const falseshare_answer answer =
        falseshare_answer_of(figures, {first.cpus, answers.false_sharing_relation, book.c2c_one_way_ns()});
    std::string line = "  ";
    for (std::size_t index = 0; index < answer.figures.size(); ++index)
      line.append(answer.figures[index]).append(index + 1 == answer.figures.size() ? ": " : ", ");
    line += answer.conclusion;
    if (!unmeasured.empty()) {
      line += "; not measured: ";
      for (std::size_t index = 0; index < unmeasured.size(); ++index)
        line.append(index == 0 ? "" : index + 1 == unmeasured.size() ? " and " : ", ").append(unmeasured[index]);
    }
    lines.push_back(std::move(line));
  }
  // Which patterns the step's layouts exercise: the probe's table says
  // (kInStepLayouts, proved against the layouts in bench/probes/falseshare.cpp).
  std::string in_step;
  for (const auto& info : probes::all_access_patterns)
    if (info.in_step_layouts) in_step.append(in_step.empty() ? "" : " and ").append(info.words);
  lines.push_back(fmt::format("  the step's layouts exercise {}: owners store plain doubles that the others read after "
                              "the sync (the syncs' atomics sit on lines of their own, which no layout moves)",
                              in_step));
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
    // The refill is a difference of two medians (with the refill against without): at or below 0 it added
    // nothing measurable, and the line says so beside the figure.
    const std::string refill = probe.refill.p50 > 0
                                   ? format_ns(probe.refill.p50) + " more"
                                   : "nothing measurable (" + format_ns(probe.refill.p50) + ")";
    lines.push_back(fmt::format("Migration: one forced move takes {} (p50), refilling {} KiB {} (probe, CPUs {}, "
                                "{} moves)",
                                format_ns(probe.move.p50), probe.bytes / 1024, refill, probe.cpus, probe.move.count));
  } else {
    lines.push_back("Migration: probe unavailable (" + probes.migration_unavailable + ")");
  }
  std::size_t unpinned = 0;
  std::size_t migrated = 0;
  for (const measured_entry& step : measured_of(book, entry_kind::rk4)) {
    if (step.entry->spec.pin != platform::placement::none) continue;
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

std::vector<stopped_entry> stopped_entries(const run_book& book) {
  std::vector<stopped_entry> stopped;
  for (const auto& entry : book.entries())
    if (entry.stopped_repetitions > 0)
      stopped.push_back({entry.name, entry.stopped_repetitions, entry.stopped_repetitions + entry.repetitions.size(),
                         entry.stop_reason});
  return stopped;
}

void left_out_lines(std::vector<std::string>& lines, const run_book& book) {
  if (!book.collapsed.empty()) {
    std::vector<std::string> syncs;
    std::set<unsigned> threads;
    double fastest = 0.0;
    double slowest = 0.0;
    for (const captured_entry* entry : collapsed_entries(book)) {
      if (std::find(syncs.begin(), syncs.end(), entry->spec.sync) == syncs.end()) syncs.push_back(entry->spec.sync);
      threads.insert(entry->spec.threads);
      const auto time = entry->median_time();
      if (!time) continue;
      fastest = fastest == 0.0 ? *time : std::min(fastest, *time);
      slowest = std::max(slowest, *time);
    }
    std::vector<std::string> thread_list;  // in numeric order
    for (const unsigned count : threads) thread_list.push_back(fmt::format("threads:{}", count));
    lines.push_back(fmt::format("Collapsed when threads outnumber CPUs ({} entries at {}, {}..{} a step or "
                                "episode, left out of rankings): {}",
                                book.collapsed.size(), short_list(thread_list), format_ns(fastest), format_ns(slowest),
                                short_list(syncs, 5)));
  }
  std::map<std::string, std::size_t> reasons;
  for (const auto& skipped : book.not_applicable) ++reasons[skipped.reason];
  for (const auto& [reason, count] : reasons) lines.push_back(fmt::format("Not applicable ({}): {}", count, reason));
  std::size_t stalled = 0;
  for (const auto& entry : book.entries()) stalled += entry.error.empty() ? 0 : 1;
  if (stalled > 0) lines.push_back(fmt::format("Stalled or skipped: {} entries (lockstep run --verbose lists them)", stalled));
  for (const auto& entry : stopped_entries(book))
    lines.push_back(fmt::format("Stopped: {} of {} repetitions of {} ({}); its figures are the other repetitions'",
                                entry.repetitions_stopped, entry.repetitions, entry.entry, entry.reason));
}

}  // namespace

std::string wrapped(const std::string& line, std::size_t width) {
  const std::size_t indent = std::min(line.find_first_not_of(' '), line.size());
  const std::string continuation(indent + 4, ' ');
  // Where the line may break: a space outside brackets and past the indent
  // (an interval "[1.07, 1.25]" stays on one line).
  std::vector<std::size_t> breaks;
  int depth = 0;
  for (std::size_t index = indent; index < line.size(); ++index) {
    if (line[index] == '[' || line[index] == '(') ++depth;
    if ((line[index] == ']' || line[index] == ')') && depth > 0) --depth;
    if (line[index] == ' ' && depth == 0) breaks.push_back(index);
  }
  std::string text;
  std::size_t start = 0;
  std::string_view prefix;  // none on the first piece, the continuation after
  for (auto next = breaks.begin(); line.size() - start + prefix.size() > width && next != breaks.end();) {
    // The last break that fits, or the first one when none does (a long word stays whole).
    auto fits = next;
    while (fits + 1 != breaks.end() && *(fits + 1) - start + prefix.size() <= width) ++fits;
    text.append(prefix).append(line, start, *fits - start).append("\n");
    start = *fits + 1;
    prefix = continuation;
    next = fits + 1;
  }
  return text.append(prefix).append(line, start).append("\n");
}

run_answer make_answer(const run_book& book, std::vector<answer_choice> choices, const answer_sources& sources) {
  run_answer answer;
  answer.choices = std::move(choices);
  answer.best = best_of(book, answer.choices);
  answer.stopped = stopped_entries(book);
  for (const captured_entry* entry : collapsed_entries(book)) answer.collapsed.push_back(entry->name);
  answer.probes = sources.probes;
  if (sources.crossover != nullptr) answer.crossover = crossover_lines(*sources.crossover);
  std::vector<std::string> choice_text;
  if (answer.choices.empty())
    choice_text.push_back("  no RK4 step was measured without error: nothing to recommend");
  for (const auto& choice : answer.choices) choice_lines(choice_text, choice, sources.cpus);
  std::vector<std::string> rest;
  false_sharing_lines(rest, book, sources.probes);
  migration_lines(rest, book, sources.probes);
  if (sources.pace != nullptr) rest.push_back("Pace: " + sources.pace->summary());
  left_out_lines(rest, book);
  const std::string& result_path = sources.result_path;
  rest.push_back(fmt::format("Results: {} (every table: lockstep run --verbose, or the report)", result_path));
  const std::string stem =
      result_path.size() > 5 && result_path.ends_with(".json") ? result_path.substr(0, result_path.size() - 5) : result_path;
  rest.push_back(fmt::format("Report: lockstep report {} --out {}-report; compare: lockstep compare {} OTHER.json",
                             result_path, stem, result_path));
  // A matrix of many thread counts keeps its first choices within the
  // answer's lines and leaves the others to the report.
  const std::size_t room = kAnswerLines - 2 - std::min(rest.size() + answer.crossover.size(), kAnswerLines - 4);
  if (choice_text.size() > room) {
    const std::size_t left = choice_text.size() - (room - 1);
    choice_text.resize(room - 1);
    choice_text.push_back(fmt::format("  ({} more lines of choices: lockstep run --verbose, or the report)", left));
  }
  std::vector<std::string>& lines = answer.lines;
  lines.push_back(fmt::format("The answer on this machine (ratios paired side by side: median [95 % interval], "
                              "noise band {:.0f} %):",
                              100.0 * book.noise));
  if (answer.best) lines.push_back(best_line(*answer.best));
  lines.insert(lines.end(), answer.crossover.begin(), answer.crossover.end());
  lines.insert(lines.end(), choice_text.begin(), choice_text.end());
  lines.insert(lines.end(), rest.begin(), rest.end());
  if (lines.size() > kAnswerLines) lines.resize(kAnswerLines);
  return answer;
}

std::string answer_text(const run_answer& answer) {
  std::string text;
  for (const auto& line : answer.lines) text += wrapped(line, kLineWidth);
  return text;
}

namespace {

nlohmann::json estimate_json(const ratio_estimate& estimate, ratio_verdict verdict) {
  return nlohmann::json{{"median", estimate.median},
                        {"ci_low", estimate.low},
                        {"ci_high", estimate.high},
                        {"verdict", to_string(verdict)}};
}

nlohmann::json optional_json(const std::optional<double>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}

nlohmann::json rival_json(const std::optional<answer_rival>& rival) {
  if (!rival) return nullptr;
  nlohmann::json json = estimate_json(rival->estimate, rival->verdict);
  json["entry"] = rival->entry;
  json["sync"] = rival->sync;
  json["layout"] = rival->layout;
  return json;
}

// The choices, as "recommendations".
nlohmann::json choices_json(const std::vector<answer_choice>& choices) {
  nlohmann::json recommendations = nlohmann::json::array();
  for (const auto& choice : choices) {
    recommendations.push_back({{"model", choice.model.name()},
                               {"threads", choice.threads},
                               {"pin", platform::to_string(choice.pin)},
                               {"entry", choice.entry},
                               {"sync", choice.sync},
                               {"layout", choice.layout},
                               {"ns_per_step", choice.ns_per_step},
                               {"spread_pct", choice.spread_pct()},
                               {"paces", choice.paces},
                               {"straddles_pace_change", choice.straddles_pace_change},
                               {"vs_c2c", optional_json(choice.vs_c2c)},
                               {"cpus_busy", optional_json(choice.cpus_busy)},
                               {"oversubscribed", choice.oversubscribed},
                               {"basis", choice.basis},
                               {"median_leader", choice.median_leader},
                               {"tied", choice.tied},
                               {"runner_up", rival_json(choice.runner_up)},
                               {"baseline", rival_json(choice.baseline)}});
  }
  return recommendations;
}

// The known-answer probes' keys: false sharing per pattern, and, as files
// before the patterns had it, the one pattern the probe measured then
// (kOlderFilesFigure: plain stores); the migration probe.
void add_probes_json(nlohmann::json& json, const known_answers& probes) {
  nlohmann::json false_sharing = nullptr;
  nlohmann::json false_sharing_patterns = nlohmann::json::array();
  for (const false_sharing_probe& probe : probes.false_sharing) {
    nlohmann::json figure = estimate_json(probe.estimate, probe.verdict);
    figure["cpus"] = probe.cpus;
    figure["sharing_stride_bytes"] = probe.sharing_stride;
    figure["apart_stride_bytes"] = probe.apart_stride;
    figure["pairs"] = probe.pairs;
    const auto pattern = probes::find_access_pattern(probe.pattern);
    if (pattern && probes::all_access_patterns[*pattern].older_files_figure) false_sharing = figure;
    figure["pattern"] = probe.pattern;
    if (pattern) {
      figure["words"] = probes::all_access_patterns[*pattern].words;
      figure["in_step_layouts"] = probes::all_access_patterns[*pattern].in_step_layouts;
    }
    figure["cpus_relation"] = probes.false_sharing_relation;
    false_sharing_patterns.push_back(std::move(figure));
  }
  nlohmann::json migration = nullptr;
  if (const auto& probe = probes.migration) {
    migration = {{"cpus", probe->cpus},
                 {"bytes", probe->bytes},
                 {"moves", probe->move.count},
                 {"move_p50_ns", probe->move.p50},
                 {"refill_p50_ns", probe->refill.p50}};
  }
  json["false_sharing_probe"] = false_sharing;
  json["false_sharing_patterns"] = false_sharing_patterns;
  json["false_sharing_probe_unavailable"] = probes.false_sharing_unavailable;
  json["migration_probe"] = migration;
  json["migration_probe_unavailable"] = probes.migration_unavailable;
}

nlohmann::json best_json(const std::optional<best_choice>& best) {
  if (!best) return nullptr;
  nlohmann::json level = nlohmann::json::array();
  for (const auto& other : best->level)
    level.push_back({{"threads", other.threads}, {"pin", platform::to_string(other.pin)}, {"entry", other.entry},
                     {"ns_per_step", other.ns_per_step}});
  return {{"model", best->model.name()},
          {"threads", best->threads},
          {"pin", platform::to_string(best->pin)},
          {"entry", best->entry},
          {"ns_per_step", best->ns_per_step},
          {"serial_ns_per_step", optional_json(best->serial_ns_per_step)},
          {"vs_serial", optional_json(best->vs_serial)},
          {"level", level}};
}

}  // namespace

nlohmann::json answer_json(const run_answer& answer) {
  nlohmann::json stopped = nlohmann::json::array();
  for (const auto& entry : answer.stopped)
    stopped.push_back({{"entry", entry.entry},
                       {"repetitions_stopped", entry.repetitions_stopped},
                       {"repetitions", entry.repetitions},
                       {"reason", entry.reason}});
  nlohmann::json json{{"lines", answer.lines},
                      {"answer", best_json(answer.best)},
                      {"crossover", answer.crossover},
                      {"stopped", stopped},
                      {"recommendations", choices_json(answer.choices)},
                      {"collapsed", answer.collapsed}};
  add_probes_json(json, answer.probes);
  return json;
}

}  // namespace lockstep::bench
