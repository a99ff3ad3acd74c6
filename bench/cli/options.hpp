#pragma once
// lockstep's one command-line grammar, shared by every command:
//  * a result is written with --out FILE (checked before any measurement:
//    a missing or unwritable directory fails at once, exit 2);
//  * how many times the whole measurement is repeated is --repetitions N in
//    every command that repeats one (run, falseshare, migrate, mpi); a
//    command's older name (falseshare's and migrate's --repeats, mpi's
//    --rounds) stays as an alias that the help marks as old;
//  * durations and periods take a unit (ns, us, ms, s): --period 1ms,
//    --min-time 40ms, --window 100ms, --duration 10s;
//  * sizes take a binary unit or none (bytes): --bytes 256KiB, 4MiB, 65536;
//  * a noise band is a percentage, the sign optional: --noise 5, --noise 5%;
//  * name lists are comma lists of names from the registries, each checked,
//    none empty; counts are whole numbers in a stated range;
//  * CPU lists read as 0,2,4-7.
// Every parse failure throws usage_error with one line naming the option; a
// mistyped command or option is named with the nearest valid one
// (unknown_word_message).
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
// `min_ns` and at most `max_ns`. A number without a unit is refused ("'40'
// needs a unit (ns, us, ms or s; ...)"), and so is a unit it does not know
// ("'40sec': unknown unit 'sec' (ns, us, ms or s)"); a time out of range is refused with its range in units, each bound in the largest
// unit that divides it ("out of range (1ms to 60s)").
std::int64_t parse_duration_ns(const std::string& text, const std::string& option, std::int64_t min_ns = 1,
                               std::int64_t max_ns = 10'000'000'000'000);

// The same grammar as a double in seconds, for simulated times (verify's
// --dt 1ms, --t-end 2s): finite, any positive value; the caller checks
// its range.
double parse_duration_seconds(const std::string& text, const std::string& option);

// "256KiB", "4MiB", "1GiB", "64B", "65536": a size in bytes, at least
// `min_bytes` and at most `max_bytes`. Binary units only (B, KiB = 1024,
// MiB, GiB), a number alone is bytes, and a fraction is fine when the size
// comes out a whole number of bytes ("0.5KiB"). KB, MB, GB (and K, M, G)
// are refused with a hint: some tools read them as powers of ten, others as
// powers of two.
std::uint64_t parse_size_bytes(const std::string& text, const std::string& option, std::uint64_t min_bytes = 1,
                               std::uint64_t max_bytes = std::uint64_t{1} << 40);

// "8,64,1KiB": every item a size as parse_size_bytes reads it, in
// min..max; repeats dropped, the order kept; at least one item.
std::vector<std::uint64_t> parse_size_list(const std::string& text, const std::string& option,
                                           std::uint64_t min_bytes, std::uint64_t max_bytes);

// "5", "5%", "0.5 %", " 7 % ": a percentage from 0 to 100, the per cent sign
// and the spaces around it optional (the words `lockstep compare --noise`
// takes). A decimal number: no exponent, no sign.
double parse_percent(const std::string& text, const std::string& option);

// "8,16,32": every item a whole number in min..max; at least one item.
std::vector<long long> parse_number_list(const std::string& text, const std::string& option, long long min,
                                         long long max);

// `name`, when it is one of `valid`; else throws usage_error, one line that
// says what was looked for (`unknown`: "--pin: unknown value", "unknown
// list") and the valid name nearest it ("--pin: unknown value 'compakt' (did
// you mean compact?)", by nearest_name) or, with none near, every valid one
// ("(valid: none, compact, scatter, migrate)"). Every name a command takes
// from a list of names is matched here, select_names' too.
const std::string& check_name(const std::string& name, const std::vector<std::string>& valid,
                              const std::string& unknown);

// Every name in the comma list `wanted` must be in `valid` (check_name; repeats
// dropped, the order kept); `wanted` not given: all of `valid`. An empty list,
// an empty item, or a list of nothing but commas, is refused.
std::vector<std::string> select_names(const std::optional<std::string>& wanted, const std::vector<std::string>& valid,
                                      const std::string& option);

// The names --sync, --layout and --pin take, in `lockstep list`'s order: the
// registries the benchmark matrix iterates (sync/registry.hpp,
// layouts/registry.hpp, platform/placement.hpp).
std::vector<std::string> sync_names();
std::vector<std::string> layout_names();
std::vector<std::string> placement_names();

// "a, b, c": for messages that list the valid names.
std::string joined(const std::vector<std::string>& names);

// Throws usage_error (one line) when a result cannot be written to `path`
// (bench/results/result_file.hpp: check_result_path). Empty: nothing asked.
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
// `member` is what the command splits the model among, "thread" (run, delay)
// or "rank" (mpi), and the help says how its count picks the default; empty
// (verify) when nothing is split: the default is the paper's two masses.
// `masses` stays empty when not given.
inline constexpr std::size_t kMassesMax = 4096;
CLI::Option* add_masses_option(CLI::App& command, std::optional<std::size_t>& masses, const std::string& member);

// The --out option, the same words in every command that writes a result.
CLI::Option* add_out_option(CLI::App& command, std::string& path, const std::string& what = "the result as JSON");

// --noise PCT, the noise band of a command's verdicts, read by parse_percent
// into `percent` (its value before parsing is the default the help shows).
// `what` says what the band decides.
CLI::Option* add_noise_option(CLI::App& command, double& percent, const std::string& what);

// --repetitions N: how many times the whole measurement is repeated, 1 to
// `max` (its value before parsing is the default the help shows). `one` says
// what one repetition measures. `old_name` (e.g. "--repeats"), when given,
// is accepted as well and the help says it is the old name.
CLI::Option* add_repetitions_option(CLI::App& command, int& repetitions, int max, const std::string& one,
                                    const std::string& old_name = "");

// Typing mistakes. The number of single-character insertions, deletions,
// substitutions and swaps of neighbours that turn `a` into `b` (the optimal
// string alignment distance).
std::size_t edit_distance(const std::string& a, const std::string& b);

// The candidate `word` most likely misspells: the nearest by edit_distance
// when it is at most 1 edit away for a word of up to 4 characters, 2 for up
// to 8, 3 beyond (ties: the first candidate); else the one candidate that
// `word` (3 characters or more) begins. Nothing when none is that near.
std::optional<std::string> nearest_name(const std::string& word, const std::vector<std::string>& candidates);

// "unknown command 'runn'; did you mean 'run'?" (or, with nothing near,
// where the commands are listed): for `lockstep WORD` and `lockstep help WORD`.
std::string unknown_command_message(const CLI::App& app, const std::string& word);

// After CLI11 refused a command line (main.cpp): the one line that names the
// first word no command or option took and, when one is near (or another
// command takes the word as an old name of an option this one has), the valid
// spelling: "unknown option --quik; did you mean --quick?", "unknown command
// 'runn'; did you mean 'run'?", "no command given; ...". Empty when every
// word was taken (the refusal was about something else).
std::string unknown_word_message(const CLI::App& app);

}  // namespace lockstep::cli
