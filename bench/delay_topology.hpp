#pragma once
// What the delay commands (c2c, falseshare, migrate, delay) need from hwloc:
// the CPUs they may pin to, and the relation of two CPUs (the label of a c2c
// pair). Loaded from the machine, or from a synthetic description
// (HWLOC_SYNTHETIC syntax, e.g. "pack:2 l3:2 l2:2 core:2 pu:2") so that tests
// can label the pairs of a two-socket machine on a two-core one.
//
// Local to the delay commands until platform/topology.hpp is published; the
// relation names are the agreed ones.
#include <hwloc.h>
#include <sched.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace lockstep::bench::delay {

// The five relations of two distinct CPUs, closest first.
inline constexpr const char* kSmtSiblings = "SMT siblings";        // one core
inline constexpr const char* kSharedL2 = "shared L2";              // different cores, one L2
inline constexpr const char* kSharedL3 = "shared L3";              // different L2s, one L3
inline constexpr const char* kDifferentL3 = "different L3";        // one package, no common L3
inline constexpr const char* kDifferentPackage = "different package";

struct topology_summary {
  int packages = 0;
  int l3 = 0;
  int cores = 0;
  int pus = 0;
  std::string text() const {
    return "packages=" + std::to_string(packages) + " l3=" + std::to_string(l3) +
           " cores=" + std::to_string(cores) + " pus=" + std::to_string(pus);
  }
};

class topology_view {
 public:
  // The machine this process runs on (only the CPUs it is allowed to use).
  static topology_view from_system() { return topology_view(nullptr); }
  // A synthetic machine; throws std::invalid_argument for a bad description.
  static topology_view from_synthetic(const std::string& description) { return topology_view(&description); }

  topology_view(const topology_view&) = delete;  // owns an hwloc topology
  topology_view& operator=(const topology_view&) = delete;
  topology_view(topology_view&& other) noexcept : topology_(other.topology_), synthetic_(other.synthetic_) {
    other.topology_ = nullptr;
  }
  topology_view& operator=(topology_view&&) = delete;
  ~topology_view() {
    if (topology_ != nullptr) hwloc_topology_destroy(topology_);
  }

  // The relation of two CPUs given by OS index; throws std::invalid_argument
  // when either is not a CPU of this topology or they are the same CPU.
  std::string relation(int cpu_a, int cpu_b) const {
    if (cpu_a == cpu_b) throw std::invalid_argument("a CPU has no relation to itself");
    const hwloc_obj_t a = pu(cpu_a);
    const hwloc_obj_t b = pu(cpu_b);
    if (shared(HWLOC_OBJ_CORE, a, b)) return kSmtSiblings;
    if (shared(HWLOC_OBJ_L2CACHE, a, b)) return kSharedL2;
    if (shared(HWLOC_OBJ_L3CACHE, a, b)) return kSharedL3;
    if (shared(HWLOC_OBJ_PACKAGE, a, b)) return kDifferentL3;
    return kDifferentPackage;
  }

  // CPUs (OS indices, ascending) this process may use. With
  // include_smt_siblings false, only the first usable PU of each core.
  std::vector<int> cpus(bool include_smt_siblings) const {
    cpu_set_t allowed;
    CPU_ZERO(&allowed);
    const bool check_affinity = synthetic_ ? false : ::sched_getaffinity(0, sizeof allowed, &allowed) == 0;
    std::vector<int> result;
    hwloc_obj_t last_core = nullptr;
    for (hwloc_obj_t obj = hwloc_get_next_obj_by_type(topology_, HWLOC_OBJ_PU, nullptr); obj != nullptr;
         obj = hwloc_get_next_obj_by_type(topology_, HWLOC_OBJ_PU, obj)) {
      const int cpu = static_cast<int>(obj->os_index);
      if (check_affinity && (cpu >= CPU_SETSIZE || !CPU_ISSET(static_cast<std::size_t>(cpu), &allowed))) continue;
      const hwloc_obj_t core = hwloc_get_ancestor_obj_by_type(topology_, HWLOC_OBJ_CORE, obj);
      if (!include_smt_siblings && core != nullptr && core == last_core) continue;
      last_core = core;
      result.push_back(cpu);
    }
    return result;
  }

  topology_summary summary() const {
    topology_summary s;
    s.packages = count(HWLOC_OBJ_PACKAGE);
    s.l3 = count(HWLOC_OBJ_L3CACHE);
    s.cores = count(HWLOC_OBJ_CORE);
    s.pus = count(HWLOC_OBJ_PU);
    return s;
  }

 private:
  explicit topology_view(const std::string* synthetic) : synthetic_(synthetic != nullptr) {
    if (hwloc_topology_init(&topology_) != 0) throw std::runtime_error("hwloc_topology_init failed");
    if (synthetic != nullptr && hwloc_topology_set_synthetic(topology_, synthetic->c_str()) != 0) {
      hwloc_topology_destroy(topology_);
      topology_ = nullptr;
      throw std::invalid_argument("bad synthetic topology '" + *synthetic + "'");
    }
    if (hwloc_topology_load(topology_) != 0) {
      hwloc_topology_destroy(topology_);
      topology_ = nullptr;
      throw std::runtime_error("hwloc_topology_load failed");
    }
  }

  hwloc_obj_t pu(int cpu) const {
    const hwloc_obj_t obj = cpu < 0 ? nullptr : hwloc_get_pu_obj_by_os_index(topology_, static_cast<unsigned>(cpu));
    if (obj == nullptr) throw std::invalid_argument("CPU " + std::to_string(cpu) + " is not in the topology");
    return obj;
  }

  bool shared(hwloc_obj_type_t type, hwloc_obj_t a, hwloc_obj_t b) const {
    const hwloc_obj_t above_a = hwloc_get_ancestor_obj_by_type(topology_, type, a);
    return above_a != nullptr && above_a == hwloc_get_ancestor_obj_by_type(topology_, type, b);
  }

  int count(hwloc_obj_type_t type) const {
    const int n = hwloc_get_nbobjs_by_type(topology_, type);
    return n < 0 ? 0 : n;
  }

  hwloc_topology_t topology_ = nullptr;
  bool synthetic_ = false;
};

// The hwloc release the binary was built against (the runtime library only
// reports its API version, which lags the release number).
inline std::string hwloc_version_string() { return HWLOC_VERSION; }

}  // namespace lockstep::bench::delay
