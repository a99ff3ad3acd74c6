// lockstep run: the benchmark matrix (DESIGN.md, Commands; issue 4).
//
// Registers the entries the filters select (harness.hpp explains the timing),
// runs them with Google Benchmark, writes its JSON atomically, and prints the
// summary on stdout. Progress goes to stderr.
#include <benchmark/benchmark.h>
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <regex>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/cli/options.hpp"
#include "bench/harness/barrier_entries.hpp"
#include "bench/cli/command.hpp"
#include "bench/harness/machine_context.hpp"
#include "bench/harness/pace.hpp"
#include "bench/harness/paired_blocks.hpp"
#include "bench/harness/run_book.hpp"
#include "bench/harness/reporters.hpp"
#include "bench/harness/result_file.hpp"
#include "bench/harness/summary.hpp"
#include "bench/harness/team_driver.hpp"
#include "bench/harness/rk4_entries.hpp"
#include "kernels/oscillator.hpp"
#include "layouts/registry.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"
#include "platform/topology.hpp"
#include "sync/registry.hpp"

namespace lockstep::cli {

namespace {

struct run_options {
  std::optional<std::string> syncs;  // not given: the defaults
  std::optional<std::string> layouts;
  std::optional<std::string> pins;
  std::optional<std::string> threads;
  int repetitions = 0;   // 0: the mode's default
  std::string min_time;  // empty: the mode's default
  std::string out;
  bool quick = false;
  bool no_accounting = false;
  bool no_interleave = false;
  bool interleave = false;  // the default now; kept so that older command lines still run
  int pairs = -1;           // -1: the mode's default
  double noise_pct = 100.0 * bench::kDefaultNoise;
  std::vector<std::string> benchmark_flags;
};

// The mode's defaults (harness.hpp, run_settings): how long each entry runs.
constexpr int kDefaultRepetitions = 5;
constexpr int kQuickRepetitions = 3;
constexpr const char* kDefaultMinTime = "40ms";
constexpr const char* kQuickMinTime = "5ms";
// Paired comparisons (paired_blocks.hpp): pairs per comparison and the timed
// block. Blocks of about 1 ms (0.5 ms quick) put both sides of a pair within
// a few milliseconds of each other; the development VM keeps a pace for
// seconds at least, so a pair straddles a change rarely (the trace says when).
constexpr int kDefaultPairs = 10;
constexpr int kQuickPairs = 6;
constexpr std::int64_t kDefaultBlockNs = 1'000'000;
constexpr std::int64_t kQuickBlockNs = 500'000;
// A comparison's time budget (after its first kMinPairs pairs): about 60 ms
// buys the default pairs of two fast sides; 174 comparisons of the default
// matrix then fit in about half a minute.
constexpr std::int64_t kDefaultPairBudgetNs = 150'000'000;
constexpr std::int64_t kQuickPairBudgetNs = 50'000'000;

// The thread counts: the paper's four and this machine's core count by
// default, each a count the model can split (the 2-mass model has four
// equations: one per thread at most).
std::vector<unsigned> select_threads(const std::optional<std::string>& wanted, const platform::topology& machine) {
  constexpr unsigned kEquations = kernels::two_mass_model::kEquations;
  std::vector<unsigned> threads;
  if (!wanted) {
    threads.push_back(kEquations);
    const unsigned cores = std::max(1u, machine.core_count());
    if (cores < kEquations) threads.push_back(cores);
  } else {
    for (long long count : parse_number_list(*wanted, "--threads", 1, 1024)) {
      if (count > kEquations)
        throw usage_error(fmt::format("--threads: the model cannot split over {} threads (the paper's 2-mass model "
                                      "has {} equations, one per thread at most)",
                                      count, kEquations));
      threads.push_back(static_cast<unsigned>(count));
    }
  }
  std::sort(threads.begin(), threads.end());
  return threads;
}

std::vector<std::string> sync_names() {
  std::vector<std::string> names;
  for (const auto& info : sync::all_primitive_info) names.emplace_back(info.name);
  return names;
}

std::vector<std::string> layout_names() {
  std::vector<std::string> names;
  for (const auto& info : layouts::all_layout_info) names.emplace_back(info.name);
  return names;
}

std::vector<std::string> placement_names() {
  std::vector<std::string> names;
  for (const auto& description : platform::placements()) names.emplace_back(description.name);
  return names;
}

// How many registered entries Google Benchmark's own --benchmark_filter keeps
// (for the progress estimate only).
std::size_t count_selected(const std::vector<std::string>& names) {
  std::string filter = benchmark::GetBenchmarkFilter();
  if (filter.empty() || filter == "." || filter == "all") return names.size();
  bool negative = false;
  if (filter.front() == '-') {
    negative = true;
    filter.erase(0, 1);
  }
  try {
    const std::regex pattern(filter);
    return static_cast<std::size_t>(std::count_if(names.begin(), names.end(), [&](const std::string& name) {
      return std::regex_search(name, pattern) != negative;
    }));
  } catch (const std::regex_error&) {
    return names.size();
  }
}

int execute(const run_options& options) {
  // The topology first: it reads the affinity set before anything pins.
  const platform::topology machine = platform::topology::this_machine();

  // The result file first: a destination that cannot be written fails here,
  // in a millisecond, before anything is measured.
  std::optional<bench::atomic_result_file> result_file;
  try {
    result_file.emplace(options.out.empty() ? bench::default_result_path() : options.out);
  } catch (const bench::result_path_error& error) {
    throw usage_error(std::string("--out: ") + error.what());
  }

  bench::run_selection selection;
  selection.syncs = select_names(options.syncs, sync_names(), "--sync");
  std::vector<std::string> default_pins{"none", "compact"};
  const std::vector<std::string> pins =
      options.pins ? select_names(options.pins, placement_names(), "--pin") : default_pins;
  for (const auto& pin : pins) selection.pins.push_back(platform::parse_placement(pin));
  selection.threads = select_threads(options.threads, machine);
  selection.layouts = select_names(options.layouts, layout_names(), "--layout");
  const std::int64_t min_time_ns = parse_duration_ns(
      options.min_time.empty() ? (options.quick ? kQuickMinTime : kDefaultMinTime) : options.min_time, "--min-time",
      1'000'000, 60'000'000'000);
  for (const auto& flag : options.benchmark_flags) {
    if (flag.rfind("--benchmark_out", 0) == 0)
      throw usage_error("the result file is lockstep's: use --out FILE instead of " + flag);
    if (flag.rfind("--benchmark_", 0) != 0 && flag.rfind("--v=", 0) != 0)
      throw usage_error("unknown argument '" + flag +
                        "': Google Benchmark's flags (--benchmark_...) go after --, lockstep's before it");
  }

  // The mode: how long each entry runs (harness.hpp, run_settings).
  bench::harness_state harness;
  bench::run_book book;
  harness.machine = &machine;
  harness.book = &book;
  harness.settings.accounting = !options.no_accounting;
  // The stall bound per step (or episode) sits far above a preemption on a
  // busy machine (tens of ms) and far below the paper's 1000 ms timeout, so a
  // lost wake-up is caught at its first occurrence.
  int repetitions = kDefaultRepetitions;
  harness.settings.stall_unit_ns = 200'000'000;
  harness.settings.call_budget_ns = 5'000'000'000;
  if (options.quick) {
    repetitions = kQuickRepetitions;
    harness.settings.target_batch_ns = 500'000;
    harness.settings.stall_unit_ns = 100'000'000;
    harness.settings.call_budget_ns = 2'000'000'000;
    harness.stalls_before_skipping_sync = 2;
  }
  // The harness-overhead pair gets three times the repetitions (at least the
  // run's): its on / off ratio is read to a percent or two.
  harness.settings.overhead_repetitions = 3 * (options.repetitions > 0 ? options.repetitions : repetitions);
  if (options.repetitions > 0) repetitions = options.repetitions;
  // What one clock reading costs here, taken off every timed sync span
  // (rk4_benchmarks.cpp) and stated in the context.
  book.clock_read_ns = platform::clock_read_cost_ns();
  // The pace trace (pace.hpp): a reading around every call of an entry and
  // every pair of blocks.
  bench::pace_probe pace(machine);
  harness.pace = &pace;

  // Google Benchmark's flags: ours first, the user's after (the last wins).
  std::vector<std::string> arguments{"lockstep run",
                                     "--benchmark_out=" + result_file->temporary_path(),
                                     "--benchmark_out_format=json",
                                     fmt::format("--benchmark_repetitions={}", repetitions),
                                     fmt::format("--benchmark_min_time={}", static_cast<double>(min_time_ns) / 1e9)};
  const bool interleave = !options.no_interleave;
  if (interleave) arguments.emplace_back("--benchmark_enable_random_interleaving=true");
  arguments.insert(arguments.end(), options.benchmark_flags.begin(), options.benchmark_flags.end());
  std::vector<char*> argv;
  for (auto& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  int argc = static_cast<int>(arguments.size());
  benchmark::Initialize(&argc, argv.data());
  if (argc > 1) throw usage_error(fmt::format("Google Benchmark does not know the flag '{}'", argv[1]));

  benchmark::AddCustomContext("lockstep_mode", options.quick ? "quick" : "default");
  benchmark::AddCustomContext("lockstep_accounting", harness.settings.accounting ? "on" : "off");
  {
    // The primitives whose entries omit futex_waits_per_step: their futex calls
    // happen inside a library, out of sight (sync/registry.hpp: counts_futex_waits).
    std::string hidden;
    for (const auto& info : sync::all_primitive_info)
      if (!info.counts_futex_waits) hidden += (hidden.empty() ? "" : ",") + std::string(info.name);
    benchmark::AddCustomContext("futex_waits_unavailable", hidden.empty() ? "none" : hidden);
  }
  benchmark::AddCustomContext("lockstep_order", interleave
                                                    ? "random interleaving (the default): the repetitions of every "
                                                      "entry shuffled over the whole run"
                                                    : "registration order (--no-interleave): every entry's "
                                                      "repetitions back to back");
  benchmark::AddCustomContext("noise_band", fmt::format("{:g}", options.noise_pct / 100.0));
  benchmark::AddCustomContext("clock_read_ns", fmt::format("{:.1f}", book.clock_read_ns));
  benchmark::AddCustomContext(
      "lockstep_timing",
      "manual time per batch of steps (episodes) on a persistent pinned team; team start-up outside the timed "
      "region; medians over repetitions");

  std::vector<std::string> names = bench::register_calibration_benchmarks(harness);
  for (auto& name : bench::register_overhead_pair(selection, harness)) names.push_back(std::move(name));
  for (auto& name : bench::register_barrier_benchmarks(selection, harness)) names.push_back(std::move(name));
  for (auto& name : bench::register_rk4_benchmarks(selection, harness)) names.push_back(std::move(name));

  bench::progress_reporter progress(book, count_selected(names));
  bench::result_json_reporter json;
  fmt::print(stderr, "lockstep run: {} entries, {} repetitions each; JSON to {}\n", count_selected(names),
             repetitions, result_file->destination());
  std::fflush(stderr);
  benchmark::RunSpecifiedBenchmarks(&progress, &json);
  benchmark::Shutdown();
  book.derive_ratios();

  // The paired comparisons, after the matrix: the plan needs its medians.
  bench::pairing_settings pairing;
  pairing.pairs = static_cast<unsigned>(options.pairs >= 0 ? options.pairs : options.quick ? kQuickPairs : kDefaultPairs);
  pairing.block_ns = options.quick ? kQuickBlockNs : kDefaultBlockNs;
  pairing.noise = options.noise_pct / 100.0;
  pairing.budget_ns = options.quick ? kQuickPairBudgetNs : kDefaultPairBudgetNs;
  const std::vector<bench::comparison> plan = bench::plan_comparisons(book);
  if (pairing.pairs > 0 && !plan.empty()) {
    fmt::print(stderr, "lockstep run: {} paired comparisons, {} pairs of blocks of about {} each\n", plan.size(),
               pairing.pairs, bench::format_ns(static_cast<double>(pairing.block_ns)));
    std::fflush(stderr);
  }
  bench::measure_pairs(harness, plan, pairing, [](std::size_t done, std::size_t total) {
    if (done % 25 == 0 || done == total) {
      fmt::print(stderr, "  paired {}/{}\n", done, total);
      std::fflush(stderr);
    }
  });
  pace.take();  // the trace's last reading
  const bench::pace_modes modes = bench::find_modes(pace.trace());
  bench::assign_pace_modes(book, modes);

  // The in-run context keys, then the rename.
  nlohmann::json document;
  {
    std::ifstream written(result_file->temporary_path());
    try {
      document = nlohmann::json::parse(written);
    } catch (const nlohmann::json::exception& error) {
      throw std::runtime_error(std::string("Google Benchmark's result JSON does not parse: ") + error.what());
    }
  }
  if (!document.contains("benchmarks"))
    throw std::runtime_error("Google Benchmark wrote no entries (was --benchmark_list_tests given?)");
  bench::derive_ratios(document, {book.c2c_one_way_ns(), book.serial_step_ns()});
  bench::write_pace_and_pairs(document, book, &pace, modes);
  // The machine's fingerprint from the one producer (replacing Google
  // Benchmark's host_name and num_cpus with the same figures), then the
  // in-run keys.
  bench::merge_into_result(document, bench::machine_context(machine));
  bench::context_map in_run;
  in_run["c2c_one_way_ns"] = book.c2c_one_way_ns() ? fmt::format("{:.1f}", *book.c2c_one_way_ns()) : "unavailable";
  in_run["serial_step_ns"] = book.serial_step_ns() ? fmt::format("{:.2f}", *book.serial_step_ns()) : "unavailable";
  in_run["pace_summary"] = modes.summary();
  in_run["oversubscribed_note"] =
      bench::oversubscribed_note(book, static_cast<unsigned>(machine.affinity().size()));
  std::string not_applicable;
  for (const auto& skipped : book.not_applicable)
    not_applicable += (not_applicable.empty() ? "" : "; ") + skipped.name + ": " + skipped.reason;
  in_run["not_applicable"] = not_applicable.empty() ? "none" : not_applicable;
  std::string stalled;
  for (const auto& entry : book.entries())
    if (!entry.error.empty()) stalled += (stalled.empty() ? "" : "; ") + entry.name + ": " + entry.error;
  in_run["stalled"] = stalled.empty() ? "none" : stalled;
  bench::merge_into_result(document, in_run);
  result_file->write(document.dump(2) + "\n");
  result_file->commit();

  fmt::print("{}", bench::render_summary(book, result_file->destination()));
  std::fflush(stdout);
  fmt::print(stderr, "lockstep run: results written to {}\n", result_file->destination());
  return kExitOk;
}

}  // namespace

void add_run(CLI::App& app, int& result) {
  auto options = std::make_shared<run_options>();
  CLI::App* run = app.add_subcommand(
      "run",
      "Run the benchmark matrix (sync x layout x placement x threads) and write Google Benchmark JSON.\n"
      "Google Benchmark's own flags go after --, e.g. lockstep run --quick -- --benchmark_filter=barrier");
  run->add_option("--sync", options->syncs, "Primitives, a comma list (default: all; `lockstep list` names them)");
  run->add_option("--layout", options->layouts, "Layouts, a comma list (default: all)");
  run->add_option("--pin", options->pins, "Placements, a comma list (default: none,compact)");
  run->add_option("--threads", options->threads,
                  "Thread counts, a comma list, each at most the model's 4 equations (default: 4, and this machine's core count when fewer)");
  run->add_option("--repetitions", options->repetitions,
                  fmt::format("Repetitions per entry (default {}; --quick {})", kDefaultRepetitions, kQuickRepetitions))
      ->check(CLI::Range(1, 1000));
  run->add_option("--min-time", options->min_time,
                  fmt::format("Minimum measured time per repetition, with a unit (default {}; --quick {})",
                              kDefaultMinTime, kQuickMinTime));
  add_out_option(*run, options->out, "the result JSON (default results/<host>-<timestamp>.json)");
  run->add_flag("--quick", options->quick, "Shorter runs: the whole matrix in well under 30 s on 2 cores");
  run->add_flag("--no-interleave", options->no_interleave,
                "Run every entry's repetitions back to back. The default shuffles the repetitions of all entries "
                "over the whole run (Google Benchmark's random interleaving), so that a machine that changes pace "
                "widens every entry's spread instead of shifting the entries that ran at the wrong moment");
  run->add_flag("--interleave", options->interleave, "The default (kept for older command lines)");
  run->add_option("--pairs", options->pairs,
                  fmt::format("Pairs of alternating blocks per paired comparison (the summary's ratios with "
                              "their intervals; default {}, --quick {}; 0: none)",
                              kDefaultPairs, kQuickPairs))
      ->check(CLI::Range(0, 1000));
  run->add_option("--noise", options->noise_pct,
                  "The noise band in percent: a paired ratio whose interval reaches within it of 1 is "
                  "\"within noise\" (default 5)")
      ->check(CLI::Range(0.0, 100.0));
  run->add_flag("--no-accounting", options->no_accounting,
                "Per-thread accounting and sync-time instrumentation off (their counters are omitted)");
  run->add_option("benchmark_flags", options->benchmark_flags, "Google Benchmark's flags, after --");
  run->callback([options, &result] { result = execute(*options); });
}

}  // namespace lockstep::cli
