// Placement plans from a topology, and pinning the calling thread.
#include "platform/placement.hpp"

#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <functional>
#include <tuple>

#include <fmt/format.h>

namespace lockstep::platform {

namespace {

constexpr std::array kPlacements{
    placement_description{placement::none, "none",
                          "no affinity: the OS may migrate threads (the paper's OpenMP 2.0 case)", false, false},
    placement_description{placement::compact, "compact",
                          "one thread per core, filling an L3 domain, then a NUMA node, then a package first",
                          true, false},
    placement_description{placement::compact_smt, "compact_smt",
                          "compact, but both SMT siblings of a core before the next core", true, true},
    placement_description{placement::scatter, "scatter",
                          "one thread per core, alternating packages, then NUMA nodes, then L3 domains", true,
                          false},
    placement_description{placement::migrate, "migrate",
                          "pinned like compact, moved to the next core every N steps (prices a migration)", false,
                          false},
};

// The PUs of a core that are in the affinity set, in logical order.
std::vector<unsigned> usable_pus(const core_info& core, const std::vector<unsigned>& affinity) {
  std::vector<unsigned> pus;
  for (unsigned os_index : core.pus) {
    if (std::binary_search(affinity.begin(), affinity.end(), os_index)) pus.push_back(os_index);
  }
  return pus;
}

// The levels a plan orders cores by, from the top: package, NUMA node, L3,
// L2. Compact keeps each group together; scatter deals from them in turn.
using level_key = std::function<int(const core_info&)>;
const std::array<level_key, 4>& tree_levels() {
  static const std::array<level_key, 4> kLevels{
      [](const core_info& core) { return static_cast<int>(core.package); },
      [](const core_info& core) { return core.numa; },
      [](const core_info& core) { return core.l3; },
      [](const core_info& core) { return core.l2; },
  };
  return kLevels;
}

// `cores` in groups by the key of `level`, in the order each key first appears.
std::vector<std::vector<unsigned>> group_by(const topology& machine, const std::vector<unsigned>& cores,
                                            const level_key& key_of) {
  std::vector<int> keys;
  std::vector<std::vector<unsigned>> groups;
  for (unsigned core : cores) {
    const int key = key_of(machine.cores()[core]);
    auto found = std::find(keys.begin(), keys.end(), key);
    if (found == keys.end()) {
      keys.push_back(key);
      groups.emplace_back();
      found = keys.end() - 1;
    }
    groups[static_cast<std::size_t>(found - keys.begin())].push_back(core);
  }
  return groups;
}

// Compact: the cores of one group of each level together, level by level,
// groups in the order they first appear (hwloc's logical order follows the
// tree, so this keeps it wherever the levels nest; it also keeps a NUMA node
// together where hwloc's tree does not nest it under the L3 or package).
std::vector<unsigned> gather(const topology& machine, const std::vector<unsigned>& cores, std::size_t level) {
  if (level == tree_levels().size() || cores.size() <= 1) return cores;
  std::vector<unsigned> order;
  for (const auto& group : group_by(machine, cores, tree_levels()[level])) {
    const std::vector<unsigned> inner = gather(machine, group, level + 1);
    order.insert(order.end(), inner.begin(), inner.end());
  }
  return order;
}

// Scatter: consecutive entries differ at the highest level first: group by
// the key of `level`, order each group by the next levels, then take one core
// from each group in turn.
std::vector<unsigned> interleave(const topology& machine, const std::vector<unsigned>& cores, std::size_t level) {
  if (level == tree_levels().size() || cores.size() <= 1) return cores;
  std::vector<std::vector<unsigned>> groups = group_by(machine, cores, tree_levels()[level]);
  for (auto& group : groups) group = interleave(machine, group, level + 1);
  std::vector<unsigned> order;
  for (std::size_t round = 0; order.size() < cores.size(); ++round) {
    for (const auto& group : groups) {
      if (round < group.size()) order.push_back(group[round]);
    }
  }
  return order;
}

// The usable cores (a PU in the affinity set) by kind, the most performant
// kind first; one group on a machine without kinds.
std::vector<std::vector<unsigned>> usable_cores_by_kind(const topology& machine) {
  std::vector<std::pair<unsigned, std::vector<unsigned>>> by_rank;
  for (const core_info& core : machine.cores()) {
    const std::vector<unsigned> pus = usable_pus(core, machine.affinity());
    if (pus.empty()) continue;
    const unsigned rank = machine.performance_rank(pus.front());
    auto found = std::find_if(by_rank.begin(), by_rank.end(), [rank](const auto& entry) { return entry.first == rank; });
    if (found == by_rank.end()) {
      by_rank.emplace_back(rank, std::vector<unsigned>{});
      found = by_rank.end() - 1;
    }
    found->second.push_back(core.logical_index);
  }
  std::stable_sort(by_rank.begin(), by_rank.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::vector<unsigned>> groups;
  for (auto& [rank, cores] : by_rank) groups.push_back(std::move(cores));
  return groups;
}

// The cores a team of `threads` takes, in the placement's order: the most
// performant kind with room for the whole team (a core a thread; compact_smt:
// a PU a thread), else every kind, the most performant first (mixed).
struct team_cores {
  std::vector<unsigned> order;
  bool mixed_kinds = false;
};

team_cores choose_cores(const topology& machine, placement kind, unsigned threads) {
  const bool per_pu = describe(kind).smt_siblings_first;
  const auto order_of = [&](const std::vector<unsigned>& cores) {
    return kind == placement::scatter ? interleave(machine, cores, 0) : gather(machine, cores, 0);
  };
  const std::vector<std::vector<unsigned>> kinds = usable_cores_by_kind(machine);
  for (const std::vector<unsigned>& cores : kinds) {
    std::size_t room = cores.size();
    if (per_pu) {
      room = 0;
      for (unsigned core : cores) room += usable_pus(machine.cores()[core], machine.affinity()).size();
    }
    if (room >= threads) return {order_of(cores), false};
  }
  team_cores all;
  for (const std::vector<unsigned>& cores : kinds) {
    const std::vector<unsigned> order = order_of(cores);
    all.order.insert(all.order.end(), order.begin(), order.end());
  }
  all.mixed_kinds = kinds.size() > 1;
  return all;
}

// The PUs of `order` in the order threads take them: a placement of one
// thread per core takes every core's first PU, then every core's second
// (cores without one skipped), ...; compact_smt every PU of a core before the
// next core.
std::vector<std::pair<unsigned, unsigned>> pu_slots(const topology& machine, const std::vector<unsigned>& order,
                                                    bool smt_siblings_first) {
  std::vector<std::pair<unsigned, unsigned>> slots;  // (core, PU)
  std::vector<std::vector<unsigned>> pus;
  for (unsigned core : order) pus.push_back(usable_pus(machine.cores()[core], machine.affinity()));
  if (smt_siblings_first) {
    for (std::size_t at = 0; at < order.size(); ++at)
      for (unsigned pu : pus[at]) slots.emplace_back(order[at], pu);
    return slots;
  }
  std::size_t total = 0;
  for (const auto& list : pus) total += list.size();
  for (std::size_t round = 0; slots.size() < total; ++round) {
    for (std::size_t at = 0; at < order.size(); ++at)
      if (round < pus[at].size()) slots.emplace_back(order[at], pus[at][round]);
  }
  return slots;
}

thread_placement entry_for(const topology& machine, const std::vector<std::pair<unsigned, unsigned>>& slots,
                           unsigned thread, std::uint64_t slot) {
  const auto& [core, pu] = slots[static_cast<std::size_t>(slot % slots.size())];
  const pu_info& info = machine.pu(pu);
  return thread_placement{thread, pu, core, info.numa, info.kind};
}

void set_affinity_or_throw(std::span<const unsigned> os_pus) {
  cpu_set_t mask;
  CPU_ZERO(&mask);
  for (unsigned cpu : os_pus) {
    if (cpu >= CPU_SETSIZE) throw placement_error(fmt::format("CPU {} is beyond CPU_SETSIZE", cpu));
    CPU_SET(cpu, &mask);
  }
  // pid 0: the calling thread (Linux affinity is per thread).
  if (::sched_setaffinity(0, sizeof mask, &mask) != 0) {
    const int error = errno;
    throw placement_error(fmt::format("cannot pin the thread to CPU(s) {}: {}", fmt::join(os_pus, ","),
                                      std::strerror(error)));
  }
}

}  // namespace

std::span<const placement_description> placements() noexcept { return kPlacements; }

const placement_description& describe(placement kind) noexcept {
  for (const auto& entry : kPlacements) {
    if (entry.kind == kind) return entry;
  }
  return kPlacements.front();
}

std::string_view to_string(placement kind) noexcept { return describe(kind).name; }

std::string placement_names() {
  std::string names;
  for (const auto& entry : kPlacements) {
    if (!names.empty()) names += ", ";
    names += entry.name;
  }
  return names;
}

placement parse_placement(std::string_view name) {
  for (const auto& entry : kPlacements) {
    if (entry.name == name) return entry.kind;
  }
  throw std::invalid_argument(fmt::format("unknown placement '{}' (valid: {})", name, placement_names()));
}

std::vector<unsigned> compact_core_order(const topology& machine) {
  std::vector<unsigned> order;
  for (const std::vector<unsigned>& cores : usable_cores_by_kind(machine)) {
    const std::vector<unsigned> kind_order = gather(machine, cores, 0);
    order.insert(order.end(), kind_order.begin(), kind_order.end());
  }
  return order;
}

std::vector<unsigned> scatter_core_order(const topology& machine) {
  std::vector<unsigned> order;
  for (const std::vector<unsigned>& cores : usable_cores_by_kind(machine)) {
    const std::vector<unsigned> kind_order = interleave(machine, cores, 0);
    order.insert(order.end(), kind_order.begin(), kind_order.end());
  }
  return order;
}

namespace {

// What the plan says of where it runs: its nodes, its kinds (the most
// performant first), participant 0's node.
void describe_where(const topology& machine, placement_plan& plan) {
  std::vector<unsigned> cpus;
  for (const auto* entries : {&plan.entries, &plan.migrate_cycle})  // migrate: every CPU its cycle visits
    for (const thread_placement& entry : *entries)
      if (entry.pu) cpus.push_back(*entry.pu);
  if (cpus.empty()) cpus = plan.affinity;
  std::vector<int> kinds;
  for (unsigned cpu : cpus) {
    const pu_info& info = machine.pu(cpu);
    if (std::find(plan.numa_nodes.begin(), plan.numa_nodes.end(), info.numa) == plan.numa_nodes.end())
      plan.numa_nodes.push_back(info.numa);
    if (info.kind != kNoObject && std::find(kinds.begin(), kinds.end(), info.kind) == kinds.end())
      kinds.push_back(info.kind);
  }
  std::sort(plan.numa_nodes.begin(), plan.numa_nodes.end());
  std::sort(kinds.rbegin(), kinds.rend());
  for (int kind : kinds) plan.kinds.push_back(machine.kinds()[static_cast<std::size_t>(kind)].name());
  if (plan.entries.front().pu) plan.memory_node = plan.entries.front().numa;
}

// The plan's one line worth saying, its clauses joined: what stops migrate,
// then what the team shares or mixes.
std::string plan_note(const placement_plan& plan, std::size_t cores, std::size_t one_kind_room) {
  std::vector<std::string> clauses;
  if (plan.kind == placement::migrate && cores == 1)
    clauses.emplace_back("one usable core: migrate cannot move a thread to another core");
  if (plan.oversubscribed) {
    clauses.push_back(fmt::format("oversubscribed: {} threads on {} CPUs", plan.threads, plan.affinity.size()));
  } else if (plan.wrapped) {
    clauses.push_back(fmt::format("wrapped: {} threads on {} cores share cores (SMT siblings first)", plan.threads,
                                  cores));
  }
  if (plan.mixed_kinds) {
    clauses.push_back(fmt::format("mixed kinds: {} threads, at most {} on one kind ({}), the most performant first",
                                  plan.threads, one_kind_room, fmt::join(plan.kinds, ", ")));
  }
  return fmt::format("{}", fmt::join(clauses, "; "));
}

// How many threads the roomiest kind holds (a core a thread; compact_smt a PU).
std::size_t one_kind_room(const topology& machine, bool per_pu) {
  std::size_t room = 0;
  for (const std::vector<unsigned>& cores : usable_cores_by_kind(machine)) {
    std::size_t kind_room = cores.size();
    if (per_pu) {
      kind_room = 0;
      for (unsigned core : cores) kind_room += usable_pus(machine.cores()[core], machine.affinity()).size();
    }
    room = std::max(room, kind_room);
  }
  return room;
}

}  // namespace

placement_plan plan_placement(const topology& machine, placement kind, unsigned threads,
                              std::uint64_t migrate_every_steps) {
  if (threads == 0) throw std::invalid_argument("a placement plan needs at least one thread");
  if (kind == placement::migrate && migrate_every_steps == 0) {
    throw std::invalid_argument("migrate needs a period of at least one step");
  }
  placement_plan plan;
  plan.kind = kind;
  plan.threads = threads;
  plan.affinity = machine.affinity();
  plan.for_this_system = machine.is_this_system();
  const auto cpus = static_cast<unsigned>(plan.affinity.size());
  plan.oversubscribed = is_oversubscribed(threads, cpus);

  std::size_t cores = 0;
  if (kind == placement::none) {
    for (unsigned thread = 0; thread < threads; ++thread) plan.entries.push_back({thread, {}, {}});
  } else {
    const bool per_pu = describe(kind).smt_siblings_first;
    const team_cores team = choose_cores(machine, kind, threads);
    const auto slots = pu_slots(machine, team.order, per_pu);
    cores = team.order.size();
    plan.mixed_kinds = team.mixed_kinds;
    plan.wrapped = threads > (per_pu ? slots.size() : team.order.size());
    for (unsigned thread = 0; thread < threads; ++thread) plan.entries.push_back(entry_for(machine, slots, thread, thread));
    if (kind == placement::migrate) {
      plan.migrate_every_steps = migrate_every_steps;
      const std::size_t cycle = std::max<std::size_t>(threads, team.order.size());
      for (std::size_t slot = 0; slot < cycle; ++slot)
        plan.migrate_cycle.push_back(entry_for(machine, slots, static_cast<unsigned>(slot), slot));
    }
  }
  plan.machine_numa_nodes = machine.numa_nodes();
  plan.machine_hybrid = machine.hybrid();
  describe_where(machine, plan);
  plan.note = plan_note(plan, cores, one_kind_room(machine, describe(kind).smt_siblings_first));
  return plan;
}

std::optional<unsigned> placement_plan::pu_at(unsigned thread, std::uint64_t step) const {
  if (thread >= entries.size()) {
    throw std::out_of_range(fmt::format("thread {} is not in a plan of {} threads", thread, entries.size()));
  }
  if (kind != placement::migrate || migrate_every_steps == 0) return entries[thread].pu;
  // Migrate: every period each thread advances one slot along the cycle.
  if (migrate_cycle.empty()) return entries[thread].pu;
  const std::uint64_t period = step / migrate_every_steps;
  return migrate_cycle[static_cast<std::size_t>((thread + period) % migrate_cycle.size())].pu;
}

bool placement_plan::moves_at(std::uint64_t step) const noexcept {
  return kind == placement::migrate && migrate_every_steps != 0 && step != 0 && step % migrate_every_steps == 0;
}

std::string placement_plan::describe() const {
  std::string text = fmt::format("{} threads={}:", to_string(kind), threads);
  for (const thread_placement& entry : entries) {
    if (entry.pu) {
      text += fmt::format(" {}->pu{}", entry.thread, *entry.pu);
    } else {
      text += fmt::format(" {}->any", entry.thread);
    }
  }
  if (machine_numa_nodes > 1)
    text += fmt::format(" on node{} {}", numa_nodes.size() == 1 ? "" : "s", fmt::join(numa_nodes, ","));
  if (!kinds.empty() && machine_hybrid) text += fmt::format(" on {}", fmt::join(kinds, " and "));
  std::vector<std::string> flags;
  if (kind == placement::migrate) flags.push_back(fmt::format("moves every {} steps", migrate_every_steps));
  if (wrapped) flags.emplace_back("wrapped");
  if (oversubscribed) flags.emplace_back("oversubscribed");
  if (mixed_kinds) flags.emplace_back("mixed kinds");
  if (!flags.empty()) text += fmt::format(" ({})", fmt::join(flags, ", "));
  return text;
}

nlohmann::json team_cpus_json(const team_cpus& seen) {
  const auto cpu = [](const std::optional<unsigned>& value) {
    return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
  };
  nlohmann::json list = nlohmann::json::array();
  for (const participant_cpus& participant : seen) list.push_back({cpu(participant.start), cpu(participant.end)});
  return list;
}

std::string off_plan(const placement_plan& plan, const team_cpus& seen, std::uint64_t start_step,
                     std::uint64_t end_step) {
  if (seen.size() != plan.entries.size()) {
    throw std::invalid_argument(
        fmt::format("{} participants' CPUs for a plan of {} threads", seen.size(), plan.entries.size()));
  }
  for (unsigned thread = 0; thread < seen.size(); ++thread) {
    for (const auto& [reading, step, when] : {std::tuple{seen[thread].start, start_step, "start"},
                                              std::tuple{seen[thread].end, end_step, "end"}}) {
      const std::optional<unsigned> planned = plan.pu_at(thread, step);
      const std::string where =
          planned ? fmt::format("planned on CPU {}", *planned) : std::string("free to run on its affinity set");
      if (!reading) return fmt::format("participant {}, {}, read no CPU at the {}", thread, where, when);
      const bool on_plan = planned ? *reading == *planned
                                   : std::binary_search(plan.affinity.begin(), plan.affinity.end(), *reading);
      if (!on_plan) return fmt::format("participant {}, {}, read CPU {} at the {}", thread, where, *reading, when);
    }
  }
  return {};
}

first_touch_scope::first_touch_scope(const placement_plan& plan) {
  if (!plan.for_this_system || plan.entries.empty() || !plan.entries.front().pu) return;
  saved_ = current_thread_affinity();
  if (saved_.empty()) return;
  pin_current_thread_to_pu(*plan.entries.front().pu);
  cpu_ = plan.entries.front().pu;
}

void first_touch_scope::end() noexcept {
  if (!cpu_) return;
  cpu_.reset();
  try {
    set_current_thread_affinity(saved_);
  } catch (const placement_error&) {
    // The CPUs it had are gone (a cpuset changed under the process): it keeps
    // participant 0's, which it may still run on.
  }
}

void pin_current_thread(const placement_plan& plan, unsigned thread, std::uint64_t step) {
  if (!plan.for_this_system) {
    throw placement_error("cannot pin to a plan made for another machine (synthetic or XML topology)");
  }
  const std::optional<unsigned> pu = plan.pu_at(thread, step);
  if (pu) {
    pin_current_thread_to_pu(*pu);
  } else {
    set_current_thread_affinity(plan.affinity);
  }
}

void pin_current_thread_to_pu(unsigned os_pu) {
  const std::array<unsigned, 1> one{os_pu};
  set_affinity_or_throw(one);
}

void set_current_thread_affinity(std::span<const unsigned> os_pus) {
  if (os_pus.empty()) throw placement_error("an empty CPU set cannot run a thread");
  set_affinity_or_throw(os_pus);
}

std::optional<unsigned> current_cpu() noexcept {
  const int cpu = ::sched_getcpu();
  if (cpu < 0) return std::nullopt;
  return static_cast<unsigned>(cpu);
}

std::vector<unsigned> current_thread_affinity() {
  cpu_set_t mask;
  CPU_ZERO(&mask);
  std::vector<unsigned> cpus;
  // pid 0: the calling thread, as set_affinity_or_throw sets it.
  if (::sched_getaffinity(0, sizeof mask, &mask) != 0) return cpus;
  for (unsigned cpu = 0; cpu < CPU_SETSIZE; ++cpu)
    if (CPU_ISSET(cpu, &mask)) cpus.push_back(cpu);
  return cpus;
}

unsigned affinity_cpu_count() noexcept {
  cpu_set_t mask;
  CPU_ZERO(&mask);
  if (::sched_getaffinity(::getpid(), sizeof mask, &mask) != 0) {
    const long online = ::sysconf(_SC_NPROCESSORS_ONLN);
    return online > 0 ? static_cast<unsigned>(online) : 1U;
  }
  const int count = CPU_COUNT(&mask);
  return count > 0 ? static_cast<unsigned>(count) : 1U;
}

}  // namespace lockstep::platform
