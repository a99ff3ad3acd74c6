// What the run derived, into its file (derived_sections.hpp).
#include "bench/run/derived_sections.hpp"

#include <algorithm>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "bench/run/paired_blocks.hpp"
#include "bench/run/ranking.hpp"
#include "kernels/normal_modes.hpp"
#include "kernels/oscillator.hpp"
#include "kernels/rk4.hpp"
#include "kernels/verification.hpp"
#include "layouts/registry.hpp"
#include "platform/statistics.hpp"

namespace lockstep::bench {

namespace {

nlohmann::json layouts_json() {
  nlohmann::json layouts = nlohmann::json::array();
  for (const auto& info : layouts::all_layout_info)
    layouts.push_back({{"name", std::string(info.name)},
                       {"kind", info.kind == layouts::layout_kind::shared ? "shared" : "private_copy"},
                       {"writer_isolation", info.writer_isolation}});
  return layouts;
}

nlohmann::json planned_json(const run_book& book) {
  nlohmann::json planned = nlohmann::json::array();
  for (const comparison& what : book.planned)
    planned.push_back({{"comparison", std::string(to_string(what.kind))}, {"group", what.group}, {"a", what.a}, {"b", what.b}});
  return planned;
}

nlohmann::json entry_medians_json(const run_book& book) {
  nlohmann::json medians = nlohmann::json::array();
  for (const entry_in_modes& entry : entries_in_several_modes(book)) {
    nlohmann::json modes = nlohmann::json::array();
    for (const pace_mode_time& mode : entry.times.modes)
      modes.push_back({{"mode", mode.mode}, {"median_ns", mode.median}, {"repetitions", mode.repetitions}});
    medians.push_back({{"entry", entry.entry->name}, {"modes", modes}, {"straddling", entry.times.straddling}});
  }
  return medians;
}

nlohmann::json rankings_json(const run_book& book) {
  nlohmann::json rankings = nlohmann::json::array();
  for (const ranked_group& group : rank_groups(book, entry_kind::rk4)) {
    nlohmann::json entries = nlohmann::json::array();
    for (const measured_entry& step : group.entries) {
      const auto vs_serial = step.entry->median("vs_serial");
      entries.push_back({{"entry", step.entry->name},
                         {"ns_per_step", step.median},
                         {"vs_serial", vs_serial ? nlohmann::json(*vs_serial) : nlohmann::json(nullptr)}});
    }
    rankings.push_back(
        {{"pin", std::string(platform::to_string(group.pin))}, {"threads", group.threads}, {"entries", entries}});
  }
  return rankings;
}

// The paper's two-mass system, the model of the run's answer: its C/m, initial
// positions, normal modes beside the paper's printed roots, and the
// derivative evaluations of one serial step.
nlohmann::json model_json() {
  const kernels::two_mass_params params{};
  const kernels::two_mass_frequencies roots = kernels::two_mass_angular_frequencies(params);
  return {{"c_over_m", params.c1 / params.m1},
          {"positions_0", {params.x1, params.x2}},
          {"roots",
           {{"computed_rad_s", {{"fast", roots.fast}, {"slow", roots.slow}}},
            {"paper_rad_s", {{"fast", kernels::kPaperFastRoot}, {"slow", kernels::kPaperSlowRoot}}},
            {"paper_implied_c_over_m", kernels::kPaperFastRoot * kernels::kPaperSlowRoot}}},
          {"evaluations_per_step", kernels::two_mass_model::kEquations * kernels::kRk4Stages}};
}

}  // namespace

std::vector<entry_in_modes> entries_in_several_modes(const run_book& book) {
  std::vector<entry_in_modes> several;
  for (const auto& entry : book.entries()) {
    if (!entry.error.empty()) continue;
    if (entry.spec.kind != entry_kind::rk4 && entry.spec.kind != entry_kind::barrier) continue;
    pace_mode_times times = entry.pace_medians();
    if (times.modes.size() >= 2) several.push_back({&entry, std::move(times)});
  }
  return several;
}

void write_derived_sections(nlohmann::json& document, const run_book& book) {
  document["lockstep_layouts"] = layouts_json();
  document["lockstep_planned_pairs"] = planned_json(book);
  if (document.contains("lockstep_pace") && document["lockstep_pace"].is_object())
    document["lockstep_pace"]["entry_medians"] = entry_medians_json(book);
  document["lockstep_rankings"] = rankings_json(book);
  document["lockstep_model"] = model_json();
}

}  // namespace lockstep::bench
