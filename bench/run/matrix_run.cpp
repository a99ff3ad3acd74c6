// `lockstep run` as one call (matrix_run.hpp).
#include "bench/run/matrix_run.hpp"

#include <benchmark/benchmark.h>
#include <fmt/core.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "bench/run/barrier_entries.hpp"
#include "bench/run/crossover_sweep.hpp"
#include "bench/run/derived_sections.hpp"
#include "bench/results/derived_figures.hpp"
#include "bench/run/answer.hpp"
#include "bench/run/known_answers.hpp"
#include "bench/results/machine_context.hpp"
#include "bench/run/pace.hpp"
#include "bench/run/paired_blocks.hpp"
#include "bench/run/reporters.hpp"
#include "bench/run/rk4_entries.hpp"
#include "bench/run/scaling.hpp"
#include "bench/run/summary.hpp"
#include "bench/run/team_driver.hpp"
#include "kernels/model_choice.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"
#include "sync/registry.hpp"

namespace lockstep::bench {

namespace {

// --plan: what the run would measure and how long it would take, from the
// entries registered exactly as a run registers them; nothing is measured or
// written.
// How many paired comparisons the plan expects of these entries: any figure
// will do, plan_comparisons reads which entries exist (a run plans fewer:
// collapsed entries and unpinned entries that did not migrate drop out).
std::size_t planned_comparisons(const std::vector<entry_spec>& entries) {
  run_book planned;
  for (const entry_spec& spec : entries) {
    captured_entry entry;
    entry.spec = spec;
    entry.name = spec.name();
    entry.repetitions.push_back({{"ns_per_step", 1.0}, {"ns_per_episode", 1.0}, {"migrations_per_kstep", 1.0}});
    planned.record(std::move(entry));
  }
  return plan_comparisons(planned).size();
}

// "the paper's two-mass system at threads 2,4; a chain of 4 masses (8
// equations) at threads 8": each model the registered parallel steps
// integrate, with their thread counts.
std::string models_of(const std::vector<entry_spec>& entries) {
  std::vector<std::pair<kernels::model_choice, std::set<unsigned>>> models;
  for (const entry_spec& spec : entries) {
    if (!spec.is_parallel_step()) continue;
    auto found = std::find_if(models.begin(), models.end(), [&](const auto& model) { return model.first == spec.model; });
    if (found == models.end()) found = models.insert(models.end(), {spec.model, {}});
    found->second.insert(spec.threads);
  }
  std::string text;
  for (const auto& [model, threads] : models)
    text += fmt::format("{}{} at threads {}", text.empty() ? "" : "; ", model.description(), fmt::join(threads, ","));
  return text;
}

std::string plan_of(const platform::topology& machine, const matrix_request& request,
                    const std::vector<entry_spec>& entries, const run_book& book, const run_cost& cost) {
  const run_selection& selection = request.selection;
  std::map<std::string_view, std::size_t> by_kind;
  for (const entry_spec& spec : entries) ++by_kind[to_string(spec.kind)];
  const std::size_t comparisons = planned_comparisons(entries);
  const run_estimate estimate = estimate_run(entries.size(), comparisons, cost);
  const std::string models = models_of(entries);
  std::string kinds;
  for (const auto& [kind, count] : by_kind) kinds += fmt::format("{}{} {}", kinds.empty() ? "" : ", ", count, kind);
  std::string thread_list;
  for (const unsigned threads : selection.threads)
    thread_list += (thread_list.empty() ? "" : ", ") + std::to_string(threads);
  std::string listed;
  for (const entry_spec& spec : entries) listed += "  " + spec.name() + "\n";
  if (!book.not_applicable.empty()) listed += "not applicable:\n";
  for (const auto& skipped : book.not_applicable) listed += "  " + skipped.name + ": " + skipped.reason + "\n";
  std::string crossover;
  if (request.crossover) {
    std::size_t counts = 0;
    for (const unsigned threads : selection.threads) counts += threads > 1 ? 1 : 0;
    const std::size_t series = 3 * counts;
    crossover = fmt::format(
        "crossover sweep (--crossover): up to {} series (per thread count above 1, the run's choice, a rival "
        "tied with it, and std_barrier at pin:compact, and beside them the machine's ceiling: the chain's blocks "
        "stepped at once with no sync), S = {} to {} masses doubling, {} pairs of {} blocks a point, up to {} more "
        "batches where its "
        "interval is wider than {:.0f} % of its median; estimated {} (every series to the largest size, one batch "
        "a point; a series stops once two points clear 1), budget {}\n",
        series, kCrossoverFirstMasses, request.crossover->max_masses, request.crossover->pairs,
        format_ns(static_cast<double>(request.crossover->block_ns)), kCrossoverMoreBatches,
        kCrossoverWideShare * 100.0, format_seconds(estimate_crossover_s(series, counts, *request.crossover)),
        format_seconds(static_cast<double>(request.crossover->budget_ns) / 1e9));
  }
  return fmt::format("lockstep run --plan (nothing measured)\n"
             "machine: {} ({}, {} CPUs in the affinity set)\n"
             "threads: {}\n"
             "models: {}\n"
             "entries: {} ({}), {} repetitions each; not applicable: {}\n"
             "paired comparisons: {}, {} pairs each\n"
             "estimated time: {} (matrix {}, pairs {}; calibrated on a 2-vCPU VM, an estimate)\n"
             "{}"
             "entries to measure:\n{}",
             machine.source(), machine.summary(), machine.affinity().size(), thread_list, models, entries.size(),
             kinds, cost.repetitions, book.not_applicable.size(), comparisons, cost.pairs,
             format_seconds(estimate.total_s()), format_seconds(estimate.matrix_s),
             format_seconds(estimate.pairs_s), crossover, listed);
}

// How many registered entries Google Benchmark's own --benchmark_filter keeps
// (for the progress estimate only).
std::size_t count_selected(const std::vector<entry_spec>& entries) {
  std::string filter = benchmark::GetBenchmarkFilter();
  if (filter.empty() || filter == "." || filter == "all") return entries.size();
  bool negative = false;
  if (filter.front() == '-') {
    negative = true;
    filter.erase(0, 1);
  }
  try {
    const std::regex pattern(filter);
    return static_cast<std::size_t>(std::count_if(entries.begin(), entries.end(), [&](const entry_spec& spec) {
      return std::regex_search(spec.name(), pattern) != negative;
    }));
  } catch (const std::regex_error&) {
    return entries.size();
  }
}


// Google Benchmark's flags that lockstep cannot pass on: refused before
// anything is registered or measured.
void check_benchmark_flags(const std::vector<std::string>& flags) {
  for (const auto& flag : flags) {
    if (flag.rfind("--benchmark_out", 0) == 0)
      throw matrix_request_error("the result file is lockstep's: use --out FILE instead of " + flag);
    if (flag.rfind("--benchmark_", 0) != 0 && flag.rfind("--v=", 0) != 0)
      throw matrix_request_error("unknown argument '" + flag +
                                 "': Google Benchmark's flags (--benchmark_...) go after --, lockstep's before it");
  }
}

// One run's preparation, shared by the plan and the run, so that the plan
// counts exactly the entries a run registers: the mode's settings, Google
// Benchmark initialised with lockstep's flags and context, every entry
// registered. The harness points into the book and the pace probe, so the
// whole is built in place and never moved.
struct prepared_matrix {
  explicit prepared_matrix(const platform::topology& machine) : pace(machine) {
    harness.machine = &machine;
    harness.book = &book;
    harness.pace = &pace;
  }
  prepared_matrix(const prepared_matrix&) = delete;
  prepared_matrix& operator=(const prepared_matrix&) = delete;

  run_book book;
  pace_probe pace;  // a reading around every call of an entry and every pair of blocks (pace.hpp)
  harness_state harness;
  int repetitions = kDefaultRepetitions;
  pairing_settings pairing;
  run_cost cost;
  std::vector<entry_spec> entries;  // as registered, in registration order
  registered_entries registered;    // the same by name, for the reporters
  std::vector<std::string> benchmark_arguments;  // what Google Benchmark was initialised with
  result_json_reporter json;                     // Google Benchmark's JSON, written when the run is over
};

// The mode: how long each entry runs (run_book.hpp, run_settings), how many
// repetitions, and the paired comparisons' settings.
void apply_mode(const matrix_request& request, prepared_matrix& run) {
  run_settings& settings = run.harness.settings;
  settings.accounting = request.accounting;
  run.book.scaling = request.scaling;
  // The stall bound per step (or episode) sits far above a preemption on a
  // busy machine (tens of ms) and far below the paper's 1000 ms timeout, so a
  // lost wake-up is caught at its first occurrence.
  run.repetitions = kDefaultRepetitions;
  settings.stall_unit_ns = 200'000'000;
  settings.call_budget_ns = 5'000'000'000;
  if (request.quick) {
    run.repetitions = kQuickRepetitions;
    settings.target_batch_ns = 500'000;
    settings.stall_unit_ns = 100'000'000;
    settings.call_budget_ns = 2'000'000'000;
    run.harness.stalls_before_skipping_sync = 2;
  }
  // --min-time in batches of the target size (run_book.hpp: timed_batches).
  const std::int64_t target = settings.target_batch_ns;
  settings.timed_batches =
      static_cast<unsigned>(std::clamp<std::int64_t>((request.min_time_ns + target - 1) / target, 1, 1'000'000));
  // The harness-overhead pair gets three times the repetitions (at least the
  // run's): its on / off ratio is read to a percent or two.
  settings.overhead_repetitions = 3 * (request.repetitions > 0 ? request.repetitions : run.repetitions);
  if (request.repetitions > 0) run.repetitions = request.repetitions;

  // The paired comparisons' settings (measured after the matrix).
  run.pairing.pairs =
      static_cast<unsigned>(request.pairs >= 0 ? request.pairs : request.quick ? kQuickPairs : kDefaultPairs);
  run.pairing.block_ns = request.quick ? kQuickBlockNs : kDefaultBlockNs;
  run.pairing.noise = request.noise;
  run.pairing.budget_ns = request.quick ? kQuickPairBudgetNs : kDefaultPairBudgetNs;
  run.cost = {run.repetitions, request.min_time_ns, run.pairing.pairs, run.pairing.block_ns, run.pairing.budget_ns};
}

// Google Benchmark's flags: ours first, the user's after (the last wins).
// Google Benchmark keeps pointers into them (its context's executable is
// argv[0]): `arguments` must outlive the run. --benchmark_out only because
// Google Benchmark takes a file reporter on no other terms: the reporter
// keeps its text (reporters.hpp), and /dev/null gets nothing.
void initialize_benchmark(const matrix_request& request, int repetitions, std::vector<std::string>& arguments) {
  arguments = {"lockstep run", "--benchmark_out=/dev/null", "--benchmark_out_format=json",
               fmt::format("--benchmark_repetitions={}", repetitions)};
  if (request.interleave) arguments.emplace_back("--benchmark_enable_random_interleaving=true");
  arguments.insert(arguments.end(), request.benchmark_flags.begin(), request.benchmark_flags.end());
  std::vector<char*> argv;
  for (auto& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  int argc = static_cast<int>(arguments.size());
  benchmark::Initialize(&argc, argv.data());
  if (argc > 1) throw matrix_request_error(fmt::format("Google Benchmark does not know the flag '{}'", argv[1]));
}

// The context keys known before anything is measured.
void add_run_context(const matrix_request& request, const prepared_matrix& run) {
  benchmark::AddCustomContext("lockstep_mode", request.quick ? "quick" : "default");
  benchmark::AddCustomContext("lockstep_accounting", run.harness.settings.accounting ? "on" : "off");
  benchmark::AddCustomContext("lockstep_scaling", request.scaling ? "on" : "off");
  // The primitives whose entries omit futex_waits_per_step: their futex calls
  // happen inside a library, out of sight (sync/registry.hpp: counts_futex_waits).
  std::string hidden;
  for (const auto& info : sync::all_primitive_info)
    if (!info.counts_futex_waits) hidden += fmt::format("{}{}", hidden.empty() ? "" : ",", info.name);
  benchmark::AddCustomContext("futex_waits_unavailable", hidden.empty() ? "none" : hidden);
  benchmark::AddCustomContext("lockstep_order", request.interleave
                                                    ? "random interleaving (the default): the repetitions of every "
                                                      "entry shuffled over the whole run"
                                                    : "registration order (--no-interleave): every entry's "
                                                      "repetitions back to back");
  benchmark::AddCustomContext("noise_band", fmt::format("{:g}", request.noise));
  benchmark::AddCustomContext("clock_read_ns", fmt::format("{:.1f}", run.book.clock_read_ns));
  benchmark::AddCustomContext(
      "lockstep_timing",
      "manual time per step (episode): one iteration is a batch of steps (episodes) on a persistent pinned "
      "team, timed as a whole and reported divided by its steps (steps_per_batch), so real_time is ns_per_step "
      "(ns_per_episode) and cpu_time is participant 0's thread CPU time per step (episode); team start-up "
      "outside the timed region; medians over repetitions");
}

std::unique_ptr<prepared_matrix> prepare_matrix(const matrix_request& request, const platform::topology& machine) {
  check_benchmark_flags(request.benchmark_flags);
  auto run = std::make_unique<prepared_matrix>(machine);
  apply_mode(request, *run);
  // What one clock reading costs here, taken off every timed sync span
  // (bench/run/rk4_entries.cpp) and stated in the context.
  run->book.clock_read_ns = platform::clock_read_cost_ns();
  initialize_benchmark(request, run->repetitions, run->benchmark_arguments);
  add_run_context(request, *run);
  for (auto* register_entries : {&register_calibration_benchmarks, &register_overhead_pair,
                                 &register_barrier_benchmarks, &register_rk4_benchmarks})
    for (entry_spec& spec : (*register_entries)(request.selection, run->harness)) {
      run->registered.emplace(spec.name(), spec);
      run->entries.push_back(std::move(spec));
    }
  return run;
}

// The matrix under Google Benchmark, its progress on stderr; then the
// ratios derived from the whole run's calibrations and the collapsed entries.
void measure_entries(prepared_matrix& run, const std::string& destination) {
  const std::size_t selected = count_selected(run.entries);
  // The estimate comes from the plan (run_plan.hpp), the same one --plan prints.
  const run_estimate planned = estimate_run(selected, planned_comparisons(run.entries), run.cost);
  progress_reporter progress(run.book, run.registered, selected, planned.matrix_s);
  run.harness.after_call = [&progress] { progress.tick(); };
  fmt::print(stderr,
             "lockstep run: {} entries, {} repetitions each, then the paired comparisons: about {} in all (the plan's "
             "estimate: {} and {}); JSON to {}\n",
             selected, run.repetitions, format_seconds(planned.total_s()), format_seconds(planned.matrix_s),
             format_seconds(planned.pairs_s), destination);
  std::fflush(stderr);
  benchmark::RunSpecifiedBenchmarks(&progress, &run.json);
  benchmark::Shutdown();
  run.harness.after_call = nullptr;
  run.book.derive_ratios();
  run.book.collapsed = find_collapsed(run.book);
}

// The paired comparisons, after the matrix: the plan needs its medians.
void measure_comparisons(prepared_matrix& run) {
  run.book.planned = plan_comparisons(run.book);
  const std::vector<comparison>& plan = run.book.planned;
  const double planned_pairs_s = estimate_run(0, plan.size(), run.cost).pairs_s;
  if (run.pairing.pairs > 0 && !plan.empty()) {
    fmt::print(stderr, "lockstep run: {} paired comparisons, {} rounds of a pair of blocks of about {} each, about {}\n",
               plan.size(), run.pairing.pairs, format_ns(static_cast<double>(run.pairing.block_ns)),
               format_seconds(planned_pairs_s));
    std::fflush(stderr);
  }
  const std::int64_t pairs_start_ns = platform::now_ns();
  measure_pairs(run.harness, plan, run.pairing, [&](std::size_t round, std::size_t rounds) {
    const double elapsed = static_cast<double>(platform::now_ns() - pairs_start_ns) / 1e9;
    fmt::print(stderr, "  paired round {}/{}, {} elapsed, {}\n", round, rounds, format_seconds(elapsed),
               time_left(elapsed, planned_pairs_s, round, rounds));
    std::fflush(stderr);
  });
}

// --crossover: the series from the run's choices (the answer's, made once,
// before the sweep), then the sweep (crossover_sweep.hpp).
crossover_sweep measure_crossovers(prepared_matrix& run, const crossover_settings& settings,
                                   const std::vector<answer_choice>& choices) {
  std::vector<crossover_series> series = plan_crossover_series(run.book, choices);
  fmt::print(stderr,
             "lockstep run: crossover sweep, {} series, S = {} to {} masses doubling, {} pairs a point (up to {} "
             "more batches where its interval is wide), at most {}\n",
             series.size(), kCrossoverFirstMasses, settings.max_masses, settings.pairs, kCrossoverMoreBatches,
             format_seconds(static_cast<double>(settings.budget_ns) / 1e9));
  std::fflush(stderr);
  return sweep_crossovers(run.harness, std::move(series), settings, [](std::size_t masses, double elapsed) {
    fmt::print(stderr, "  crossover: {} masses done, {} elapsed\n", masses, format_seconds(elapsed));
    std::fflush(stderr);
  });
}

// The context keys only the finished run knows.
context_map in_run_context(const run_book& book, const pace_modes& modes, unsigned cpus) {
  context_map in_run;
  in_run["c2c_one_way_ns"] = book.c2c_one_way_ns() ? fmt::format("{:.1f}", *book.c2c_one_way_ns()) : "unavailable";
  in_run["serial_step_ns"] = book.serial_step_ns() ? fmt::format("{:.2f}", *book.serial_step_ns()) : "unavailable";
  in_run["pace_summary"] = modes.summary();
  in_run["oversubscribed_note"] = oversubscribed_note(book, cpus);
  std::string not_applicable;
  for (const auto& skipped : book.not_applicable)
    not_applicable += (not_applicable.empty() ? "" : "; ") + skipped.name + ": " + skipped.reason;
  in_run["not_applicable"] = not_applicable.empty() ? "none" : not_applicable;
  std::string stalled;
  for (const auto& entry : book.entries())
    if (!entry.error.empty()) stalled += (stalled.empty() ? "" : "; ") + entry.name + ": " + entry.error;
  in_run["stalled"] = stalled.empty() ? "none" : stalled;
  return in_run;
}

// The result file, assembled once: Google Benchmark's context and entries
// as lockstep completed them (reporters.hpp: result_json_reporter), the pace
// trace and pairs, the derived sections, the answer, the scaling curve and
// the machine's context; then the rename.
// Seconds a run spent: measuring the matrix's repetitions, and in all.
struct run_seconds {
  double matrix = 0.0;
  double wall = 0.0;
};

void write_result(const matrix_request& request, const platform::topology& machine, prepared_matrix& run,
                  const run_result& result, atomic_result_file& result_file, run_seconds seconds) {
  const pace_modes& modes = *result.pace;
  nlohmann::json document = run.json.run_document(run.book, run.registered, modes);
  if (!document.contains("benchmarks"))
    throw std::runtime_error("Google Benchmark wrote no entries (was --benchmark_list_tests given?)");
  write_pace_and_pairs(document, run.book, &run.pace, modes);
  write_derived_sections(document, run.book);
  document["lockstep_answer"] = answer_json(result.answer);
  if (result.crossover) document["lockstep_crossover"] = crossover_json(*result.crossover);
  if (request.scaling) document["lockstep_scaling"] = scaling_json(scaling_of(run.book), run.book.c2c_one_way_ns());
  // The machine's fingerprint from the one producer (replacing Google
  // Benchmark's host_name and num_cpus with the same figures), then the
  // in-run keys.
  merge_into_result(document, machine_context(machine));
  merge_into_result(document, in_run_context(run.book, modes, run.book.cpus));
  // A run of a group (lockstep run --runs K): its index and the group's
  // size, numbers, which lockstep compare reads to take the group's files as
  // replicates in order.
  if (request.runs > 0) {
    document["context"]["lockstep_run_index"] = request.run_index;
    document["context"]["lockstep_runs"] = request.runs;
  }
  document["context"]["lockstep_matrix_s"] = fmt::format("{:.3f}", seconds.matrix);
  document["context"]["lockstep_wall_s"] = fmt::format("{:.3f}", seconds.wall);
  result_file.write(document.dump(2) + "\n");
  result_file.commit();
}

}  // namespace

std::string plan_text(const matrix_request& request, const platform::topology& machine) {
  const std::unique_ptr<prepared_matrix> run = prepare_matrix(request, machine);
  return plan_of(machine, request, run->entries, run->book, run->cost);
}

run_result run_matrix(const matrix_request& request, const platform::topology& machine,
                      atomic_result_file& result_file) {
  // The run's costs, stated in the context for lockstep compare --plan: the
  // matrix's repetitions (lockstep_matrix_s) and the whole run from here
  // (lockstep_wall_s), whose difference is a run's fixed part.
  const auto started = std::chrono::steady_clock::now();
  const std::unique_ptr<prepared_matrix> run = prepare_matrix(request, machine);
  const auto matrix_started = std::chrono::steady_clock::now();
  measure_entries(*run, result_file.destination());
  const std::chrono::duration<double> matrix = std::chrono::steady_clock::now() - matrix_started;
  measure_comparisons(*run);
  const known_answers probes = measure_known_answers(machine, request.quick);
  // The trace's last reading, then its modes: the matrix's pace (the
  // crossover sweep takes no readings: crossover_sweep.cpp).
  run->pace.take();
  run_result result;
  result.pace = find_modes(run->pace.trace());
  assign_pace_modes(run->book, *result.pace);
  run->book.cpus = static_cast<unsigned>(machine.affinity().size());
  // The choices, once: the crossover sweeps from them, the answer states them.
  std::vector<answer_choice> choices = choose_combinations(run->book);
  if (request.crossover) result.crossover = measure_crossovers(*run, *request.crossover, choices);
  result.answer = make_answer(run->book, std::move(choices),
                              {probes, run->book.cpus, result_file.destination(), &*result.pace,
                               result.crossover ? &*result.crossover : nullptr});
  const std::chrono::duration<double> wall = std::chrono::steady_clock::now() - started;
  write_result(request, machine, *run, result, result_file, {matrix.count(), wall.count()});
  result.book = std::move(run->book);
  return result;
}

}  // namespace lockstep::bench
