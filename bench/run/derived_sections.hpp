#pragma once
// What `lockstep run` derived, written into its file for compare and report
// to read rather than derive again (reports/lockstep_reports/read/derived_reader.py
// reads each; docs/schemas/run.schema.json holds their shapes):
//
//   lockstep_layouts          every layout of the registry, in its order, with
//                             its kind and writer isolation (the traits that
//                             plan the false-sharing comparisons)
//   lockstep_planned_pairs    every comparison the run planned, measured or not
//   lockstep_pace.entry_medians
//                             each entry that ran in more than one pace mode:
//                             its median per mode (summary.cpp prints the same)
//   lockstep_rankings         per placement and thread count, the RK4 entries
//                             fastest first, collapsed entries left out
//   lockstep_model            the model's constants and normal modes as the
//                             kernel holds them
#include <nlohmann/json.hpp>

#include "bench/run/run_book.hpp"

namespace lockstep::bench {

// Adds the sections above to the result document (lockstep_pace must be
// there already, when the run has a pace trace).
void write_derived_sections(nlohmann::json& document, const run_book& book);

// The rk4 and barrier entries whose repetitions ran in two pace modes or
// more, with their medians per mode (captured_entry::pace_medians), as the
// summary prints them and the file holds them.
struct entry_in_modes {
  const captured_entry* entry = nullptr;
  pace_mode_times times;
};
std::vector<entry_in_modes> entries_in_several_modes(const run_book& book);

}  // namespace lockstep::bench
