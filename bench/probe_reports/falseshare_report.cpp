// What a false-sharing measurement means, as text and as a result file (falseshare_report.hpp).
#include "bench/probe_reports/falseshare_report.hpp"

#include <fmt/core.h>

#include <algorithm>

#include "bench/results/machine_context.hpp"
#include "bench/results/result_json.hpp"

namespace lockstep::bench {

falseshare_analysis analyse_falseshare(const std::vector<probes::stride_cost>& costs) {
  falseshare_analysis analysis;
  for (const auto& cost : costs)
    analysis.ns_per_write.push_back(
        cost.ns_per_write.empty() ? std::nullopt
                                  : std::optional<platform::distribution>(platform::summarize(cost.ns_per_write)));

  const auto sharing = std::find_if(costs.begin(), costs.end(), [](const auto& cost) { return cost.shares_line; });
  const auto apart = std::find_if(costs.begin(), costs.end(),
                                  [](const auto& cost) { return !cost.shares_line && !cost.shares_line_pair; });
  if (sharing == costs.end() || apart == costs.end()) return analysis;
  falseshare_penalty penalty;
  penalty.sharing_stride_bytes = sharing->stride_bytes;
  penalty.apart_stride_bytes = apart->stride_bytes;
  for (std::size_t repeat = 0; repeat < sharing->repeat_mean_ns.size() && repeat < apart->repeat_mean_ns.size();
       ++repeat)
    if (sharing->repeat_mean_ns[repeat] && apart->repeat_mean_ns[repeat] && *apart->repeat_mean_ns[repeat] > 0.0)
      penalty.ratios.push_back(*sharing->repeat_mean_ns[repeat] / *apart->repeat_mean_ns[repeat]);
  if (penalty.ratios.empty()) return analysis;
  penalty.estimate = bootstrap_median(penalty.ratios);
  penalty.verdict = verdict_of(penalty.estimate);
  analysis.penalty = std::move(penalty);
  return analysis;
}

std::string falseshare_text(const probes::falseshare_settings& settings, const std::string& window_text,
                            const std::vector<probes::stride_cost>& costs, const falseshare_analysis& analysis) {
  std::string cpu_text;
  for (int cpu : settings.cpus) cpu_text += (cpu_text.empty() ? "" : ",") + std::to_string(cpu);
  std::string text = fmt::format("false sharing: {} writers pinned to CPUs {}, counters `stride` bytes apart\n",
                                 settings.cpus.size(), cpu_text);
  text += fmt::format("time per write, ns ({} repeats x {} threads, {} each)\n", settings.repeats, settings.cpus.size(),
                      window_text);
  text += fmt::format("{:>7}  {:<28} {:>9} {:>9} {:>9} {:>8}\n", "stride", "writers share", "min", "median", "max",
                      "samples");
  for (std::size_t i = 0; i < costs.size(); ++i) {
    const auto& cost = costs[i];
    if (!analysis.ns_per_write[i]) {
      text += fmt::format("{:>7}  no writer was scheduled during any window (machine overloaded)\n", cost.stride_bytes);
      continue;
    }
    const platform::distribution& d = *analysis.ns_per_write[i];
    const char* sharing = cost.shares_line        ? "a 64-byte line"
                          : cost.shares_line_pair ? "a 128-byte pair, not a line"
                                                  : "nothing";
    text += fmt::format("{:>7}  {:<28} {:>9.2f} {:>9.2f} {:>9.2f} {:>8}\n", cost.stride_bytes, sharing, d.min, d.p50,
                        d.max, d.count);
  }
  if (analysis.penalty) {
    const falseshare_penalty& penalty = *analysis.penalty;
    text += fmt::format(
        "false-sharing penalty, stride {} / stride {} paired per repeat: {:.2f}x [{:.2f}, {:.2f}] {} ({} "
        "pairs, {:.0f} % bootstrap interval, noise band {:.0f} %)\n",
        penalty.sharing_stride_bytes, penalty.apart_stride_bytes, penalty.estimate.median, penalty.estimate.low,
        penalty.estimate.high, to_string(penalty.verdict), penalty.ratios.size(), 100.0 * kConfidence,
        100.0 * kDefaultNoise);
  }
  return text;
}

nlohmann::json falseshare_json(const probes::falseshare_settings& settings,
                               const std::vector<probes::stride_cost>& costs, const falseshare_analysis& analysis,
                               const platform::topology& machine) {
  nlohmann::json document = result_document("falseshare", machine);
  if (analysis.penalty) {
    const falseshare_penalty& penalty = *analysis.penalty;
    document["penalty"] = {{"a_stride_bytes", penalty.sharing_stride_bytes},
                           {"b_stride_bytes", penalty.apart_stride_bytes},
                           {"ratios", penalty.ratios},
                           {"median", penalty.estimate.median},
                           {"ci_low", penalty.estimate.low},
                           {"ci_high", penalty.estimate.high},
                           {"confidence", kConfidence},
                           {"noise", kDefaultNoise},
                           {"verdict", to_string(penalty.verdict)}};
  }
  document["settings"] = {{"threads", settings.cpus.size()},
                          {"cpus", settings.cpus},
                          {"window_ns", settings.window_ns},
                          {"repeats", settings.repeats}};
  document["strides"] = nlohmann::json::array();
  for (const auto& cost : costs)
    document["strides"].push_back({{"stride_bytes", cost.stride_bytes},
                                   {"share_line", cost.shares_line},
                                   {"share_line_pair", cost.shares_line_pair},
                                   {"ns_per_write", distribution_json(cost.ns_per_write)}});
  return document;
}

}  // namespace lockstep::bench
