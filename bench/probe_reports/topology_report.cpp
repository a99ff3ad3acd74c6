// What hwloc sees and the placement plans, as text and as a result file (topology_report.hpp).
#include "bench/probe_reports/topology_report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>

#include "bench/results/build_info.hpp"

namespace lockstep::bench {

namespace {

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

}  // namespace

std::vector<platform::placement_plan> topology_plans(const platform::topology& machine) {
  std::vector<platform::placement_plan> plans;
  for (const auto& description : platform::placements()) {
    for (unsigned threads : thread_counts(machine)) {
      plans.push_back(platform::plan_placement(machine, description.kind, threads));
    }
  }
  return plans;
}

std::string topology_text(const platform::topology& machine, const std::vector<platform::placement_plan>& plans) {
  std::string text;
  text += fmt::format("topology of {} (hwloc {})\n", machine.source(), machine.hwloc_version());
  text += fmt::format("summary: {}\n", machine.summary());
  text += fmt::format("packages {}, L3 domains {}, L2 domains {}, cores {}, PUs {}\n", machine.packages(),
                      machine.l3_domains(), machine.l2_domains(), machine.core_count(), machine.pu_count());
  text += fmt::format("\ncaches:\n");
  if (machine.caches().empty()) text += fmt::format("  none reported\n");
  for (const auto& cache : machine.caches()) {
    text += fmt::format("  L{} {:<12} {:>9} x {:<4} line {}\n", cache.level, cache.kind, human_size(cache.size_bytes),
                        cache.instances,
                        cache.line_bytes == 0 ? std::string("unknown") : fmt::format("{} B", cache.line_bytes));
  }
  text += fmt::format("\ncores (logical index: package, L3, L2, PUs by OS index):\n");
  for (const auto& core : machine.cores()) {
    std::vector<unsigned> pus = core.pus;
    std::sort(pus.begin(), pus.end());
    text += fmt::format("  core {:>3}: package {}, L3 {}, L2 {}, PUs {}\n", core.logical_index, core.package,
                        index_or_none(core.l3), index_or_none(core.l2), cpu_list(pus));
  }
  if (machine.is_this_system()) {
    text += fmt::format("\naffinity: CPUs {} ({} of {} PUs)\n", cpu_list(machine.affinity()), machine.affinity().size(),
                        machine.pu_count());
  } else {
    text += fmt::format("\naffinity: every PU ({}; not this machine, so nothing can be pinned)\n", machine.pu_count());
  }
  text += fmt::format("\nplacement plans (thread->PU by OS index):\n");
  for (const auto& plan : plans) {
    text += fmt::format("  {}\n", plan.describe());
    if (!plan.note.empty()) text += fmt::format("      {}\n", plan.note);
  }
  return text;
}

nlohmann::json topology_json(const platform::topology& machine, const std::vector<platform::placement_plan>& plans) {
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
    for (const auto& entry : plan.entries)
      pus.push_back(entry.pu ? nlohmann::json(*entry.pu) : nlohmann::json(nullptr));
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

}  // namespace lockstep::bench
