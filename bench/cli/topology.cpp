// lockstep topology: what hwloc sees, the affinity set, the placement plans
// for 1, 2, 4 threads and the core count, and the machine's state
// (bench/probe_reports/machine_state_report.hpp). The plans and the two
// readings: bench/probe_reports/topology_report.hpp; this file is the options, their
// checks, that call and the readings.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/results/result_file.hpp"
#include "bench/probe_reports/machine_state_report.hpp"
#include "bench/probe_reports/topology_report.hpp"
#include "platform/machine_state.hpp"
#include "platform/placement.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {

namespace {

struct topology_options {
  std::string synthetic;
  std::string xml;
  std::string out;
  bool synthetic_given = false;
  bool xml_given = false;
};

platform::topology load(const topology_options& options) {
  if (options.synthetic_given && options.xml_given) {
    throw usage_error("give --synthetic or --xml, not both");
  }
  try {
    if (options.synthetic_given) return platform::topology::from_synthetic(options.synthetic);
    if (options.xml_given) return platform::topology::from_xml_file(options.xml);
    return platform::topology::this_machine();
  } catch (const platform::topology_error& error) {
    throw usage_error(error.what());
  }
}

}  // namespace

void add_topology(CLI::App& app, int& result) {
  auto options = std::make_shared<topology_options>();
  auto* command = app.add_subcommand("topology", "What hwloc sees on this machine (or another), and the placement plans");
  command->add_option("--synthetic", options->synthetic,
                      "Show a synthetic machine in hwloc's syntax instead, e.g. \"package:2 l3:2 core:4 pu:2\"");
  command->add_option("--xml", options->xml, "Show a machine saved with `lstopo FILE.xml` instead");
  add_out_option(*command, options->out, "the topology and plans as JSON");
  command->callback([options, command, &result] {
    options->synthetic_given = command->count("--synthetic") > 0;
    options->xml_given = command->count("--xml") > 0;
    const platform::topology machine = load(*options);
    check_out(options->out);
    const std::vector<platform::placement_plan> plans = bench::topology_plans(machine);
    const platform::machine_state state = platform::read_machine_state();
    fmt::print("{}", bench::topology_text(machine, plans));
    fmt::print("{}", bench::machine_state_text(state, machine.affinity()));
    if (!options->out.empty()) {
      nlohmann::json document = bench::topology_json(machine, plans);
      document["machine_state"] = bench::machine_state_json(state, machine.affinity());
      bench::write_result_file(options->out, document.dump(2) + "\n");
      fmt::print(stderr, "topology written to {}\n", options->out);
    }
    result = kExitOk;
  });
}

}  // namespace lockstep::cli
