// lockstep migrate: the cost of one forced migration, the move and the cache
// refill (the migrate probe, bench/probes/migrate.hpp). What it means and its
// two readings: bench/probe_reports/migrate_report.hpp; this file is the options,
// their checks, that call and the readings.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/probe_reports/migrate_report.hpp"
#include "bench/results/result_file.hpp"
#include "bench/probes/migrate.hpp"
#include "platform/cache_line.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {
namespace {

struct migrate_options {
  std::string cores;  // two CPUs: from,to
  std::string bytes = "256KiB";  // the working set
  int repetitions = 200;
  std::string out;
};

void run_migrate(const migrate_options& options, int& result) {
  const platform::topology machine = platform::topology::this_machine();
  std::vector<int> cpus = usable_cpus(machine, false);
  if (!options.cores.empty()) {
    cpus = restrict_to(usable_cpus(machine, true), parse_cpu_list(options.cores, "--cores"), "--cores");
    if (cpus.size() != 2) throw usage_error("--cores: name exactly two CPUs, the two ends of the move (e.g. 0,1)");
  }
  if (cpus.size() < 2) throw usage_error(fmt::format("migrate needs two usable CPUs, found {}", cpus.size()));
  bench::probes::migrate_settings settings;
  settings.from = static_cast<unsigned>(cpus[0]);
  settings.to = static_cast<unsigned>(cpus[1]);
  settings.bytes = parse_size_bytes(options.bytes, "--bytes", platform::kCacheLine, std::uint64_t{1} << 34);
  settings.repeats = options.repetitions;
  settings.on_progress = [](int done, int total) { fmt::print(stderr, "migrate: {}/{} migrations\n", done, total); };
  check_out(options.out);

  fmt::print(stderr, "migrate: {} migrations between CPU {} and CPU {}, working set {} bytes\n", settings.repeats,
             settings.from, settings.to, settings.bytes);
  bench::probes::migrate_result samples;
  try {
    samples = bench::probes::measure_migration(settings);
  } catch (const std::runtime_error& e) {
    throw usage_error(std::string(e.what()) + "; choose usable CPUs with --cores");
  }
  const bench::migrate_analysis analysis = bench::analyse_migrate(settings, samples, machine);
  fmt::print("{}", bench::migrate_text(settings, analysis));

  if (!options.out.empty()) {
    bench::write_result_file(options.out, bench::migrate_json(settings, samples, analysis, machine).dump(2) + "\n");
    fmt::print(stderr, "migrate: wrote {}\n", options.out);
  }
  result = kExitOk;
}

}  // namespace

void add_migrate(CLI::App& app, int& result) {
  auto options = std::make_shared<migrate_options>();
  auto* command = app.add_subcommand(
      "migrate", "Cost of one forced migration: the move itself, and the cache refill of a working set");
  command->add_option("--cores", options->cores, "The two CPUs to move between, e.g. 0,1 (default: first two cores)");
  command->add_option("--bytes", options->bytes,
                      fmt::format("Working set, a size: 256KiB, 4MiB, or bytes (one cache line, {} bytes, to 16GiB; "
                                  "default {})",
                                  platform::kCacheLine, options->bytes))
      ->option_text("SIZE");
  add_repetitions_option(*command, options->repetitions, 1'000'000,
                         "one forced migration (the move, the stay baseline, the two passes over the working set)",
                         "--repeats");
  add_out_option(*command, options->out);
  command->callback([options, &result] { run_migrate(*options, result); });
}

}  // namespace lockstep::cli
