#pragma once
// Where each thread of a run goes: the placements (docs/design.md) as plans
// computed from a topology, and the call that pins a thread to its entry.
//
//   none         no affinity: every thread may run on any CPU of the affinity
//                set, the OS may migrate it (the paper's OpenMP 2.0 case)
//   compact      one thread per core, filling cores that share caches and
//                memory first: an L2 domain, then an L3 domain, then a NUMA
//                node, then a package, before the next
//   compact_smt  compact, but every hardware thread of a core before the next
//                core: SMT siblings on purpose (OpenMP's places=threads,
//                proc_bind=close); on a machine without SMT it is compact
//   scatter      one thread per core, alternating packages first, then NUMA
//                nodes, then L3 domains, then L2 domains (round-robin at each
//                level of the tree)
//   migrate      pinned like compact, but every N steps each thread moves to
//                the next entry of the compact order, on purpose, to price a
//                migration
//
// SMT siblings are used only where a placement asks for them (compact_smt)
// or where the cores run out. More threads than usable cores (cores with a
// PU in the affinity set): the plan wraps. The first round takes each core's
// first usable PU in the placement's core order; the next round each core's
// second (its SMT sibling; cores without one are skipped), and so on; past
// the last PU the rounds start again (threads then share a CPU). The plan
// then says `wrapped` (compact_smt: only when its threads outnumber the PUs);
// it says `oversubscribed` when the threads outnumber the CPUs of the affinity
// set (some threads must share a CPU), the same test `is_oversubscribed`
// makes.
//
// CPU kinds (hybrid processors, platform/topology.hpp): a team stays on one
// kind. Every pinned placement takes the most performant kind whose usable
// cores (compact_smt: PUs) hold the whole team, so that no thread of a
// lockstep team waits for a slower core; when no kind holds it, the team
// takes every kind, the most performant's cores first, and the plan says
// `mixed kinds`. To place a team on a chosen kind, give the process only that
// kind's CPUs (`taskset -c 16-23 lockstep ...`): plans use the affinity set.
//
// Plans are pure functions of (topology, placement, threads): tests check them
// against synthetic and XML topologies. Pinning needs a topology of this system.
#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "platform/topology.hpp"

namespace lockstep::platform {

enum class placement { none, compact, compact_smt, scatter, migrate };

struct placement_description {
  placement kind;
  std::string_view name;         // as in benchmark names: pin:<name>
  std::string_view description;  // one line, for `lockstep list`
  // Traits (ask these, never the name):
  bool fixed_cpus;        // each thread stays on one CPU of its own choosing for the whole run
  bool smt_siblings_first;  // fills every hardware thread of a core before the next core
};

// Every placement, in the order above (and of docs/design.md).
std::span<const placement_description> placements() noexcept;
const placement_description& describe(placement kind) noexcept;
std::string_view to_string(placement kind) noexcept;
// "none, compact, compact_smt, scatter, migrate"
std::string placement_names();
// The placement with this name; throws std::invalid_argument with one line
// that lists the valid names ("unknown placement 'x' (valid: none, compact,
// compact_smt, scatter, migrate)"). Commands rethrow it as cli::usage_error.
placement parse_placement(std::string_view name);

// How often `migrate` moves every thread unless the caller says otherwise:
// rarely enough that a step mostly runs on a warm core, often enough that a
// few-thousand-step benchmark sees several moves.
inline constexpr std::uint64_t kDefaultMigrateEverySteps = 1000;

// One thread's entry. For `none` pu and core are empty and numa, kind kNoObject.
struct thread_placement {
  unsigned thread = 0;
  std::optional<unsigned> pu;    // OS index of the PU it is pinned to
  std::optional<unsigned> core;  // logical index of that PU's core
  int numa = kNoObject;          // that PU's NUMA node (the kernel's number)
  int kind = kNoObject;          // that PU's CPU kind (topology::kinds() index), kNoObject without kinds
};

struct placement_plan {
  placement kind = placement::none;
  unsigned threads = 0;
  std::vector<thread_placement> entries;  // one per thread, at step 0
  bool wrapped = false;          // threads > usable cores: cores reused (see above)
  bool oversubscribed = false;   // threads > CPUs in the affinity set
  bool mixed_kinds = false;      // the team holds CPUs of two kinds: no one kind had room for it
  std::uint64_t migrate_every_steps = 0;  // migrate only; 0 otherwise
  // Migrate only: the cycle of entries the threads move along, max(threads,
  // usable cores) long, in compact order. In period e = step / N thread t is
  // on migrate_cycle[(t + e) % size]: every thread changes core each period
  // (when there are two cores or more) and no two threads share a slot.
  std::vector<thread_placement> migrate_cycle;
  std::vector<unsigned> affinity;         // the affinity set the plan used (OS indices)
  // The NUMA nodes of the plan's CPUs (none: of its affinity set; migrate:
  // of every CPU its cycle visits), ascending, and the kind names of those
  // CPUs, the most performant first (empty without kinds): what the plan
  // says of where it runs.
  std::vector<int> numa_nodes;
  std::vector<std::string> kinds;
  // Participant 0's NUMA node (kNoObject for none): the node a step's shared
  // lines belong on when the step is built from participant 0's CPU
  // (first_touch_scope below; docs/design.md says who builds it today).
  int memory_node = kNoObject;
  unsigned machine_numa_nodes = 1;  // the topology's NUMA nodes: describe() names the plan's when above 1
  bool machine_hybrid = false;      // the topology has two CPU kinds or more: describe() names the plan's
  bool for_this_system = false;  // pin_current_thread accepts only such plans
  std::string note;              // one line when something is worth saying, else empty

  // The PU thread `thread` runs on at step `step` (migrate: the schedule;
  // others: the fixed entry; none: empty).
  std::optional<unsigned> pu_at(unsigned thread, std::uint64_t step = 0) const;
  // True when a migrate plan moves threads before this step (step > 0 and a
  // multiple of migrate_every_steps). The harness checks it outside the timed
  // region and then calls pin_current_thread(plan, thread, step).
  bool moves_at(std::uint64_t step) const noexcept;
  // One line: "compact threads=4: 0->pu0 1->pu1 2->pu0 3->pu1 (wrapped, oversubscribed)";
  // on a machine of several NUMA nodes it names the plan's nodes ("on nodes
  // 0,1"), on a hybrid one its kinds ("on IntelCore").
  std::string describe() const;
};

// The plan for `threads` threads (>= 1; throws std::invalid_argument for 0).
// migrate_every_steps is used by `migrate` only (>= 1).
placement_plan plan_placement(const topology& machine, placement kind, unsigned threads,
                              std::uint64_t migrate_every_steps = kDefaultMigrateEverySteps);

// The cores in compact and in scatter order (logical core indices, only cores
// with a PU in the affinity set; every kind, the most performant first).
std::vector<unsigned> compact_core_order(const topology& machine);
std::vector<unsigned> scatter_core_order(const topology& machine);

// Pinning fails: not this system's plan, a CPU outside the affinity set, or
// the kernel refused. One line, with the reason.
class placement_error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Pins the calling thread to its plan entry at `step` (sched_setaffinity on
// the thread). For `none` it gives the thread the plan's whole affinity set,
// undoing any pin inherited from the thread that created it.
void pin_current_thread(const placement_plan& plan, unsigned thread, std::uint64_t step = 0);
// Pins the calling thread to one CPU (OS index).
void pin_current_thread_to_pu(unsigned os_pu);
// Lets the calling thread run on any of these CPUs.
void set_current_thread_affinity(std::span<const unsigned> os_pus);
// The CPU the calling thread runs on now (sched_getcpu), or empty: what a
// participant calls to learn where it runs.
std::optional<unsigned> current_cpu() noexcept;

// Where one participant ran over one span of a run (a repetition), as it read
// it itself with current_cpu(): at the span's start and at its end. Empty
// where the kernel would not say.
struct participant_cpus {
  std::optional<unsigned> start;
  std::optional<unsigned> end;
  bool operator==(const participant_cpus&) const = default;
};
// A team's, in participant order: what the run records for every entry and
// repetition, so that a reader of the file can check each participant
// against its plan without the binary (docs/result-files.md).
using team_cpus = std::vector<participant_cpus>;
// As the file writes it: [[start, end], ...], null where unknown.
nlohmann::json team_cpus_json(const team_cpus& seen);
// Empty when every participant read, at both ends, a CPU its plan gives it
// at that step (pinned: pu_at(thread, step); none: any CPU of the affinity
// set); else one line naming the first that did not ("participant 1,
// planned on CPU 6, read CPU 7 at the end"). A participant with no reading
// is named too: unproven is not on plan. Throws std::invalid_argument when
// `seen` does not hold one record per thread of the plan.
std::string off_plan(const placement_plan& plan, const team_cpus& seen, std::uint64_t start_step = 0,
                     std::uint64_t end_step = 0);

// Pins the calling thread to participant 0's CPU of a pinned plan of this
// system while it lives (nothing for none, or a plan of another machine),
// and gives it back the CPUs it had. Build a step inside one: the pages its
// constructor writes first are then touched from participant 0's CPU, which
// the kernel's default policy places on plan.memory_node; end() gives the
// CPUs back early (before the team starts). Pages the allocator had touched
// before (a reused heap block) stay where they were: the node a step's lines
// are on is observed with memory_nodes_of (platform/placement_memory.hpp).
class first_touch_scope {
 public:
  explicit first_touch_scope(const placement_plan& plan);
  ~first_touch_scope() { end(); }
  first_touch_scope(const first_touch_scope&) = delete;  // gives the CPUs back once
  first_touch_scope& operator=(const first_touch_scope&) = delete;
  void end() noexcept;
  // The CPU the scope pinned the thread to, or empty when it left it alone.
  std::optional<unsigned> cpu() const noexcept { return cpu_; }

 private:
  std::vector<unsigned> saved_;
  std::optional<unsigned> cpu_;
};
// The CPUs the calling thread may run on now (sched_getaffinity of the
// thread: what pinning left it), ascending; empty when the kernel will not say.
std::vector<unsigned> current_thread_affinity();

// CPUs in the process's affinity set right now (sched_getaffinity of the
// process), at least 1. Cheap enough for a primitive's constructor.
unsigned affinity_cpu_count() noexcept;
// More runnable threads than CPUs to run them: some must wait for a CPU, so
// spinning on a value another waiting thread will write is wasted time.
constexpr bool is_oversubscribed(unsigned runnable_threads, unsigned cpus) noexcept {
  return runnable_threads > cpus;
}

}  // namespace lockstep::platform
