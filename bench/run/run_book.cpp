// The run book and batch sizing (run_book.hpp).
#include "bench/run/run_book.hpp"

#include "bench/results/derived_figures.hpp"
#include "platform/statistics.hpp"

#include <algorithm>
#include <cmath>

namespace lockstep::bench {

namespace {

std::vector<double> values_of(const captured_entry& entry, std::string_view counter) {
  std::vector<double> values;
  const std::string key(counter);
  for (const auto& repetition : entry.repetitions) {
    const auto found = repetition.find(key);
    if (found != repetition.end()) values.push_back(found->second);
  }
  return values;
}

}  // namespace

std::optional<double> captured_entry::median(std::string_view counter) const {
  const std::vector<double> values = values_of(*this, counter);
  if (values.empty()) return std::nullopt;
  return platform::median(values);
}

std::optional<std::pair<double, double>> captured_entry::range(std::string_view counter) const {
  const std::vector<double> values = values_of(*this, counter);
  if (values.empty()) return std::nullopt;
  const auto [low, high] = std::minmax_element(values.begin(), values.end());
  return std::pair{*low, *high};
}

pace_mode_times captured_entry::pace_medians() const {
  std::map<int, std::vector<double>> by_mode;
  const std::string time(spec.time_counter());
  for (const auto& repetition : repetitions) {
    const auto mode = repetition.find("pace_mode");
    const auto value = repetition.find(time);
    if (mode != repetition.end() && value != repetition.end())
      by_mode[static_cast<int>(mode->second)].push_back(value->second);
  }
  pace_mode_times times;
  for (const auto& [mode, values] : by_mode) {
    if (mode < 0)
      times.straddling += values.size();
    else
      times.modes.push_back({mode, platform::median(values), values.size()});
  }
  return times;
}

void run_book::record(captured_entry entry) {
  for (auto& existing : entries_) {
    if (existing.name == entry.name) {
      existing = std::move(entry);
      return;
    }
  }
  entries_.push_back(std::move(entry));
}

const captured_entry* run_book::find(const std::string& name) const {
  for (const auto& entry : entries_)
    if (entry.name == name) return &entry;
  return nullptr;
}

std::optional<double> run_book::c2c_one_way_ns() const {
  const captured_entry* entry = find(entry_spec::c2c_calibration().name());
  if (entry == nullptr || !entry->error.empty()) return std::nullopt;
  return entry->median_time();
}

std::optional<double> run_book::serial_step_ns(const kernels::model_choice& model) const {
  const captured_entry* entry = find(entry_spec::serial_step(model).name());
  if (entry == nullptr || !entry->error.empty()) return std::nullopt;
  return entry->median_time();
}

void run_book::derive_ratios() {
  for (captured_entry& entry : entries_) {
    if (!entry.spec.is_parallel_step()) continue;
    const calibrations run = calibrations_for(entry.spec.model);
    for (auto& repetition : entry.repetitions)
      for (const derived_ratio& ratio : derived_ratios(repetition, run)) repetition[ratio.name] = ratio.value;
  }
}

calibrations run_book::calibrations_for(const kernels::model_choice& model) const {
  return {c2c_one_way_ns(), serial_step_ns(model)};
}

std::uint64_t units_for_batch(double unit_ns, const run_settings& settings) {
  if (!(unit_ns > 0.0)) return 1;
  const double units = std::floor(static_cast<double>(settings.target_batch_ns) / unit_ns);
  return static_cast<std::uint64_t>(std::clamp(units, 1.0, static_cast<double>(kMaxUnitsPerBatch)));
}

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> items;
  std::string item;
  for (char c : text) {
    if (c == ',') {
      if (!item.empty()) items.push_back(item);
      item.clear();
    } else if (c != ' ') {
      item += c;
    }
  }
  if (!item.empty()) items.push_back(item);
  return items;
}

}  // namespace lockstep::bench
