#pragma once
// The late steps' causes (attribution.hpp) as a person reads them and as the
// result file holds them (docs/schemas/delay.schema.json, $defs/causes).
#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>

#include "bench/delay/attribution.hpp"

namespace lockstep::bench {

// The line of one late step ("step 18233, 7.9 ms late: participant 2 on CPU 1
// reached stage 3 7.8 ms after the others; no switch, no fault, no
// interrupt: machine stall").
std::string late_step_line(const late_step& step);

// The causes' table, the tail's top causes, per CPU, the latest steps and
// what the record cost, under `title`; `worst_shown` of the latest steps.
std::string causes_text(const delay_causes& causes, const std::string& title, std::size_t worst_shown);

// The causes object of the result file.
nlohmann::json causes_json(const delay_causes& causes);

// The causes in delay_cause's order, each {"key", "words"} (kCauseNaming):
// the result file's cause_kinds, so that a reader takes the order and the
// words from the file instead of a copy of the table.
nlohmann::json cause_kinds_json();

// A row's causes above 0.5 % of its excess, largest first: "run-queue wait
// 97 %, machine stall 3 %".
std::string ranked_causes(const cause_row& row);

}  // namespace lockstep::bench
