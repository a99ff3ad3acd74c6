// What a delay measurement means, as text and as a result file (delay_report.hpp).
#include "bench/delay/delay_report.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "bench/delay/attribution_output.hpp"
#include "bench/delay/delay_output.hpp"
#include "bench/results/machine_context.hpp"
#include "bench/results/result_json.hpp"

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

// The run's result: the overrun first, when steps overran, then the
// distributions and the misses.
std::string result_text(const std::string& title, const paced_result& run, std::int64_t period_ns,
                        const std::optional<overrun_reading>& overrun) {
  std::string out = fmt::format("\n{}\n", title);
  if (overrun) out += overrun_line(*overrun) + "\n";
  out += fmt::format("{:<22} {:>10} {:>10} {:>10} {:>10} {:>10} {:>9}\n", "us", "min", "p50", "p99", "p99.9", "max",
                     "count");
  out += distribution_line("wake-up latency", run.wakeup_ns);
  out += distribution_line("completion (deadline)", run.completion_ns);
  out += fmt::format("deadline misses: {} of {}{} (deadline = period = {} us)\n", run.deadline_misses,
                     run.completion_ns.size(),
                     run.skipped_periods == 0
                         ? std::string()
                         : fmt::format(" steps, and {} periods skipped after them", run.skipped_periods),
                     microseconds_text(period_ns));
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

nlohmann::json overrun_json(const std::optional<overrun_reading>& overrun) {
  if (!overrun) return nullptr;
  return {{"steps", overrun->steps},
          {"overran", overrun->overran},
          {"skipped_periods", overrun->skipped_periods},
          {"periods", overrun->periods},
          {"schedules", overrun->schedules},
          {"period_ns", overrun->period_ns},
          {"completion_p50_ns", overrun->completion_p50_ns},
          {"completion_max_ns", overrun->completion_max_ns},
          {"step_exceeds_period", overrun->step_exceeds_period},
          {"line", overrun_line(*overrun)}};
}

nlohmann::json per_cpu_json(const delay_analysis& analysis) {
  nlohmann::json rows = nlohmann::json::array();
  for (const per_cpu_row& row : analysis.per_cpu)
    rows.push_back({{"cpu", row.cpu ? nlohmann::json(*row.cpu) : nullptr},
                    {"wakeup_latency_ns", distribution_json(row.wakeup_ns)},
                    {"completion_ns", distribution_json(row.completion_ns)},
                    {"deadline_misses", row.deadline_misses},
                    {"skipped_periods", row.skipped_periods}});
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
                 {"step", run.stop->step},
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
          {"skipped_periods", trial.outcome.skipped},
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

// --find-period: which causes made the misses (the failed trial next to the
// answer, and the confirming run's), one line.
std::string misses_line(const delay_analysis& analysis) {
  std::string out;
  if (analysis.trial_causes && analysis.trial_causes->misses)
    out += fmt::format("what made the failed trial miss ({} misses): {}\n", analysis.trial_causes->misses->steps,
                       ranked_causes(*analysis.trial_causes->misses));
  if (analysis.causes && analysis.causes->misses)
    out += fmt::format("what made the confirming run miss ({} misses): {}\n", analysis.causes->misses->steps,
                       ranked_causes(*analysis.causes->misses));
  return out;
}

}  // namespace

std::optional<overrun_reading> overrun_of(const paced_result& run, std::int64_t period_ns) {
  if (run.deadline_misses == 0 || run.completion_ns.empty()) return std::nullopt;
  const platform::distribution completion = platform::summarize(run.completion_ns);
  overrun_reading overrun;
  overrun.steps = static_cast<std::int64_t>(run.completion_ns.size());
  overrun.overran = run.deadline_misses;
  overrun.skipped_periods = run.skipped_periods;
  overrun.periods = overrun.steps + static_cast<std::int64_t>(run.skipped_periods);
  overrun.schedules = run.independent ? run.participants : 1U;
  overrun.period_ns = period_ns;
  overrun.completion_p50_ns = completion.p50;
  overrun.completion_max_ns = completion.max;
  overrun.step_exceeds_period = completion.p50 > static_cast<double>(period_ns);
  return overrun;
}

std::string overrun_line(const overrun_reading& overrun) {
  const std::string period = microseconds_text(overrun.period_ns);
  const std::string skipped =
      fmt::format("{} of the {} periods{} were skipped (after an overrun the next step waits for the next period "
                  "boundary, as a real-time loop does",
                  overrun.skipped_periods, overrun.periods,
                  overrun.schedules > 1 ? fmt::format(" of the {} participants' own schedules", overrun.schedules)
                                        : std::string());
  if (overrun.step_exceeds_period)
    return fmt::format(
        "overrun: the step does not fit the period: its completion p50 is {:.1f} us against a period of {} us ({:.1f} "
        "periods); {} of {} steps overran, and {}: each latency below is of its own period)",
        overrun.completion_p50_ns / 1e3, period,
        overrun.completion_p50_ns / static_cast<double>(overrun.period_ns), overrun.overran, overrun.steps, skipped);
  return fmt::format("overrun: {} of {} steps overran the {} us period (the longest completed {:.1f} us after its "
                     "period's start); {})",
                     overrun.overran, overrun.steps, period, overrun.completion_max_ns / 1e3, skipped);
}

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
  analysis.overrun = overrun_of(run, measured.period_ns);
  if (measured.unpinned) analysis.unpinned_overrun = overrun_of(*measured.unpinned, measured.period_ns);
  analysis.histogram.bound_us = measured.settings.histogram_bound_us;
  if (!run.wakeup_ns.empty())
    for (unsigned id = 0; id < run.participants; ++id)
      analysis.histogram.columns.push_back(probes::histogram_column(
          probes::samples_of(run, run.wakeup_ns, id), measured.settings.histogram_bound_us,
          thread_name(run, id, per_cpu), run.cpus[id]));

  if (per_cpu && !run.wakeup_ns.empty()) {
    std::vector<cpu_latency> latencies;
    std::vector<std::size_t> row_of_latency;
    for (unsigned id = 0; id < run.participants; ++id) {
      per_cpu_row row;
      row.cpu = run.cpus[id];
      row.shown_cpu = run.cpus[id].value_or(id);
      row.wakeup_ns = probes::samples_of(run, run.wakeup_ns, id);
      row.completion_ns = probes::samples_of(run, run.end_ns, id);
      for (double end : row.completion_ns) row.deadline_misses += end > static_cast<double>(measured.period_ns) ? 1 : 0;
      if (id < run.skipped_by_participant.size()) row.skipped_periods = run.skipped_by_participant[id];
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
  std::string out = fmt::format("{}: {} periods of {} us{}\n", measured.name, pinned.periods_scheduled,
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
                     pinned, measured.period_ns, analysis.overrun);
  if (settings.per_cpu) out += per_cpu_text(analysis, measured.period_ns);
  if (settings.stop_above_ns) out += stop_text(measured);
  std::vector<labelled_samples> series;
  if (settings.per_cpu) {
    for (unsigned id = 0; id < pinned.participants; ++id)
      series.push_back({thread_name(pinned, id, true), probes::samples_of(pinned, pinned.wakeup_ns, id)});
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
    out += result_text("unpinned (--pin none)", *measured.unpinned, measured.period_ns, analysis.unpinned_overrun);
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
      {"periods_scheduled", pinned.periods_scheduled},
      {"skipped_periods", pinned.skipped_periods},
      {"overrun", overrun_json(analysis.overrun)},
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
  document["cause_kinds"] = cause_kinds_json();
  if (analysis.search)
    document["find_period"]["failed_trial_causes"] =
        analysis.trial_causes ? causes_json(*analysis.trial_causes) : nlohmann::json(nullptr);
  if (measured.unpinned) {
    document["figure5_unpinned"] = figure5_json(measured.unpinned->figure5);
    document["unpinned"] = {{"wakeup_latency_ns", distribution_json(measured.unpinned->wakeup_ns)},
                            {"completion_ns", distribution_json(measured.unpinned->completion_ns)},
                            {"deadline_misses", measured.unpinned->deadline_misses},
                            {"skipped_periods", measured.unpinned->skipped_periods}};
  }
  return document;
}

}  // namespace lockstep::bench
