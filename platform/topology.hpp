#pragma once
// The machine as hwloc sees it: packages, NUMA nodes, L3 domains, cores, PUs,
// CPU kinds, caches, the CPUs this process may run on, and how two PUs relate.
//
// hwloc is the only source of topology in lockstep. A topology is loaded once
// (this machine, a synthetic description, or an XML file exported by
// `lstopo foo.xml`) and turned into plain tables; the hwloc handle is released
// at the end of the load, so a `topology` is a cheap, copyable value that
// never calls hwloc again. That makes it safe to share read-only between
// threads and lets the placement logic run against a 2-socket description on
// a 2-core VM.
//
// Indices: `os_index` is the number the kernel uses (sched_setaffinity,
// /proc/cpuinfo "processor"), and so is a NUMA node's (`numa`: node N of
// numactl and /sys/devices/system/node/nodeN, hwloc's OS index of the node);
// every other index (core, l2, l3, package) is hwloc's logical index of that
// object, which follows the tree, so cores that share caches have
// neighbouring logical indices. A CPU kind is hwloc's kind index (0 is the
// kind hwloc ranks least performant; see cpu_kind).
//
// Load it early: for this machine the affinity set is read from the main
// thread at load time, so load it before anything pins a thread.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace lockstep::platform {

// A topology that cannot be loaded or a description that hwloc cannot parse.
// The message is one line and says what was wrong.
class topology_error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// How two PUs relate, from closest to farthest. c2c labels each pair with this.
// Memory comes before caches within a package: two PUs of one package on two
// NUMA nodes are other_numa_node even where hwloc shows them one L3 (Intel's
// sub-NUMA clustering homes each line in its own cluster's slice of it).
enum class pu_relation {
  same_pu,            // the same hardware thread
  smt_siblings,       // two hardware threads of one core
  shared_l2,          // different cores behind one L2
  shared_l3,          // different L2 (or no L2 object), one L3, one NUMA node
  same_package,       // one package and node, but the package has no L3 object to share
  different_l3,       // one package and NUMA node, different L3 domains
  other_numa_node,    // one package, two NUMA nodes (AMD's NPS2/NPS4, sub-NUMA clustering)
  different_package,  // different packages (sockets); c2c states both nodes beside it
};

// Every relation, closest first: the order of the enum, which c2c writes
// into its file so that readers rank a label without a table of their own.
inline constexpr pu_relation kRelationsClosestFirst[] = {
    pu_relation::same_pu,      pu_relation::smt_siblings, pu_relation::shared_l2,
    pu_relation::shared_l3,    pu_relation::same_package, pu_relation::different_l3,
    pu_relation::other_numa_node, pu_relation::different_package,
};

// "SMT siblings", "shared L2", "shared L3", "same package", "different L3",
// "other NUMA node", "different package", "same PU": the labels of
// `lockstep c2c` and its JSON.
std::string_view to_string(pu_relation relation) noexcept;

// Ancestor index that does not exist in this topology (a synthetic description
// without an L2 level, a machine without an L3).
inline constexpr int kNoObject = -1;

struct pu_info {
  unsigned os_index = 0;       // the kernel's CPU number
  unsigned logical_index = 0;  // hwloc's logical PU index
  unsigned core = 0;           // logical index of its core
  int l2 = kNoObject;          // logical index of its L2 cache, or kNoObject
  int l3 = kNoObject;          // logical index of its L3 cache, or kNoObject
  unsigned package = 0;        // logical index of its package (0 when hwloc has none)
  int numa = kNoObject;        // the kernel's number of its NUMA node, or kNoObject (see topology.cpp)
  int kind = kNoObject;        // index of its CPU kind in kinds(), or kNoObject when hwloc reports none
};

struct core_info {
  unsigned logical_index = 0;
  unsigned package = 0;
  int l3 = kNoObject;
  int l2 = kNoObject;
  int numa = kNoObject;       // its first PU's
  int kind = kNoObject;       // its first PU's (hwloc gives every PU of a core one kind)
  std::vector<unsigned> pus;  // OS indices of its PUs, in logical order
};

// A kind of CPU core (a hybrid processor's performance and efficiency cores,
// ARM's big.LITTLE), as hwloc's cpukinds report it. hwloc lists kinds from the
// least to the most performant (hwloc_cpukinds_get_info), ranking them by the
// efficiency the OS reports, else by its CoreType, else by frequency; a
// homogeneous machine has one kind or none.
struct cpu_kind {
  unsigned index = 0;           // hwloc's kind index: 0 the least performant
  int efficiency = -1;          // hwloc's efficiency rank, -1 when hwloc could not rank the kinds
  std::string core_type;        // hwloc's CoreType info ("IntelCore", "IntelAtom"), empty when absent
  unsigned max_mhz = 0;         // hwloc's FrequencyMaxMHz info, 0 when absent
  std::vector<unsigned> pus;    // OS indices of its PUs, ascending
  // What the reports call it: its CoreType, else "kind N".
  std::string name() const;
};

struct cache_info {
  unsigned level = 0;           // 1, 2, 3, ...
  std::string kind;             // "data", "instruction" or "unified"
  std::uint64_t size_bytes = 0; // size of one instance
  unsigned line_bytes = 0;      // 0 when hwloc does not know it
  unsigned instances = 0;       // how many of them the machine has
};

class topology {
 public:
  // This machine (hwloc's native discovery; HWLOC_SYNTHETIC / HWLOC_XMLFILE in
  // the environment are honoured by hwloc itself, and is_this_system() then
  // says false). The affinity set is the process's CPU set at load time.
  static topology this_machine();

  // A synthetic machine in hwloc's syntax, e.g. "package:2 l3:2 core:4 pu:2"
  // (levels from the top: package, numa, l3, l2, l1, core, pu). Every PU is in
  // the affinity set. Throws topology_error when hwloc rejects the text.
  static topology from_synthetic(std::string_view description);

  // A machine saved with `lstopo file.xml` (or hwloc_topology_export_xml).
  // Throws topology_error when the file is missing or not a topology.
  static topology from_xml_file(const std::string& path);

  // Counts as hwloc reports them (packages: at least 1; a topology without
  // Package objects is one package; l3_domains() is 0 when there is no L3;
  // numa_nodes() counts the nodes that hold a PU, at least 1: a node of
  // memory alone, such as CXL or HBM without CPUs, places no thread).
  unsigned packages() const noexcept { return packages_; }
  unsigned numa_nodes() const noexcept { return numa_nodes_; }
  unsigned l3_domains() const noexcept { return l3_domains_; }
  unsigned l2_domains() const noexcept { return l2_domains_; }
  unsigned core_count() const noexcept { return static_cast<unsigned>(cores_.size()); }
  unsigned pu_count() const noexcept { return static_cast<unsigned>(pus_.size()); }

  const std::vector<core_info>& cores() const noexcept { return cores_; }
  const std::vector<pu_info>& pus() const noexcept { return pus_; }  // logical order
  const std::vector<cache_info>& caches() const noexcept { return caches_; }
  // hwloc's CPU kinds in its order (the least performant first); empty when
  // hwloc reports none. hybrid(): two kinds or more.
  const std::vector<cpu_kind>& kinds() const noexcept { return kinds_; }
  bool hybrid() const noexcept { return kinds_.size() > 1; }
  // How performant a PU's kind is, for placement: the kind's index (hwloc
  // lists kinds least performant first), 0 for every PU when hwloc reports no
  // kind. Higher is more performant.
  unsigned performance_rank(unsigned os_index) const;
  // The name of a PU's kind (cpu_kind::name), or empty when hwloc reports none.
  std::string kind_name(unsigned os_index) const;

  // OS indices of the PUs this process may run on (sched_getaffinity at load
  // time, intersected with the topology), ascending.
  const std::vector<unsigned>& affinity() const noexcept { return affinity_; }
  // Pretend the process may run only on these PUs (tests; `taskset` does the
  // same for real). Throws topology_error for an index the topology lacks or
  // an empty set.
  void restrict_affinity(std::vector<unsigned> os_indices);

  // The PU with this OS index; throws topology_error when there is none.
  const pu_info& pu(unsigned os_index) const;
  bool has_pu(unsigned os_index) const noexcept;

  // How the PUs with these OS indices relate (throws topology_error for an
  // unknown index).
  pu_relation relation(unsigned os_pu_a, unsigned os_pu_b) const;

  // The agreed one-line form: "packages=1 l3=1 cores=2 pus=2", with
  // " numa=N" when the PUs sit on two NUMA nodes or more and " kinds=K" on a
  // hybrid machine ("packages=2 l3=4 cores=16 pus=32 numa=2"), so that a
  // machine of one node and kind reads as it always has.
  std::string summary() const;

  // Each CPU's package, L3 domain, NUMA node, core and kind as comma lists
  // whose position is the CPU's OS index ("0,0,1,1"; "-" where the kernel has
  // no such CPU or the CPU has no such object): the compact per-CPU table of
  // the result context and `lockstep topology --out` (docs/result-files.md).
  // kinds lists the kind names by index ("IntelAtom,IntelCore"; empty
  // without kinds).
  struct per_cpu_table {
    std::string package;
    std::string l3;
    std::string numa_node;
    std::string core;
    std::string kind;
    std::string kinds;
  };
  per_cpu_table cpu_table() const;
  // Where it came from: "this machine", "synthetic: <text>", "xml: <path>".
  const std::string& source() const noexcept { return source_; }
  // True only when the tables describe the machine this process runs on, i.e.
  // when pinning a thread by these OS indices means something.
  bool is_this_system() const noexcept { return is_this_system_; }
  // The hwloc library version that loaded it, e.g. "2.9.0".
  const std::string& hwloc_version() const noexcept { return hwloc_version_; }

 private:
  topology() = default;
  friend struct topology_loader;

  std::string source_;
  bool is_this_system_ = false;
  std::string hwloc_version_;
  unsigned packages_ = 1;
  unsigned numa_nodes_ = 1;
  unsigned l3_domains_ = 0;
  unsigned l2_domains_ = 0;
  std::vector<core_info> cores_;
  std::vector<pu_info> pus_;
  std::vector<cache_info> caches_;
  std::vector<cpu_kind> kinds_;
  std::vector<unsigned> affinity_;
};

// The hwloc version this binary was compiled against, e.g. "2.9.0".
std::string_view hwloc_compile_version() noexcept;

}  // namespace lockstep::platform
