#pragma once
// The machine's state in the result context (platform/machine_state.hpp
// reads it): the keys machine_context adds for every command, and the same
// keys in `lockstep topology --out`'s "machine_state". Every value is text;
// a value that could not be read is "unavailable".
//
//   machine_state_root           where sys/ and proc/ were read: "/", or LOCKSTEP_STATE_ROOT
//   cpufreq_driver               scaling_driver of the online CPUs
//   cpufreq_governor             scaling_governor
//   cpufreq_min_khz              cpuinfo_min_freq
//   cpufreq_max_khz              cpuinfo_max_freq
//       one value when every online CPU reads the same ("powersave"), else
//       each value with its CPUs: "powersave (CPUs 0-3); performance (CPUs 4-7)"
//   cpufreq_pstate_status        "intel_pstate active", "amd_pstate guided"
//   cpu_boost                    "on (intel_pstate/no_turbo = 0)", "off (cpufreq/boost = 0)"
//   cpufreq_sampled_khz          scaling_cur_freq of the CPUs the command may use, sampled at its
//                                start, its quiet moments and its end: "800000-4700000 (median
//                                3900000) over 3 samples of CPUs 0-3"
//   smt_control, smt_active      sys/devices/system/cpu/smt/: "on", "1"
//   isolated_cpus                "2-3", "none"
//   nohz_full_cpus               "2-3", "none"; "unavailable" on a kernel without nohz_full
//   irq_cpus                     the CPUs the two IRQ keys are about: those the command may use
//   irqs_allowed                 IRQs whose smp_affinity_list holds one of them: "28 of 30: 0-9,11,14-30"
//   irqs_effective               those whose effective_affinity_list does: "6 of 30: 1,4,8-9,24-25"
//   transparent_hugepage         the enabled choice: "always", "madvise", "never"
//   transparent_hugepage_defrag  the defrag choice
//
// All but two are the same whichever command writes them, unless the
// machine was set up differently in between; kPerCommandStateKeys are the
// command's own readings (the frequency during it; the IRQs' effective
// CPUs, which irqbalance moves).
#include <nlohmann/json.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "platform/machine_state.hpp"

namespace lockstep::bench {

inline constexpr std::array<const char*, 2> kPerCommandStateKeys = {"cpufreq_sampled_khz", "irqs_effective"};

// The keys above for a state read, the CPUs a command may use and the
// frequency sampled during it.
nlohmann::json machine_state_context(const platform::machine_state& state, const std::vector<unsigned>& cpus,
                                     const platform::frequency_summary& sampled);

// machine_state_context of the state under platform::state_root() and this
// command's frequency trace, set into `context` (machine_context calls it).
void add_machine_state(nlohmann::json& context, const std::vector<unsigned>& cpus);

// One value per CPU as the context writes it: "v" when all agree, else
// "v (CPUs 0-3); w (CPUs 4-7)", values in the order of their first CPU.
struct cpu_value {
  unsigned cpu = 0;
  std::string value;
};
std::string values_by_cpu(const std::vector<cpu_value>& values);

// "none", "2-3", or "unavailable".
std::string cpu_list_words(const std::optional<std::vector<unsigned>>& cpus);

}  // namespace lockstep::bench
