// What a `lockstep mpi` measurement means, as text and as result entries (report.hpp).
#include "distributed/report.hpp"

#include <fmt/core.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <utility>

#include "platform/distribution_json.hpp"
#include "platform/format.hpp"
#include "platform/statistics.hpp"

namespace lockstep::distributed {

namespace {

using platform::format_ns;

std::string exchange_name(const exchange_entry& entry, const world& job) {
  return fmt::format("mpi/{}/ranks:{}/hosts:{}", entry.segment, job.size, job.hosts);
}
std::string pingpong_name(const world& job) { return fmt::format("mpi/pingpong/ranks:2/hosts:{}", job.hosts); }

// Each host's ranks, in rank order (hosts by name).
std::map<std::string, std::vector<int>> ranks_by_host(const world& job) {
  std::map<std::string, std::vector<int>> result;
  for (std::size_t rank = 0; rank < job.host_of_rank.size(); ++rank)
    result[job.host_of_rank[rank]].push_back(static_cast<int>(rank));
  return result;
}

// The path between ranks: across hosts, shared memory (vader) within a host
// and TCP between hosts (distributed/launcher.hpp); tcp is TCP everywhere.
std::string transport_label(const report_input& input) {
  if (input.job->hosts > 1 && input.how == transport::shared_memory) return "shm+tcp";
  return std::string(to_string(input.how));
}

// "bound: rank 0 to CPU 0, rank 1 to CPU 1; hosts a, b on one kernel; no rank yields when idle"
std::string bound_text(const rank_placement& placement) {
  std::vector<std::string> ranks;
  std::vector<int> yielding;
  bool unknown = false;
  for (const rank_report& report : placement.ranks) {
    ranks.push_back(fmt::format("rank {} to CPU{} {}", report.rank, report.cpus_bound.size() == 1 ? "" : "s",
                                fmt::join(report.cpus_bound, ",")));
    if (!report.yields_when_idle) unknown = true;
    if (report.yields_when_idle.value_or(false)) yielding.push_back(report.rank);
  }
  std::string kernels;
  for (const machine& each : placement.machines)
    if (each.hosts.size() > 1) kernels += fmt::format("; hosts {} on one kernel", fmt::join(each.hosts, ", "));
  std::string yields = fmt::format("ranks {} yield when idle", fmt::join(yielding, ", "));
  if (unknown) yields = "the MPI library does not say whether ranks yield when idle";
  else if (yielding.empty()) yields = "no rank yields when idle";
  else if (yielding.size() == placement.ranks.size()) yields = "every rank yields when idle";
  return fmt::format("bound: {}{}; {}\n", fmt::join(ranks, ", "), kernels, yields);
}

// The result file's `placement`: every rank's report, every kernel's ranks,
// what was found and done.
nlohmann::json placement_json(const rank_placement& placement) {
  nlohmann::json ranks = nlohmann::json::array();
  for (const rank_report& report : placement.ranks)
    ranks.push_back({{"rank", report.rank},
                     {"host", report.host},
                     {"kernel", report.kernel},
                     {"cpus_given", report.cpus_given},
                     {"cpus_bound", report.cpus_bound},
                     {"cpu_host_by_host",
                      report.cpu_host_by_host ? nlohmann::json(*report.cpu_host_by_host) : nlohmann::json(nullptr)},
                     {"yields_when_idle",
                      report.yields_when_idle ? nlohmann::json(*report.yields_when_idle) : nlohmann::json(nullptr)}});
  nlohmann::json machines = nlohmann::json::array();
  for (std::size_t index = 0; index < placement.machines.size(); ++index) {
    const machine& each = placement.machines[index];
    const machine_verdict& verdict = placement.verdicts.at(index);
    nlohmann::json host_by_host = nlohmann::json::array();
    for (const shared_cpu& shared : verdict.host_by_host)
      host_by_host.push_back({{"cpu", shared.cpu}, {"ranks", shared.ranks}});
    machines.push_back({{"kernel", each.kernel},
                        {"hosts", each.hosts},
                        {"ranks", each.ranks},
                        {"cpus", each.cpus},
                        {"crowded", verdict.crowded ? nlohmann::json{{"ranks", verdict.crowded->ranks},
                                                                     {"cpus", verdict.crowded->cpus}}
                                                    : nlohmann::json(nullptr)},
                        {"host_by_host_shared", std::move(host_by_host)},
                        {"remedy", to_string(verdict.remedy)}});
  }
  return {{"remedy", to_string(placement.remedy)},
          {"warning", placement.line.empty() ? nlohmann::json(nullptr) : nlohmann::json(placement.line)},
          {"ranks", std::move(ranks)},
          {"machines", std::move(machines)}};
}

}  // namespace

mpi_analysis analyse(const report_input& input) {
  mpi_analysis analysis;
  analysis.input = input;
  const world& job = *input.job;
  const benchmark_settings& settings = *input.settings;
  const benchmark_result& measured = *input.measured;
  const std::string library = library_version();
  analysis.library_short = library.substr(0, library.find(','));
  std::vector<double> pingpong_means;
  for (const auto& p : measured.pingpongs) {
    pingpong_means.push_back(p.one_way_mean_ns);
    analysis.pingpong_of_round[p.round] = p.one_way_mean_ns;
  }
  if (!pingpong_means.empty()) {
    analysis.pingpong_median_ns = platform::median(pingpong_means);
    analysis.pingpong_min_ns = *std::min_element(pingpong_means.begin(), pingpong_means.end());
    analysis.pingpong_max_ns = *std::max_element(pingpong_means.begin(), pingpong_means.end());
  }
  for (const exchange_entry* entry : settings.exchanges) {
    std::vector<double> steps, p50, p99, p999, max, skew50, skew99, transfer50, over_pingpong;
    std::vector<std::uint64_t> slowest(static_cast<std::size_t>(job.size), 0);
    exchange_reading reading;
    reading.entry = entry;
    reading.name = exchange_name(*entry, job);
    for (const auto& figures : measured.exchanges) {
      if (figures.entry != entry) continue;
      steps.push_back(figures.step_ns);
      p50.push_back(figures.stage_latency.p50);
      p99.push_back(figures.stage_latency.p99);
      p999.push_back(figures.stage_latency.p999);
      max.push_back(figures.stage_latency.max);
      skew50.push_back(figures.skew.p50);
      skew99.push_back(figures.skew.p99);
      over_pingpong.push_back(figures.transfer.p50 / analysis.pingpong_of_round.at(figures.round));
      transfer50.push_back(figures.transfer.p50);
      for (std::size_t rank = 0; rank < slowest.size(); ++rank) slowest[rank] += figures.slowest_counts[rank];
      reading.bitwise = reading.bitwise && figures.bitwise;
    }
    if (steps.empty()) continue;
    reading.step_median_ns = platform::median(steps);
    reading.step_min_ns = *std::min_element(steps.begin(), steps.end());
    reading.step_max_ns = *std::max_element(steps.begin(), steps.end());
    reading.stage_p50_ns = platform::median(p50);
    reading.stage_p99_ns = platform::median(p99);
    reading.stage_p999_ns = platform::median(p999);
    reading.stage_max_ns = platform::median(max);
    reading.skew_p50_ns = platform::median(skew50);
    reading.skew_p99_ns = platform::median(skew99);
    reading.transfer_p50_ns = platform::median(transfer50);
    reading.over_pingpong_median = platform::median(over_pingpong);
    reading.over_pingpong_min = *std::min_element(over_pingpong.begin(), over_pingpong.end());
    reading.over_pingpong_max = *std::max_element(over_pingpong.begin(), over_pingpong.end());
    const auto most = std::max_element(slowest.begin(), slowest.end());
    std::uint64_t total = 0;
    for (std::uint64_t count : slowest) total += count;
    reading.slowest_rank = static_cast<int>(most - slowest.begin());
    reading.slowest_rank_host = job.host_of_rank.at(static_cast<std::size_t>(reading.slowest_rank));
    reading.slowest_rank_percent = total ? 100.0 * static_cast<double>(*most) / static_cast<double>(total) : 0.0;
    analysis.all_bitwise = analysis.all_bitwise && reading.bitwise;
    analysis.exchanges.push_back(std::move(reading));
  }
  return analysis;
}

std::string mpi_text(const mpi_analysis& analysis) {
  const report_input& input = analysis.input;
  const world& job = *input.job;
  const benchmark_settings& settings = *input.settings;
  const benchmark_result& measured = *input.measured;
  std::string out = fmt::format(
      "lockstep mpi: {} ranks on {} host{} ({} transport, {}), {}, pin {}, {} rounds of {} steps\n", job.size,
      job.hosts, job.hosts == 1 ? "" : "s", transport_label(input), analysis.library_short,
      settings.model.description(), input.pin, settings.rounds, settings.steps);
  if (!measured.placement.plan.note.empty()) out += fmt::format("placement: {}\n", measured.placement.plan.note);
  if (!job.one_host()) {
    std::string hosts;
    for (const auto& [host, ranks] : ranks_by_host(job))
      hosts += fmt::format("{}{}: rank{} {}", hosts.empty() ? "" : "; ", host, ranks.size() == 1 ? "" : "s",
                           fmt::join(ranks, ", "));
    out += fmt::format("hosts: {}\n", hosts);
  }
  out += bound_text(measured.placement);
  if (!measured.pingpongs.empty()) {
    const auto& last = measured.pingpongs.back();
    out += fmt::format(
        "ping-pong, ranks 0 and 1{}, 0 bytes: one-way {} (OSU style: mean of {} round trips / 2; median of {} rounds, "
        "range {}..{}); per round trip, last round: min {}, p50 {}, p99 {}\n",
        job.one_host() ? std::string()
                       : fmt::format(" (on {} and {})", job.host_of_rank.at(0), job.host_of_rank.at(1)),
        format_ns(analysis.pingpong_median_ns), settings.pingpong_round_trips, measured.pingpongs.size(),
        format_ns(analysis.pingpong_min_ns), format_ns(analysis.pingpong_max_ns), format_ns(last.one_way.min),
        format_ns(last.one_way.p50), format_ns(last.one_way.p99));
  }
  out += fmt::format("{:<21} {:>22} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>14} {:>28} {:>8}\n", "exchange",
                     "step (median, range)", "stage p50", "p99", "p99.9", "max", "skew p50", "skew p99",
                     "slowest rank", "transfer p50", "bitwise");
  for (const exchange_reading& reading : analysis.exchanges)
    out += fmt::format(
        "{:<21} {:>22} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>14} {:>28} {:>8}\n", reading.entry->label,
        fmt::format("{} ({}..{})", format_ns(reading.step_median_ns), format_ns(reading.step_min_ns),
                    format_ns(reading.step_max_ns)),
        format_ns(reading.stage_p50_ns), format_ns(reading.stage_p99_ns), format_ns(reading.stage_p999_ns),
        format_ns(reading.stage_max_ns), format_ns(reading.skew_p50_ns), format_ns(reading.skew_p99_ns),
        job.one_host() ? fmt::format("{} ({:.0f}%)", reading.slowest_rank, reading.slowest_rank_percent)
                       : fmt::format("{} on {} ({:.0f}%)", reading.slowest_rank, reading.slowest_rank_host,
                                     reading.slowest_rank_percent),
        fmt::format("{} {:.2f}x ({:.2f}..{:.2f})", format_ns(reading.transfer_p50_ns), reading.over_pingpong_median,
                    reading.over_pingpong_min, reading.over_pingpong_max),
        reading.bitwise ? "yes" : "NO");
  out += fmt::format(
      "stage figures: medians over rounds of each round's pooled per-stage exchange times (every rank, every "
      "stage); skew: latest minus earliest arrival at a stage{}; transfer: latest departure minus latest arrival, "
      "p50, and over the ping-pong one-way mean of the same round (median and range over rounds)\n",
      measured.one_clock ? "" : " (clocks of several hosts, offsets estimated against rank 0)");
  for (const auto& [name, reason] : input.not_applicable) out += fmt::format("not applicable: {}: {}\n", name, reason);
  return out;
}

std::map<std::string, std::string> mpi_context(const mpi_analysis& analysis) {
  const report_input& input = analysis.input;
  const world& job = *input.job;
  return {{"mpi_library", library_version()},
          {"mpi_standard", standard_version()},
          {"mpi_transport", transport_label(input)},
          {"mpi_hosts", std::to_string(job.hosts)},
          {"mpi_ranks", std::to_string(job.size)},
          {"mpi_ranks_per_host", std::to_string(job.ranks_per_host_max)},
          {"mpi_launch", input.launch_text},
          {"lockstep_mode", "mpi"}};
}

nlohmann::json mpi_json(const mpi_analysis& analysis) {
  const report_input& input = analysis.input;
  const world& job = *input.job;
  const benchmark_settings& settings = *input.settings;
  const benchmark_result& measured = *input.measured;
  nlohmann::json names = nlohmann::json::array();
  for (const auto* entry : settings.exchanges) names.push_back(entry->label);
  nlohmann::json document;
  document["settings"] = {{"ranks", job.size},
                          {"hosts", job.hosts},
                          {"transport", transport_label(input)},
                          {"model", settings.model.key()},
                          {"equations", settings.model.equations()},
                          {"steps", settings.steps},
                          {"warmup_steps", settings.warmup_steps},
                          {"rounds", settings.rounds},
                          {"pin", input.pin},
                          {"exchanges", names},
                          {"pingpong_round_trips", settings.pingpong_round_trips},
                          {"pingpong_warmup_round_trips", settings.pingpong_warmup},
                          {"watchdog_ns", input.watchdog_ns},
                          {"arrival_clock", measured.one_clock ? "one host" : "offset-estimated"}};
  nlohmann::json per_host = nlohmann::json::object();
  for (const auto& [host, ranks] : ranks_by_host(job)) per_host[host] = ranks.size();
  document["settings"]["ranks_per_host"] = std::move(per_host);
  document["settings"]["host_of_rank"] = job.host_of_rank;
  nlohmann::json benchmarks = nlohmann::json::array();
  for (const auto& p : measured.pingpongs) {
    const std::string name = pingpong_name(job);
    benchmarks.push_back({{"name", name}, {"run_name", name}, {"run_type", "iteration"},
                          {"repetitions", settings.rounds}, {"repetition_index", p.round}, {"threads", 1},
                          {"iterations", p.round_trips}, {"real_time", p.one_way_mean_ns},
                          {"cpu_time", p.one_way_mean_ns}, {"time_unit", "ns"}, {"one_way_min_ns", p.one_way.min},
                          {"one_way_p50_ns", p.one_way.p50}, {"one_way_p99_ns", p.one_way.p99}});
  }
  for (const auto& figures : measured.exchanges) {
    const std::string name = exchange_name(*figures.entry, job);
    const auto most = std::max_element(figures.slowest_counts.begin(), figures.slowest_counts.end());
    const double stages = static_cast<double>(figures.skew.count);
    std::int64_t switches = 0;
    std::int64_t migrations = 0;
    bool migrations_known = true;  // every rank's count is available
    for (const auto& rank : figures.ranks) {
      switches += rank.context_switches;
      migrations += rank.migrations.value_or(0);
      migrations_known = migrations_known && rank.migrations.has_value();
    }
    const double timed_steps = static_cast<double>(settings.steps);
    const double pingpong = analysis.pingpong_of_round.at(figures.round);
    nlohmann::json entry = {{"name", name}, {"run_name", name}, {"run_type", "iteration"},
                            {"repetitions", settings.rounds}, {"repetition_index", figures.round}, {"threads", 1},
                            {"iterations", settings.steps}, {"real_time", figures.step_ns},
                            {"cpu_time", figures.step_ns}, {"time_unit", "ns"},
                            {"stage_p50_ns", figures.stage_latency.p50}, {"stage_p99_ns", figures.stage_latency.p99},
                            {"stage_p999_ns", figures.stage_latency.p999}, {"stage_max_ns", figures.stage_latency.max},
                            {"skew_p50_ns", figures.skew.p50}, {"skew_p99_ns", figures.skew.p99},
                            {"skew_max_ns", figures.skew.max}, {"slowest_rank", most - figures.slowest_counts.begin()},
                            {"transfer_p50_ns", figures.transfer.p50}, {"transfer_p99_ns", figures.transfer.p99},
                            {"transfer_p50_over_pingpong", figures.transfer.p50 / pingpong},
                            {"stage_p50_over_pingpong", figures.stage_latency.p50 / pingpong},
                            {"slowest_rank_share", stages > 0 ? static_cast<double>(*most) / stages : 0.0},
                            {"context_switches_per_step", static_cast<double>(switches) / timed_steps},
                            {"bitwise", figures.bitwise ? 1 : 0}};
    if (migrations_known) entry["migrations_per_step"] = static_cast<double>(migrations) / timed_steps;
    benchmarks.push_back(std::move(entry));
  }
  document["benchmarks"] = std::move(benchmarks);
  nlohmann::json details = nlohmann::json::array();
  for (const auto& figures : measured.exchanges) {
    if (figures.round + 1 != settings.rounds) continue;  // the last round's details
    nlohmann::json ranks = nlohmann::json::array();
    for (const auto& rank : figures.ranks)
      ranks.push_back({{"rank", rank.rank}, {"host", rank.host},
                       {"cpu", rank.cpu ? nlohmann::json(*rank.cpu) : nlohmann::json(nullptr)},
                       {"stage_p50_ns", rank.stage_p50_ns}, {"stage_p99_ns", rank.stage_p99_ns},
                       {"context_switches", rank.context_switches},
                       {"migrations", rank.migrations ? nlohmann::json(*rank.migrations) : nlohmann::json("unavailable")},
                       {"futex_waits", rank.futex_waits}});
    details.push_back({{"exchange", figures.entry->name}, {"sync", figures.entry->sync},
                       {"label", figures.entry->label}, {"name", exchange_name(*figures.entry, job)},
                       {"description", figures.entry->description}, {"round", figures.round},
                       {"stage_latency_ns", platform::distribution_json(figures.stage_latency)},
                       {"skew_ns", platform::distribution_json(figures.skew)},
                       {"transfer_ns", platform::distribution_json(figures.transfer)},
                       {"slowest_rank_counts", figures.slowest_counts},
                       {"slowest_rank_host",
                        job.host_of_rank.at(static_cast<std::size_t>(
                            std::max_element(figures.slowest_counts.begin(), figures.slowest_counts.end()) -
                            figures.slowest_counts.begin()))},
                       {"per_rank", ranks}});
  }
  document["exchanges"] = std::move(details);
  document["not_applicable"] = input.not_applicable;
  document["placement"] = placement_json(measured.placement);
  return document;
}

}  // namespace lockstep::distributed
