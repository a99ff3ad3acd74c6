// lockstep falseshare: false sharing priced directly (the falseshare probe,
// bench/probes/falseshare.hpp): pinned writers, counters `stride` bytes apart.
// What it means and its two readings: bench/probe_reports/falseshare_report.hpp;
// this file is the options, their checks, that call and the readings.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cstdint>
#include <memory>
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
  // Nine repetitions of 50 ms windows: nine pairs for the penalty's interval
  // in the same 2.7 s that five repetitions of 100 ms took.
  std::string window = "50ms";
  int repetitions = 9;
  std::string out;
};

void run_falseshare(const falseshare_options& options, int& result) {
  bench::probes::falseshare_settings settings;
  for (const std::uint64_t stride : parse_size_list(options.strides, "--strides", 8, 4096)) {
    if (stride % 8 != 0) throw usage_error(fmt::format("--strides: {} bytes is not a multiple of 8", stride));
    settings.strides.push_back(static_cast<std::size_t>(stride));
  }
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

  settings.on_repeat = [&](int repeat) {
    fmt::print(stderr, "falseshare: repetition {}/{} ({} strides x {})\n", repeat + 1, settings.repeats,
               settings.strides.size(), options.window);
  };
  std::vector<bench::probes::stride_cost> costs;
  try {
    costs = bench::probes::measure_false_sharing(settings);
  } catch (const std::runtime_error& e) {
    throw usage_error(std::string(e.what()) + "; choose usable CPUs with --cores");
  }

  const bench::falseshare_analysis analysis = bench::analyse_falseshare(costs);
  fmt::print("{}", bench::falseshare_text(settings, options.window, costs, analysis));

  if (!options.out.empty()) {
    bench::write_result_file(options.out, bench::falseshare_json(settings, costs, analysis, machine).dump(2) + "\n");
    fmt::print(stderr, "falseshare: wrote {}\n", options.out);
  }
  result = kExitOk;
}

}  // namespace

void add_falseshare(CLI::App& app, int& result) {
  auto options = std::make_shared<falseshare_options>();
  auto* command = app.add_subcommand(
      "falseshare", "False sharing priced directly: pinned threads write counters `stride` bytes apart (by default 8 to 256)");
  command->add_option("--threads", options->threads, "Writers, each pinned to its own CPU")
      ->check(CLI::Range(2, 1024))
      ->capture_default_str();
  command->add_option("--cores", options->cores, "CPUs for the writers, e.g. 0,1 (default: one PU per core)");
  command->add_option("--strides", options->strides,
                      "Strides between neighbouring counters, a comma list of sizes (bytes, or with a unit: 1KiB), "
                      "multiples of 8 from 8 to 4KiB")
      ->capture_default_str();
  command->add_option("--window", options->window, "How long the writers write per measurement, with a unit")
      ->capture_default_str();
  add_repetitions_option(*command, options->repetitions, 1000, "every stride measured once, for one --window each",
                         "--repeats");
  add_out_option(*command, options->out);
  command->callback([options, &result] { run_falseshare(*options, result); });
}

}  // namespace lockstep::cli
