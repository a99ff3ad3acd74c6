// lockstep c2c: the core-to-core latency matrix, each pair labelled with its
// hwloc relation (SMT siblings, shared L2, shared L3, different L3, other NUMA
// node, different package) and, where they differ, its two NUMA nodes. The
// measurement is the c2c probe (bench/probes/core_to_core.hpp),
// the pairs its plan (bench/probes/c2c_pairs.hpp), what it means and its two
// readings bench/probe_reports/c2c_report.hpp; this file is the options, their
// checks, that call and the readings.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/probes/core_to_core.hpp"
#include "bench/cli/options.hpp"
#include "bench/probe_reports/c2c_report.hpp"
#include "bench/results/result_file.hpp"
#include "bench/probes/c2c_pairs.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {
namespace {

using bench::c2c::method;
namespace probes = bench::probes;

struct c2c_options {
  std::string cores;
  bool smt = false;
  std::string methods = "both";
  int samples = 300;
  int rounds = 100;
  int max_pairs = 256;
  unsigned seed = 1;
  std::string out;
  std::string synthetic;  // hidden: label the pairs of a synthetic topology without measuring
};


std::vector<method> parse_methods(const std::string& text) {
  check_name(text, {"cas", "store_load", "stage", "both", "all"}, "--method: unknown value");
  if (text == "cas") return {method::cas};
  if (text == "store_load") return {method::store_load};
  if (text == "stage") return {method::stage};
  if (text == "all") return {method::cas, method::store_load, method::stage};
  return {method::cas, method::store_load};
}

platform::topology load_machine(const std::string& synthetic) {
  try {
    return synthetic.empty() ? platform::topology::this_machine() : platform::topology::from_synthetic(synthetic);
  } catch (const platform::topology_error& e) {
    throw usage_error(std::string(synthetic.empty() ? "" : "--synthetic: ") + e.what());
  }
}

void run_c2c(const c2c_options& options, int& result) {
  const auto methods = parse_methods(options.methods);

  const platform::topology machine = load_machine(options.synthetic);
  std::vector<int> cpus = usable_cpus(machine, options.smt);
  if (!options.cores.empty()) cpus = restrict_to(cpus, parse_cpu_list(options.cores, "--cores"), "--cores");
  if (cpus.size() < 2)
    throw usage_error("c2c needs at least two usable CPUs (found " + std::to_string(cpus.size()) +
                      "); name them with --cores, or add --smt to count SMT siblings");
  check_out(options.out);

  const probes::c2c_plan plan =
      probes::plan_c2c_pairs(machine, cpus, static_cast<std::size_t>(options.max_pairs), options.seed);
  if (plan.sampled)
    fmt::print("sampled {} of {} pairs (fixed seed {}; raise --max-pairs to measure more)\n", plan.pairs.size(),
               plan.all_pairs, options.seed);

  // --synthetic: the labels only (a synthetic machine cannot be measured).
  if (!options.synthetic.empty()) {
    for (const auto& pair : plan.pairs)
      fmt::print("{} {} {}\n", pair.a, pair.b, probes::pair_words(pair.relation, pair.node_a, pair.node_b));
    result = kExitOk;
    return;
  }

  bench::c2c::c2c_settings settings;
  for (const auto& pair : plan.pairs) settings.pairs.emplace_back(pair.a, pair.b);
  settings.methods = methods;
  settings.samples = options.samples;
  settings.rounds_per_sample = options.rounds;
  settings.on_pair = [](std::size_t done, std::size_t total, int a, int b, method how) {
    fmt::print(stderr, "c2c: pair {}/{}: CPU {} <-> CPU {} ({})\n", done + 1, total, a, b, bench::c2c::to_string(how));
  };
  std::vector<bench::c2c::pair_latency> results;
  try {
    results = bench::c2c::measure_pairs(settings);
  } catch (const std::runtime_error& e) {
    throw usage_error(std::string(e.what()) + "; choose usable CPUs with --cores");
  }
  const bench::c2c_analysis analysis = bench::analyse_c2c(results, methods, machine);
  fmt::print("{}", bench::c2c_text(settings, cpus, results, analysis));

  if (!options.out.empty()) {
    bench::write_result_file(options.out, bench::c2c_json(plan, settings, results, analysis, machine).dump(2) + "\n");
    fmt::print(stderr, "c2c: wrote {}\n", options.out);
  }
  result = kExitOk;
}

}  // namespace

void add_c2c(CLI::App& app, int& result) {
  auto options = std::make_shared<c2c_options>();
  auto* command = app.add_subcommand(
      "c2c", "Core-to-core latency matrix: two pinned threads bounce one cache line; pairs labelled by hwloc relation");
  command->add_option("--cores", options->cores, "CPUs to measure, e.g. 0,2,4-7 (default: every usable core)");
  command->add_flag("--smt", options->smt, "Include SMT siblings (default: one PU per core)");
  command->add_option("--method", options->methods,
                      "cas, store_load, both (those two), stage (each thread writes its own line and waits for the "
                      "other's: the floor of a two-thread stage sync, in one-way latencies) or all")->capture_default_str();
  command->add_option("--samples", options->samples, "One-way latency samples per pair and method, taken back to back, each the mean of --rounds round trips")
      ->check(CLI::Range(1, 1'000'000))
      ->capture_default_str();
  command->add_option("--rounds", options->rounds, "Round trips averaged into one sample")
      ->check(CLI::Range(1, 1'000'000))
      ->capture_default_str();
  command->add_option("--max-pairs", options->max_pairs,
                      "Measure at most this many pairs; more are sampled at random (said in the output)")
      ->check(CLI::Range(1, 1'000'000))
      ->capture_default_str();
  command->add_option("--seed", options->seed, "Seed of the pair sampling")->capture_default_str();
  add_out_option(*command, options->out);
  command->add_option("--synthetic", options->synthetic,
                      "Print the pair relations of a synthetic hwloc topology (e.g. 'pack:2 l3:1 core:2 pu:2') "
                      "instead of measuring");
  command->callback([options, &result] { run_c2c(*options, result); });
}

}  // namespace lockstep::cli
