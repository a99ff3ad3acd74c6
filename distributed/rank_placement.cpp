// Where the ranks run and whether two must share a CPU (rank_placement.hpp).
#include "distributed/rank_placement.hpp"

#include <fmt/core.h>
#include <fmt/ranges.h>
#include <sched.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>
#include <map>

#include "distributed/yield_when_idle.hpp"

namespace lockstep::distributed {
namespace {

// The first line of a small file, trimmed; empty when it cannot be read.
std::string first_line(const char* path) {
  std::ifstream file(path);
  std::string line;
  if (!file || !std::getline(file, line)) return {};
  while (!line.empty() && (line.back() == ' ' || line.back() == '\n' || line.back() == '\r')) line.pop_back();
  return line;
}

bool contains(const std::vector<unsigned>& sorted, unsigned cpu) {
  return std::binary_search(sorted.begin(), sorted.end(), cpu);
}

// "0", "0 and 1", "0, 1 and 2".
template <typename T>
std::string listed(const std::vector<T>& items) {
  std::string text;
  for (std::size_t index = 0; index < items.size(); ++index) {
    if (index != 0) text += index + 1 == items.size() ? " and " : ", ";
    text += fmt::format("{}", items[index]);
  }
  return text;
}

// Kuhn's augmenting path: gives rank `index` a CPU of `allowed[index]`,
// moving ranks that hold one to another of theirs. `owner`: CPU -> index.
bool augment(std::size_t index, const std::vector<std::vector<unsigned>>& allowed, std::map<unsigned, std::size_t>& owner,
             std::vector<std::optional<unsigned>>& assigned, std::vector<bool>& visited_cpu,
             const std::map<unsigned, std::size_t>& position) {
  for (unsigned cpu : allowed[index]) {
    const std::size_t at = position.at(cpu);
    if (visited_cpu[at]) continue;
    visited_cpu[at] = true;
    const auto held = owner.find(cpu);
    if (held == owner.end() || augment(held->second, allowed, owner, assigned, visited_cpu, position)) {
      owner[cpu] = index;
      assigned[index] = cpu;
      return true;
    }
  }
  return false;
}

// A maximum matching of the machine's ranks (by index) to their allowed
// CPUs, each rank trying `preferred` first; `assigned` as it left them.
// `allowed` lists are in the order ranks try CPUs in (plan_machine's: the
// plan's), not ascending, so membership is a search, not a binary search.
std::vector<std::optional<unsigned>> maximum_matching(const std::vector<std::vector<unsigned>>& allowed,
                                                      const std::vector<std::optional<unsigned>>& preferred,
                                                      std::map<unsigned, std::size_t>& owner,
                                                      const std::map<unsigned, std::size_t>& position) {
  std::vector<std::optional<unsigned>> assigned(allowed.size());
  for (std::size_t index = 0; index < allowed.size(); ++index) {
    const std::optional<unsigned> cpu = preferred[index];
    if (cpu && std::find(allowed[index].begin(), allowed[index].end(), *cpu) != allowed[index].end() &&
        owner.find(*cpu) == owner.end()) {
      owner[*cpu] = index;
      assigned[index] = *cpu;
    }
  }
  for (std::size_t index = 0; index < allowed.size(); ++index) {
    if (assigned[index]) continue;
    std::vector<bool> visited_cpu(position.size(), false);
    (void)augment(index, allowed, owner, assigned, visited_cpu, position);
  }
  return assigned;
}

// The plan of `kind` for all of a machine's ranks, over every CPU one of
// them was given that this topology knows (a container's topology may lack
// another container's CPUs).
platform::placement_plan plan_over_machine(const platform::topology& hardware, platform::placement kind,
                                           const machine& ranks) {
  std::vector<unsigned> cpus;
  for (unsigned cpu : ranks.cpus)
    if (hardware.has_pu(cpu)) cpus.push_back(cpu);
  platform::topology all = hardware;
  if (!cpus.empty()) all.restrict_affinity(cpus);
  return platform::plan_placement(all, kind, static_cast<unsigned>(ranks.ranks.size()));
}

std::string hosts_clause(const machine& ranks) {
  return ranks.hosts.size() == 1 ? "host " + ranks.hosts.front()
                                 : fmt::format("hosts {} (one kernel, {})", listed(ranks.hosts), ranks.kernel);
}

}  // namespace

std::string kernel_identity(const platform::topology& hardware, const std::string& host) {
  if (const std::string boot = first_line("/proc/sys/kernel/random/boot_id"); !boot.empty()) return "boot id " + boot;
  std::string id = first_line("/etc/machine-id");
  if (id.empty()) id = first_line("/var/lib/dbus/machine-id");
  if (!id.empty()) {
    std::vector<unsigned> pus;
    for (const auto& pu : hardware.pus()) pus.push_back(pu.os_index);
    std::sort(pus.begin(), pus.end());
    return fmt::format("machine id {}, {}, PUs {}", id, hardware.summary(), fmt::join(pus, ","));
  }
  return "host " + host;
}

std::vector<machine> machines_of(std::span<const rank_report> reports) {
  std::vector<machine> result;
  for (const rank_report& report : reports) {
    auto found = std::find_if(result.begin(), result.end(),
                              [&](const machine& known) { return known.kernel == report.kernel; });
    if (found == result.end()) {
      result.push_back({report.kernel, {}, {}, {}});
      found = result.end() - 1;
    }
    if (std::find(found->hosts.begin(), found->hosts.end(), report.host) == found->hosts.end())
      found->hosts.push_back(report.host);
    found->ranks.push_back(report.rank);
    found->cpus.insert(found->cpus.end(), report.cpus_given.begin(), report.cpus_given.end());
  }
  for (machine& each : result) {
    std::sort(each.cpus.begin(), each.cpus.end());
    each.cpus.erase(std::unique(each.cpus.begin(), each.cpus.end()), each.cpus.end());
  }
  return result;
}

std::vector<std::vector<unsigned>> plan_machine(const platform::topology& hardware, platform::placement kind,
                                                const machine& ranks, std::span<const rank_report> reports) {
  const std::size_t count = ranks.ranks.size();
  std::vector<std::vector<unsigned>> allowed;
  for (int rank : ranks.ranks) allowed.push_back(reports[static_cast<std::size_t>(rank)].cpus_given);
  if (kind == platform::placement::none) return allowed;

  const platform::placement_plan plan = plan_over_machine(hardware, kind, ranks);
  std::vector<std::optional<unsigned>> preferred;
  std::map<unsigned, std::size_t> position;  // CPU -> its place in the order ranks try CPUs in
  for (const auto& entry : plan.entries) {
    preferred.push_back(entry.pu);
    if (entry.pu && position.find(*entry.pu) == position.end()) position.emplace(*entry.pu, position.size());
  }
  for (const auto& given : allowed)
    for (unsigned cpu : given)
      if (position.find(cpu) == position.end()) position.emplace(cpu, position.size());
  // Each rank tries its CPUs in the plan's order.
  for (auto& given : allowed)
    std::sort(given.begin(), given.end(), [&](unsigned a, unsigned b) { return position.at(a) < position.at(b); });

  std::map<unsigned, std::size_t> owner;
  std::vector<std::optional<unsigned>> assigned = maximum_matching(allowed, preferred, owner, position);
  std::map<unsigned, unsigned> load;  // CPU -> ranks on it
  for (const auto& cpu : assigned)
    if (cpu) ++load[*cpu];
  std::vector<std::vector<unsigned>> result(count);
  for (std::size_t index = 0; index < count; ++index) {
    if (!assigned[index]) {
      // Crowded: no CPU of its own is left. Its preferred one (the plan
      // wraps as on one host), else its least used.
      if (preferred[index] && contains(reports[static_cast<std::size_t>(ranks.ranks[index])].cpus_given,
                                       *preferred[index])) {
        assigned[index] = preferred[index];
      } else if (!allowed[index].empty()) {
        assigned[index] = *std::min_element(allowed[index].begin(), allowed[index].end(),
                                            [&](unsigned a, unsigned b) { return load[a] < load[b]; });
      }
      if (assigned[index]) ++load[*assigned[index]];
    }
    if (assigned[index]) result[index] = {*assigned[index]};
  }
  return result;
}

std::optional<crowding> find_crowding(const machine& ranks, std::span<const rank_report> reports) {
  std::vector<std::vector<unsigned>> bound;
  std::map<unsigned, std::size_t> position;
  for (int rank : ranks.ranks) {
    bound.push_back(reports[static_cast<std::size_t>(rank)].cpus_bound);
    for (unsigned cpu : bound.back())
      if (position.find(cpu) == position.end()) position.emplace(cpu, position.size());
  }
  std::map<unsigned, std::size_t> owner;
  const std::vector<std::optional<unsigned>> assigned =
      maximum_matching(bound, std::vector<std::optional<unsigned>>(bound.size()), owner, position);
  // From every rank left out, alternating paths: a rank's CPUs, each CPU's
  // matched rank. The ranks reached have only the CPUs reached, one fewer
  // per rank left out.
  std::vector<bool> rank_reached(bound.size(), false);
  std::vector<std::size_t> frontier;
  for (std::size_t index = 0; index < bound.size(); ++index)
    if (!assigned[index]) {
      rank_reached[index] = true;
      frontier.push_back(index);
    }
  if (frontier.empty()) return std::nullopt;
  std::vector<unsigned> cpus_reached;
  while (!frontier.empty()) {
    const std::size_t index = frontier.back();
    frontier.pop_back();
    for (unsigned cpu : bound[index]) {
      if (std::find(cpus_reached.begin(), cpus_reached.end(), cpu) != cpus_reached.end()) continue;
      cpus_reached.push_back(cpu);
      const auto held = owner.find(cpu);
      if (held != owner.end() && !rank_reached[held->second]) {
        rank_reached[held->second] = true;
        frontier.push_back(held->second);
      }
    }
  }
  crowding result;
  for (std::size_t index = 0; index < bound.size(); ++index)
    if (rank_reached[index]) result.ranks.push_back(ranks.ranks[index]);
  std::sort(cpus_reached.begin(), cpus_reached.end());
  result.cpus = std::move(cpus_reached);
  return result;
}

std::vector<shared_cpu> host_by_host_sharing(const machine& ranks, std::span<const rank_report> reports) {
  std::map<unsigned, std::vector<int>> by_cpu;
  for (int rank : ranks.ranks)
    if (const auto cpu = reports[static_cast<std::size_t>(rank)].cpu_host_by_host) by_cpu[*cpu].push_back(rank);
  std::vector<shared_cpu> result;
  for (auto& [cpu, on_it] : by_cpu)
    if (on_it.size() > 1) result.push_back({cpu, std::move(on_it)});
  return result;
}

std::string_view to_string(sharing_remedy remedy) noexcept {
  switch (remedy) {
    case sharing_remedy::none: return "none";
    case sharing_remedy::placed_apart: return "placed_apart";
    case sharing_remedy::yield_when_idle: return "yield_when_idle";
  }
  return "none";
}

std::vector<machine_verdict> judge(std::span<const machine> machines, std::span<const rank_report> reports) {
  std::vector<machine_verdict> verdicts;
  for (const machine& ranks : machines) {
    machine_verdict verdict;
    verdict.crowded = find_crowding(ranks, reports);
    verdict.host_by_host = host_by_host_sharing(ranks, reports);
    if (verdict.crowded) {
      const bool all_yield = std::all_of(ranks.ranks.begin(), ranks.ranks.end(), [&](int rank) {
        return reports[static_cast<std::size_t>(rank)].yields_when_idle.value_or(false);
      });
      verdict.remedy = all_yield ? sharing_remedy::yield_when_idle : sharing_remedy::none;
    } else if (!verdict.host_by_host.empty()) {
      verdict.remedy = sharing_remedy::placed_apart;
    }
    verdicts.push_back(std::move(verdict));
  }
  return verdicts;
}

sharing_remedy job_remedy(std::span<const machine_verdict> verdicts) noexcept {
  sharing_remedy result = sharing_remedy::none;
  for (const machine_verdict& verdict : verdicts) {
    if (verdict.remedy == sharing_remedy::yield_when_idle) return verdict.remedy;
    if (verdict.remedy == sharing_remedy::placed_apart) result = verdict.remedy;
  }
  return result;
}

std::string sharing_line(std::span<const machine> machines, std::span<const machine_verdict> verdicts,
                         std::span<const rank_report> reports) {
  std::vector<std::string> clauses;
  for (std::size_t index = 0; index < machines.size(); ++index) {
    const machine& ranks = machines[index];
    const machine_verdict& verdict = verdicts[index];
    if (verdict.crowded) {
      const crowding& crowded = *verdict.crowded;
      std::string clause = fmt::format("ranks {} on {} are bound to {} {} between them", listed(crowded.ranks),
                                       hosts_clause(ranks), crowded.cpus.size() == 1 ? "CPU" : "CPUs",
                                       listed(crowded.cpus));
      clause += verdict.remedy == sharing_remedy::yield_when_idle
                    ? "; they yield when idle (Open MPI's mpi_yield_when_idle), so that a wait hands the CPU over"
                    : "; their MPI library cannot be made to yield when idle, so a wait can cost a scheduler tick";
      clauses.push_back(std::move(clause));
    } else if (verdict.remedy == sharing_remedy::placed_apart) {
      std::vector<std::string> would;
      for (const shared_cpu& shared : verdict.host_by_host)
        would.push_back(fmt::format("ranks {} would all run on CPU {}", listed(shared.ranks), shared.cpu));
      if (would.size() == 1 && verdict.host_by_host.front().ranks.size() == 2)
        would.front() = fmt::format("ranks {} would both run on CPU {}", listed(verdict.host_by_host.front().ranks),
                                    verdict.host_by_host.front().cpu);
      std::vector<std::string> placed;
      for (int rank : ranks.ranks)
        placed.push_back(fmt::format("rank {} on CPU {}", rank,
                                     fmt::join(reports[static_cast<std::size_t>(rank)].cpus_bound, ",")));
      clauses.push_back(
          ranks.hosts.size() == 1
              ? fmt::format("on host {}, planned each inside its own CPUs, {}; placed together instead: {}",
                            ranks.hosts.front(), fmt::join(would, ", "), fmt::join(placed, ", "))
              : fmt::format("hosts {} share one kernel ({}): placed host by host, {}; placed as one machine "
                            "instead: {}",
                            listed(ranks.hosts), ranks.kernel, fmt::join(would, ", "), fmt::join(placed, ", ")));
    }
  }
  if (clauses.empty()) return {};
  return fmt::format("busy-polling ranks could share a CPU: {}", fmt::join(clauses, "; also "));
}

std::optional<unsigned> rank_placement::bound_cpu(int rank) const {
  const std::vector<unsigned>& cpus = ranks.at(static_cast<std::size_t>(rank)).cpus_bound;
  if (cpus.size() != 1) return std::nullopt;
  return cpus.front();
}

namespace {

// A CPU set as a fixed array of words, for the collectives.
constexpr std::size_t kMaskWords = CPU_SETSIZE / 64;
using cpu_mask = std::array<std::uint64_t, kMaskWords>;

cpu_mask to_mask(const std::vector<unsigned>& cpus) {
  cpu_mask mask{};
  for (unsigned cpu : cpus)
    if (cpu < CPU_SETSIZE) mask[cpu / 64] |= std::uint64_t{1} << (cpu % 64);
  return mask;
}

std::vector<unsigned> from_mask(const std::uint64_t* words) {
  std::vector<unsigned> cpus;
  for (unsigned cpu = 0; cpu < CPU_SETSIZE; ++cpu)
    if ((words[cpu / 64] >> (cpu % 64)) & 1U) cpus.push_back(cpu);
  return cpus;
}

constexpr std::size_t kKernelChars = 256;

}  // namespace

rank_placement place_ranks(const world& job, platform::placement kind, const platform::topology& hardware) {
  if (!hardware.is_this_system())
    throw platform::placement_error("cannot place ranks by a topology of another machine (synthetic or XML topology)");
  rank_placement result;
  const auto size = static_cast<std::size_t>(job.size);
  result.ranks.resize(size);
  for (std::size_t rank = 0; rank < size; ++rank) {
    result.ranks[rank].rank = static_cast<int>(rank);
    result.ranks[rank].host = job.host_of_rank.at(rank);
  }

  // 1. Each rank's kernel and the CPUs it was given.
  {
    std::array<char, kKernelChars> kernel{};
    const std::string mine = kernel_identity(hardware, job.host);
    std::memcpy(kernel.data(), mine.data(), std::min(mine.size(), kKernelChars - 1));
    std::vector<char> kernels(size * kKernelChars);
    MPI_Allgather(kernel.data(), kKernelChars, MPI_CHAR, kernels.data(), kKernelChars, MPI_CHAR, job.comm);
    const cpu_mask given = to_mask(hardware.affinity());
    std::vector<std::uint64_t> masks(size * kMaskWords);
    MPI_Allgather(given.data(), kMaskWords, MPI_UINT64_T, masks.data(), kMaskWords, MPI_UINT64_T, job.comm);
    for (std::size_t rank = 0; rank < size; ++rank) {
      result.ranks[rank].kernel.assign(kernels.data() + rank * kKernelChars);
      result.ranks[rank].cpus_given = from_mask(masks.data() + rank * kMaskWords);
    }
  }

  // 2. Placed by machine, pinned; where its host alone would have put it.
  result.machines = machines_of(result.ranks);
  for (std::size_t index = 0; index < result.machines.size(); ++index) {
    const auto& ranks = result.machines[index].ranks;
    if (std::find(ranks.begin(), ranks.end(), job.rank) != ranks.end()) result.my_machine = index;
  }
  const machine& mine = result.machines[result.my_machine];
  const auto my_index =
      static_cast<std::size_t>(std::find(mine.ranks.begin(), mine.ranks.end(), job.rank) - mine.ranks.begin());
  result.plan = plan_over_machine(hardware, kind, mine);
  const std::vector<std::vector<unsigned>> placed = plan_machine(hardware, kind, mine, result.ranks);
  platform::set_current_thread_affinity(placed.at(my_index));
  const platform::placement_plan host_alone =
      platform::plan_placement(hardware, kind, static_cast<unsigned>(job.host_size));
  const std::optional<unsigned> alone = host_alone.pu_at(static_cast<unsigned>(job.host_rank));

  // 3. What every rank is bound to now.
  {
    const cpu_mask bound = to_mask(platform::current_thread_affinity());
    std::vector<std::uint64_t> masks(size * kMaskWords);
    MPI_Allgather(bound.data(), kMaskWords, MPI_UINT64_T, masks.data(), kMaskWords, MPI_UINT64_T, job.comm);
    const std::int64_t mine_alone = alone ? static_cast<std::int64_t>(*alone) : -1;
    std::vector<std::int64_t> alones(size);
    MPI_Allgather(&mine_alone, 1, MPI_INT64_T, alones.data(), 1, MPI_INT64_T, job.comm);
    for (std::size_t rank = 0; rank < size; ++rank) {
      result.ranks[rank].cpus_bound = from_mask(masks.data() + rank * kMaskWords);
      if (alones[rank] >= 0) result.ranks[rank].cpu_host_by_host = static_cast<unsigned>(alones[rank]);
    }
  }

  // 4. Crowded ranks yield when idle; whether every rank does.
  if (find_crowding(mine, result.ranks)) (void)make_yield_when_idle();
  {
    const std::optional<bool> yields = yields_when_idle();
    const int mine_yields = yields ? (*yields ? 1 : 0) : -1;
    std::vector<int> all_yields(size);
    MPI_Allgather(&mine_yields, 1, MPI_INT, all_yields.data(), 1, MPI_INT, job.comm);
    for (std::size_t rank = 0; rank < size; ++rank)
      if (all_yields[rank] >= 0) result.ranks[rank].yields_when_idle = all_yields[rank] == 1;
  }

  result.verdicts = judge(result.machines, result.ranks);
  result.remedy = job_remedy(result.verdicts);
  result.line = sharing_line(result.machines, result.verdicts, result.ranks);
  return result;
}

}  // namespace lockstep::distributed
