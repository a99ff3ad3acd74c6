// The machine's state as `lockstep topology` shows it (machine_state_report.hpp).
#include "bench/probe_reports/machine_state_report.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <optional>
#include <sstream>

#include "bench/results/machine_state_context.hpp"
#include "platform/cpu_list.hpp"

namespace lockstep::bench {

namespace {

using platform::kUnavailable;

constexpr std::size_t kLineWidth = 120;

// A line cut at words to kLineWidth columns, continuation lines indented four
// past the line's own indent; a word longer than the width stays whole.
std::string wrapped(const std::string& line) {
  const std::size_t indent = std::min(line.find_first_not_of(' '), line.size());
  const std::string continuation(indent + 4, ' ');
  std::string text;
  std::string current = line.substr(0, indent);
  bool first_word = true;
  std::istringstream words(line.substr(indent));
  std::string word;
  while (words >> word) {
    if (!first_word && current.size() + 1 + word.size() > kLineWidth) {
      text += current + "\n";
      current = continuation + word;
    } else {
      current += (first_word ? "" : " ") + word;
    }
    first_word = false;
  }
  return text + current + "\n";
}

// "800-4700 MHz" over every CPU that has both ends; nullopt when none has.
std::optional<std::string> range_mhz(const std::vector<platform::cpu_frequency>& readings,
                                     std::optional<std::uint64_t> platform::cpu_frequency::*low,
                                     std::optional<std::uint64_t> platform::cpu_frequency::*high) {
  std::optional<std::uint64_t> lowest;
  std::optional<std::uint64_t> highest;
  for (const auto& reading : readings) {
    if (const auto& value = reading.*low) lowest = lowest ? std::min(*lowest, *value) : *value;
    if (const auto& value = reading.*high) highest = highest ? std::max(*highest, *value) : *value;
  }
  if (!lowest || !highest) return std::nullopt;
  if (*lowest == *highest) return fmt::format("{} MHz", *lowest / 1000);
  return fmt::format("{}-{} MHz", *lowest / 1000, *highest / 1000);
}

std::string cpufreq_line(const platform::machine_state& state) {
  const auto words = [&](auto field) {
    std::vector<cpu_value> values;
    for (const auto& reading : state.frequencies) values.push_back({reading.cpu, reading.*field});
    return values_by_cpu(values);
  };
  const std::string driver = words(&platform::cpu_frequency::driver);
  const std::string governor = words(&platform::cpu_frequency::governor);
  const auto hardware = range_mhz(state.frequencies, &platform::cpu_frequency::min_khz,
                                  &platform::cpu_frequency::max_khz);
  const auto now = range_mhz(state.frequencies, &platform::cpu_frequency::current_khz,
                             &platform::cpu_frequency::current_khz);
  if (driver == kUnavailable && governor == kUnavailable && !hardware && !now)
    return "  cpufreq: unavailable (no cpufreq files: no cpufreq driver runs here)";
  return fmt::format("  cpufreq: driver {}{}, governor {}, {}, now {}", driver,
                     state.pstate_status == kUnavailable ? "" : " (" + state.pstate_status + ")", governor,
                     hardware.value_or("range unavailable"), now.value_or(kUnavailable));
}

std::string boost_line(const platform::machine_state& state) {
  std::string boost = kUnavailable;
  if (state.boost.setting != platform::boost_setting::unavailable) {
    boost = fmt::format("{} ({})", state.boost.setting == platform::boost_setting::on ? "on" : "off",
                        state.boost.read_from);
  }
  return fmt::format("  {}: {}; SMT: control {}, active {}", state.boost.word, boost, state.smt_control,
                     state.smt_active);
}

std::string irq_line(const platform::machine_state& state, const std::vector<unsigned>& cpus) {
  const auto irqs = platform::irqs_on(state, cpus);
  if (!irqs) return "  IRQs: unavailable";
  return fmt::format("  IRQs that may land on CPUs {}: {} of {}; that do: {}", platform::format_cpu_list(cpus),
                     irqs->allowed.size(), irqs->total,
                     irqs->effective ? fmt::format("{} of {}", irqs->effective->size(), irqs->total)
                                     : std::string(kUnavailable));
}

}  // namespace

std::string machine_state_text(const platform::machine_state& state, const std::vector<unsigned>& cpus) {
  // The root is never cut: the header is not wrapped.
  std::string text = fmt::format("\nmachine state (read under {}):\n", state.root.string());
  text += wrapped(cpufreq_line(state));
  text += wrapped(boost_line(state));
  text += wrapped(fmt::format("  isolated CPUs: {}; nohz_full CPUs: {}", cpu_list_words(state.isolated),
                              cpu_list_words(state.nohz_full)));
  text += wrapped(irq_line(state, cpus));
  text += wrapped(fmt::format("  transparent huge pages: {}; defrag: {}", state.transparent_hugepage,
                              state.transparent_hugepage_defrag));
  const std::string bias = platform::bias_line(state, cpus, platform::bias_focus::step_times);
  if (!bias.empty()) text += wrapped("  a run here: " + bias);
  return text;
}

nlohmann::json machine_state_json(const platform::machine_state& state, const std::vector<unsigned>& cpus) {
  return machine_state_context(state, cpus, platform::command_frequency_summary());
}

}  // namespace lockstep::bench
