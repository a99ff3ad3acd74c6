// The machine's state in the result context (machine_state_context.hpp).
#include "bench/results/machine_state_context.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <functional>
#include <utility>

#include "platform/cpu_list.hpp"

namespace lockstep::bench {

namespace {

using platform::kUnavailable;

std::string khz_or_unavailable(const std::optional<std::uint64_t>& khz) {
  return khz ? std::to_string(*khz) : std::string(kUnavailable);
}

std::string per_cpu(const platform::machine_state& state,
                    const std::function<std::string(const platform::cpu_frequency&)>& value_of) {
  std::vector<cpu_value> values;
  for (const auto& reading : state.frequencies) values.push_back({reading.cpu, value_of(reading)});
  return values_by_cpu(values);
}

std::string boost_words(const platform::boost_state& boost) {
  switch (boost.setting) {
    case platform::boost_setting::on: return fmt::format("on ({})", boost.read_from);
    case platform::boost_setting::off: return fmt::format("off ({})", boost.read_from);
    case platform::boost_setting::unavailable: break;
  }
  return kUnavailable;
}

std::string sampled_words(const platform::frequency_summary& sampled) {
  if (!sampled.lowest_khz || !sampled.median_khz || !sampled.highest_khz) return kUnavailable;
  return fmt::format("{}-{} (median {}) over {} sample{} of {} {}", *sampled.lowest_khz, *sampled.highest_khz,
                     *sampled.median_khz, sampled.samples, sampled.samples == 1 ? "" : "s",
                     sampled.cpus.size() == 1 ? "CPU" : "CPUs", platform::format_cpu_list(sampled.cpus));
}

std::string irq_words(unsigned total, const std::vector<unsigned>& irqs) {
  if (irqs.empty()) return fmt::format("0 of {}", total);
  return fmt::format("{} of {}: {}", irqs.size(), total, platform::format_cpu_list(irqs));
}

}  // namespace

std::string values_by_cpu(const std::vector<cpu_value>& values) {
  if (values.empty()) return kUnavailable;
  std::vector<std::pair<std::string, std::vector<unsigned>>> groups;
  for (const auto& [cpu, value] : values) {
    auto group = std::find_if(groups.begin(), groups.end(), [&](const auto& g) { return g.first == value; });
    if (group == groups.end()) groups.push_back({value, {cpu}});
    else group->second.push_back(cpu);
  }
  if (groups.size() == 1) return groups.front().first;
  std::string text;
  for (const auto& [value, cpus] : groups) {
    if (!text.empty()) text += "; ";
    text += fmt::format("{} ({} {})", value, cpus.size() == 1 ? "CPU" : "CPUs", platform::format_cpu_list(cpus));
  }
  return text;
}

std::string cpu_list_words(const std::optional<std::vector<unsigned>>& cpus) {
  if (!cpus) return kUnavailable;
  if (cpus->empty()) return "none";
  return platform::format_cpu_list(*cpus);
}

nlohmann::json machine_state_context(const platform::machine_state& state, const std::vector<unsigned>& cpus,
                                     const platform::frequency_summary& sampled) {
  nlohmann::json keys = nlohmann::json::object();
  keys["machine_state_root"] = state.root.string();
  keys["cpufreq_driver"] = per_cpu(state, [](const auto& reading) { return reading.driver; });
  keys["cpufreq_governor"] = per_cpu(state, [](const auto& reading) { return reading.governor; });
  keys["cpufreq_min_khz"] = per_cpu(state, [](const auto& reading) { return khz_or_unavailable(reading.min_khz); });
  keys["cpufreq_max_khz"] = per_cpu(state, [](const auto& reading) { return khz_or_unavailable(reading.max_khz); });
  keys["cpufreq_pstate_status"] = state.pstate_status;
  keys["cpu_boost"] = boost_words(state.boost);
  keys["cpufreq_sampled_khz"] = sampled_words(sampled);
  keys["smt_control"] = state.smt_control;
  keys["smt_active"] = state.smt_active;
  keys["isolated_cpus"] = cpu_list_words(state.isolated);
  keys["nohz_full_cpus"] = cpu_list_words(state.nohz_full);
  keys["irq_cpus"] = cpus.empty() ? std::string("none") : platform::format_cpu_list(cpus);
  const auto irqs = platform::irqs_on(state, cpus);
  keys["irqs_allowed"] = irqs ? irq_words(irqs->total, irqs->allowed) : std::string(kUnavailable);
  keys["irqs_effective"] =
      irqs && irqs->effective ? irq_words(irqs->total, *irqs->effective) : std::string(kUnavailable);
  keys["transparent_hugepage"] = state.transparent_hugepage;
  keys["transparent_hugepage_defrag"] = state.transparent_hugepage_defrag;
  return keys;
}

void add_machine_state(nlohmann::json& context, const std::vector<unsigned>& cpus) {
  const nlohmann::json keys = machine_state_context(platform::read_machine_state(platform::state_root()), cpus,
                                                    platform::command_frequency_summary());
  for (const auto& [key, value] : keys.items()) context[key] = value;
}

}  // namespace lockstep::bench
