// Placement plans from a topology, and pinning the calling thread.
#include "platform/placement.hpp"

#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <functional>

#include <fmt/format.h>

namespace lockstep::platform {

namespace {

constexpr std::array kPlacements{
    placement_description{placement::none, "none",
                          "no affinity: the OS may migrate threads (the paper's OpenMP 2.0 case)"},
    placement_description{placement::compact, "compact",
                          "one thread per core, filling cores that share caches first"},
    placement_description{placement::scatter, "scatter",
                          "one thread per core, spreading across packages, then L3 domains, first"},
    placement_description{placement::migrate, "migrate",
                          "pinned like compact, moved to the next core every N steps (prices a migration)"},
};

// The PUs of a core that are in the affinity set, in logical order.
std::vector<unsigned> usable_pus(const core_info& core, const std::vector<unsigned>& affinity) {
  std::vector<unsigned> pus;
  for (unsigned os_index : core.pus) {
    if (std::binary_search(affinity.begin(), affinity.end(), os_index)) pus.push_back(os_index);
  }
  return pus;
}

// Orders `cores` so that consecutive entries differ at the highest level
// first: group by the key of `level` (first appearance order), order each
// group by the next levels, then take one core from each group in turn.
std::vector<unsigned> interleave(const topology& machine, const std::vector<unsigned>& cores, std::size_t level) {
  using key_of = std::function<int(const core_info&)>;
  static const std::array<key_of, 3> kLevels{
      [](const core_info& core) { return static_cast<int>(core.package); },
      [](const core_info& core) { return core.l3; },
      [](const core_info& core) { return core.l2; },
  };
  if (level == kLevels.size() || cores.size() <= 1) return cores;
  std::vector<int> keys;
  std::vector<std::vector<unsigned>> groups;
  for (unsigned core : cores) {
    const int key = kLevels[level](machine.cores()[core]);
    auto found = std::find(keys.begin(), keys.end(), key);
    if (found == keys.end()) {
      keys.push_back(key);
      groups.emplace_back();
      found = keys.end() - 1;
    }
    groups[static_cast<std::size_t>(found - keys.begin())].push_back(core);
  }
  for (auto& group : groups) group = interleave(machine, group, level + 1);
  std::vector<unsigned> order;
  for (std::size_t round = 0; order.size() < cores.size(); ++round) {
    for (const auto& group : groups) {
      if (round < group.size()) order.push_back(group[round]);
    }
  }
  return order;
}

// Entry `slot` of a pinned plan over `order`: the core order[slot % cores],
// and on it PU number (slot / cores) % (its usable PUs).
thread_placement entry_for(const topology& machine, const std::vector<unsigned>& order,
                           const std::vector<unsigned>& affinity, unsigned thread, std::uint64_t slot) {
  const unsigned core = order[static_cast<std::size_t>(slot % order.size())];
  const std::vector<unsigned> pus = usable_pus(machine.cores()[core], affinity);
  const auto round = static_cast<std::size_t>(slot / order.size());
  return thread_placement{thread, pus[round % pus.size()], core};
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

std::string_view to_string(placement kind) noexcept {
  for (const auto& entry : kPlacements) {
    if (entry.kind == kind) return entry.name;
  }
  return "unknown";
}

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
  for (const core_info& core : machine.cores()) {
    if (!usable_pus(core, machine.affinity()).empty()) order.push_back(core.logical_index);
  }
  return order;
}

std::vector<unsigned> scatter_core_order(const topology& machine) {
  return interleave(machine, compact_core_order(machine), 0);
}

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

  if (kind == placement::none) {
    for (unsigned thread = 0; thread < threads; ++thread) plan.entries.push_back({thread, {}, {}});
  } else {
    const std::vector<unsigned> order =
        kind == placement::scatter ? scatter_core_order(machine) : compact_core_order(machine);
    plan.wrapped = threads > order.size();
    for (unsigned thread = 0; thread < threads; ++thread) {
      plan.entries.push_back(entry_for(machine, order, plan.affinity, thread, thread));
    }
    if (kind == placement::migrate) {
      plan.migrate_every_steps = migrate_every_steps;
      const std::size_t slots = std::max<std::size_t>(threads, order.size());
      for (std::size_t slot = 0; slot < slots; ++slot) {
        plan.migrate_cycle.push_back(entry_for(machine, order, plan.affinity, static_cast<unsigned>(slot), slot));
      }
      if (order.size() == 1) plan.note = "one usable core: migrate cannot move a thread to another core";
    }
  }
  if (plan.note.empty() && plan.oversubscribed) {
    plan.note = fmt::format("oversubscribed: {} threads on {} CPUs", threads, cpus);
  } else if (plan.note.empty() && plan.wrapped) {
    plan.note = fmt::format("wrapped: {} threads on {} cores share cores (SMT siblings first)", threads,
                            compact_core_order(machine).size());
  }
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
  if (kind == placement::migrate) text += fmt::format(" (moves every {} steps)", migrate_every_steps);
  std::vector<std::string> flags;
  if (wrapped) flags.emplace_back("wrapped");
  if (oversubscribed) flags.emplace_back("oversubscribed");
  if (!flags.empty()) text += fmt::format(" ({})", fmt::join(flags, ", "));
  return text;
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
