// Loading a topology with hwloc and turning it into plain tables.
#include "platform/topology.hpp"

#include <hwloc.h>
#include <sched.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <memory>
#include <tuple>

#include <fmt/core.h>

namespace lockstep::platform {

std::string_view to_string(pu_relation relation) noexcept {
  switch (relation) {
    case pu_relation::same_pu: return "same PU";
    case pu_relation::smt_siblings: return "SMT siblings";
    case pu_relation::shared_l2: return "shared L2";
    case pu_relation::shared_l3: return "shared L3";
    case pu_relation::same_package: return "same package";
    case pu_relation::different_l3: return "different L3";
    case pu_relation::other_numa_node: return "other NUMA node";
    case pu_relation::different_package: return "different package";
  }
  return "unknown";
}

std::string_view hwloc_compile_version() noexcept { return HWLOC_VERSION; }

namespace {

// Owns an hwloc topology for the duration of one load.
struct hwloc_handle {
  hwloc_topology_t handle = nullptr;
  hwloc_handle() {
    if (hwloc_topology_init(&handle) != 0) throw topology_error("hwloc_topology_init failed");
  }
  ~hwloc_handle() { hwloc_topology_destroy(handle); }
  hwloc_handle(const hwloc_handle&) = delete;  // owns the hwloc topology
  hwloc_handle& operator=(const hwloc_handle&) = delete;
};

int logical_or_none(hwloc_obj_t object) {
  return object == nullptr ? kNoObject : static_cast<int>(object->logical_index);
}

// The nearest ancestor of this type, or nullptr (hwloc's inline helper does
// the same but trips GCC's -Wnull-dereference at -O2).
hwloc_obj_t ancestor_of_type(hwloc_obj_t object, hwloc_obj_type_t type) {
  for (hwloc_obj_t parent = object != nullptr ? object->parent : nullptr; parent != nullptr; parent = parent->parent) {
    if (parent->type == type) return parent;
  }
  return nullptr;
}

// The L2 / L3 ancestor of a PU: a data or unified cache of that level.
hwloc_obj_t cache_ancestor(hwloc_obj_t pu, unsigned level) {
  for (hwloc_obj_t parent = pu != nullptr ? pu->parent : nullptr; parent != nullptr; parent = parent->parent) {
    if (hwloc_obj_type_is_dcache(parent->type) && parent->attr->cache.depth == level) return parent;
  }
  return nullptr;
}

std::string_view cache_kind(hwloc_obj_cache_type_t type) {
  switch (type) {
    case HWLOC_OBJ_CACHE_DATA: return "data";
    case HWLOC_OBJ_CACHE_INSTRUCTION: return "instruction";
    case HWLOC_OBJ_CACHE_UNIFIED: return "unified";
  }
  return "unknown";
}

// Each PU's NUMA node, by OS index: the node whose CPU set holds it. Where
// two nodes hold one PU (a node of ordinary memory and one of HBM or CXL
// memory beside it, which hwloc marks with a subtype), the ordinary one is
// the PU's: its memory is where the kernel puts a page that PU touches first
// by default. Among equals, the first in hwloc's order.
std::map<unsigned, int> numa_node_of_pus(hwloc_topology_t handle) {
  std::map<unsigned, int> node_of;
  const int count = hwloc_get_nbobjs_by_type(handle, HWLOC_OBJ_NUMANODE);
  for (const bool ordinary : {true, false}) {
    for (int index = 0; index < count; ++index) {
      hwloc_obj_t node = hwloc_get_obj_by_type(handle, HWLOC_OBJ_NUMANODE, static_cast<unsigned>(index));
      if (node == nullptr || node->cpuset == nullptr || (node->subtype == nullptr) != ordinary) continue;
      unsigned pu = 0;
      hwloc_bitmap_foreach_begin(pu, node->cpuset) {
        node_of.try_emplace(pu, static_cast<int>(node->os_index));
      }
      hwloc_bitmap_foreach_end();
    }
  }
  return node_of;
}

struct bitmap_deleter {
  void operator()(hwloc_bitmap_s* bitmap) const noexcept { hwloc_bitmap_free(bitmap); }
};

// hwloc's CPU kinds, least performant first (its order), with the PUs of
// each; empty when hwloc reports none.
std::vector<cpu_kind> read_cpu_kinds(hwloc_topology_t handle) {
  std::vector<cpu_kind> kinds;
  const int count = hwloc_cpukinds_get_nr(handle, 0);
  if (count <= 0) return kinds;
  const std::unique_ptr<hwloc_bitmap_s, bitmap_deleter> cpuset(hwloc_bitmap_alloc());
  if (!cpuset) return kinds;
  for (int index = 0; index < count; ++index) {
    int efficiency = -1;
    unsigned infos_count = 0;
    hwloc_info_s* infos = nullptr;
    if (hwloc_cpukinds_get_info(handle, static_cast<unsigned>(index), cpuset.get(), &efficiency, &infos_count, &infos,
                                0) != 0) {
      continue;
    }
    cpu_kind kind;
    kind.index = static_cast<unsigned>(kinds.size());
    kind.efficiency = efficiency;
    for (unsigned info = 0; info < infos_count; ++info) {
      const std::string_view name = infos[info].name != nullptr ? infos[info].name : "";
      const char* value = infos[info].value != nullptr ? infos[info].value : "";
      if (name == "CoreType") kind.core_type = value;
      if (name == "FrequencyMaxMHz") kind.max_mhz = static_cast<unsigned>(std::strtoul(value, nullptr, 10));
    }
    unsigned pu = 0;
    hwloc_bitmap_foreach_begin(pu, cpuset.get()) { kind.pus.push_back(pu); }
    hwloc_bitmap_foreach_end();
    kinds.push_back(std::move(kind));
  }
  return kinds;
}

// A comma list with one entry per OS index from 0 to the highest: value(pu)
// where the topology has that PU, "-" where it has not.
template <class Value>
std::string per_cpu_list(const std::vector<pu_info>& pus, Value value) {
  unsigned highest = 0;
  for (const pu_info& pu : pus) highest = std::max(highest, pu.os_index);
  std::vector<std::string> cells(static_cast<std::size_t>(highest) + 1, "-");
  for (const pu_info& pu : pus) cells[pu.os_index] = value(pu);
  std::string text;
  for (const std::string& cell : cells) {
    if (!text.empty()) text += ',';
    text += cell;
  }
  return text;
}

// The caches, grouped by (level, kind); the size and line of the first instance.
std::vector<cache_info> read_caches(hwloc_topology_t handle) {
  std::map<std::tuple<unsigned, int>, cache_info> caches;
  for (hwloc_obj_type_t type : {HWLOC_OBJ_L1CACHE, HWLOC_OBJ_L2CACHE, HWLOC_OBJ_L3CACHE, HWLOC_OBJ_L4CACHE,
                                HWLOC_OBJ_L5CACHE, HWLOC_OBJ_L1ICACHE, HWLOC_OBJ_L2ICACHE, HWLOC_OBJ_L3ICACHE}) {
    const int count = hwloc_get_nbobjs_by_type(handle, type);
    for (int index = 0; index < count; ++index) {
      hwloc_obj_t cache = hwloc_get_obj_by_type(handle, type, static_cast<unsigned>(index));
      if (cache == nullptr || cache->attr == nullptr) continue;
      const auto& attributes = cache->attr->cache;
      auto [slot, inserted] = caches.try_emplace({attributes.depth, static_cast<int>(attributes.type)});
      if (inserted) {
        slot->second.level = attributes.depth;
        slot->second.kind = std::string(cache_kind(attributes.type));
        slot->second.size_bytes = attributes.size;
        slot->second.line_bytes = attributes.linesize;
      }
      ++slot->second.instances;
    }
  }
  std::vector<cache_info> result;
  for (auto& [key, cache] : caches) result.push_back(std::move(cache));
  return result;
}

// CPUs of the calling process (its main thread's mask), or empty if unknown.
std::vector<unsigned> process_affinity() {
  std::vector<unsigned> cpus;
  cpu_set_t mask;
  CPU_ZERO(&mask);
  if (::sched_getaffinity(::getpid(), sizeof mask, &mask) != 0) return cpus;
  for (unsigned cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
    if (CPU_ISSET(cpu, &mask)) cpus.push_back(cpu);
  }
  return cpus;
}

}  // namespace

// Reads the loaded hwloc topology into the tables of `topology`.
struct topology_loader {
  static topology load(hwloc_handle& hwloc, std::string source) {
    if (hwloc_topology_load(hwloc.handle) != 0) {
      throw topology_error(fmt::format("hwloc could not load the topology ({})", source));
    }
    hwloc_topology_t handle = hwloc.handle;
    topology machine;
    machine.source_ = std::move(source);
    machine.is_this_system_ = hwloc_topology_is_thissystem(handle) != 0;
    const char* version = hwloc_obj_get_info_by_name(hwloc_get_root_obj(handle), "hwlocVersion");
    machine.hwloc_version_ = version != nullptr ? version : std::string(hwloc_compile_version());

    const int packages = hwloc_get_nbobjs_by_type(handle, HWLOC_OBJ_PACKAGE);
    machine.packages_ = packages > 0 ? static_cast<unsigned>(packages) : 1U;
    const std::map<unsigned, int> numa_of = numa_node_of_pus(handle);
    machine.kinds_ = read_cpu_kinds(handle);

    // Cores are built from the PUs: a PU without a Core ancestor (a synthetic
    // "package:2 pu:4") is its own core, as the kernel would schedule it.
    std::map<hwloc_obj_t, unsigned> core_of_object;
    std::vector<int> l2_seen;
    std::vector<int> l3_seen;
    const int pu_total = hwloc_get_nbobjs_by_type(handle, HWLOC_OBJ_PU);
    if (pu_total <= 0) throw topology_error(fmt::format("hwloc found no PU ({})", machine.source_));
    for (int index = 0; index < pu_total; ++index) {
      hwloc_obj_t pu = hwloc_get_obj_by_type(handle, HWLOC_OBJ_PU, static_cast<unsigned>(index));
      if (pu == nullptr) continue;
      hwloc_obj_t core = ancestor_of_type(pu, HWLOC_OBJ_CORE);
      hwloc_obj_t core_key = core != nullptr ? core : pu;
      hwloc_obj_t package = ancestor_of_type(pu, HWLOC_OBJ_PACKAGE);

      pu_info info;
      info.os_index = pu->os_index;
      info.logical_index = pu->logical_index;
      info.l2 = logical_or_none(cache_ancestor(pu, 2));
      info.l3 = logical_or_none(cache_ancestor(pu, 3));
      info.package = package != nullptr ? package->logical_index : 0U;
      if (const auto node = numa_of.find(info.os_index); node != numa_of.end()) info.numa = node->second;
      for (const cpu_kind& kind : machine.kinds_) {
        if (std::binary_search(kind.pus.begin(), kind.pus.end(), info.os_index)) info.kind = static_cast<int>(kind.index);
      }

      auto [slot, inserted] = core_of_object.try_emplace(core_key, static_cast<unsigned>(machine.cores_.size()));
      if (inserted) {
        core_info new_core;
        new_core.logical_index = slot->second;
        new_core.package = info.package;
        new_core.l2 = info.l2;
        new_core.l3 = info.l3;
        new_core.numa = info.numa;
        new_core.kind = info.kind;
        machine.cores_.push_back(std::move(new_core));
      }
      info.core = slot->second;
      machine.cores_[slot->second].pus.push_back(info.os_index);
      machine.pus_.push_back(info);
      if (info.l2 != kNoObject && std::find(l2_seen.begin(), l2_seen.end(), info.l2) == l2_seen.end()) {
        l2_seen.push_back(info.l2);
      }
      if (info.l3 != kNoObject && std::find(l3_seen.begin(), l3_seen.end(), info.l3) == l3_seen.end()) {
        l3_seen.push_back(info.l3);
      }
    }
    std::vector<int> nodes;
    for (const pu_info& pu : machine.pus_) {
      if (pu.numa != kNoObject && std::find(nodes.begin(), nodes.end(), pu.numa) == nodes.end()) nodes.push_back(pu.numa);
    }
    machine.numa_nodes_ = std::max<unsigned>(1U, static_cast<unsigned>(nodes.size()));
    machine.l2_domains_ = static_cast<unsigned>(l2_seen.size());
    machine.l3_domains_ = static_cast<unsigned>(l3_seen.size());

    machine.caches_ = read_caches(handle);

    // The affinity set: every PU for a machine that is not this one.
    std::vector<unsigned> allowed;
    if (machine.is_this_system_) allowed = process_affinity();
    for (const pu_info& pu : machine.pus_) {
      if (!machine.is_this_system_ || std::find(allowed.begin(), allowed.end(), pu.os_index) != allowed.end()) {
        machine.affinity_.push_back(pu.os_index);
      }
    }
    if (machine.affinity_.empty()) {
      for (const pu_info& pu : machine.pus_) machine.affinity_.push_back(pu.os_index);
    }
    std::sort(machine.affinity_.begin(), machine.affinity_.end());
    return machine;
  }
};

topology topology::this_machine() {
  hwloc_handle hwloc;
  return topology_loader::load(hwloc, "this machine");
}

topology topology::from_synthetic(std::string_view description) {
  hwloc_handle hwloc;
  const std::string text(description);
  if (text.find_first_not_of(" \t") == std::string::npos ||
      hwloc_topology_set_synthetic(hwloc.handle, text.c_str()) != 0) {
    throw topology_error(fmt::format(
        "invalid synthetic topology '{}' (hwloc's syntax, e.g. \"package:2 l3:2 core:4 pu:2\")", text));
  }
  return topology_loader::load(hwloc, "synthetic: " + text);
}

topology topology::from_xml_file(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0 || !S_ISREG(info.st_mode)) {
    throw topology_error(fmt::format("cannot read topology file '{}' (save one with `lstopo FILE.xml`)", path));
  }
  hwloc_handle hwloc;
  if (hwloc_topology_set_xml(hwloc.handle, path.c_str()) != 0) {
    throw topology_error(fmt::format("'{}' is not an hwloc XML topology (save one with `lstopo FILE.xml`)", path));
  }
  try {
    return topology_loader::load(hwloc, "xml: " + path);
  } catch (const topology_error&) {
    throw topology_error(fmt::format("'{}' is not an hwloc XML topology (save one with `lstopo FILE.xml`)", path));
  }
}

bool topology::has_pu(unsigned os_index) const noexcept {
  return std::any_of(pus_.begin(), pus_.end(), [os_index](const pu_info& pu) { return pu.os_index == os_index; });
}

const pu_info& topology::pu(unsigned os_index) const {
  for (const pu_info& candidate : pus_) {
    if (candidate.os_index == os_index) return candidate;
  }
  throw topology_error(fmt::format("no PU with OS index {} in this topology ({} PUs)", os_index, pus_.size()));
}

pu_relation topology::relation(unsigned os_pu_a, unsigned os_pu_b) const {
  const pu_info& a = pu(os_pu_a);
  const pu_info& b = pu(os_pu_b);
  if (a.os_index == b.os_index) return pu_relation::same_pu;
  if (a.core == b.core) return pu_relation::smt_siblings;
  if (a.l2 != kNoObject && a.l2 == b.l2) return pu_relation::shared_l2;
  if (a.package != b.package) return pu_relation::different_package;
  if (a.numa != b.numa) return pu_relation::other_numa_node;
  if (a.l3 != kNoObject && a.l3 == b.l3) return pu_relation::shared_l3;
  return a.l3 == kNoObject && b.l3 == kNoObject ? pu_relation::same_package : pu_relation::different_l3;
}

std::string cpu_kind::name() const { return core_type.empty() ? fmt::format("kind {}", index) : core_type; }

unsigned topology::performance_rank(unsigned os_index) const {
  const int kind = pu(os_index).kind;
  return kind == kNoObject ? 0U : static_cast<unsigned>(kind);
}

std::string topology::kind_name(unsigned os_index) const {
  const int kind = pu(os_index).kind;
  return kind == kNoObject ? std::string() : kinds_[static_cast<std::size_t>(kind)].name();
}

topology::per_cpu_table topology::cpu_table() const {
  const auto index = [](int value) { return value == kNoObject ? std::string("-") : std::to_string(value); };
  per_cpu_table table;
  table.package = per_cpu_list(pus_, [](const pu_info& pu) { return std::to_string(pu.package); });
  table.l3 = per_cpu_list(pus_, [&](const pu_info& pu) { return index(pu.l3); });
  table.numa_node = per_cpu_list(pus_, [&](const pu_info& pu) { return index(pu.numa); });
  table.core = per_cpu_list(pus_, [](const pu_info& pu) { return std::to_string(pu.core); });
  table.kind = per_cpu_list(pus_, [&](const pu_info& pu) { return index(pu.kind); });
  for (const cpu_kind& kind : kinds_) table.kinds += (table.kinds.empty() ? "" : ",") + kind.name();
  return table;
}

void topology::restrict_affinity(std::vector<unsigned> os_indices) {
  if (os_indices.empty()) throw topology_error("an affinity set needs at least one CPU");
  for (unsigned os_index : os_indices) {
    if (!has_pu(os_index)) throw topology_error(fmt::format("no PU with OS index {} in this topology", os_index));
  }
  std::sort(os_indices.begin(), os_indices.end());
  os_indices.erase(std::unique(os_indices.begin(), os_indices.end()), os_indices.end());
  affinity_ = std::move(os_indices);
}

std::string topology::summary() const {
  std::string text = fmt::format("packages={} l3={} cores={} pus={}", packages_, l3_domains_, core_count(), pu_count());
  if (numa_nodes_ > 1) text += fmt::format(" numa={}", numa_nodes_);
  if (hybrid()) text += fmt::format(" kinds={}", kinds_.size());
  return text;
}

}  // namespace lockstep::platform
