// lockstep c2c: the core-to-core latency matrix, each pair labelled with its
// hwloc relation (SMT siblings, shared L2, shared L3, different L3, different
// package). The measurement is the c2c probe (bench/probes/core_to_core.hpp),
// the pairs its plan (bench/probes/c2c_pairs.hpp).
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

#include "bench/cli/command.hpp"
#include "bench/probes/core_to_core.hpp"
#include "bench/cli/options.hpp"
#include "bench/harness/machine_context.hpp"
#include "bench/harness/result_file.hpp"
#include "bench/harness/result_json.hpp"
#include "bench/probes/c2c_pairs.hpp"
#include "platform/stats.hpp"
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

void print_matrix(const std::vector<int>& cpus, const std::vector<bench::c2c::pair_latency>& results, method how) {
  std::map<std::pair<int, int>, double> median;
  for (const auto& r : results)
    if (r.how == how) median[{r.a, r.b}] = median[{r.b, r.a}] = platform::summarize(r.one_way_ns).p50;
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
    for (const auto& pair : plan.pairs) fmt::print("{} {} {}\n", pair.a, pair.b, pair.relation);
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
  const auto relation_of = [&](int a, int b) {
    return std::string(platform::to_string(machine.relation(static_cast<unsigned>(a), static_cast<unsigned>(b))));
  };

  fmt::print("one-way latency = round trip / 2, {} samples of {} round trips per pair\n", options.samples,
             options.rounds);
  fmt::print("{:>5} {:>5}  {:<18} {:<10} {:>9} {:>9} {:>9}\n", "cpu", "cpu", "relation", "method", "min ns", "p50 ns",
             "p99 ns");
  for (const auto& r : results) {
    const platform::distribution one_way = platform::summarize(r.one_way_ns);
    fmt::print("{:>5} {:>5}  {:<18} {:<10} {:>9.1f} {:>9.1f} {:>9.1f}\n", r.a, r.b, relation_of(r.a, r.b),
               bench::c2c::to_string(r.how), one_way.min, one_way.p50, one_way.p99);
  }
  for (method how : methods) print_matrix(cpus, results, how);

  if (!options.out.empty()) {
    nlohmann::json document = bench::result_document("c2c", machine);
    document["sampled"] = plan.sampled;
    document["pairs_total"] = plan.all_pairs;
    document["samples_per_pair"] = options.samples;
    document["rounds_per_sample"] = options.rounds;
    document["pairs"] = nlohmann::json::array();
    for (const auto& r : results)
      document["pairs"].push_back({{"a", r.a},
                                   {"b", r.b},
                                   {"relation", relation_of(r.a, r.b)},
                                   {"method", bench::c2c::to_string(r.how)},
                                   {"one_way_ns", bench::distribution_json(r.one_way_ns)},
                                   {"samples", r.one_way_ns.size()}});
    bench::write_result_file(options.out, document.dump(2) + "\n");
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
  command->add_option("--method", options->methods, "cas, store_load or both")->capture_default_str();
  command->add_option("--samples", options->samples, "One-way latency samples per pair")
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
