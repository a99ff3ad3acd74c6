// What hwloc sees and the placement plans, as text and as a result file (topology_report.hpp).
#include "bench/probe_reports/topology_report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>

#include "bench/results/build_info.hpp"

namespace lockstep::bench {

namespace {

// No line of the text is wider (a 64-CPU machine's plans wrap).
constexpr std::size_t kTextWidth = 120;

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

// The lines of a longer text, each at most `width` columns where its words
// allow: the first starts with `first_indent` spaces, the others with
// `indent`, and lines break at spaces.
std::vector<std::string> wrapped(const std::string& text, std::size_t width, std::size_t first_indent,
                                 std::size_t indent) {
  std::vector<std::string> lines{std::string(first_indent, ' ')};
  bool line_has_words = false;
  for (std::size_t at = 0; at <= text.size();) {
    const std::size_t space = std::min(text.find(' ', at), text.size());
    const std::string word = text.substr(at, space - at);
    at = space + 1;
    if (word.empty()) continue;
    if (line_has_words && lines.back().size() + 1 + word.size() > width) {
      lines.push_back(std::string(indent, ' '));
      line_has_words = false;
    }
    lines.back() += (line_has_words ? " " : "") + word;
    line_has_words = true;
  }
  return lines;
}

// "IntelCore: CPUs 0-15 (efficiency 1, up to 5200 MHz)"
std::string kind_line(const platform::cpu_kind& kind) {
  std::vector<std::string> facts;
  facts.push_back(kind.efficiency >= 0 ? fmt::format("efficiency {}", kind.efficiency) : "efficiency unknown");
  if (kind.max_mhz > 0) facts.push_back(fmt::format("up to {} MHz", kind.max_mhz));
  return fmt::format("{}: CPUs {} ({})", kind.name(), cpu_list(kind.pus), fmt::join(facts, ", "));
}

// Each NUMA node's CPUs: "node 0: CPUs 0-15".
std::vector<std::string> node_lines(const platform::topology& machine) {
  std::vector<int> nodes;
  for (const auto& pu : machine.pus())
    if (std::find(nodes.begin(), nodes.end(), pu.numa) == nodes.end()) nodes.push_back(pu.numa);
  std::sort(nodes.begin(), nodes.end());
  std::vector<std::string> lines;
  for (int node : nodes) {
    std::vector<unsigned> cpus;
    for (const auto& pu : machine.pus())
      if (pu.numa == node) cpus.push_back(pu.os_index);
    std::sort(cpus.begin(), cpus.end());
    lines.push_back(fmt::format("node {}: CPUs {}", index_or_none(node), cpu_list(cpus)));
  }
  return lines;
}

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
  text += fmt::format("packages {}, NUMA nodes {}, L3 domains {}, L2 domains {}, cores {}, PUs {}\n",
                      machine.packages(), machine.numa_nodes(), machine.l3_domains(), machine.l2_domains(),
                      machine.core_count(), machine.pu_count());
  text += fmt::format("\nNUMA nodes (the kernel's numbers):\n");
  for (const std::string& line : node_lines(machine)) text += fmt::format("  {}\n", line);
  if (machine.kinds().empty()) {
    text += fmt::format("\nCPU kinds: none reported by hwloc (every CPU one kind)\n");
  } else {
    text += fmt::format("\nCPU kinds, the most performant first (placements keep a team on one kind):\n");
    for (auto kind = machine.kinds().rbegin(); kind != machine.kinds().rend(); ++kind)
      text += fmt::format("  {}\n", kind_line(*kind));
  }
  text += fmt::format("\ncaches:\n");
  if (machine.caches().empty()) text += fmt::format("  none reported\n");
  for (const auto& cache : machine.caches()) {
    text += fmt::format("  L{} {:<12} {:>9} x {:<4} line {}\n", cache.level, cache.kind, human_size(cache.size_bytes),
                        cache.instances,
                        cache.line_bytes == 0 ? std::string("unknown") : fmt::format("{} B", cache.line_bytes));
  }
  text += fmt::format("\ncores (logical index: package, NUMA node, L3, L2, PUs by OS index{}):\n",
                      machine.kinds().empty() ? "" : ", kind");
  for (const auto& core : machine.cores()) {
    std::vector<unsigned> pus = core.pus;
    std::sort(pus.begin(), pus.end());
    const std::string kind = core.kind == platform::kNoObject
                                 ? std::string()
                                 : ", " + machine.kinds()[static_cast<std::size_t>(core.kind)].name();
    text += fmt::format("  core {:>3}: package {}, node {}, L3 {}, L2 {}, PUs {}{}\n", core.logical_index,
                        core.package, index_or_none(core.numa), index_or_none(core.l3), index_or_none(core.l2),
                        cpu_list(pus), kind);
  }
  if (machine.is_this_system()) {
    text += fmt::format("\naffinity: CPUs {} ({} of {} PUs)\n", cpu_list(machine.affinity()), machine.affinity().size(),
                        machine.pu_count());
  } else {
    text += fmt::format("\naffinity: every PU ({}; not this machine, so nothing can be pinned)\n", machine.pu_count());
  }
  text += fmt::format("\nplacement plans (thread->PU by OS index):\n");
  for (const auto& plan : plans) {
    for (const std::string& line : wrapped(plan.describe(), kTextWidth, 2, 6)) text += line + "\n";
    if (!plan.note.empty())
      for (const std::string& line : wrapped(plan.note, kTextWidth, 6, 6)) text += line + "\n";
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
                     {"numa_node", optional_index(core.numa)},
                     {"l3", optional_index(core.l3)},
                     {"l2", optional_index(core.l2)},
                     {"kind", optional_index(core.kind)},
                     {"pus", core.pus}});
  }
  nlohmann::json kinds = nlohmann::json::array();
  for (const auto& kind : machine.kinds()) {
    kinds.push_back({{"index", kind.index},
                     {"name", kind.name()},
                     {"efficiency", kind.efficiency},
                     {"core_type", kind.core_type},
                     {"max_mhz", kind.max_mhz},
                     {"pus", kind.pus}});
  }
  const platform::topology::per_cpu_table table = machine.cpu_table();
  const nlohmann::json cpu_table{{"package", table.package},
                                 {"l3", table.l3},
                                 {"numa_node", table.numa_node},
                                 {"core", table.core},
                                 {"kind", table.kind}};
  nlohmann::json plan_list = nlohmann::json::array();
  for (const auto& plan : plans) {
    nlohmann::json pus = nlohmann::json::array();
    nlohmann::json nodes = nlohmann::json::array();
    nlohmann::json pu_kinds = nlohmann::json::array();
    for (const auto& entry : plan.entries) {
      pus.push_back(entry.pu ? nlohmann::json(*entry.pu) : nlohmann::json(nullptr));
      nodes.push_back(entry.pu ? optional_index(entry.numa) : nlohmann::json(nullptr));
      pu_kinds.push_back(entry.pu ? optional_index(entry.kind) : nlohmann::json(nullptr));
    }
    nlohmann::json item{{"placement", std::string(platform::to_string(plan.kind))},
                        {"threads", plan.threads},
                        {"pus", pus},
                        {"pu_numa_nodes", nodes},
                        {"pu_kinds", pu_kinds},
                        {"numa_nodes", plan.numa_nodes},
                        {"kinds", plan.kinds},
                        {"memory_node", optional_index(plan.memory_node)},
                        {"wrapped", plan.wrapped},
                        {"oversubscribed", plan.oversubscribed},
                        {"mixed_kinds", plan.mixed_kinds},
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
          {"topology_numa_nodes", machine.numa_nodes()},
          {"topology_l3", machine.l3_domains()},
          {"topology_l2", machine.l2_domains()},
          {"topology_cores", machine.core_count()},
          {"topology_pus", machine.pu_count()},
          {"caches", caches},
          {"kinds", kinds},
          {"cores", cores},
          {"cpu_table", cpu_table},
          {"affinity", machine.affinity()},
          {"plans", plan_list}};
}

}  // namespace lockstep::bench
