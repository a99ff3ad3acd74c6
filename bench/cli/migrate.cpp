// lockstep migrate: the cost of one forced migration, the move and the cache
// refill (the migrate probe, bench/probes/migrate.hpp).
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/harness/machine_context.hpp"
#include "bench/harness/result_file.hpp"
#include "bench/harness/result_json.hpp"
#include "bench/probes/migrate.hpp"
#include "platform/cache_line.hpp"
#include "platform/stats.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {
namespace {

struct migrate_options {
  std::string cores;  // two CPUs: from,to
  std::uint64_t bytes = 256 * 1024;
  int repeats = 200;
  std::string out;
};

void print_row(const char* what, const std::vector<double>& values) {
  const auto d = platform::summarize(values);
  fmt::print("{:<34} {:>10.0f} {:>10.0f} {:>10.0f} {:>10.0f}\n", what, d.min, d.p50, d.p99, d.max);
}

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
  settings.bytes = options.bytes;
  settings.repeats = options.repeats;
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
  const std::string relation(platform::to_string(machine.relation(settings.from, settings.to)));

  fmt::print("forced migration between CPU {} and CPU {} ({}), working set {} bytes, {} migrations\n", settings.from,
             settings.to, relation, settings.bytes, settings.repeats);
  fmt::print("{:<34} {:>10} {:>10} {:>10} {:>10}\n", "ns", "min", "median", "p99", "max");
  print_row("move (setaffinity until there)", samples.move_ns);
  print_row("  baseline: setaffinity, no move", samples.stay_ns);
  print_row("refill (first pass - next pass)", samples.refill_ns);
  print_row("  first pass after the move", samples.first_pass_ns);
  print_row("  next pass (lines local)", samples.next_pass_ns);
  const auto move = platform::summarize(samples.move_ns);
  const auto refill = platform::summarize(samples.refill_ns);
  fmt::print("one migration ~ {:.0f} ns move + {:.0f} ns refill (medians)\n", move.p50, refill.p50);

  if (!options.out.empty()) {
    nlohmann::json document = bench::result_document("migrate", machine);
    document["settings"] = {{"from", settings.from},   {"to", settings.to},          {"relation", relation},
                            {"bytes", settings.bytes}, {"repeats", settings.repeats}};
    document["move_ns"] = bench::distribution_json(samples.move_ns);
    document["setaffinity_no_move_ns"] = bench::distribution_json(samples.stay_ns);
    document["refill_ns"] = bench::distribution_json(samples.refill_ns);
    document["first_pass_ns"] = bench::distribution_json(samples.first_pass_ns);
    document["next_pass_ns"] = bench::distribution_json(samples.next_pass_ns);
    bench::write_result_file(options.out, document.dump(2) + "\n");
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
  command->add_option("--bytes", options->bytes, "Working set in bytes")
      ->check(CLI::Range(std::uint64_t{platform::kCacheLine}, std::uint64_t{1} << 34))
      ->capture_default_str();
  command->add_option("--repeats", options->repeats, "Migrations measured")
      ->check(CLI::Range(1, 1'000'000))
      ->capture_default_str();
  add_out_option(*command, options->out);
  command->callback([options, &result] { run_migrate(*options, result); });
}

}  // namespace lockstep::cli
