// lockstep run: the benchmark matrix (README.md, Commands; its entries and
// counters: docs/names-and-counters.md).
//
// Registers the entries the filters select (bench/harness/run_book.hpp
// explains the timing), runs them with Google Benchmark, writes its JSON
// atomically, and prints the
// summary on stdout. Progress goes to stderr.
#include <benchmark/benchmark.h>
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <map>
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
#include "bench/harness/run_plan.hpp"
#include "bench/harness/scaling.hpp"
#include "kernels/model_choice.hpp"
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
  std::optional<std::size_t> masses;  // --masses: not given, each thread count's own model
  bool plan = false;                  // --plan: print what would run, measure nothing
  bool scaling = false;               // --scaling: the thread sweep, one placement
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

// The mode's defaults (bench/harness/run_book.hpp, run_settings): how long each entry runs.
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

// The thread counts (run_plan.hpp says which by default and for --scaling),
// each a count its model can split (kernels/model_choice.hpp: only a chain
// chosen with --masses can have fewer equations than threads).
std::vector<unsigned> select_threads(const run_options& options, const platform::topology& machine) {
  std::vector<unsigned> threads;
  if (options.threads) {
    for (long long count : parse_number_list(*options.threads, "--threads", 1, 1024))
      threads.push_back(static_cast<unsigned>(count));
  } else if (options.scaling) {
    threads = bench::scaling_thread_counts(static_cast<unsigned>(machine.affinity().size()));
  } else {
    threads = bench::default_thread_counts(machine.core_count());
  }
  for (const unsigned count : threads) {
    const kernels::model_choice model = kernels::model_for(count, options.masses);
    if (count > model.equations())
      throw usage_error(fmt::format("--threads: {} threads cannot split {}: at most {} threads, one equation each",
                                    count, model.description(), model.equations()));
  }
  std::sort(threads.begin(), threads.end());
  threads.erase(std::unique(threads.begin(), threads.end()), threads.end());
  return threads;
}

// The machine a run measures, or, for --plan, the one it plans for: hwloc's
// HWLOC_SYNTHETIC or HWLOC_XMLFILE describe another machine, whose every PU
// counts as the affinity set (this process's own set belongs to this machine).
platform::topology machine_for(bool plan) {
  if (plan) {
    if (const char* synthetic = std::getenv("HWLOC_SYNTHETIC"); synthetic != nullptr && *synthetic != '\0')
      return platform::topology::from_synthetic(synthetic);
    if (const char* xml = std::getenv("HWLOC_XMLFILE"); xml != nullptr && *xml != '\0')
      return platform::topology::from_xml_file(xml);
  }
  platform::topology machine = platform::topology::this_machine();
  if (!plan && !machine.is_this_system())
    throw usage_error("HWLOC_SYNTHETIC or HWLOC_XMLFILE is set, so hwloc describes another machine: only --plan "
                      "can use it (unset it to measure this one)");
  return machine;
}

// --plan: what the run would measure and how long it would take, from the
// entries registered exactly as a run registers them; nothing is measured or
// written.
int print_plan(const platform::topology& machine, const bench::run_selection& selection,
               const std::vector<std::string>& names, const bench::run_book& book, const bench::run_cost& cost) {
  std::map<std::string, std::size_t> by_kind;
  bench::run_book planned;
  for (const auto& name : names) {
    bench::captured_entry entry;
    entry.name = name;
    entry.fields = bench::parse_entry_name(name);
    ++by_kind[entry.fields["kind"]];
    // Any figure will do: the plan of comparisons reads which entries exist.
    entry.repetitions.push_back({{"ns_per_step", 1.0}, {"ns_per_episode", 1.0}});
    planned.record(std::move(entry));
  }
  const std::size_t comparisons = bench::plan_comparisons(planned).size();
  const bench::run_estimate estimate = bench::estimate_run(names.size(), comparisons, cost);
  std::string models;
  std::vector<std::size_t> seen;
  for (const unsigned threads : selection.threads) {
    const kernels::model_choice model = kernels::model_for(threads, selection.masses);
    if (std::find(seen.begin(), seen.end(), model.masses) != seen.end()) continue;
    seen.push_back(model.masses);
    std::string at;
    for (const unsigned other : selection.threads)
      if (kernels::model_for(other, selection.masses) == model) at += (at.empty() ? "" : ",") + std::to_string(other);
    models += fmt::format("{}{} at threads {}", models.empty() ? "" : "; ", model.description(), at);
  }
  std::string kinds;
  for (const auto& [kind, count] : by_kind) kinds += fmt::format("{}{} {}", kinds.empty() ? "" : ", ", count, kind);
  std::string thread_list;
  for (const unsigned threads : selection.threads)
    thread_list += (thread_list.empty() ? "" : ", ") + std::to_string(threads);
  std::string entries;
  for (const auto& name : names) entries += "  " + name + "\n";
  if (!book.not_applicable.empty()) entries += "not applicable:\n";
  for (const auto& skipped : book.not_applicable) entries += "  " + skipped.name + ": " + skipped.reason + "\n";
  fmt::print("lockstep run --plan (nothing measured)\n"
             "machine: {} ({}, {} CPUs in the affinity set)\n"
             "threads: {}\n"
             "models: {}\n"
             "entries: {} ({}), {} repetitions each; not applicable: {}\n"
             "paired comparisons: {}, {} pairs each\n"
             "estimated time: {} (matrix {}, pairs {}; calibrated on a 2-vCPU VM, an estimate)\n"
             "entries to measure:\n{}",
             machine.source(), machine.summary(), machine.affinity().size(), thread_list, models, names.size(), kinds,
             cost.repetitions, book.not_applicable.size(), comparisons, cost.pairs,
             bench::format_seconds(estimate.total_s()), bench::format_seconds(estimate.matrix_s),
             bench::format_seconds(estimate.pairs_s), entries);
  return kExitOk;
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
  platform::topology machine = [&] {
    try {
      return machine_for(options.plan);
    } catch (const platform::topology_error& error) {
      throw usage_error(std::string("--plan: ") + error.what());
    }
  }();

  // The result file first: a destination that cannot be written fails here,
  // in a millisecond, before anything is measured. A plan writes nothing.
  std::optional<bench::atomic_result_file> result_file;
  if (!options.plan) {
    try {
      result_file.emplace(options.out.empty() ? bench::default_result_path() : options.out);
    } catch (const bench::result_path_error& error) {
      throw usage_error(std::string("--out: ") + error.what());
    }
  }

  bench::run_selection selection;
  selection.syncs = select_names(options.syncs, sync_names(), "--sync");
  // The scaling sweep holds the placement still (compact unless --pin says).
  std::vector<std::string> default_pins =
      options.scaling ? std::vector<std::string>{"compact"} : std::vector<std::string>{"none", "compact"};
  const std::vector<std::string> pins =
      options.pins ? select_names(options.pins, placement_names(), "--pin") : default_pins;
  for (const auto& pin : pins) selection.pins.push_back(platform::parse_placement(pin));
  selection.masses = options.masses;
  selection.threads = select_threads(options, machine);
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

  // The mode: how long each entry runs (bench/harness/run_book.hpp, run_settings).
  bench::harness_state harness;
  bench::run_book book;
  harness.machine = &machine;
  harness.book = &book;
  harness.settings.accounting = !options.no_accounting;
  book.scaling = options.scaling;
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
  // (bench/harness/rk4_entries.cpp) and stated in the context.
  book.clock_read_ns = platform::clock_read_cost_ns();
  // The pace trace (pace.hpp): a reading around every call of an entry and
  // every pair of blocks.
  bench::pace_probe pace(machine);
  harness.pace = &pace;

  // Google Benchmark's flags: ours first, the user's after (the last wins).
  std::vector<std::string> arguments{"lockstep run",
                                     "--benchmark_out=" + (result_file ? result_file->temporary_path() : "/dev/null"),
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
  benchmark::AddCustomContext("lockstep_scaling", options.scaling ? "on" : "off");
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
      "manual time per step (episode): one iteration is a batch of steps (episodes) on a persistent pinned "
      "team, timed as a whole and reported divided by its steps (steps_per_batch), so real_time is ns_per_step "
      "(ns_per_episode) and cpu_time is participant 0's thread CPU time per step (episode); team start-up "
      "outside the timed region; medians over repetitions");

  std::vector<std::string> names = bench::register_calibration_benchmarks(selection, harness);
  for (auto& name : bench::register_overhead_pair(selection, harness)) names.push_back(std::move(name));
  for (auto& name : bench::register_barrier_benchmarks(selection, harness)) names.push_back(std::move(name));
  for (auto& name : bench::register_rk4_benchmarks(selection, harness)) names.push_back(std::move(name));

  // The paired comparisons' settings (measured after the matrix).
  bench::pairing_settings pairing;
  pairing.pairs = static_cast<unsigned>(options.pairs >= 0 ? options.pairs : options.quick ? kQuickPairs : kDefaultPairs);
  pairing.block_ns = options.quick ? kQuickBlockNs : kDefaultBlockNs;
  pairing.noise = options.noise_pct / 100.0;
  pairing.budget_ns = options.quick ? kQuickPairBudgetNs : kDefaultPairBudgetNs;
  if (options.plan) {
    const bench::run_cost cost{repetitions, min_time_ns, pairing.pairs, pairing.block_ns, pairing.budget_ns};
    return print_plan(machine, selection, names, book, cost);
  }

  bench::progress_reporter progress(book, count_selected(names));
  bench::result_json_reporter json;
  fmt::print(stderr, "lockstep run: {} entries, {} repetitions each; JSON to {}\n", count_selected(names),
             repetitions, result_file->destination());
  std::fflush(stderr);
  benchmark::RunSpecifiedBenchmarks(&progress, &json);
  benchmark::Shutdown();
  book.derive_ratios();

  // The paired comparisons, after the matrix: the plan needs its medians.
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
  bench::derive_ratios(document, book);
  bench::write_pace_and_pairs(document, book, &pace, modes);
  if (options.scaling) document["lockstep_scaling"] = bench::scaling_json(bench::scaling_of(book), book.c2c_one_way_ns());
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
                  "Thread counts, a comma list (default: the paper's 4, this machine's core count, and up to three "
                  "counts between; beyond 4 threads the model is a chain of one equation per thread)");
  add_masses_option(*run, options->masses);
  auto* plan = run->add_flag("--plan", options->plan,
                             "Print the entries the run would measure and its estimated time, measure nothing; "
                             "HWLOC_SYNTHETIC or HWLOC_XMLFILE plan for another machine");
  run->add_flag("--scaling", options->scaling,
                "The scaling sweep: threads 2, 4, 8, ... up to the CPUs (at least 8), pin:compact unless --pin, "
                "every layout; the summary draws sync time per stage against threads, per primitive on its best layout");
  run->add_option("--repetitions", options->repetitions,
                  fmt::format("Repetitions per entry (default {}; --quick {})", kDefaultRepetitions, kQuickRepetitions))
      ->check(CLI::Range(1, 1000));
  run->add_option("--min-time", options->min_time,
                  fmt::format("Minimum measured time per repetition, with a unit (default {}; --quick {})",
                              kDefaultMinTime, kQuickMinTime));
  add_out_option(*run, options->out, "the result JSON (default results/<host>-<timestamp>.json)")->excludes(plan);
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
                  "The noise band in percent: a paired ratio whose interval lies inside it is \"within noise\", "
                  "one whose interval straddles its edge \"unsure\" (default 5)")
      ->check(CLI::Range(0.0, 100.0));
  run->add_flag("--no-accounting", options->no_accounting,
                "Per-thread accounting and sync-time instrumentation off (their counters are omitted)");
  run->add_option("benchmark_flags", options->benchmark_flags, "Google Benchmark's flags, after --");
  run->callback([options, &result] { result = execute(*options); });
}

}  // namespace lockstep::cli
