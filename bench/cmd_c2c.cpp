// lockstep c2c: the core-to-core latency matrix, each pair labelled with its
// hwloc relation (SMT siblings, shared L2, shared L3, different L3, different
// package). The measurement itself is bench/core_to_core.hpp.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "bench/command.hpp"
#include "bench/core_to_core.hpp"
#include "bench/delay_common.hpp"
#include "bench/delay_c2c_plan.hpp"
#include "platform/stats.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {
namespace {

using bench::c2c::method;
namespace delay = bench::delay;

struct c2c_options {
  std::string cores;
  bool smt = false;
  std::string methods = "both";
  int samples = 300;
  int rounds = 100;
  int max_pairs = 256;
  unsigned seed = 1;
  std::string json;
  std::string synthetic;  // hidden: label the pairs of a synthetic topology without measuring
};

struct pair_measurement {
  int a = 0;
  int b = 0;
  std::string relation;
  method how = method::cas;
  std::vector<double> one_way_ns;
  platform::distribution one_way() const { return platform::summarize(one_way_ns); }
};

std::vector<method> parse_methods(const std::string& text) {
  if (text == "both") return {method::cas, method::store_load};
  if (text == "cas") return {method::cas};
  if (text == "store_load") return {method::store_load};
  throw usage_error("--method: '" + text + "' is not one of cas, store_load, both");
}

platform::topology load_machine(const std::string& synthetic) {
  try {
    return synthetic.empty() ? platform::topology::this_machine() : platform::topology::from_synthetic(synthetic);
  } catch (const platform::topology_error& e) {
    throw usage_error(std::string(synthetic.empty() ? "" : "--synthetic: ") + e.what());
  }
}

void print_matrix(const std::vector<int>& cpus, const std::vector<pair_measurement>& results, method how) {
  std::map<std::pair<int, int>, double> median;
  for (const auto& r : results)
    if (r.how == how) median[{r.a, r.b}] = median[{r.b, r.a}] = r.one_way().p50;
  fmt::print("\nmedian one-way latency, ns ({}):\n{:>6}", bench::c2c::to_string(how), "");
  for (int cpu : cpus) fmt::print(" {:>7}", cpu);
  fmt::print("\n");
  for (int row : cpus) {
    fmt::print("{:>6}", row);
    for (int col : cpus) {
      const auto found = median.find({row, col});
      if (row == col)
        fmt::print(" {:>7}", "-");
      else if (found == median.end())
        fmt::print(" {:>7}", ".");  // not sampled
      else
        fmt::print(" {:>7.1f}", found->second);
    }
    fmt::print("\n");
  }
}

void run_c2c(const c2c_options& options, int& result) {
  const auto methods = parse_methods(options.methods);
  if (options.samples < 1 || options.samples > 1'000'000) throw usage_error("--samples must be in 1..1000000");
  if (options.rounds < 1 || options.rounds > 1'000'000) throw usage_error("--rounds must be in 1..1000000");
  if (options.max_pairs < 1) throw usage_error("--max-pairs must be at least 1");

  const platform::topology machine = load_machine(options.synthetic);
  std::vector<int> cpus = delay::usable_cpus(machine, options.smt);
  if (!options.cores.empty()) cpus = delay::restrict_to(cpus, delay::parse_cpu_list(options.cores, "--cores"), "--cores");
  if (cpus.size() < 2)
    throw usage_error("c2c needs at least two usable CPUs (found " + std::to_string(cpus.size()) +
                      "); name them with --cores, or add --smt to count SMT siblings");
  delay::check_writable(options.json);

  const delay::c2c_plan plan =
      delay::plan_c2c_pairs(machine, cpus, static_cast<std::size_t>(options.max_pairs), options.seed);
  if (plan.sampled)
    fmt::print("sampled {} of {} pairs (fixed seed {}; raise --max-pairs to measure more)\n", plan.pairs.size(),
               plan.all_pairs, options.seed);

  // --synthetic: the labels only (a synthetic machine cannot be measured).
  if (!options.synthetic.empty()) {
    for (const auto& pair : plan.pairs) fmt::print("{} {} {}\n", pair.a, pair.b, pair.relation);
    result = kExitOk;
    return;
  }

  std::vector<pair_measurement> results;
  const std::size_t total = plan.pairs.size() * methods.size();
  std::size_t done = 0;
  for (const auto& [a, b, relation] : plan.pairs) {
    for (method how : methods) {
      fmt::print(stderr, "c2c: pair {}/{}: CPU {} <-> CPU {} ({}, {})\n", ++done, total, a, b, relation,
                 bench::c2c::to_string(how));
      bench::c2c::pair_request request;
      request.cpu_a = a;
      request.cpu_b = b;
      request.how = how;
      request.samples = options.samples;
      request.rounds_per_sample = options.rounds;
      request.warmup_rounds = std::max(100, options.rounds * 10);
      std::vector<double> samples;
      try {
        samples = bench::c2c::measure_pair(request);
      } catch (const std::runtime_error& e) {
        throw usage_error(std::string(e.what()) + "; choose usable CPUs with --cores");
      }
      results.push_back({a, b, relation, how, std::move(samples)});
    }
  }

  fmt::print("one-way latency = round trip / 2, {} samples of {} round trips per pair\n", options.samples,
             options.rounds);
  fmt::print("{:>5} {:>5}  {:<18} {:<10} {:>9} {:>9} {:>9}\n", "cpu", "cpu", "relation", "method", "min ns", "p50 ns",
             "p99 ns");
  for (const auto& r : results)
    fmt::print("{:>5} {:>5}  {:<18} {:<10} {:>9.1f} {:>9.1f} {:>9.1f}\n", r.a, r.b, r.relation,
               bench::c2c::to_string(r.how), r.one_way().min, r.one_way().p50, r.one_way().p99);
  for (method how : methods) print_matrix(cpus, results, how);

  if (!options.json.empty()) {
    nlohmann::json document = {{"kind", "c2c"},
                               {"lockstep_schema", build_info::kResultSchema},
                               {"context", delay::result_context(machine)},
                               {"sampled", plan.sampled},
                               {"pairs_total", plan.all_pairs},
                               {"samples_per_pair", options.samples},
                               {"rounds_per_sample", options.rounds},
                               {"pairs", nlohmann::json::array()}};
    for (const auto& r : results)
      document["pairs"].push_back({{"a", r.a},
                                   {"b", r.b},
                                   {"relation", r.relation},
                                   {"method", bench::c2c::to_string(r.how)},
                                   {"one_way_ns", delay::distribution_json(r.one_way_ns)},
                                   {"samples", r.one_way_ns.size()}});
    delay::write_file_atomically(options.json, document.dump(2) + "\n");
    fmt::print(stderr, "c2c: wrote {}\n", options.json);
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
  command->add_option("--method", options->methods, "cas, store_load or both")->capture_default_str();
  command->add_option("--samples", options->samples, "One-way latency samples per pair")->capture_default_str();
  command->add_option("--rounds", options->rounds, "Round trips averaged into one sample")->capture_default_str();
  command->add_option("--max-pairs", options->max_pairs,
                      "Measure at most this many pairs; more are sampled at random (said in the output)")
      ->capture_default_str();
  command->add_option("--seed", options->seed, "Seed of the pair sampling")->capture_default_str();
  command->add_option("--json", options->json, "Write the result as JSON to this file (atomically)");
  command->add_option("--synthetic", options->synthetic,
                      "Print the pair relations of a synthetic hwloc topology (e.g. 'pack:2 l3:1 core:2 pu:2') "
                      "instead of measuring");
  command->callback([options, &result] { run_c2c(*options, result); });
}

}  // namespace lockstep::cli
