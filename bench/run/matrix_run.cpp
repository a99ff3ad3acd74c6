// `lockstep run` as one call (matrix_run.hpp).
#include "bench/run/matrix_run.hpp"

#include <benchmark/benchmark.h>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <regex>
#include <string>
#include <utility>
#include <vector>

#include "bench/run/barrier_entries.hpp"
#include "bench/results/derived_figures.hpp"
#include "bench/probe_reports/falseshare_report.hpp"
#include "bench/run/headline.hpp"
#include "bench/results/machine_context.hpp"
#include "bench/probe_reports/migrate_report.hpp"
#include "bench/run/pace.hpp"
#include "bench/run/paired_blocks.hpp"
#include "bench/run/reporters.hpp"
#include "bench/run/rk4_entries.hpp"
#include "bench/run/scaling.hpp"
#include "bench/run/summary.hpp"
#include "bench/run/team_driver.hpp"
#include "bench/probes/falseshare.hpp"
#include "bench/probes/migrate.hpp"
#include "kernels/model_choice.hpp"
#include "platform/cache_line.hpp"
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
std::size_t planned_comparisons(const std::vector<std::string>& names) {
  run_book planned;
  for (const auto& name : names) {
    captured_entry entry;
    entry.name = name;
    entry.fields = parse_entry_name(name);
    entry.repetitions.push_back({{"ns_per_step", 1.0}, {"ns_per_episode", 1.0}, {"migrations_per_kstep", 1.0}});
    planned.record(std::move(entry));
  }
  return plan_comparisons(planned).size();
}

std::string plan_of(const platform::topology& machine, const run_selection& selection,
               const std::vector<std::string>& names, const run_book& book, const run_cost& cost) {
  std::map<std::string, std::size_t> by_kind;
  for (const auto& name : names) ++by_kind[parse_entry_name(name)["kind"]];
  const std::size_t comparisons = planned_comparisons(names);
  const run_estimate estimate = estimate_run(names.size(), comparisons, cost);
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
  return fmt::format("lockstep run --plan (nothing measured)\n"
             "machine: {} ({}, {} CPUs in the affinity set)\n"
             "threads: {}\n"
             "models: {}\n"
             "entries: {} ({}), {} repetitions each; not applicable: {}\n"
             "paired comparisons: {}, {} pairs each\n"
             "estimated time: {} (matrix {}, pairs {}; calibrated on a 2-vCPU VM, an estimate)\n"
             "entries to measure:\n{}",
             machine.source(), machine.summary(), machine.affinity().size(), thread_list, models, names.size(), kinds,
             cost.repetitions, book.not_applicable.size(), comparisons, cost.pairs,
             format_seconds(estimate.total_s()), format_seconds(estimate.matrix_s),
             format_seconds(estimate.pairs_s), entries);
}

// The known answers the headline sets the step's ratios beside
// (headline.hpp), each a short run of a probe lockstep also has as a command:
// falseshare's two strides (one line, 8 bytes apart, against 128 bytes apart:
// no shared line nor shared prefetch pair) on the pinned pair, and migrate's
// forced moves between those two CPUs. Blocks of 20 ms (10 ms quick) over 7
// repeats (5 quick) cost about 0.3 s; 60 moves (30 quick) a few ms.
known_answers measure_known_answers(const platform::topology& machine, bool quick) {
  known_answers answers;
  const platform::placement_plan pair = platform::plan_placement(machine, platform::placement::compact, 2);
  if (pair.oversubscribed || pair.wrapped || !pair.entries[0].pu || !pair.entries[1].pu ||
      *pair.entries[0].pu == *pair.entries[1].pu) {
    answers.false_sharing_unavailable = answers.migration_unavailable = "fewer than two CPUs to pin two threads on";
    return answers;
  }
  const unsigned first = *pair.entries[0].pu;
  const unsigned second = *pair.entries[1].pu;
  try {
    probes::falseshare_settings settings;
    settings.cpus = {static_cast<int>(first), static_cast<int>(second)};
    settings.strides = {8, platform::kPrefetchPair};
    settings.window_ns = quick ? 10'000'000 : 20'000'000;
    settings.repeats = quick ? 5 : 7;
    const falseshare_analysis analysis = analyse_falseshare(probes::measure_false_sharing(settings));
    if (analysis.penalty) {
      answers.false_sharing = false_sharing_probe{fmt::format("{},{}", first, second),
                                                  analysis.penalty->sharing_stride_bytes,
                                                  analysis.penalty->apart_stride_bytes,
                                                  analysis.penalty->estimate,
                                                  analysis.penalty->verdict,
                                                  analysis.penalty->ratios.size()};
    } else {
      answers.false_sharing_unavailable = "no repeat scheduled both writers";
    }
  } catch (const std::exception& error) {
    answers.false_sharing_unavailable = error.what();
  }
  try {
    probes::migrate_settings settings;
    settings.from = first;
    settings.to = second;
    settings.repeats = quick ? 30 : 60;
    const probes::migrate_result result = probes::measure_migration(settings);
    const migrate_analysis analysis = analyse_migrate(settings, result, machine);
    answers.migration = migration_probe{fmt::format("{}<->{}", first, second), settings.bytes, analysis.move,
                                        analysis.refill};
  } catch (const std::exception& error) {
    answers.migration_unavailable = error.what();
  }
  return answers;
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

// The run, or with `plan_out` the plan: the same preparation either way, so
// the plan counts exactly the entries a run registers.
run_book execute_matrix(const matrix_request& request, const platform::topology& machine,
                        atomic_result_file* result_file, std::string* plan_out) {
  for (const auto& flag : request.benchmark_flags) {
    if (flag.rfind("--benchmark_out", 0) == 0)
      throw matrix_request_error("the result file is lockstep's: use --out FILE instead of " + flag);
    if (flag.rfind("--benchmark_", 0) != 0 && flag.rfind("--v=", 0) != 0)
      throw matrix_request_error("unknown argument '" + flag +
                                 "': Google Benchmark's flags (--benchmark_...) go after --, lockstep's before it");
  }

  // The mode: how long each entry runs (bench/run/run_book.hpp, run_settings).
  harness_state harness;
  run_book book;
  harness.machine = &machine;
  harness.book = &book;
  harness.settings.accounting = request.accounting;
  book.scaling = request.scaling;
  // The stall bound per step (or episode) sits far above a preemption on a
  // busy machine (tens of ms) and far below the paper's 1000 ms timeout, so a
  // lost wake-up is caught at its first occurrence.
  int repetitions = kDefaultRepetitions;
  harness.settings.stall_unit_ns = 200'000'000;
  harness.settings.call_budget_ns = 5'000'000'000;
  if (request.quick) {
    repetitions = kQuickRepetitions;
    harness.settings.target_batch_ns = 500'000;
    harness.settings.stall_unit_ns = 100'000'000;
    harness.settings.call_budget_ns = 2'000'000'000;
    harness.stalls_before_skipping_sync = 2;
  }
  // --min-time in batches of the target size (run_book.hpp: timed_batches).
  const std::int64_t target = harness.settings.target_batch_ns;
  harness.settings.timed_batches =
      static_cast<unsigned>(std::clamp<std::int64_t>((request.min_time_ns + target - 1) / target, 1, 1'000'000));
  // The harness-overhead pair gets three times the repetitions (at least the
  // run's): its on / off ratio is read to a percent or two.
  harness.settings.overhead_repetitions = 3 * (request.repetitions > 0 ? request.repetitions : repetitions);
  if (request.repetitions > 0) repetitions = request.repetitions;
  // What one clock reading costs here, taken off every timed sync span
  // (bench/run/rk4_entries.cpp) and stated in the context.
  book.clock_read_ns = platform::clock_read_cost_ns();
  // The pace trace (pace.hpp): a reading around every call of an entry and
  // every pair of blocks.
  pace_probe pace(machine);
  harness.pace = &pace;

  // Google Benchmark's flags: ours first, the user's after (the last wins).
  std::vector<std::string> arguments{"lockstep run",
                                     "--benchmark_out=" + (result_file ? result_file->temporary_path() : std::string("/dev/null")),
                                     "--benchmark_out_format=json",
                                     fmt::format("--benchmark_repetitions={}", repetitions)};
  const bool interleave = request.interleave;
  if (interleave) arguments.emplace_back("--benchmark_enable_random_interleaving=true");
  arguments.insert(arguments.end(), request.benchmark_flags.begin(), request.benchmark_flags.end());
  std::vector<char*> argv;
  for (auto& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  int argc = static_cast<int>(arguments.size());
  benchmark::Initialize(&argc, argv.data());
  if (argc > 1) throw matrix_request_error(fmt::format("Google Benchmark does not know the flag '{}'", argv[1]));

  benchmark::AddCustomContext("lockstep_mode", request.quick ? "quick" : "default");
  benchmark::AddCustomContext("lockstep_accounting", harness.settings.accounting ? "on" : "off");
  benchmark::AddCustomContext("lockstep_scaling", request.scaling ? "on" : "off");
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
  benchmark::AddCustomContext("noise_band", fmt::format("{:g}", request.noise));
  benchmark::AddCustomContext("clock_read_ns", fmt::format("{:.1f}", book.clock_read_ns));
  benchmark::AddCustomContext(
      "lockstep_timing",
      "manual time per step (episode): one iteration is a batch of steps (episodes) on a persistent pinned "
      "team, timed as a whole and reported divided by its steps (steps_per_batch), so real_time is ns_per_step "
      "(ns_per_episode) and cpu_time is participant 0's thread CPU time per step (episode); team start-up "
      "outside the timed region; medians over repetitions");

  std::vector<std::string> names = register_calibration_benchmarks(request.selection, harness);
  for (auto& name : register_overhead_pair(request.selection, harness)) names.push_back(std::move(name));
  for (auto& name : register_barrier_benchmarks(request.selection, harness)) names.push_back(std::move(name));
  for (auto& name : register_rk4_benchmarks(request.selection, harness)) names.push_back(std::move(name));

  // The paired comparisons' settings (measured after the matrix).
  pairing_settings pairing;
  pairing.pairs = static_cast<unsigned>(request.pairs >= 0 ? request.pairs : request.quick ? kQuickPairs : kDefaultPairs);
  pairing.block_ns = request.quick ? kQuickBlockNs : kDefaultBlockNs;
  pairing.noise = request.noise;
  pairing.budget_ns = request.quick ? kQuickPairBudgetNs : kDefaultPairBudgetNs;
  if (plan_out != nullptr) {
    const run_cost cost{repetitions, request.min_time_ns, pairing.pairs, pairing.block_ns, pairing.budget_ns};
    *plan_out = plan_of(machine, request.selection, names, book, cost);
    return book;
  }

  // The estimate comes from the plan (run_plan.hpp), the same one --plan prints.
  const run_cost cost{repetitions, request.min_time_ns, pairing.pairs, pairing.block_ns, pairing.budget_ns};
  const std::size_t selected = count_selected(names);
  const run_estimate planned = estimate_run(selected, planned_comparisons(names), cost);
  progress_reporter progress(book, selected, planned.matrix_s);
  harness.after_call = [&progress] { progress.tick(); };
  result_json_reporter json;
  fmt::print(stderr,
             "lockstep run: {} entries, {} repetitions each, then the paired comparisons: about {} in all (the plan's "
             "estimate: {} and {}); JSON to {}\n",
             selected, repetitions, format_seconds(planned.total_s()), format_seconds(planned.matrix_s),
             format_seconds(planned.pairs_s), result_file->destination());
  std::fflush(stderr);
  benchmark::RunSpecifiedBenchmarks(&progress, &json);
  benchmark::Shutdown();
  harness.after_call = nullptr;
  book.derive_ratios();
  book.collapsed = find_collapsed(book);

  // The paired comparisons, after the matrix: the plan needs its medians.
  const std::vector<comparison> plan = plan_comparisons(book);
  const double planned_pairs_s = estimate_run(0, plan.size(), cost).pairs_s;
  if (pairing.pairs > 0 && !plan.empty()) {
    fmt::print(stderr, "lockstep run: {} paired comparisons, {} rounds of a pair of blocks of about {} each, about {}\n",
               plan.size(), pairing.pairs, format_ns(static_cast<double>(pairing.block_ns)),
               format_seconds(planned_pairs_s));
    std::fflush(stderr);
  }
  const std::int64_t pairs_start_ns = platform::now_ns();
  measure_pairs(harness, plan, pairing, [&](std::size_t round, std::size_t rounds) {
    const double elapsed = static_cast<double>(platform::now_ns() - pairs_start_ns) / 1e9;
    fmt::print(stderr, "  paired round {}/{}, {} elapsed, {}\n", round, rounds, format_seconds(elapsed),
               time_left(elapsed, planned_pairs_s, round, rounds));
    std::fflush(stderr);
  });
  const known_answers probes = measure_known_answers(machine, request.quick);
  pace.take();  // the trace's last reading
  const pace_modes modes = find_modes(pace.trace());
  assign_pace_modes(book, modes);
  book.cpus = static_cast<unsigned>(machine.affinity().size());
  book.headline = make_headline(book, probes, book.cpus, result_file->destination());

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
  derive_ratios(document, book);
  write_pace_and_pairs(document, book, &pace, modes);
  document["lockstep_headline"] = headline_json(book.headline);
  if (request.scaling) document["lockstep_scaling"] = scaling_json(scaling_of(book), book.c2c_one_way_ns());
  // The machine's fingerprint from the one producer (replacing Google
  // Benchmark's host_name and num_cpus with the same figures), then the
  // in-run keys.
  merge_into_result(document, machine_context(machine));
  context_map in_run;
  in_run["c2c_one_way_ns"] = book.c2c_one_way_ns() ? fmt::format("{:.1f}", *book.c2c_one_way_ns()) : "unavailable";
  in_run["serial_step_ns"] = book.serial_step_ns() ? fmt::format("{:.2f}", *book.serial_step_ns()) : "unavailable";
  in_run["pace_summary"] = modes.summary();
  in_run["oversubscribed_note"] =
      oversubscribed_note(book, static_cast<unsigned>(machine.affinity().size()));
  std::string not_applicable;
  for (const auto& skipped : book.not_applicable)
    not_applicable += (not_applicable.empty() ? "" : "; ") + skipped.name + ": " + skipped.reason;
  in_run["not_applicable"] = not_applicable.empty() ? "none" : not_applicable;
  std::string stalled;
  for (const auto& entry : book.entries())
    if (!entry.error.empty()) stalled += (stalled.empty() ? "" : "; ") + entry.name + ": " + entry.error;
  in_run["stalled"] = stalled.empty() ? "none" : stalled;
  merge_into_result(document, in_run);
  result_file->write(document.dump(2) + "\n");
  result_file->commit();
  return book;
}


}  // namespace

std::string plan_text(const matrix_request& request, const platform::topology& machine) {
  std::string text;
  execute_matrix(request, machine, nullptr, &text);
  return text;
}

run_book run_matrix(const matrix_request& request, const platform::topology& machine,
                    atomic_result_file& result_file) {
  return execute_matrix(request, machine, &result_file, nullptr);
}

}  // namespace lockstep::bench
