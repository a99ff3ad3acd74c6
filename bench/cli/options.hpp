#pragma once
// lockstep's one command-line grammar, shared by every command:
//  * a result is written with --out FILE (checked before any measurement:
//    a missing or unwritable directory fails at once, exit 2);
//  * durations and periods take a unit (ns, us, ms, s): --period 1ms,
//    --min-time 40ms, --window 100ms, --duration 10s;
//  * name lists are comma lists of names from the registries, each checked,
//    none empty; counts are whole numbers in a stated range;
//  * CPU lists read as 0,2,4-7.
// Every parse failure throws usage_error with one line naming the option.
#include <CLI/CLI.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {

// "1ms", "250us", "1000000ns", "2s", "0.5s": a time in nanoseconds, at least
// `min_ns` and at most `max_ns`. A number without a unit is refused.
std::int64_t parse_duration_ns(const std::string& text, const std::string& option, std::int64_t min_ns = 1,
                               std::int64_t max_ns = 10'000'000'000'000);

// The same grammar as a double in seconds, for simulated times (verify's
// --dt 1ms, --t-end 2s): finite, any positive value; the caller checks
// its range.
double parse_duration_seconds(const std::string& text, const std::string& option);

// "8,16,32": every item a whole number in min..max; at least one item.
std::vector<long long> parse_number_list(const std::string& text, const std::string& option, long long min,
                                         long long max);

// Every name in the comma list `wanted` must be in `valid` (repeats dropped,
// the order kept); `wanted` not given: all of `valid`. An empty list, an
// empty item, or a list of nothing but commas, is refused.
std::vector<std::string> select_names(const std::optional<std::string>& wanted, const std::vector<std::string>& valid,
                                      const std::string& option);

// "a, b, c": for messages that list the valid names.
std::string joined(const std::vector<std::string>& names);

// Throws usage_error (one line) when a result cannot be written to `path`
// (bench/harness/result_file.hpp: check_result_path). Empty: nothing asked.
void check_out(const std::string& path);

// CPU lists: "0,2,4-7" into CPU numbers (ascending, no duplicates).
std::vector<int> parse_cpu_list(const std::string& text, const std::string& option);
// The CPUs (OS indices, ascending) of the affinity set, one PU per core
// unless include_smt_siblings.
std::vector<int> usable_cpus(const platform::topology& machine, bool include_smt_siblings);
// `requested`, each of which must be in `usable`.
std::vector<int> restrict_to(const std::vector<int>& usable, const std::vector<int>& requested,
                             const std::string& option);

// --masses S, the same words and range in every command that integrates the
// model (kernels/model_choice.hpp: which oscillator T threads integrate).
// `masses` stays empty when not given.
inline constexpr std::size_t kMassesMax = 4096;
CLI::Option* add_masses_option(CLI::App& command, std::optional<std::size_t>& masses);

// The --out option, the same words in every command that writes a result.
CLI::Option* add_out_option(CLI::App& command, std::string& path, const std::string& what = "the result as JSON");

}  // namespace lockstep::cli
