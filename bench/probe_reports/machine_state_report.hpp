#pragma once
// The machine's state as `lockstep topology` shows it (platform/machine_state.hpp
// reads it): a few lines, none wider than 120 columns, then the line that
// says what would bias a run on these CPUs, if anything does. What each
// value means: docs/machine-state.md. The result file carries the same
// values as every command's context (bench/results/machine_state_context.hpp).
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "platform/machine_state.hpp"

namespace lockstep::bench {

// `cpus`: the CPUs a run may use (the affinity set).
//
//   machine state (read under /):
//     cpufreq: driver intel_pstate (intel_pstate active), governor powersave, 800-4700 MHz, now 1200-3900 MHz
//     turbo: on (intel_pstate/no_turbo = 0); SMT: control on, active 1
//     isolated CPUs: 2-3; nohz_full CPUs: none
//     IRQs that may land on CPUs 0-3: 9 of 9; that do: 4 of 9
//     transparent huge pages: always; defrag: madvise
//     a run here: CPUs 0-3 run the powersave governor with turbo on: ... (wrapped)
std::string machine_state_text(const platform::machine_state& state, const std::vector<unsigned>& cpus);

// The context's machine-state keys for `lockstep topology --out` ("machine_state").
nlohmann::json machine_state_json(const platform::machine_state& state, const std::vector<unsigned>& cpus);

}  // namespace lockstep::bench
