#pragma once
// Where each thread of a run goes: the placements (docs/design.md) as plans
// computed from a topology, and the call that pins a thread to its entry.
//
//   none     no affinity: every thread may run on any CPU of the affinity set,
//            the OS may migrate it (the paper's OpenMP 2.0 case)
//   compact  one thread per core, filling cores that share caches first
//            (hwloc's logical core order: the cores of one L2, then of one L3,
//            then of one package are neighbours)
//   scatter  one thread per core, spreading across packages first, then L3
//            domains, then L2 domains (round-robin at each level of the tree)
//   migrate  pinned like compact, but every N steps each thread moves to the
//            next entry of the compact order, on purpose, to price a migration
//
// More threads than usable cores (cores with a PU in the affinity set): the
// plan wraps. Thread t takes core order[t % cores] and, on that core, its
// PU number (t / cores) % (PUs of that core): the second round lands on the
// SMT siblings when the core has them, otherwise on the same PU again. The
// plan then says `wrapped`; it says `oversubscribed` when the threads
// outnumber the CPUs of the affinity set (some threads must share a CPU), the
// same test `is_oversubscribed` makes.
//
// Plans are pure functions of (topology, placement, threads): tests check them
// against synthetic topologies. Pinning needs a topology of this system.
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "platform/topology.hpp"

namespace lockstep::platform {

enum class placement { none, compact, scatter, migrate };

struct placement_description {
  placement kind;
  std::string_view name;         // as in benchmark names: pin:<name>
  std::string_view description;  // one line, for `lockstep list`
};

// Every placement, in the order above (and of docs/design.md).
std::span<const placement_description> placements() noexcept;
std::string_view to_string(placement kind) noexcept;
// "none, compact, scatter, migrate"
std::string placement_names();
// The placement with this name; throws std::invalid_argument with one line
// that lists the valid names ("unknown placement 'x' (valid: none, compact,
// scatter, migrate)"). Commands rethrow it as cli::usage_error.
placement parse_placement(std::string_view name);

// How often `migrate` moves every thread unless the caller says otherwise:
// rarely enough that a step mostly runs on a warm core, often enough that a
// few-thousand-step benchmark sees several moves.
inline constexpr std::uint64_t kDefaultMigrateEverySteps = 1000;

// One thread's entry. For `none` both are empty.
struct thread_placement {
  unsigned thread = 0;
  std::optional<unsigned> pu;    // OS index of the PU it is pinned to
  std::optional<unsigned> core;  // logical index of that PU's core
};

struct placement_plan {
  placement kind = placement::none;
  unsigned threads = 0;
  std::vector<thread_placement> entries;  // one per thread, at step 0
  bool wrapped = false;          // threads > usable cores: cores reused (see above)
  bool oversubscribed = false;   // threads > CPUs in the affinity set
  std::uint64_t migrate_every_steps = 0;  // migrate only; 0 otherwise
  // Migrate only: the cycle of entries the threads move along, max(threads,
  // usable cores) long, in compact order. In period e = step / N thread t is
  // on migrate_cycle[(t + e) % size]: every thread changes core each period
  // (when there are two cores or more) and no two threads share a slot.
  std::vector<thread_placement> migrate_cycle;
  std::vector<unsigned> affinity;         // the affinity set the plan used (OS indices)
  bool for_this_system = false;  // pin_current_thread accepts only such plans
  std::string note;              // one line when something is worth saying, else empty

  // The PU thread `thread` runs on at step `step` (migrate: the schedule;
  // others: the fixed entry; none: empty).
  std::optional<unsigned> pu_at(unsigned thread, std::uint64_t step = 0) const;
  // True when a migrate plan moves threads before this step (step > 0 and a
  // multiple of migrate_every_steps). The harness checks it outside the timed
  // region and then calls pin_current_thread(plan, thread, step).
  bool moves_at(std::uint64_t step) const noexcept;
  // One line: "compact threads=4: 0->pu0 1->pu1 2->pu0 3->pu1 (wrapped, oversubscribed)".
  std::string describe() const;
};

// The plan for `threads` threads (>= 1; throws std::invalid_argument for 0).
// migrate_every_steps is used by `migrate` only (>= 1).
placement_plan plan_placement(const topology& machine, placement kind, unsigned threads,
                              std::uint64_t migrate_every_steps = kDefaultMigrateEverySteps);

// The cores in compact and in scatter order (logical core indices, only cores
// with a PU in the affinity set).
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
// The CPU the calling thread runs on now (sched_getcpu), or empty.
std::optional<unsigned> current_cpu() noexcept;
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
