// The late steps' causes as text and JSON (attribution_output.hpp).
#include "bench/delay/attribution_output.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

namespace lockstep::bench {

namespace {

std::string duration_words(double ns) {
  if (ns >= 1e6) return fmt::format("{:.1f} ms", ns / 1e6);
  if (ns >= 1e3) return fmt::format("{:.1f} us", ns / 1e3);
  return fmt::format("{:.0f} ns", ns);
}

}  // namespace

std::string late_step_line(const late_step& step) {
  std::string where = fmt::format("participant {}{}", step.participant, step.cpu ? fmt::format(" on CPU {}", *step.cpu) : "");
  std::string what;
  switch (step.kind) {
    case part_kind::compute:
      what = fmt::format("{} reached stage {} {} after the others", where, step.stage, duration_words(step.lead_ns));
      break;
    case part_kind::sync_resume:
      what = fmt::format("{} left stage {}'s sync {} later than usual after the release", where, step.stage,
                         duration_words(step.part_excess_ns));
      break;
    case part_kind::timer_wakeup:
      what = fmt::format("{} woke {} later than usual", where, duration_words(step.part_excess_ns));
      break;
  }
  std::vector<std::string> evidence;
  if (step.inherited) evidence.push_back("as in the step before, whose overrun delayed this one's start");
  if (step.moved_from) evidence.push_back(fmt::format("moved from CPU {}", *step.moved_from));
  if (!step.switches)
    evidence.push_back("switches unknown");
  else
    evidence.push_back(*step.switches == 0 ? "no switch"
                                           : fmt::format("{} switch{}", *step.switches, *step.switches == 1 ? "" : "es"));
  if (step.run_queue_wait_ns && *step.run_queue_wait_ns >= 1000)
    evidence.push_back(fmt::format("{} waiting to run", duration_words(*step.run_queue_wait_ns)));
  if (!step.page_faults)
    evidence.push_back("faults unknown");
  else
    evidence.push_back(*step.page_faults == 0 ? "no fault"
                                              : fmt::format("{} page fault{}", *step.page_faults,
                                                            *step.page_faults == 1 ? "" : "s"));
  if (!step.interrupts)
    evidence.push_back("interrupts unknown");
  else
    evidence.push_back(*step.interrupts == 0 ? "no interrupt"
                                             : fmt::format("{} more interrupt{} than usual", *step.interrupts,
                                                           *step.interrupts == 1 ? "" : "s"));
  std::string joined;
  for (const std::string& item : evidence) joined += (joined.empty() ? "" : ", ") + item;
  return fmt::format("step {}, {} late: {}; {}: {}", step.period, duration_words(step.excess_ns), what, joined,
                     cause_words(step.top));
}

namespace {

std::string share_cell(double ns, double total) {
  if (total <= 0) return "-";
  const double share = 100.0 * ns / total;
  return share < 0.5 ? "." : fmt::format("{:.0f}%", share);
}

std::string cause_table_row(const std::string& label, std::size_t steps, double excess_ns, const cause_split& split,
                            std::optional<double> explained) {
  std::string line = fmt::format("{:<12} {:>6} {:>10.3f}", label, steps, excess_ns / 1e6);
  for (std::size_t cause = 0; cause < kDelayCauses; ++cause) line += fmt::format(" {:>8}", share_cell(split[cause], excess_ns));
  line += explained ? fmt::format(" {:>9.1f}%", 100 * *explained) : std::string();
  return line + "\n";
}

nlohmann::json split_json(const cause_split& split) {
  nlohmann::json object = nlohmann::json::object();
  for (std::size_t cause = 0; cause < kDelayCauses; ++cause) object[cause_key(static_cast<delay_cause>(cause))] = split[cause];
  return object;
}

nlohmann::json row_json(const cause_row& row) {
  return {{"label", row.label},
          {"threshold_ns", row.threshold_ns},
          {"steps", row.steps},
          {"excess_ns", row.excess_ns},
          {"cause_ns", split_json(row.cause_ns)},
          {"explained_share", row.explained_share},
          {"guest_share", row.guest_share},
          {"top", row.top ? nlohmann::json(cause_key(*row.top)) : nullptr}};
}

std::string kind_key(part_kind kind) {
  switch (kind) {
    case part_kind::timer_wakeup: return "timer_wakeup";
    case part_kind::compute: return "compute";
    case part_kind::sync_resume: return "sync_resume";
  }
  return "compute";
}

}  // namespace

std::string causes_text(const delay_causes& causes, const std::string& title, std::size_t worst_shown) {
  std::string out = fmt::format("\n{}\n", title);
  if (!causes.unavailable.empty()) return out + fmt::format("  not attributed: {}\n", causes.unavailable);
  out += fmt::format(
      "each late step's excess over the median completion ({:.1f} us), split along its critical path "
      "(share of the excess; stages 0-3)\n",
      causes.median_completion_ns / 1e3);
  std::string header = fmt::format("{:<12} {:>6} {:>10}", "steps", "count", "excess ms");
  for (const cause_naming& naming : kCauseNaming) header += fmt::format(" {:>8}", naming.column);
  out += header + fmt::format(" {:>10}\n", "explained");
  for (const cause_row& row : causes.tail) out += cause_table_row(row.label, row.steps, row.excess_ns, row.cause_ns, row.explained_share);
  if (causes.misses) out += cause_table_row("misses", causes.misses->steps, causes.misses->excess_ns, causes.misses->cause_ns,
                                            causes.misses->explained_share);
  for (const cause_row& row : causes.tail)
    if (row.top)
      out += fmt::format("{}: {} (top cause: {}, {:.0f} % of the excess; explained {:.1f} %, by a guest event {:.1f} %)\n",
                         row.label, row.steps == 1 ? "1 step" : fmt::format("{} steps", row.steps), cause_words(*row.top),
                         100 * row.cause_ns[static_cast<std::size_t>(*row.top)] / row.excess_ns,
                         100 * row.explained_share, 100 * row.guest_share);
  if (!causes.per_cpu.empty()) {
    out += "per CPU, above p99 (by the CPU of each step's largest part):";
    for (const auto& [cpu, split] : causes.per_cpu) {
      double total = 0;
      for (double ns : split) total += ns;
      const delay_cause top = static_cast<delay_cause>(std::max_element(split.begin(), split.end()) - split.begin());
      out += fmt::format(" CPU {} {:.3f} ms ({} {:.0f} %);", cpu, total / 1e6, cause_words(top),
                         total > 0 ? 100 * split[static_cast<std::size_t>(top)] / total : 0.0);
    }
    out.back() = '\n';
  }
  if (!causes.worst.empty()) {
    out += fmt::format("the {} latest steps:\n", std::min(worst_shown, causes.worst.size()));
    for (std::size_t index = 0; index < causes.worst.size() && index < worst_shown; ++index)
      out += "  " + late_step_line(causes.worst[index]) + "\n";
  }
  out += fmt::format(
      "record: per stage 2 clock reads and 2 CPU reads in the sync and a CPU read after the step's end; once every "
      "participant has ended, the last one reads everyone's counters ({:.1f} us each) and the interrupt tables "
      "({:.1f} us), outside the completion; run-queue wait and switches {}; on-CPU time from each thread's CPU "
      "clock; page faults from /proc/thread-self/stat; per-CPU interrupts {}\n",
      causes.snapshot_cost_ns / 1e3, causes.interrupt_read_cost_ns / 1e3,
      causes.schedstat ? "from /proc/thread-self/schedstat" : "unavailable (no /proc/thread-self/schedstat)",
      causes.interrupts ? "from /proc/interrupts and /proc/softirqs" : "unavailable");
  if (causes.cost)
    out += fmt::format(
        "recording cost: completion p50 {:+.2f} % with the record (median of {} pairs of adjacent {}-period blocks, "
        "on then off; pairs {:+.2f} % to {:+.2f} %; p50 {:.1f} us on, {:.1f} us off)\n",
        100 * (causes.cost->median_ratio - 1), causes.cost->pairs, causes.cost->block_periods,
        100 * (causes.cost->low_ratio - 1), 100 * (causes.cost->high_ratio - 1), causes.cost->on_p50_ns / 1e3,
        causes.cost->off_p50_ns / 1e3);
  return out;
}

nlohmann::json causes_json(const delay_causes& causes) {
  nlohmann::json document = {{"unavailable", causes.unavailable.empty() ? nlohmann::json(nullptr) : nlohmann::json(causes.unavailable)},
                             {"median_completion_ns", causes.median_completion_ns},
                             {"schedstat", causes.schedstat},
                             {"interrupts", causes.interrupts},
                             {"snapshot_cost_ns", causes.snapshot_cost_ns},
                             {"interrupt_read_cost_ns", causes.interrupt_read_cost_ns}};
  nlohmann::json tail = nlohmann::json::array();
  for (const cause_row& row : causes.tail) tail.push_back(row_json(row));
  document["tail"] = tail;
  document["misses"] = causes.misses ? row_json(*causes.misses) : nlohmann::json(nullptr);
  nlohmann::json per_cpu = nlohmann::json::array();
  for (const auto& [cpu, split] : causes.per_cpu) per_cpu.push_back({{"cpu", cpu}, {"cause_ns", split_json(split)}});
  document["per_cpu"] = per_cpu;
  nlohmann::json worst = nlohmann::json::array();
  for (const late_step& step : causes.worst)
    worst.push_back({{"period", step.period},
                     {"completion_ns", step.completion_ns},
                     {"excess_ns", step.excess_ns},
                     {"cause_ns", split_json(step.cause_ns)},
                     {"top", cause_key(step.top)},
                     {"part", kind_key(step.kind)},
                     {"participant", step.participant},
                     {"cpu", step.cpu ? nlohmann::json(*step.cpu) : nullptr},
                     {"stage", step.stage},
                     {"part_excess_ns", step.part_excess_ns},
                     {"lead_ns", step.lead_ns},
                     {"switches", step.switches ? nlohmann::json(*step.switches) : nullptr},
                     {"page_faults", step.page_faults ? nlohmann::json(*step.page_faults) : nullptr},
                     {"interrupts", step.interrupts ? nlohmann::json(*step.interrupts) : nullptr},
                     {"run_queue_wait_ns", step.run_queue_wait_ns ? nlohmann::json(*step.run_queue_wait_ns) : nullptr},
                     {"moved_from", step.moved_from ? nlohmann::json(*step.moved_from) : nullptr},
                     {"inherited", step.inherited},
                     {"line", late_step_line(step)}});
  document["worst"] = worst;
  if (causes.cost)
    document["recording_cost"] = {{"pairs", causes.cost->pairs},
                                  {"block_periods", causes.cost->block_periods},
                                  {"median_ratio", causes.cost->median_ratio},
                                  {"low_ratio", causes.cost->low_ratio},
                                  {"high_ratio", causes.cost->high_ratio},
                                  {"on_p50_ns", causes.cost->on_p50_ns},
                                  {"off_p50_ns", causes.cost->off_p50_ns}};
  else
    document["recording_cost"] = nullptr;
  return document;
}

nlohmann::json cause_kinds_json() {
  nlohmann::json kinds = nlohmann::json::array();
  for (const cause_naming& naming : kCauseNaming) kinds.push_back({{"key", naming.key}, {"words", naming.words}});
  return kinds;
}

std::string ranked_causes(const cause_row& row) {
  std::vector<std::pair<double, std::string>> ranked;
  for (std::size_t cause = 0; cause < kDelayCauses; ++cause)
    if (row.cause_ns[cause] > 0.005 * row.excess_ns)
      ranked.emplace_back(row.cause_ns[cause], cause_words(static_cast<delay_cause>(cause)));
  std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::string text;
  for (const auto& [ns, name] : ranked)
    text += fmt::format("{}{} {:.0f} %", text.empty() ? "" : ", ", name, 100 * ns / row.excess_ns);
  return text;
}

}  // namespace lockstep::bench
