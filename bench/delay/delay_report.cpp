// What a delay measurement means, as text and as a result file (delay_report.hpp).
#include "bench/delay/delay_report.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "bench/delay/delay_output.hpp"
#include "bench/results/machine_context.hpp"
#include "bench/results/result_json.hpp"
#include "kernels/rk4.hpp"

namespace lockstep::bench {

namespace {

using probes::delay_measurement;
using probes::microseconds_text;
using probes::paced_result;

std::string thread_name(const paced_result& run, unsigned participant, bool per_cpu) {
  if (per_cpu && run.cpus[participant]) return "cpu " + std::to_string(*run.cpus[participant]);
  return "worker " + std::to_string(participant);
}

// "held at 0 us" / "not held (--no-dma-latency)" / "not held (cannot hold ...)"
std::string idle_state(const probes::idle_setting& idle) {
  if (!idle.requested_us) return "not held (--no-dma-latency)";
  if (!idle.held) return fmt::format("not held (cannot hold {} at {} us: {})", idle.path, *idle.requested_us, idle.problem);
  return fmt::format("held at {} us", *idle.requested_us);
}

std::string idle_line(const probes::idle_setting& idle) {
  std::string words;
  if (!idle.requested_us)
    words = fmt::format("{} left alone (--no-dma-latency): the CPUs may enter deep idle states between periods",
                        idle.path);
  else if (!idle.held)
    words = fmt::format("{} could not be held at {} us ({}): idle states not limited", idle.path, *idle.requested_us,
                        idle.problem);
  else
    words = fmt::format("{} held at {} us for the run{}{}", idle.path, *idle.requested_us,
                        *idle.requested_us == 0 ? ", as cyclictest does by default" : "",
                        idle.in_force_us && *idle.in_force_us != *idle.requested_us
                            ? fmt::format(" (in force: {} us, another process asks for less)", *idle.in_force_us)
                            : "");
  return fmt::format("idle: {}; cpuidle driver {}, governor {}; clocksource {}", words, idle.driver, idle.governor,
                     idle.clocksource);
}

nlohmann::json idle_json(const probes::idle_setting& idle) {
  return {{"requested_us", idle.requested_us ? nlohmann::json(*idle.requested_us) : nullptr},
          {"held", idle.held},
          {"in_force_us", idle.in_force_us ? nlohmann::json(*idle.in_force_us) : nullptr},
          {"path", idle.path},
          {"problem", idle.problem.empty() ? nlohmann::json(nullptr) : nlohmann::json(idle.problem)},
          {"cpuidle_driver", idle.driver},
          {"cpuidle_governor", idle.governor},
          {"clocksource", idle.clocksource}};
}

nlohmann::json figure5_json(const platform::figure5_table& table) {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& row : table.rows())
    rows.push_back({{"thread", row.thread},
                    {"role", row.role},
                    {"cross_core_csw", row.cross_core_csw ? nlohmann::json(*row.cross_core_csw) : nullptr},
                    {"total_csw", row.total_csw},
                    {"pct", row.pct ? nlohmann::json(*row.pct) : nullptr}});
  return rows;
}

std::string distribution_line(const std::string& what, const std::vector<double>& samples) {
  if (samples.empty()) return fmt::format("{:<22} no samples\n", what);
  const auto d = platform::summarize(samples);
  return fmt::format("{:<22} {:>10.1f} {:>10.1f} {:>10.1f} {:>10.1f} {:>10.1f} {:>9}\n", what, d.min / 1e3,
                     d.p50 / 1e3, d.p99 / 1e3, d.p999 / 1e3, d.max / 1e3, d.count);
}

std::string result_text(const std::string& title, const paced_result& run, std::int64_t period_ns) {
  std::string out = fmt::format("\n{}\n", title);
  out += fmt::format("{:<22} {:>10} {:>10} {:>10} {:>10} {:>10} {:>9}\n", "us", "min", "p50", "p99", "p99.9", "max",
                     "count");
  out += distribution_line("wake-up latency", run.wakeup_ns);
  out += distribution_line("completion (deadline)", run.completion_ns);
  out += fmt::format("deadline misses: {} of {} (deadline = period = {} us)\n", run.deadline_misses,
                     run.completion_ns.size(), microseconds_text(period_ns));
  for (const auto& error : run.errors) out += fmt::format("warning: {}\n", error);
  return out;
}

std::string per_cpu_text(const delay_analysis& analysis, std::int64_t period_ns) {
  std::string out = "\nper CPU: one paced thread on each CPU, each computing the step alone (like cyclictest -S)\n";
  out += fmt::format("{:<8} {:>10} {:>10} {:>10} {:>10} {:>10} {:>9} {:>8}   wake-up latency, us; misses of {} us\n",
                     "cpu", "min", "p50", "p99", "p99.9", "max", "count", "misses", microseconds_text(period_ns));
  for (const per_cpu_row& row : analysis.per_cpu) {
    if (row.wakeup_ns.empty()) continue;
    const platform::distribution& d = row.wakeup;
    out += fmt::format("{:<8} {:>10.1f} {:>10.1f} {:>10.1f} {:>10.1f} {:>10.1f} {:>9} {:>8}\n", row.shown_cpu,
                       d.min / 1e3, d.p50 / 1e3, d.p99 / 1e3, d.p999 / 1e3, d.max / 1e3, d.count, row.deadline_misses);
  }
  if (analysis.noisiest) {
    const per_cpu_row& worst = analysis.per_cpu[*analysis.noisiest];
    out += fmt::format("noisiest CPU: {} (p99 {:.1f} us; rule: {})\n", worst.shown_cpu, worst.wakeup.p99 / 1e3,
                       kNoisiestRule);
  }
  return out;
}

nlohmann::json per_cpu_json(const delay_analysis& analysis) {
  nlohmann::json rows = nlohmann::json::array();
  for (const per_cpu_row& row : analysis.per_cpu)
    rows.push_back({{"cpu", row.cpu ? nlohmann::json(*row.cpu) : nullptr},
                    {"wakeup_latency_ns", distribution_json(row.wakeup_ns)},
                    {"completion_ns", distribution_json(row.completion_ns)},
                    {"deadline_misses", row.deadline_misses}});
  nlohmann::json noisiest = nullptr;
  if (analysis.noisiest) {
    const per_cpu_row& worst = analysis.per_cpu[*analysis.noisiest];
    noisiest = {{"cpu", worst.shown_cpu}, {"p99_ns", worst.wakeup.p99}, {"max_ns", worst.wakeup.max}, {"rule", kNoisiestRule}};
  }
  return {{"cpus", rows}, {"noisiest", noisiest}};
}

std::string stop_text(const delay_measurement& measured) {
  const paced_result& run = measured.pinned;
  const std::int64_t threshold_ns = *measured.settings.stop_above_ns;
  const bool per_cpu = measured.settings.per_cpu;
  if (!run.stop)
    return fmt::format("\n--stop-above {} us: no wake-up was later; the run went to its end\n",
                       microseconds_text(threshold_ns));
  const probes::paced_stop& stop = *run.stop;
  std::string out = fmt::format(
      "\nstopped: period {} ({:.6f} s after the start): {}{} woke {} us late (--stop-above {} us; period {} us)\n",
      stop.period, static_cast<double>(stop.since_start_ns) / 1e9, thread_name(run, stop.participant, per_cpu),
      stop.cpu && !per_cpu ? fmt::format(" on CPU {}", *stop.cpu) : "", microseconds_text(stop.wakeup_ns),
      microseconds_text(threshold_ns), microseconds_text(measured.period_ns));
  if (stop.previous_end_ns)
    out += fmt::format("  its step in the period before ended {} us after that period's start{}\n",
                       microseconds_text(*stop.previous_end_ns),
                       *stop.previous_end_ns > measured.period_ns ? " (an overrun: a deadline miss)" : "");
  else
    out += "  it was the first period of the run\n";
  return out;
}

nlohmann::json stop_json(const delay_measurement& measured) {
  const paced_result& run = measured.pinned;
  nlohmann::json stop = {{"threshold_ns", *measured.settings.stop_above_ns},
                         {"stopped", run.stop.has_value()},
                         {"periods_kept", run.periods}};
  if (run.stop) {
    stop.update({{"period", run.stop->period},
                 {"since_start_ns", run.stop->since_start_ns},
                 {"participant", run.stop->participant},
                 {"thread", thread_name(run, run.stop->participant, measured.settings.per_cpu)},
                 {"cpu", run.stop->cpu ? nlohmann::json(*run.stop->cpu) : nullptr},
                 {"wakeup_latency_ns", run.stop->wakeup_ns},
                 {"period_ns", measured.period_ns},
                 {"previous_end_ns", run.stop->previous_end_ns ? nlohmann::json(*run.stop->previous_end_ns) : nullptr}});
  }
  return stop;
}

nlohmann::json trial_json(const probes::period_trial& trial) {
  return {{"period_ns", trial.period_ns},
          {"periods", trial.outcome.periods},
          {"misses", trial.outcome.misses},
          {"miss_rate", trial.miss_rate},
          {"upper_bound", trial.upper_bound},
          {"holds", trial.holds},
          {"completion_p50_ns", trial.outcome.completion_p50_ns},
          {"completion_p99_ns", trial.outcome.completion_p99_ns},
          {"elapsed_s", static_cast<double>(trial.outcome.elapsed_ns) / 1e9}};
}

std::string search_text(const delay_measurement& measured, const search_reading& reading) {
  const auto& settings = measured.settings.search;
  const auto& search = measured.searched->search;
  std::string out = fmt::format("\nfind-period: the shortest period at which {} misses its deadline at most at rate {:g}\n",
                                measured.name, settings.miss_rate);
  out += fmt::format("rule: {}\n", search_rule(settings, search.trial_periods));
  out += fmt::format("{:>5} {:>12} {:>9} {:>7} {:>10} {:>10} {:>8} {:>12} {:>12}\n", "trial", "period us", "periods",
                     "misses", "rate", "bound", "verdict", "compl. p50", "compl. p99");
  for (std::size_t index = 0; index < search.trials.size(); ++index) {
    const auto& trial = search.trials[index];
    out += fmt::format("{:>5} {:>12} {:>9} {:>7} {:>10.3g} {:>10.3g} {:>8} {:>12.1f} {:>12.1f}\n", index + 1,
                       microseconds_text(trial.period_ns), trial.outcome.periods, trial.outcome.misses,
                       trial.miss_rate, trial.upper_bound, trial.holds ? "holds" : "fails",
                       trial.outcome.completion_p50_ns / 1e3, trial.outcome.completion_p99_ns / 1e3);
  }
  std::string why;
  if (search.stopped_because == "converged")
    why = fmt::format("the bracket closed within {:g} %", 100 * settings.tolerance);
  else if (search.stopped_because == "budget")
    why = fmt::format("the search budget ({} s) cut the search: the next trial and the confirming run would not fit",
                      static_cast<double>(settings.budget_ns) / 1e9);
  else if (search.stopped_because == "floor")
    why = fmt::format("it held at the shortest period the search tries ({} us)",
                      microseconds_text(settings.floor_period_ns));
  else
    why = fmt::format("it failed at the longest period the search tries ({} us)",
                      microseconds_text(settings.ceiling_period_ns));
  if (search.found_period_ns)
    out += fmt::format("answer: {} us{} ({})\n", microseconds_text(*search.found_period_ns),
                       search.failed_period_ns
                           ? fmt::format("; {} us failed", microseconds_text(*search.failed_period_ns))
                           : "",
                       why);
  else
    out += fmt::format("answer: none: no period tried held ({})\n", why);
  if (search.confirm) {
    const auto& trial = *search.confirm;
    out += fmt::format(
        "confirming run at {} us: {} misses in {} periods, rate {:.3g}: {} the rate {:g}; the {:g} % bound {:.3g} {}\n",
        microseconds_text(trial.period_ns), trial.outcome.misses, trial.outcome.periods, trial.miss_rate,
        reading.confirm_within_rate.value_or(false) ? "within" : "NOT within", settings.miss_rate,
        100 * settings.confidence, trial.upper_bound, trial.holds ? "holds too" : "does not hold");
  }
  if (reading.set_by_stalls)
    out += fmt::format(
        "set by stalls: every trial's completion p99 was at most {:.1f} us, the answer is {} us: the misses "
        "that failed shorter periods were rare stalls of the machine{}, not the step's cost; such an answer "
        "moves between runs with the stalls' rate (compare it only with one measured beside it)\n",
        reading.largest_completion_p99_ns / 1e3, microseconds_text(*search.found_period_ns),
        reading.confirm_longest_completion_ns > 0
            ? fmt::format(" (the confirming run's longest completion {:.1f} us)",
                          reading.confirm_longest_completion_ns / 1e3)
            : std::string{});
  out += fmt::format("search time: {:.1f} s of the {:g} s budget (the confirming run included)\n",
                     static_cast<double>(search.elapsed_ns) / 1e9, static_cast<double>(settings.budget_ns) / 1e9);
  return out;
}

nlohmann::json search_json(const delay_measurement& measured, const search_reading& reading) {
  const auto& settings = measured.settings.search;
  const auto& search = measured.searched->search;
  nlohmann::json confirm = nullptr;
  if (search.confirm) {
    confirm = trial_json(*search.confirm);
    confirm["within_rate"] = reading.confirm_within_rate.value_or(false);
  }
  nlohmann::json trials = nlohmann::json::array();
  for (const auto& trial : search.trials) trials.push_back(trial_json(trial));
  return {{"miss_rate", settings.miss_rate},
          {"confidence", settings.confidence},
          {"rule", search_rule(settings, search.trial_periods)},
          {"trial_periods", search.trial_periods},
          {"start_period_ns", settings.start_period_ns},
          {"floor_period_ns", settings.floor_period_ns},
          {"ceiling_period_ns", settings.ceiling_period_ns},
          {"tolerance", settings.tolerance},
          {"budget_ns", settings.budget_ns},
          {"budget_cut", search.budget_cut},
          {"stopped_because", search.stopped_because},
          {"elapsed_s", static_cast<double>(search.elapsed_ns) / 1e9},
          {"found_period_ns", search.found_period_ns ? nlohmann::json(*search.found_period_ns) : nullptr},
          {"failed_period_ns", search.failed_period_ns ? nlohmann::json(*search.failed_period_ns) : nullptr},
          {"trials", trials},
          {"largest_completion_p99_ns", reading.largest_completion_p99_ns},
          {"set_by_stalls", reading.set_by_stalls},
          {"confirm", confirm}};
}

}  // namespace

// ---- Why a step was late (attribute_delay) ----------------------------------

namespace {

using probes::participant_period;
using probes::step_record;

constexpr int kStages = static_cast<int>(kernels::kRk4Stages);

double median_or(std::vector<double> samples, double otherwise) {
  if (samples.empty()) return otherwise;
  return platform::summarize(std::move(samples)).p50;
}

// Minor and major faults together, when the window has both.
std::optional<std::int64_t> faults_of(const platform::thread_step_counters& counters) {
  if (!counters.minor_faults || !counters.major_faults) return std::nullopt;
  return *counters.minor_faults + *counters.major_faults;
}

// A window's count above the participant's median of it (never below 0),
// when the window has the count.
std::optional<std::int64_t> above_median(std::optional<std::int64_t> count, double median) {
  if (!count) return std::nullopt;
  return std::max<std::int64_t>(0, *count - static_cast<std::int64_t>(std::llround(median)));
}

struct part {
  part_kind kind = part_kind::compute;
  unsigned participant = 0;
  int stage = 0;
  double ns = 0;
  double typical = 0;
  std::int32_t cpu_start = -1;
  std::int32_t cpu_end = -1;
  double lead_ns = 0;
};

// What the record says, period by period, and the run's medians of it.
class step_reader {
 public:
  explicit step_reader(const probes::paced_result& run) : run_(run), record_(*run.record) {
    participants_ = record_.participants;
    periods_ = record_.periods;
    period_ns_ = static_cast<double>(record_.period_ns);
    columns_ = record_.cpus.size();
    median_completion_ = run.completion_ns.empty() ? 0 : platform::summarize(run.completion_ns).p50;
    // Typical part lengths, and the counters' medians, over recorded periods.
    std::vector<std::vector<double>> compute(participants_ * kStages), resume(participants_ * kStages),
        timer(participants_);
    std::vector<std::vector<double>> on_cpu(participants_), run_queue(participants_), blocked_time(participants_),
        switches(participants_), faults(participants_);
    for (std::int64_t k = 0; k < periods_; ++k) {
      for (unsigned p = 0; p < participants_; ++p) {
        const participant_period& row = record_.at(k, p);
        if (!row.recorded) continue;
        timer[p].push_back(wake(k, p));
        for (int s = 0; s < kStages; ++s) {
          if (const auto length = compute_length(k, p, s)) compute[p * kStages + s].push_back(*length);
          if (const auto blocker = blocker_of(k, p, s))
            resume[p * kStages + s].push_back(departure(k, p, s) - arrival(k, *blocker, s));
        }
        if (!row.counters_valid) continue;
        if (row.counters.on_cpu_ns) on_cpu[p].push_back(static_cast<double>(*row.counters.on_cpu_ns));
        if (row.counters.run_queue_wait_ns) run_queue[p].push_back(static_cast<double>(*row.counters.run_queue_wait_ns));
        if (const auto b = blocked(k, p)) blocked_time[p].push_back(*b);
        if (row.counters.switches) switches[p].push_back(static_cast<double>(*row.counters.switches));
        if (const auto f = faults_of(row.counters)) faults[p].push_back(static_cast<double>(*f));
      }
    }
    typical_compute_.resize(compute.size());
    typical_resume_.resize(resume.size());
    for (std::size_t i = 0; i < compute.size(); ++i) typical_compute_[i] = median_or(compute[i], 0);
    for (std::size_t i = 0; i < resume.size(); ++i) typical_resume_[i] = median_or(resume[i], 0);
    for (unsigned p = 0; p < participants_; ++p) {
      typical_timer_.push_back(median_or(timer[p], 0));
      medians_.push_back({median_or(on_cpu[p], 0), median_or(run_queue[p], 0), median_or(blocked_time[p], 0),
                          median_or(switches[p], 0), median_or(faults[p], 0)});
    }
    for (std::size_t column = 0; column < columns_; ++column) {
      std::vector<double> counts;
      for (std::int64_t k = 0; k < periods_; ++k)
        if (const auto count = interrupts_of(k, column)) counts.push_back(static_cast<double>(*count));
      interrupt_median_.push_back(median_or(counts, 0));
    }
  }

  std::int64_t periods() const noexcept { return periods_; }
  double median_completion() const noexcept { return median_completion_; }
  double completion(std::int64_t k) const { return run_.completion_ns[static_cast<std::size_t>(k)]; }
  bool recorded(std::int64_t k) const {
    for (unsigned p = 0; p < participants_; ++p)
      if (!record_.at(k, p).recorded) return false;
    return true;
  }
  double period_ns() const noexcept { return period_ns_; }

  double wake(std::int64_t k, unsigned p) const { return run_.wakeup_ns[index(k, p)]; }
  double end(std::int64_t k, unsigned p) const { return run_.end_ns[index(k, p)]; }
  double arrival(std::int64_t k, unsigned p, int s) const {
    return static_cast<double>(record_.at(k, p).stages[static_cast<std::size_t>(s)].arrival_ns);
  }
  // Stage 3's departure is the step's end: what follows the last sync
  // (its copy-in) belongs to the release too.
  double departure(std::int64_t k, unsigned p, int s) const {
    if (s == kStages - 1) return end(k, p);
    return static_cast<double>(record_.at(k, p).stages[static_cast<std::size_t>(s)].departure_ns);
  }
  std::int32_t arrival_cpu(std::int64_t k, unsigned p, int s) const {
    return record_.at(k, p).stages[static_cast<std::size_t>(s)].arrival_cpu;
  }
  std::int32_t departure_cpu(std::int64_t k, unsigned p, int s) const {
    if (s == kStages - 1) return record_.at(k, p).end_cpu;
    return record_.at(k, p).stages[static_cast<std::size_t>(s)].departure_cpu;
  }
  bool stage_recorded(std::int64_t k, unsigned p, int s) const {
    const auto& passage = record_.at(k, p).stages[static_cast<std::size_t>(s)];
    return passage.arrival_ns >= 0 && (s == kStages - 1 || passage.departure_ns >= 0);
  }

  // The last to arrive at stage s among p and those p waits for.
  std::optional<unsigned> blocker_of(std::int64_t k, unsigned p, int s) const {
    if (!stage_recorded(k, p, s)) return std::nullopt;
    unsigned latest = p;
    for (unsigned other : record_.waits_for[p]) {
      if (!stage_recorded(k, other, s)) return std::nullopt;
      if (arrival(k, other, s) > arrival(k, latest, s)) latest = other;
    }
    return latest;
  }
  // How long after the second latest of that set the blocker arrived.
  double lead(std::int64_t k, unsigned p, int s, unsigned blocker) const {
    double second = -1;
    const auto consider = [&](unsigned q) {
      if (q != blocker) second = std::max(second, arrival(k, q, s));
    };
    consider(p);
    for (unsigned other : record_.waits_for[p]) consider(other);
    return second < 0 ? 0 : arrival(k, blocker, s) - second;
  }
  std::optional<double> compute_length(std::int64_t k, unsigned p, int s) const {
    if (!stage_recorded(k, p, s) || (s > 0 && !stage_recorded(k, p, s - 1))) return std::nullopt;
    return arrival(k, p, s) - (s > 0 ? departure(k, p, s - 1) : wake(k, p));
  }

  // Time off the CPU and not runnable in p's step: from its wake-up to its
  // end, less the window's on-CPU time and run-queue wait (the window also
  // holds the sleep before the wake-up, whose length moves with the previous
  // step's end; that sleep is off the CPU, so it is left out here, and the
  // little CPU and run-queue time around the wake-up only shifts the median).
  std::optional<double> blocked(std::int64_t k, unsigned p) const {
    const participant_period& row = record_.at(k, p);
    if (!row.counters_valid || !row.counters.on_cpu_ns || !row.counters.run_queue_wait_ns) return std::nullopt;
    return end(k, p) - wake(k, p) - static_cast<double>(*row.counters.on_cpu_ns) -
           static_cast<double>(*row.counters.run_queue_wait_ns);
  }
  std::optional<std::int64_t> interrupts_of(std::int64_t k, std::size_t column) const {
    const std::size_t at = static_cast<std::size_t>(k) * columns_ + column;
    if (at >= record_.interrupts.size() || record_.interrupts[at] < 0) return std::nullopt;
    return record_.interrupts[at] + std::max<std::int64_t>(record_.softirqs[at], 0);
  }
  // p's CPU's interrupts and softirqs above that CPU's median in window k.
  std::optional<std::int64_t> interrupt_excess(std::int64_t k, std::int32_t cpu) const {
    if (cpu < 0) return std::nullopt;
    const auto column = record_.cpu_column(static_cast<unsigned>(cpu));
    if (!column) return std::nullopt;
    const auto count = interrupts_of(k, *column);
    if (!count) return std::nullopt;
    return *count - static_cast<std::int64_t>(std::llround(interrupt_median_[*column]));
  }

  struct counter_medians {
    double on_cpu = 0, run_queue = 0, blocked = 0, switches = 0, faults = 0;
  };
  const counter_medians& medians(unsigned p) const { return medians_[p]; }
  const participant_period& row(std::int64_t k, unsigned p) const { return record_.at(k, p); }

  // The critical path of step k (see delay_report.hpp); empty when a stage
  // of it was not recorded.
  std::vector<part> path(std::int64_t k) const {
    std::vector<part> parts;
    unsigned p = 0;
    for (unsigned q = 1; q < participants_; ++q)
      if (end(k, q) > end(k, p)) p = q;
    for (int s = kStages - 1; s >= 0; --s) {
      const auto blocker = blocker_of(k, p, s);
      if (!blocker) return {};
      const unsigned b = *blocker;
      part resume{part_kind::sync_resume, p, s, departure(k, p, s) - arrival(k, b, s),
                  typical_resume_[p * kStages + s], arrival_cpu(k, p, s), departure_cpu(k, p, s), 0};
      parts.push_back(resume);
      const auto length = compute_length(k, b, s);
      if (!length) return {};
      part work{part_kind::compute, b, s, *length, typical_compute_[b * kStages + s],
                s > 0 ? departure_cpu(k, b, s - 1) : row(k, b).wake_cpu, arrival_cpu(k, b, s), lead(k, p, s, b)};
      parts.push_back(work);
      p = b;
    }
    const std::int32_t slept_on = k > 0 && row(k - 1, p).recorded ? row(k - 1, p).end_cpu : -1;
    parts.push_back({part_kind::timer_wakeup, p, 0, wake(k, p), typical_timer_[p], slept_on, row(k, p).wake_cpu, 0});
    return parts;
  }

 private:
  std::size_t index(std::int64_t k, unsigned p) const {
    return static_cast<std::size_t>(k) * participants_ + p;
  }

  const probes::paced_result& run_;
  const step_record& record_;
  unsigned participants_ = 0;
  std::int64_t periods_ = 0;
  double period_ns_ = 0;
  std::size_t columns_ = 0;
  double median_completion_ = 0;
  std::vector<double> typical_compute_, typical_resume_, typical_timer_;
  std::vector<counter_medians> medians_;
  std::vector<double> interrupt_median_;
};

std::size_t cause_index(delay_cause cause) { return static_cast<std::size_t>(cause); }

// What is left to explain in one participant's window, shared by its parts.
struct window_budget {
  double run_queue = 0;
  double on_cpu = 0;
  double blocked = 0;
  std::int64_t fault_excess = 0;  // faults above the median
  std::int64_t major_faults = 0;
  // Switches (voluntary or not) above their median: more than none, the
  // guest scheduled it differently.
  std::int64_t extra_switches = 0;
  bool migrated = false;  // it changed CPU somewhere in its window: the move's IPIs and cold caches are the move's
};

window_budget budget_of(const step_reader& reader, std::int64_t k, unsigned p) {
  window_budget budget;
  const participant_period& row = reader.row(k, p);
  if (!row.counters_valid) return budget;
  const auto& median = reader.medians(p);
  if (row.counters.run_queue_wait_ns)
    budget.run_queue = std::max(0.0, static_cast<double>(*row.counters.run_queue_wait_ns) - median.run_queue);
  if (row.counters.on_cpu_ns) budget.on_cpu = std::max(0.0, static_cast<double>(*row.counters.on_cpu_ns) - median.on_cpu);
  if (const auto blocked = reader.blocked(k, p)) budget.blocked = std::max(0.0, *blocked - median.blocked);
  budget.fault_excess = above_median(faults_of(row.counters), median.faults).value_or(0);
  budget.major_faults = row.counters.major_faults.value_or(0);
  budget.extra_switches = above_median(row.counters.switches, median.switches).value_or(0);
  const std::int32_t woke_on = row.wake_cpu;
  const auto moved = [&](std::int32_t cpu) { return cpu >= 0 && woke_on >= 0 && cpu != woke_on; };
  if (k > 0 && reader.row(k - 1, p).recorded) budget.migrated = moved(reader.row(k - 1, p).end_cpu);
  for (const auto& passage : row.stages)
    budget.migrated = budget.migrated || moved(passage.arrival_cpu) || moved(passage.departure_cpu);
  budget.migrated = budget.migrated || moved(row.end_cpu);
  return budget;
}

// Splits one part's excess `excess` (see delay_report.hpp).
void split_part(const step_reader& reader, std::int64_t k, const part& piece, double excess, window_budget& budget,
                cause_split& split) {
  double left = excess;
  if (piece.cpu_start >= 0 && piece.cpu_end >= 0 && piece.cpu_start != piece.cpu_end) {
    // The part itself crossed CPUs: all of it is the move's.
    split[cause_index(delay_cause::migration)] += left;
    budget.run_queue -= std::min(budget.run_queue, left);
    return;
  }
  const auto interrupts = reader.interrupt_excess(k, piece.cpu_end);
  const bool more_interrupts = interrupts && *interrupts > 0;
  // Where the on-CPU time above the median went: faults, else the move's
  // IPIs and cold caches, else interrupts, else no guest event (a stall).
  const delay_cause on_cpu = budget.fault_excess > 0 ? delay_cause::page_faults
                             : budget.migrated       ? delay_cause::migration
                             : more_interrupts       ? delay_cause::interrupts
                                                     : delay_cause::machine_stall;
  // Blocked longer than usual: in its own stage, its own doing (compute);
  // in a wake-up, the kernel's wake-up path when the guest shows it at work
  // (more switches or interrupts than usual), otherwise a wake-up no guest
  // event delayed (the timer or the waker's signal was not delivered while
  // the vCPU did not run: a stall). Major faults block too.
  const bool guest_event = budget.extra_switches > 0 || more_interrupts;
  // What the guest's wake-up path can account for: each switch or interrupt
  // above the usual at most one more typical length of this part (the
  // wake-up run again: preempted once more, an interrupt served first). A
  // wake-up later than that is a wake-up nothing the guest did delayed: a
  // timer or a waker's signal that arrived while the vCPU did not run.
  const double events = static_cast<double>(budget.extra_switches + (more_interrupts ? *interrupts : 0));
  double wakeup_allowance = events * std::max(0.0, piece.typical);
  const auto credit_wakeup = [&](double ns) {
    const double wakeup = std::min(ns, wakeup_allowance);
    wakeup_allowance -= wakeup;
    split[cause_index(delay_cause::wakeup_latency)] += wakeup;
    split[cause_index(delay_cause::machine_stall)] += ns - wakeup;
  };
  const delay_cause blocked = budget.major_faults > 0           ? delay_cause::page_faults
                              : piece.kind == part_kind::compute ? delay_cause::compute
                              : guest_event                      ? delay_cause::wakeup_latency
                                                                 : delay_cause::machine_stall;
  // The part's excess is shared among the window's three kinds of time in
  // proportion to what each has above its median (each capped by it).
  // A timer wake-up lies before the step (in the sleep): of the window's
  // time only its run-queue wait can be the wake-up's.
  const bool timer = piece.kind == part_kind::timer_wakeup;
  const double available = budget.run_queue + (timer ? 0.0 : budget.on_cpu + budget.blocked);
  if (available > 0) {
    const double share = std::min(1.0, left / available);
    const double run_queue = budget.run_queue * share;
    const double cpu = timer ? 0.0 : budget.on_cpu * share;
    const double off = timer ? 0.0 : budget.blocked * share;
    split[cause_index(delay_cause::run_queue_wait)] += run_queue;
    split[cause_index(on_cpu)] += cpu;
    if (blocked == delay_cause::wakeup_latency)
      credit_wakeup(off);
    else
      split[cause_index(blocked)] += off;
    budget.run_queue -= run_queue;
    budget.on_cpu -= cpu;
    budget.blocked -= off;
    left -= run_queue + cpu + off;
  }
  if (left > 0) {
    if (piece.kind == part_kind::compute)
      split[cause_index(delay_cause::unexplained)] += left;
    else if (guest_event)
      credit_wakeup(left);
    else
      split[cause_index(delay_cause::machine_stall)] += left;
  }
}

delay_cause top_of(const cause_split& split) {
  std::size_t top = 0;
  for (std::size_t cause = 1; cause < kDelayCauses; ++cause)
    if (split[cause] > split[top]) top = cause;
  return static_cast<delay_cause>(top);
}

// `previous`: the attribution of step k - 1 when it was late (for a start
// its overrun delayed).
late_step attribute_with(const step_reader& reader, std::int64_t k, const late_step* previous) {
  late_step step;
  step.period = k;
  step.completion_ns = reader.completion(k);
  step.excess_ns = step.completion_ns - reader.median_completion();
  if (step.excess_ns <= 0) {
    step.excess_ns = 0;
    return step;
  }
  const std::vector<part> parts = reader.path(k);
  if (parts.empty()) {
    step.cause_ns[cause_index(delay_cause::unexplained)] = step.excess_ns;
    return step;
  }
  std::vector<window_budget> budgets;
  std::vector<bool> budget_made;
  cause_split split{};
  double covered = 0;
  const part* dominant = nullptr;
  double dominant_excess = 0;
  for (const part& piece : parts) {
    const double excess = piece.ns - piece.typical;
    if (excess <= 0) continue;
    covered += excess;
    if (excess > dominant_excess) {
      dominant_excess = excess;
      dominant = &piece;
    }
    if (budgets.size() <= piece.participant) {
      budgets.resize(piece.participant + 1);
      budget_made.resize(piece.participant + 1, false);
    }
    if (!budget_made[piece.participant]) {
      budgets[piece.participant] = budget_of(reader, k, piece.participant);
      budget_made[piece.participant] = true;
    }
    // A start its own previous step delayed: that step's causes, in its proportions.
    if (piece.kind == part_kind::timer_wakeup && previous != nullptr && previous->excess_ns > 0 && k > 0 &&
        reader.end(k - 1, piece.participant) > reader.period_ns()) {
      for (std::size_t cause = 0; cause < kDelayCauses; ++cause)
        split[cause] += excess * previous->cause_ns[cause] / previous->excess_ns;
      if (dominant == &piece) step.inherited = true;
      continue;
    }
    split_part(reader, k, piece, excess, budgets[piece.participant], split);
  }
  if (covered > step.excess_ns) {
    for (double& ns : split) ns *= step.excess_ns / covered;
  } else {
    split[cause_index(delay_cause::unexplained)] += step.excess_ns - covered;
  }
  step.cause_ns = split;
  step.top = top_of(split);
  if (step.inherited) {
    // Named as the step whose overrun delayed this one.
    const cause_split own = step.cause_ns;
    const double excess = step.excess_ns;
    const std::int64_t period = step.period;
    const double completion = step.completion_ns;
    step = *previous;
    step.period = period;
    step.completion_ns = completion;
    step.excess_ns = excess;
    step.cause_ns = own;
    step.top = top_of(own);
    step.inherited = true;
    return step;
  }
  if (dominant != nullptr) {
    step.kind = dominant->kind;
    step.participant = dominant->participant;
    if (dominant->cpu_end >= 0) step.cpu = static_cast<unsigned>(dominant->cpu_end);
    step.stage = dominant->stage;
    step.part_excess_ns = dominant_excess;
    step.lead_ns = dominant->lead_ns;
    if (dominant->cpu_start >= 0 && dominant->cpu_end >= 0 && dominant->cpu_start != dominant->cpu_end)
      step.moved_from = static_cast<unsigned>(dominant->cpu_start);
    const participant_period& row = reader.row(k, dominant->participant);
    if (row.counters_valid) {
      const auto& median = reader.medians(dominant->participant);
      step.switches = above_median(row.counters.switches, median.switches);
      step.page_faults = above_median(faults_of(row.counters), median.faults);
      if (row.counters.run_queue_wait_ns)
        step.run_queue_wait_ns = std::max(0.0, static_cast<double>(*row.counters.run_queue_wait_ns) - median.run_queue);
    }
    if (const auto interrupts = reader.interrupt_excess(k, dominant->cpu_end))
      step.interrupts = std::max<std::int64_t>(0, *interrupts);
  }
  return step;
}

cause_row sum_row(std::string label, double threshold, const std::vector<const late_step*>& steps) {
  cause_row row;
  row.label = std::move(label);
  row.threshold_ns = threshold;
  row.steps = steps.size();
  for (const late_step* step : steps) {
    row.excess_ns += step->excess_ns;
    for (std::size_t cause = 0; cause < kDelayCauses; ++cause) row.cause_ns[cause] += step->cause_ns[cause];
  }
  if (row.excess_ns > 0) {
    const double unexplained = row.cause_ns[cause_index(delay_cause::unexplained)];
    const double stall = row.cause_ns[cause_index(delay_cause::machine_stall)];
    row.explained_share = std::clamp(1.0 - unexplained / row.excess_ns, 0.0, 1.0);
    row.guest_share = std::clamp(1.0 - (unexplained + stall) / row.excess_ns, 0.0, 1.0);
    row.top = top_of(row.cause_ns);
  }
  return row;
}

std::optional<recording_cost> cost_of(const probes::paced_result& run) {
  const step_record& record = *run.record;
  if (record.mode != probes::step_recording::alternate_blocks || record.periods == 0) return std::nullopt;
  recording_cost cost;
  cost.block_periods = record.block_periods;
  std::vector<double> on_all, off_all, ratios;
  const std::int64_t blocks = record.periods / record.block_periods;
  for (std::int64_t pair = 0; 2 * pair + 1 < blocks; ++pair) {
    std::vector<double> on, off;
    for (std::int64_t k = 2 * pair * record.block_periods; k < (2 * pair + 1) * record.block_periods; ++k)
      on.push_back(run.completion_ns[static_cast<std::size_t>(k)]);
    for (std::int64_t k = (2 * pair + 1) * record.block_periods; k < (2 * pair + 2) * record.block_periods; ++k)
      off.push_back(run.completion_ns[static_cast<std::size_t>(k)]);
    on_all.insert(on_all.end(), on.begin(), on.end());
    off_all.insert(off_all.end(), off.begin(), off.end());
    const double off_p50 = platform::summarize(off).p50;
    if (off_p50 > 0) ratios.push_back(platform::summarize(on).p50 / off_p50);
  }
  if (ratios.empty()) return std::nullopt;
  cost.pairs = ratios.size();
  cost.median_ratio = platform::summarize(ratios).p50;
  cost.low_ratio = *std::min_element(ratios.begin(), ratios.end());
  cost.high_ratio = *std::max_element(ratios.begin(), ratios.end());
  cost.on_p50_ns = platform::summarize(on_all).p50;
  cost.off_p50_ns = platform::summarize(off_all).p50;
  return cost;
}

std::string duration_words(double ns) {
  if (ns >= 1e6) return fmt::format("{:.1f} ms", ns / 1e6);
  if (ns >= 1e3) return fmt::format("{:.1f} us", ns / 1e3);
  return fmt::format("{:.0f} ns", ns);
}

}  // namespace

std::string cause_words(delay_cause cause) {
  switch (cause) {
    case delay_cause::compute: return "compute";
    case delay_cause::run_queue_wait: return "run-queue wait";
    case delay_cause::migration: return "migration";
    case delay_cause::page_faults: return "page faults";
    case delay_cause::interrupts: return "interrupts";
    case delay_cause::wakeup_latency: return "wake-up latency";
    case delay_cause::machine_stall: return "machine stall";
    case delay_cause::unexplained: return "unexplained";
  }
  return "unexplained";
}

std::string cause_key(delay_cause cause) {
  std::string key = cause_words(cause);
  std::replace(key.begin(), key.end(), ' ', '_');
  std::replace(key.begin(), key.end(), '-', '_');
  return key;
}

late_step attribute_step(const probes::paced_result& run, std::int64_t period) {
  const step_reader reader(run);
  std::optional<late_step> previous;
  // The chain of overrunning steps before it, oldest first (each may inherit).
  std::int64_t first = period;
  while (first > 0 && reader.completion(first - 1) > reader.period_ns() && reader.recorded(first - 1)) --first;
  for (std::int64_t k = first; k < period; ++k) previous = attribute_with(reader, k, previous ? &*previous : nullptr);
  return attribute_with(reader, period, previous ? &*previous : nullptr);
}

delay_causes attribute_delay(const probes::paced_result& run, std::size_t worst) {
  delay_causes causes;
  if (!run.record) {
    causes.unavailable = "the run kept no per-step record";
    return causes;
  }
  const step_record& record = *run.record;
  causes.schedstat = record.schedstat_available;
  causes.interrupts = record.interrupts_available;
  causes.snapshot_cost_ns = record.snapshot_cost_ns;
  causes.interrupt_read_cost_ns = record.interrupt_read_cost_ns;
  if (!record.not_kept.empty()) {
    causes.unavailable = record.not_kept;
    return causes;
  }
  if (record.periods == 0 || run.completion_ns.empty()) {
    causes.unavailable = "no period was recorded";
    return causes;
  }
  causes.cost = cost_of(run);
  const step_reader reader(run);
  causes.median_completion_ns = reader.median_completion();
  std::vector<late_step> late;
  std::optional<late_step> previous;
  for (std::int64_t k = 0; k < reader.periods(); ++k) {
    if (!reader.recorded(k)) {
      previous.reset();
      continue;
    }
    late_step step = attribute_with(reader, k, previous ? &*previous : nullptr);
    if (step.excess_ns > 0) {
      late.push_back(step);
      previous = std::move(step);
    } else {
      previous.reset();
    }
  }
  const platform::distribution completion = platform::summarize(run.completion_ns);
  const auto above = [&](double threshold) {
    std::vector<const late_step*> chosen;
    for (const late_step& step : late)
      if (step.completion_ns > threshold) chosen.push_back(&step);
    return chosen;
  };
  for (const auto& [label, threshold] : {std::pair<std::string, double>{"above p99", completion.p99},
                                         std::pair<std::string, double>{"above p99.9", completion.p999}}) {
    const auto chosen = above(threshold);
    if (!chosen.empty()) causes.tail.push_back(sum_row(label, threshold, chosen));
  }
  if (!late.empty()) {
    const late_step* latest = &late.front();
    for (const late_step& step : late)
      if (step.excess_ns > latest->excess_ns) latest = &step;
    causes.tail.push_back(sum_row("maximum", latest->completion_ns, {latest}));
  }
  const auto missed = above(static_cast<double>(record.period_ns));
  if (!missed.empty()) causes.misses = sum_row("misses", static_cast<double>(record.period_ns), missed);
  // Per CPU, above p99: each step's causes under the CPU of its largest part.
  for (const late_step* step : above(completion.p99)) {
    if (!step->cpu) continue;
    auto slot = std::find_if(causes.per_cpu.begin(), causes.per_cpu.end(),
                             [&](const auto& entry) { return entry.first == *step->cpu; });
    if (slot == causes.per_cpu.end()) {
      causes.per_cpu.push_back({*step->cpu, cause_split{}});
      slot = causes.per_cpu.end() - 1;
    }
    for (std::size_t cause = 0; cause < kDelayCauses; ++cause) slot->second[cause] += step->cause_ns[cause];
  }
  std::sort(causes.per_cpu.begin(), causes.per_cpu.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::sort(late.begin(), late.end(), [](const late_step& a, const late_step& b) {
    return a.excess_ns != b.excess_ns ? a.excess_ns > b.excess_ns : a.period < b.period;
  });
  if (late.size() > worst) late.resize(worst);
  causes.worst = std::move(late);
  return causes;
}

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

std::string causes_text(const delay_causes& causes, const std::string& title, std::size_t worst_shown) {
  std::string out = fmt::format("\n{}\n", title);
  if (!causes.unavailable.empty()) return out + fmt::format("  not attributed: {}\n", causes.unavailable);
  out += fmt::format(
      "each late step's excess over the median completion ({:.1f} us), split along its critical path "
      "(share of the excess; stages 0-3)\n",
      causes.median_completion_ns / 1e3);
  static constexpr const char* kColumns[kDelayCauses] = {"compute", "rq wait", "migrate", "faults",
                                                         "irq",     "wake-up", "stall",   "unexpl."};
  std::string header = fmt::format("{:<12} {:>6} {:>10}", "steps", "count", "excess ms");
  for (const char* column : kColumns) header += fmt::format(" {:>8}", column);
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


// --find-period: which causes made the misses (the failed trial next to the
// answer, and the confirming run's), one line.
std::string misses_line(const delay_analysis& analysis) {
  const auto words = [](const cause_row& row) {
    std::vector<std::pair<double, std::string>> ranked;
    for (std::size_t cause = 0; cause < kDelayCauses; ++cause)
      if (row.cause_ns[cause] > 0.005 * row.excess_ns)
        ranked.emplace_back(row.cause_ns[cause], cause_words(static_cast<delay_cause>(cause)));
    std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::string text;
    for (const auto& [ns, name] : ranked)
      text += fmt::format("{}{} {:.0f} %", text.empty() ? "" : ", ", name, 100 * ns / row.excess_ns);
    return text;
  };
  std::string out;
  if (analysis.trial_causes && analysis.trial_causes->misses)
    out += fmt::format("what made the failed trial miss ({} misses): {}\n", analysis.trial_causes->misses->steps,
                       words(*analysis.trial_causes->misses));
  if (analysis.causes && analysis.causes->misses)
    out += fmt::format("what made the confirming run miss ({} misses): {}\n", analysis.causes->misses->steps,
                       words(*analysis.causes->misses));
  return out;
}
}  // namespace

std::string search_rule(const probes::period_search_settings& search, std::int64_t trial_periods) {
  return fmt::format(
      "a period holds when the one-sided {:g} % Clopper-Pearson upper bound on its miss rate is at most {:g}; "
      "each trial runs {} periods ({} is the fewest with which zero misses shows the rate below {:g}) and ends "
      "early at the miss that makes it fail ({} allowed); halve or double until a period fails and a longer one "
      "holds, then bisect geometrically until they are within {:g} %; the confirming run runs its whole length",
      100 * search.confidence, search.miss_rate, trial_periods,
      probes::minimum_trial_periods(search.miss_rate, search.confidence), search.miss_rate,
      probes::allowed_misses(trial_periods, search.miss_rate, search.confidence), 100 * search.tolerance);
}

delay_analysis analyse_delay(const delay_measurement& measured) {
  delay_analysis analysis;
  const paced_result& run = measured.pinned;
  const bool per_cpu = measured.settings.per_cpu;
  analysis.histogram.bound_us = measured.settings.histogram_bound_us;
  if (!run.wakeup_ns.empty())
    for (unsigned id = 0; id < run.participants; ++id)
      analysis.histogram.columns.push_back(probes::histogram_column(
          probes::participant_samples(run.wakeup_ns, run.participants, id), measured.settings.histogram_bound_us,
          thread_name(run, id, per_cpu), run.cpus[id]));

  if (per_cpu && !run.wakeup_ns.empty()) {
    std::vector<cpu_latency> latencies;
    std::vector<std::size_t> row_of_latency;
    for (unsigned id = 0; id < run.participants; ++id) {
      per_cpu_row row;
      row.cpu = run.cpus[id];
      row.shown_cpu = run.cpus[id].value_or(id);
      row.wakeup_ns = probes::participant_samples(run.wakeup_ns, run.participants, id);
      row.completion_ns = probes::participant_samples(run.end_ns, run.participants, id);
      for (double end : row.completion_ns) row.deadline_misses += end > static_cast<double>(measured.period_ns) ? 1 : 0;
      if (!row.wakeup_ns.empty()) {
        row.wakeup = platform::summarize(row.wakeup_ns);
        latencies.push_back({row.shown_cpu, row.wakeup.p99, row.wakeup.max});
        row_of_latency.push_back(analysis.per_cpu.size());
      }
      analysis.per_cpu.push_back(std::move(row));
    }
    if (const auto index = noisiest_cpu(latencies)) analysis.noisiest = row_of_latency[*index];
  }

  if (measured.searched) {
    const auto& search = measured.searched->search;
    search_reading reading;
    for (const auto& trial : search.trials)
      reading.largest_completion_p99_ns = std::max(reading.largest_completion_p99_ns, trial.outcome.completion_p99_ns);
    // Whether the step's cost or the machine's stalls set the answer: when the
    // answer is many times every trial's completion p99, the misses that kept
    // shorter periods from holding were rare stalls (a VM's vCPU descheduled
    // for milliseconds), whose rate barely falls with the period; such an
    // answer moves from run to run with the stalls.
    reading.set_by_stalls = search.found_period_ns && reading.largest_completion_p99_ns > 0 &&
                            static_cast<double>(*search.found_period_ns) >
                                kStallDominatedFactor * reading.largest_completion_p99_ns;
    if (search.confirm) reading.confirm_within_rate = search.confirm->miss_rate <= measured.settings.search.miss_rate;
    if (measured.searched->confirm && !measured.searched->confirm->completion_ns.empty())
      reading.confirm_longest_completion_ns = platform::summarize(measured.searched->confirm->completion_ns).max;
    analysis.search = reading;
    if (measured.searched->failed_trial && measured.searched->failed_trial->record)
      analysis.trial_causes = attribute_delay(*measured.searched->failed_trial);
  }
  if (run.record && !run.completion_ns.empty()) analysis.causes = attribute_delay(run);
  return analysis;
}

std::string delay_text(const delay_measurement& measured, const delay_analysis& analysis, bool histogram_file) {
  const paced_result& pinned = measured.pinned;
  const auto& settings = measured.settings;
  const bool measured_any = !pinned.wakeup_ns.empty();
  std::string out = fmt::format("{}: {} periods of {} us{}\n", measured.name, pinned.periods,
                                microseconds_text(measured.period_ns), measured.policy);
  out += idle_line(measured.idle) + "\n";
  out += fmt::format("view: {}\n", measured.view);
  out += fmt::format("placement: {}\n", measured.placement);
  if (analysis.search) out += search_text(measured, *analysis.search);
  if (analysis.search) out += misses_line(analysis);
  if (measured.searched && !measured_any) out += "\nno confirming run: nothing to show beyond the trials\n";
  if (!measured_any) return out;

  out += result_text(measured.searched          ? fmt::format("confirming run at {} us", microseconds_text(measured.period_ns))
                     : settings.compare_pinning ? "pinned (--pin " + settings.pin + ")"
                                                : std::string("result"),
                     pinned, measured.period_ns);
  if (settings.per_cpu) out += per_cpu_text(analysis, measured.period_ns);
  if (settings.stop_above_ns) out += stop_text(measured);
  std::vector<labelled_samples> series;
  if (settings.per_cpu) {
    for (unsigned id = 0; id < pinned.participants; ++id)
      series.push_back({thread_name(pinned, id, true), probes::participant_samples(pinned.wakeup_ns, pinned.participants, id)});
  } else {
    series.push_back({"count", pinned.wakeup_ns});
  }
  out += fmt::format("\nwake-up latency histogram (1-2-5 buckets; the 1 us buckets up to {} us are in the JSON{})\n{}",
                     settings.histogram_bound_us, histogram_file ? " and --histogram-file" : "",
                     log_histogram_text(series));
  out += fmt::format("\nFigure 5: context switches per thread, and the share that crossed cores\n{}",
                     pinned.figure5.render());
  if (analysis.trial_causes && measured.searched && measured.searched->search.failed_period_ns)
    out += causes_text(*analysis.trial_causes,
                       fmt::format("why the failed trial at {} us missed (the period next to the answer)",
                                   microseconds_text(*measured.searched->search.failed_period_ns)),
                       5);
  if (analysis.causes)
    out += causes_text(*analysis.causes,
                       measured.searched ? std::string("why the confirming run's late steps were late")
                                         : std::string("why the late steps were late"),
                       10);
  if (measured.unpinned) {
    out += result_text("unpinned (--pin none)", *measured.unpinned, measured.period_ns);
    out += fmt::format("\nFigure 5, unpinned\n{}", measured.unpinned->figure5.render());
  }
  return out;
}

nlohmann::json delay_json(const delay_measurement& measured, const delay_analysis& analysis,
                          const platform::topology& machine) {
  const paced_result& pinned = measured.pinned;
  const auto& settings = measured.settings;
  const auto& idle = measured.idle;
  nlohmann::json document = result_document("delay", machine);
  merge_into_result(document, context_map{{"dma_latency", idle_state(idle)},
                                          {"dma_latency_in_force_us",
                                           idle.in_force_us ? std::to_string(*idle.in_force_us) : "unavailable"},
                                          {"cpuidle_driver", idle.driver},
                                          {"cpuidle_governor", idle.governor}});
  document.update({
      {"name", measured.name},
      {"settings",
       {{"period_ns", measured.period_ns},
        {"duration_s", settings.find_period ? nlohmann::json(nullptr)
                                            : nlohmann::json(static_cast<double>(settings.duration_ns) / 1e9)},
        {"sync", settings.sync},
        {"layout", settings.layout},
        {"pin", settings.pin},
        {"threads", settings.threads},
        {"model", settings.model.key()},
        {"equations", settings.model.equations()},
        {"per_cpu", settings.per_cpu},
        {"compare_pinning", settings.compare_pinning},
        {"view", measured.view},
        {"fifo_priority", settings.fifo_priority ? nlohmann::json(*settings.fifo_priority) : nullptr},
        {"mlock", settings.mlock},
        {"periods", settings.find_period ? pinned.periods : settings.periods},
        {"dma_latency_us", settings.dma_latency_us ? nlohmann::json(*settings.dma_latency_us) : nullptr},
        {"histogram_bound_us", settings.histogram_bound_us},
        {"stop_above_ns", settings.stop_above_ns ? nlohmann::json(*settings.stop_above_ns) : nullptr},
        {"placement", measured.placement}}},
      {"idle", idle_json(idle)},
      {"periods_measured", pinned.periods},
      {"wakeup_latency_ns", distribution_json(pinned.wakeup_ns)},
      {"completion_ns", distribution_json(pinned.completion_ns)},
      {"deadline_misses", pinned.deadline_misses},
      {"histogram", histogram_json(histogram_of(pinned.wakeup_ns))},
      {"latency_histogram", latency_histogram_json(analysis.histogram)},
      {"figure5", figure5_json(pinned.figure5)},
      {"warnings", pinned.errors}});
  if (settings.per_cpu) document["per_cpu"] = pinned.wakeup_ns.empty() ? nlohmann::json(nullptr) : per_cpu_json(analysis);
  if (settings.stop_above_ns) document["stop"] = stop_json(measured);
  if (analysis.search) document["find_period"] = search_json(measured, *analysis.search);
  document["causes"] = analysis.causes ? causes_json(*analysis.causes) : nlohmann::json(nullptr);
  if (analysis.search)
    document["find_period"]["failed_trial_causes"] =
        analysis.trial_causes ? causes_json(*analysis.trial_causes) : nlohmann::json(nullptr);
  if (measured.unpinned) {
    document["figure5_unpinned"] = figure5_json(measured.unpinned->figure5);
    document["unpinned"] = {{"wakeup_latency_ns", distribution_json(measured.unpinned->wakeup_ns)},
                            {"completion_ns", distribution_json(measured.unpinned->completion_ns)},
                            {"deadline_misses", measured.unpinned->deadline_misses}};
  }
  return document;
}

}  // namespace lockstep::bench
