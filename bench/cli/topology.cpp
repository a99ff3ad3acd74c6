// lockstep topology: what hwloc sees, the affinity set, and the placement
// plans for 1, 2, 4 threads and the core count.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/harness/result_file.hpp"
#include "bench/harness/build_info.hpp"
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

// "0-3,8,10-11"
std::string cpu_list(const std::vector<unsigned>& cpus) {
  std::string text;
  for (std::size_t at = 0; at < cpus.size();) {
    std::size_t end = at;
    while (end + 1 < cpus.size() && cpus[end + 1] == cpus[end] + 1) ++end;
    if (!text.empty()) text += ',';
    text += end == at ? std::to_string(cpus[at]) : fmt::format("{}-{}", cpus[at], cpus[end]);
    at = end + 1;
  }
  return text;
}

std::string human_size(std::uint64_t bytes) {
  if (bytes >= (1ULL << 20) && bytes % (1ULL << 20) == 0) return fmt::format("{} MiB", bytes >> 20);
  if (bytes >= (1ULL << 10) && bytes % (1ULL << 10) == 0) return fmt::format("{} KiB", bytes >> 10);
  return fmt::format("{} B", bytes);
}

std::string index_or_none(int index) { return index == platform::kNoObject ? "-" : std::to_string(index); }

// 1, 2, 4 threads (4 is the paper's case) and the number of usable cores.
std::vector<unsigned> thread_counts(const platform::topology& machine) {
  std::vector<unsigned> counts{1, 2, 4};
  const auto cores = static_cast<unsigned>(platform::compact_core_order(machine).size());
  if (std::find(counts.begin(), counts.end(), cores) == counts.end()) counts.push_back(cores);
  return counts;
}

std::vector<platform::placement_plan> all_plans(const platform::topology& machine) {
  std::vector<platform::placement_plan> plans;
  for (const auto& description : platform::placements()) {
    for (unsigned threads : thread_counts(machine)) {
      plans.push_back(platform::plan_placement(machine, description.kind, threads));
    }
  }
  return plans;
}

void print_text(const platform::topology& machine, const std::vector<platform::placement_plan>& plans) {
  fmt::print("topology of {} (hwloc {})\n", machine.source(), machine.hwloc_version());
  fmt::print("summary: {}\n", machine.summary());
  fmt::print("packages {}, L3 domains {}, L2 domains {}, cores {}, PUs {}\n", machine.packages(),
             machine.l3_domains(), machine.l2_domains(), machine.core_count(), machine.pu_count());
  fmt::print("\ncaches:\n");
  if (machine.caches().empty()) fmt::print("  none reported\n");
  for (const auto& cache : machine.caches()) {
    fmt::print("  L{} {:<12} {:>9} x {:<4} line {}\n", cache.level, cache.kind, human_size(cache.size_bytes),
               cache.instances, cache.line_bytes == 0 ? std::string("unknown") : fmt::format("{} B", cache.line_bytes));
  }
  fmt::print("\ncores (logical index: package, L3, L2, PUs by OS index):\n");
  for (const auto& core : machine.cores()) {
    std::vector<unsigned> pus = core.pus;
    std::sort(pus.begin(), pus.end());
    fmt::print("  core {:>3}: package {}, L3 {}, L2 {}, PUs {}\n", core.logical_index, core.package,
               index_or_none(core.l3), index_or_none(core.l2), cpu_list(pus));
  }
  if (machine.is_this_system()) {
    fmt::print("\naffinity: CPUs {} ({} of {} PUs)\n", cpu_list(machine.affinity()), machine.affinity().size(),
               machine.pu_count());
  } else {
    fmt::print("\naffinity: every PU ({}; not this machine, so nothing can be pinned)\n", machine.pu_count());
  }
  fmt::print("\nplacement plans (thread->PU by OS index):\n");
  for (const auto& plan : plans) {
    fmt::print("  {}\n", plan.describe());
    if (!plan.note.empty()) fmt::print("      {}\n", plan.note);
  }
}

nlohmann::json to_json(const platform::topology& machine, const std::vector<platform::placement_plan>& plans) {
  nlohmann::json caches = nlohmann::json::array();
  for (const auto& cache : machine.caches()) {
    caches.push_back({{"level", cache.level},
                      {"kind", cache.kind},
                      {"size_bytes", cache.size_bytes},
                      {"line_bytes", cache.line_bytes},
                      {"instances", cache.instances}});
  }
  const auto optional_index = [](int index) {
    return index == platform::kNoObject ? nlohmann::json(nullptr) : nlohmann::json(index);
  };
  nlohmann::json cores = nlohmann::json::array();
  for (const auto& core : machine.cores()) {
    cores.push_back({{"core", core.logical_index},
                     {"package", core.package},
                     {"l3", optional_index(core.l3)},
                     {"l2", optional_index(core.l2)},
                     {"pus", core.pus}});
  }
  nlohmann::json plan_list = nlohmann::json::array();
  for (const auto& plan : plans) {
    nlohmann::json pus = nlohmann::json::array();
    for (const auto& entry : plan.entries) pus.push_back(entry.pu ? nlohmann::json(*entry.pu) : nlohmann::json(nullptr));
    nlohmann::json item{{"placement", std::string(platform::to_string(plan.kind))},
                        {"threads", plan.threads},
                        {"pus", pus},
                        {"wrapped", plan.wrapped},
                        {"oversubscribed", plan.oversubscribed},
                        {"note", plan.note}};
    if (plan.kind == platform::placement::migrate) item["migrate_every_steps"] = plan.migrate_every_steps;
    plan_list.push_back(std::move(item));
  }
  return {{"kind", "topology"},
          {"lockstep_schema", build_info::kResultSchema},
          {"lockstep_version", build_info::kVersion},
          {"source", machine.source()},
          {"is_this_system", machine.is_this_system()},
          {"hwloc_version", machine.hwloc_version()},
          {"topology", machine.summary()},
          {"topology_packages", machine.packages()},
          {"topology_l3", machine.l3_domains()},
          {"topology_l2", machine.l2_domains()},
          {"topology_cores", machine.core_count()},
          {"topology_pus", machine.pu_count()},
          {"caches", caches},
          {"cores", cores},
          {"affinity", machine.affinity()},
          {"plans", plan_list}};
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
    const std::vector<platform::placement_plan> plans = all_plans(machine);
    print_text(machine, plans);
    if (!options->out.empty()) {
      bench::write_result_file(options->out, to_json(machine, plans).dump(2) + "\n");
      fmt::print(stderr, "topology written to {}\n", options->out);
    }
    result = kExitOk;
  });
}

}  // namespace lockstep::cli
