// What a false-sharing measurement means, as text and as a result file (falseshare_report.hpp).
#include "bench/probe_reports/falseshare_report.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <exception>
#include <utility>

#include "bench/results/machine_context.hpp"
#include "bench/results/result_json.hpp"
#include "platform/format.hpp"

namespace lockstep::bench {

namespace {

const probes::access_pattern_info& info_of(std::size_t pattern) { return probes::all_access_patterns.at(pattern); }

std::optional<falseshare_penalty> penalty_of(const std::vector<probes::stride_cost>& costs) {
  const auto sharing = std::find_if(costs.begin(), costs.end(), [](const auto& cost) { return cost.shares_line; });
  const auto apart = std::find_if(costs.begin(), costs.end(),
                                  [](const auto& cost) { return !cost.shares_line && !cost.shares_line_pair; });
  if (sharing == costs.end() || apart == costs.end()) return std::nullopt;
  falseshare_penalty penalty;
  penalty.sharing_stride_bytes = sharing->stride_bytes;
  penalty.apart_stride_bytes = apart->stride_bytes;
  for (std::size_t repeat = 0; repeat < sharing->repeat_mean_ns.size() && repeat < apart->repeat_mean_ns.size();
       ++repeat)
    if (sharing->repeat_mean_ns[repeat] && apart->repeat_mean_ns[repeat] && *apart->repeat_mean_ns[repeat] > 0.0)
      penalty.ratios.push_back(*sharing->repeat_mean_ns[repeat] / *apart->repeat_mean_ns[repeat]);
  if (penalty.ratios.empty()) return std::nullopt;
  penalty.estimate = bootstrap_median(penalty.ratios);
  penalty.verdict = verdict_of(penalty.estimate);
  return penalty;
}

// "a", "a and b", "a, b and c".
std::string word_list(const std::vector<std::string>& words) {
  std::string text;
  for (std::size_t index = 0; index < words.size(); ++index) {
    if (index > 0) text += index + 1 == words.size() ? " and " : ", ";
    text += words[index];
  }
  return text;
}

std::string figure_text(const pattern_figure& figure) {
  return fmt::format("{} {:.2f}x [{:.2f}, {:.2f}] {}", info_of(figure.pattern).words, figure.estimate.median,
                     figure.estimate.low, figure.estimate.high, to_string(figure.verdict));
}

// Where the answers list a reading: paying first, then unsure, then hidden.
int rank_of(falseshare_reading reading) {
  switch (reading) {
    case falseshare_reading::pays: return 0;
    case falseshare_reading::unsure: return 1;
    case falseshare_reading::hidden: return 2;
  }
  return 2;
}

// What it means that no pattern pays, and what says so.
std::string no_penalty_meaning(const falseshare_evidence& evidence) {
  std::vector<std::string> facts;
  if (!evidence.relation.empty()) facts.push_back(fmt::format("hwloc calls CPUs {} {}", evidence.cpus, evidence.relation));
  if (evidence.c2c_one_way_ns)
    facts.push_back(fmt::format("a line travels between them in {} one way (c2c, this run)",
                                platform::format_ns(*evidence.c2c_one_way_ns)));
  std::string text =
      "no pattern pays: the two CPUs act as if they shared one core's cache (SMT siblings, which a hypervisor "
      "need not show) or took turns on one physical CPU";
  if (!facts.empty()) text += fmt::format(" ({})", word_list(facts));
  return text;
}

// The measurement's figures of one stride, for the penalty table: the median
// ns per access, or "-".
std::string median_text(const pattern_analysis& analysis, const probes::pattern_cost& cost, std::size_t stride) {
  for (std::size_t index = 0; index < cost.strides.size(); ++index)
    if (cost.strides[index].stride_bytes == stride && analysis.ns_per_access[index])
      return fmt::format("{:.2f}", analysis.ns_per_access[index]->p50);
  return "-";
}

std::vector<pattern_figure> figures_of(const falseshare_analysis& analysis) {
  std::vector<pattern_figure> figures;
  for (const auto& pattern : analysis.patterns)
    if (pattern.penalty) figures.push_back({pattern.pattern, pattern.penalty->estimate, pattern.penalty->verdict});
  return figures;
}

nlohmann::json penalty_json(const falseshare_penalty& penalty) {
  return {{"a_stride_bytes", penalty.sharing_stride_bytes},
          {"b_stride_bytes", penalty.apart_stride_bytes},
          {"ratios", penalty.ratios},
          {"median", penalty.estimate.median},
          {"ci_low", penalty.estimate.low},
          {"ci_high", penalty.estimate.high},
          {"confidence", kConfidence},
          {"noise", kDefaultNoise},
          {"verdict", to_string(penalty.verdict)}};
}

std::string answer_line(const falseshare_analysis& analysis, const falseshare_evidence& evidence) {
  const falseshare_answer answer = falseshare_answer_of(figures_of(analysis), evidence);
  if (answer.figures.empty()) return fmt::format("answer: {}\n", answer.conclusion);
  std::string figures;
  for (const auto& figure : answer.figures) {
    if (!figures.empty()) figures += ", ";
    figures += figure;
  }
  return fmt::format("answer: false sharing on CPUs {}, one line against apart, per access: {}: {}\n", evidence.cpus,
                     figures, answer.conclusion);
}

}  // namespace

falseshare_reading reading_of(ratio_verdict verdict) noexcept {
  switch (verdict) {
    case ratio_verdict::penalty: return falseshare_reading::pays;
    case ratio_verdict::within_noise:
    case ratio_verdict::gain: return falseshare_reading::hidden;
    case ratio_verdict::unsure: return falseshare_reading::unsure;
  }
  return falseshare_reading::unsure;
}

falseshare_analysis analyse_falseshare(const std::vector<probes::pattern_cost>& costs) {
  falseshare_analysis analysis;
  for (const auto& cost : costs) {
    pattern_analysis pattern;
    pattern.pattern = cost.pattern;
    for (const auto& stride : cost.strides)
      pattern.ns_per_access.push_back(stride.ns_per_access.empty() ? std::nullopt
                                                                   : std::optional<platform::distribution>(
                                                                         platform::summarize(stride.ns_per_access)));
    pattern.penalty = penalty_of(cost.strides);
    analysis.patterns.push_back(std::move(pattern));
  }
  return analysis;
}

falseshare_answer falseshare_answer_of(std::vector<pattern_figure> figures, const falseshare_evidence& evidence) {
  falseshare_answer answer;
  if (figures.empty()) {
    answer.conclusion = "no pattern was measured both on one line and apart";
    return answer;
  }
  std::stable_sort(figures.begin(), figures.end(), [](const pattern_figure& a, const pattern_figure& b) {
    const int rank_a = rank_of(reading_of(a.verdict));
    const int rank_b = rank_of(reading_of(b.verdict));
    if (rank_a != rank_b) return rank_a < rank_b;
    return rank_a == 0 && a.estimate.median > b.estimate.median;  // the larger penalty first
  });
  std::vector<std::string> paying;
  std::vector<std::string> hidden;
  std::vector<std::string> unsure;
  for (const auto& figure : figures) {
    answer.figures.push_back(figure_text(figure));
    const std::string words(info_of(figure.pattern).words);
    switch (reading_of(figure.verdict)) {
      case falseshare_reading::pays: paying.push_back(words); break;
      case falseshare_reading::hidden: hidden.push_back(words); break;
      case falseshare_reading::unsure: unsure.push_back(words); break;
    }
  }
  if (!paying.empty() && !hidden.empty()) answer.conclusion = fmt::format("this core hides it for {}", word_list(hidden));
  else if (!paying.empty() && unsure.empty()) answer.conclusion = "every pattern measured pays";
  else if (paying.empty() && !hidden.empty()) answer.conclusion = no_penalty_meaning(evidence);
  if (!unsure.empty()) {
    const std::string unsure_words = fmt::format("unsure for {} (more repetitions would tell)", word_list(unsure));
    answer.conclusion = answer.conclusion.empty() ? unsure_words : fmt::format("{}; {}", answer.conclusion, unsure_words);
  }
  return answer;
}

std::string cpus_relation(const platform::topology& machine, const std::vector<int>& cpus) {
  if (cpus.size() != 2 || cpus[0] < 0 || cpus[1] < 0) return {};
  try {
    return std::string(platform::to_string(machine.relation(static_cast<unsigned>(cpus[0]), static_cast<unsigned>(cpus[1]))));
  } catch (const std::exception&) {
    return {};  // a CPU the topology does not know: say nothing rather than guess
  }
}

std::string falseshare_text(const probes::falseshare_settings& settings, const std::string& window_text,
                            const std::vector<probes::pattern_cost>& costs, const falseshare_analysis& analysis,
                            const falseshare_evidence& evidence) {
  std::string text = fmt::format("false sharing: {} threads pinned to CPUs {}{}, each accessing its own 8-byte word, "
                                 "the words `stride` bytes apart; ns per access, {} repeats x {} threads, {} each\n",
                                 settings.cpus.size(), evidence.cpus,
                                 evidence.relation.empty() ? std::string() : fmt::format(" ({})", evidence.relation),
                                 settings.repeats, settings.cpus.size(), window_text);
  text += "access patterns:\n";
  for (const auto& cost : costs)
    text += fmt::format("  {:<26} {}\n", info_of(cost.pattern).words, info_of(cost.pattern).description);
  // The sweep: every stride of the patterns that sweep them.
  for (std::size_t index = 0; index < costs.size(); ++index) {
    const probes::pattern_cost& cost = costs[index];
    if (!info_of(cost.pattern).sweeps_strides) continue;
    text += fmt::format("{}, ns per access by stride:\n", info_of(cost.pattern).words);
    text += fmt::format("{:>7}  {:<28} {:>9} {:>9} {:>9} {:>8}\n", "stride", "words share", "min", "median", "max",
                        "samples");
    for (std::size_t stride = 0; stride < cost.strides.size(); ++stride) {
      const probes::stride_cost& measured = cost.strides[stride];
      const auto& distribution = analysis.patterns[index].ns_per_access[stride];
      if (!distribution) {
        text += fmt::format("{:>7}  no thread was scheduled during any window (machine overloaded)\n",
                            measured.stride_bytes);
        continue;
      }
      const char* sharing = measured.shares_line        ? "a 64-byte line"
                            : measured.shares_line_pair ? "a 128-byte pair, not a line"
                                                        : "nothing";
      text += fmt::format("{:>7}  {:<28} {:>9.2f} {:>9.2f} {:>9.2f} {:>8}\n", measured.stride_bytes, sharing,
                          distribution->min, distribution->p50, distribution->max, distribution->count);
    }
  }
  // The penalties: one line against apart, per pattern.
  text += fmt::format("penalty of one line against apart, paired per repeat (median [{:.0f} % bootstrap interval], "
                      "noise band {:.0f} %):\n",
                      100.0 * kConfidence, 100.0 * kDefaultNoise);
  text += fmt::format("  {:<26} {:>8} {:>8} {:>9}  {:<32} {:>5}\n", "pattern", "stride", "ns", "ns apart", "penalty",
                      "pairs");
  for (std::size_t index = 0; index < costs.size(); ++index) {
    const pattern_analysis& pattern = analysis.patterns[index];
    const std::string_view words = info_of(pattern.pattern).words;
    if (!pattern.penalty) {
      text += fmt::format("  {:<26} not measured both on one line and apart (--strides, or no repeat scheduled "
                          "every thread)\n",
                          words);
      continue;
    }
    const falseshare_penalty& penalty = *pattern.penalty;
    text += fmt::format("  {:<26} {:>8} {:>8} {:>9}  {:<32} {:>5}\n", words,
                        fmt::format("{}/{}", penalty.sharing_stride_bytes, penalty.apart_stride_bytes),
                        median_text(pattern, costs[index], penalty.sharing_stride_bytes),
                        median_text(pattern, costs[index], penalty.apart_stride_bytes),
                        fmt::format("{:.2f}x [{:.2f}, {:.2f}] {}", penalty.estimate.median, penalty.estimate.low,
                                    penalty.estimate.high, to_string(penalty.verdict)),
                        penalty.ratios.size());
  }
  text += answer_line(analysis, evidence);
  return text;
}

nlohmann::json falseshare_json(const probes::falseshare_settings& settings,
                               const std::vector<probes::pattern_cost>& costs, const falseshare_analysis& analysis,
                               const falseshare_evidence& evidence, const platform::topology& machine) {
  nlohmann::json document = result_document("falseshare", machine);
  document["settings"] = {{"threads", settings.cpus.size()},
                          {"cpus", settings.cpus},
                          {"window_ns", settings.window_ns},
                          {"repeats", settings.repeats}};
  if (!evidence.relation.empty()) document["settings"]["cpus_relation"] = evidence.relation;
  document["patterns"] = nlohmann::json::array();
  for (std::size_t index = 0; index < costs.size(); ++index) {
    const probes::access_pattern_info& info = info_of(costs[index].pattern);
    nlohmann::json pattern = {{"pattern", info.name},
                              {"words", info.words},
                              {"description", info.description},
                              {"in_step_layouts", info.in_step_layouts},
                              {"strides", nlohmann::json::array()}};
    for (const auto& stride : costs[index].strides)
      pattern["strides"].push_back({{"stride_bytes", stride.stride_bytes},
                                    {"share_line", stride.shares_line},
                                    {"share_line_pair", stride.shares_line_pair},
                                    {"ns_per_access", distribution_json(stride.ns_per_access)}});
    if (analysis.patterns[index].penalty) pattern["penalty"] = penalty_json(*analysis.patterns[index].penalty);
    document["patterns"].push_back(std::move(pattern));
  }
  std::string answer = answer_line(analysis, evidence);
  answer.pop_back();  // the newline
  document["answer"] = answer;
  return document;
}

}  // namespace lockstep::bench
