// lockstep falseshare: false sharing priced directly, per access pattern (the
// falseshare probe, bench/probes/falseshare.hpp): pinned threads, each
// accessing its own word, the words `stride` bytes apart.
// What it means and its two readings: bench/probe_reports/falseshare_report.hpp;
// this file is the options, their checks, that call and the readings.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/probe_reports/falseshare_report.hpp"
#include "bench/results/result_file.hpp"
#include "bench/probes/falseshare.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {
namespace {

struct falseshare_options {
  int threads = 2;
  std::string cores;
  std::string strides = "8,16,32,64,128,256";
  // Nine repetitions of 25 ms windows: nine pairs for each pattern's
  // interval; the plain stores' six strides and the other three patterns'
  // two each make 12 windows a repetition, 2.7 s in all.
  std::string window = "25ms";
  int repetitions = 9;
  std::string out;
};

void run_falseshare(const falseshare_options& options, int& result) {
  bench::probes::falseshare_settings settings;
  std::vector<std::size_t> strides;
  for (const std::uint64_t stride : parse_size_list(options.strides, "--strides", 8, 4096)) {
    if (stride % 8 != 0) throw usage_error(fmt::format("--strides: {} bytes is not a multiple of 8", stride));
    strides.push_back(static_cast<std::size_t>(stride));
  }
  settings.patterns = bench::probes::plan_patterns(strides);
  settings.window_ns = parse_duration_ns(options.window, "--window", 1'000'000, 60'000'000'000);
  settings.repeats = options.repetitions;
  const platform::topology machine = platform::topology::this_machine();
  std::vector<int> cpus = usable_cpus(machine, false);
  if (!options.cores.empty())
    cpus = restrict_to(usable_cpus(machine, true), parse_cpu_list(options.cores, "--cores"), "--cores");
  if (cpus.size() < static_cast<std::size_t>(options.threads))
    throw usage_error(fmt::format("--threads {} needs as many usable CPUs, found {} (each writer is pinned to its "
                                  "own CPU)",
                                  options.threads, cpus.size()));
  cpus.resize(static_cast<std::size_t>(options.threads));
  settings.cpus = cpus;
  check_out(options.out);

  std::size_t windows = 0;
  for (const auto& plan : settings.patterns) windows += plan.strides.size();
  settings.on_repeat = [&](int repeat) {
    fmt::print(stderr, "falseshare: repetition {}/{} ({} patterns, {} windows of {})\n", repeat + 1,
               settings.repeats, settings.patterns.size(), windows, options.window);
  };
  std::vector<bench::probes::pattern_cost> costs;
  try {
    costs = bench::probes::measure_false_sharing(settings);
  } catch (const std::runtime_error& e) {
    throw usage_error(std::string(e.what()) + "; choose usable CPUs with --cores");
  }

  const bench::falseshare_analysis analysis = bench::analyse_falseshare(costs);
  std::string cpu_text;
  for (const int cpu : settings.cpus) cpu_text += fmt::format("{}{}", cpu_text.empty() ? "" : ",", cpu);
  const bench::falseshare_evidence evidence{cpu_text, bench::cpus_relation(machine, settings.cpus), std::nullopt};
  fmt::print("{}", bench::falseshare_text(settings, options.window, costs, analysis, evidence));

  if (!options.out.empty()) {
    bench::write_result_file(options.out,
                             bench::falseshare_json(settings, costs, analysis, evidence, machine).dump(2) + "\n");
    fmt::print(stderr, "falseshare: wrote {}\n", options.out);
  }
  result = kExitOk;
}

}  // namespace

void add_falseshare(CLI::App& app, int& result) {
  auto options = std::make_shared<falseshare_options>();
  auto* command = app.add_subcommand(
      "falseshare",
      "False sharing priced directly, per access pattern (plain stores, atomic read-modify-writes, seq_cst stores, "
      "a writer beside a reader): pinned threads access words `stride` bytes apart (plain stores by default 8 to "
      "256, the others one line against 128 apart)");
  command->add_option("--threads", options->threads, "Threads, each pinned to its own CPU")
      ->check(CLI::Range(2, 1024))
      ->capture_default_str();
  command->add_option("--cores", options->cores, "CPUs for the writers, e.g. 0,1 (default: one PU per core)");
  command->add_option("--strides", options->strides,
                      "Strides between neighbouring words, a comma list of sizes (bytes, or with a unit: 1KiB), "
                      "multiples of 8 from 8 to 4KiB: plain stores at each, the other patterns at the first that "
                      "shares a line and the first that shares nothing")
      ->capture_default_str();
  command->add_option("--window", options->window, "How long the threads access their words per measurement, with a unit")
      ->capture_default_str();
  add_repetitions_option(*command, options->repetitions, 1000, "every pattern and stride measured once, for one --window each",
                         "--repeats");
  add_out_option(*command, options->out);
  command->callback([options, &result] { run_falseshare(*options, result); });
}

}  // namespace lockstep::cli
