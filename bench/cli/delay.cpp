// lockstep delay: the paper's real-time use of its model. The composed RK4
// step of one sync x layout x placement runs paced at a period for a
// duration (the paced probe, bench/probes/paced.hpp: absolute clock_nanosleep
// per period, as cyclictest), optionally under SCHED_FIFO and with memory
// locked, with /dev/cpu_dma_latency held at 0 as cyclictest holds it.
// Reports the wake-up latency and the completion time against the deadline as
// distributions, the deadline misses, histograms (1 us buckets as
// cyclictest's -h, and a logarithmic view for the terminal), and the paper's
// Figure 5 table (context switches per thread, and the share that crossed
// cores); with --compare-pinning the same run unpinned beside it.
//
// Views: the default is the paper's model (4 participants share one step,
// std_barrier between the stages); --threads 1 is like for like with
// `cyclictest -t1`, --per-cpu with `cyclictest -S` (one paced thread per CPU).
// --stop-above ends a run at the first late wake-up (cyclictest -b);
// --find-period searches the shortest period that holds a miss rate
// (bench/probes/period_search.hpp).
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <stop_token>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/delay_output.hpp"
#include "bench/cli/options.hpp"
#include "bench/harness/machine_context.hpp"
#include "bench/harness/result_file.hpp"
#include "bench/harness/result_json.hpp"
#include "bench/probes/latency_histogram.hpp"
#include "bench/probes/paced.hpp"
#include "bench/probes/period_search.hpp"
#include "kernels/model_choice.hpp"
#include "platform/clock.hpp"
#include "platform/idle_states.hpp"
#include "platform/placement.hpp"
#include "platform/scheduling.hpp"
#include "platform/stats.hpp"
#include "platform/thread_accounting.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {
namespace {

namespace probes = bench::probes;

// The PM QoS file the hold opens. Tests point it elsewhere (a missing path,
// a plain file) with this environment variable; nothing else reads it.
constexpr const char* kDmaLatencyPathVariable = "LOCKSTEP_DMA_LATENCY_PATH";

// The search's defaults (--find-period): the shortest period it tries (the
// shortest --period), the longest, and how close the bracket must close.
constexpr std::int64_t kSearchFloorNs = 10'000;
constexpr std::int64_t kSearchCeilingNs = 1'000'000'000;
constexpr double kSearchTolerance = 0.05;
constexpr double kSearchConfidence = 0.95;
// A rate below this needs trials of more than 3 million periods.
constexpr double kSmallestMissRate = 1e-6;

struct delay_options {
  std::string sync = "std_barrier";
  std::string layout = "padded64";
  std::string pin = "compact";
  unsigned threads = 4;
  std::optional<std::size_t> masses;  // --masses S: an S-mass chain whatever --threads
  std::string period = "1ms";
  std::string duration = "10s";
  std::optional<int> fifo;
  bool mlock = false;
  bool compare_pinning = false;
  std::string out;
  std::optional<std::string> dma_latency;
  bool no_dma_latency = false;
  std::string histogram_bound = "1000us";
  std::string histogram_file;
  bool per_cpu = false;
  std::optional<std::string> stop_above;
  bool find_period = false;
  std::optional<double> miss_rate;
  std::string search_budget = "120s";
  std::optional<std::int64_t> trial_periods;
};

// The idle-state setting in force for the run, as printed and written.
struct idle_setting {
  std::optional<std::int32_t> requested_us;  // empty: --no-dma-latency
  bool held = false;
  std::optional<std::int32_t> in_force_us;
  std::string path;
  std::string problem;  // why the hold failed, when it did
  std::string driver = platform::cpuidle_driver();
  std::string governor = platform::cpuidle_governor();
  std::string clocksource = platform::clocksource();

  // "held at 0 us" / "not held (--no-dma-latency)" / "not held (cannot open ...)"
  std::string state() const {
    if (!requested_us) return "not held (--no-dma-latency)";
    if (!held) return fmt::format("not held (cannot hold {} at {} us: {})", path, *requested_us, problem);
    return fmt::format("held at {} us", *requested_us);
  }
  // The one line of the text output.
  std::string line() const {
    std::string words;
    if (!requested_us)
      words = fmt::format("{} left alone (--no-dma-latency): the CPUs may enter deep idle states between periods",
                          path);
    else if (!held)
      words = fmt::format("{} could not be held at {} us ({}): idle states not limited", path, *requested_us, problem);
    else
      words = fmt::format("{} held at {} us for the run{}{}", path, *requested_us,
                          *requested_us == 0 ? ", as cyclictest does by default" : "",
                          in_force_us && *in_force_us != *requested_us
                              ? fmt::format(" (in force: {} us, another process asks for less)", *in_force_us)
                              : "");
    return fmt::format("idle: {}; cpuidle driver {}, governor {}; clocksource {}", words, driver, governor,
                       clocksource);
  }
  nlohmann::json json() const {
    return {{"requested_us", requested_us ? nlohmann::json(*requested_us) : nullptr},
            {"held", held},
            {"in_force_us", in_force_us ? nlohmann::json(*in_force_us) : nullptr},
            {"path", path},
            {"problem", problem.empty() ? nlohmann::json(nullptr) : nlohmann::json(problem)},
            {"cpuidle_driver", driver},
            {"cpuidle_governor", governor},
            {"clocksource", clocksource}};
  }
};

// Everything checked before any measurement.
struct delay_plan {
  std::int64_t period_ns = 0;
  std::int64_t duration_ns = 0;
  std::int64_t periods = 0;
  platform::placement kind = platform::placement::compact;
  std::optional<std::int32_t> dma_latency_us;  // empty: --no-dma-latency
  std::int64_t histogram_bound_us = probes::kDefaultHistogramBoundUs;
  std::optional<std::int64_t> stop_above_ns;
  probes::period_search_settings search;
  std::vector<unsigned> cpus;  // --per-cpu
  // What the team integrates (kernels::model_for); --per-cpu: the paper's
  // two masses, one step per CPU (bench/probes/paced.hpp).
  kernels::model_choice model;
};

std::int64_t whole_microseconds(const std::string& text, const std::string& option, std::int64_t min_us,
                                std::int64_t max_us) {
  const std::int64_t ns = parse_duration_ns(text, option, min_us * 1000, max_us * 1000);
  if (ns % 1000 != 0) throw usage_error(option + ": '" + text + "' is not a whole number of microseconds");
  return ns / 1000;
}

nlohmann::json figure5_json(const platform::figure5_table& table) {
  nlohmann::json rows = nlohmann::json::array();
  auto row_json = [](const platform::figure5_row& row) {
    return nlohmann::json{{"thread", row.thread},
                          {"role", row.role},
                          {"cross_core_csw", row.cross_core_csw ? nlohmann::json(*row.cross_core_csw) : nullptr},
                          {"total_csw", row.total_csw},
                          {"pct", row.pct ? nlohmann::json(*row.pct) : nullptr}};
  };
  for (const auto& row : table.rows()) rows.push_back(row_json(row));
  return rows;
}

void print_distribution(const std::string& what, const std::vector<double>& samples) {
  if (samples.empty()) {
    fmt::print("{:<22} no samples\n", what);
    return;
  }
  const auto d = platform::summarize(samples);
  fmt::print("{:<22} {:>10.1f} {:>10.1f} {:>10.1f} {:>10.1f} {:>10.1f} {:>9}\n", what, d.min / 1e3, d.p50 / 1e3,
             d.p99 / 1e3, d.p999 / 1e3, d.max / 1e3, d.count);
}

std::string us(std::int64_t ns) { return fmt::format("{:g}", static_cast<double>(ns) / 1e3); }

void print_result(const std::string& title, const probes::paced_result& run, std::int64_t period_ns) {
  fmt::print("\n{}\n", title);
  fmt::print("{:<22} {:>10} {:>10} {:>10} {:>10} {:>10} {:>9}\n", "us", "min", "p50", "p99", "p99.9", "max", "count");
  print_distribution("wake-up latency", run.wakeup_ns);
  print_distribution("completion (deadline)", run.completion_ns);
  fmt::print("deadline misses: {} of {} (deadline = period = {} us)\n", run.deadline_misses, run.completion_ns.size(),
             us(period_ns));
  for (const auto& error : run.errors) fmt::print("warning: {}\n", error);
}

std::string thread_name(const probes::paced_result& run, unsigned participant, bool per_cpu) {
  if (per_cpu && run.cpus[participant]) return "cpu " + std::to_string(*run.cpus[participant]);
  return "worker " + std::to_string(participant);
}

probes::latency_histogram latency_histogram_of(const probes::paced_result& run, std::int64_t bound_us, bool per_cpu) {
  probes::latency_histogram histogram;
  histogram.bound_us = bound_us;
  for (unsigned id = 0; id < run.participants; ++id)
    histogram.columns.push_back(probes::histogram_column(probes::participant_samples(run.wakeup_ns, run.participants, id),
                                                         bound_us, thread_name(run, id, per_cpu), run.cpus[id]));
  return histogram;
}

void print_stop(const probes::paced_result& run, std::int64_t threshold_ns, std::int64_t period_ns, bool per_cpu) {
  if (!run.stop) {
    fmt::print("\n--stop-above {} us: no wake-up was later; the run went to its end\n", us(threshold_ns));
    return;
  }
  const probes::paced_stop& stop = *run.stop;
  fmt::print("\nstopped: period {} ({:.6f} s after the start): {}{} woke {} us late (--stop-above {} us; period {} us)\n",
             stop.period, static_cast<double>(stop.since_start_ns) / 1e9, thread_name(run, stop.participant, per_cpu),
             stop.cpu && !per_cpu ? fmt::format(" on CPU {}", *stop.cpu) : "", us(stop.wakeup_ns), us(threshold_ns),
             us(period_ns));
  if (stop.previous_end_ns)
    fmt::print("  its step in the period before ended {} us after that period's start{}\n",
               us(*stop.previous_end_ns), *stop.previous_end_ns > period_ns ? " (an overrun: a deadline miss)" : "");
  else
    fmt::print("  it was the first period of the run\n");
}

nlohmann::json stop_json(const probes::paced_result& run, std::int64_t threshold_ns, std::int64_t period_ns,
                         bool per_cpu) {
  nlohmann::json stop = {{"threshold_ns", threshold_ns}, {"stopped", run.stop.has_value()}, {"periods_kept", run.periods}};
  if (run.stop) {
    stop.update({{"period", run.stop->period},
                 {"since_start_ns", run.stop->since_start_ns},
                 {"participant", run.stop->participant},
                 {"thread", thread_name(run, run.stop->participant, per_cpu)},
                 {"cpu", run.stop->cpu ? nlohmann::json(*run.stop->cpu) : nullptr},
                 {"wakeup_latency_ns", run.stop->wakeup_ns},
                 {"period_ns", period_ns},
                 {"previous_end_ns", run.stop->previous_end_ns ? nlohmann::json(*run.stop->previous_end_ns) : nullptr}});
  }
  return stop;
}

// The per-CPU table: one row per CPU, the noisiest named.
nlohmann::json print_per_cpu(const probes::paced_result& run, std::int64_t period_ns) {
  fmt::print("\nper CPU: one paced thread on each CPU, each computing the step alone (like cyclictest -S)\n");
  fmt::print("{:<8} {:>10} {:>10} {:>10} {:>10} {:>10} {:>9} {:>8}   wake-up latency, us; misses of {} us\n", "cpu",
             "min", "p50", "p99", "p99.9", "max", "count", "misses", us(period_ns));
  nlohmann::json rows = nlohmann::json::array();
  std::vector<cpu_latency> latencies;
  for (unsigned id = 0; id < run.participants; ++id) {
    const auto wake = probes::participant_samples(run.wakeup_ns, run.participants, id);
    const auto completion = probes::participant_samples(run.end_ns, run.participants, id);
    std::uint64_t misses = 0;
    for (double end : completion) misses += end > static_cast<double>(period_ns) ? 1 : 0;
    const unsigned cpu = run.cpus[id].value_or(id);
    if (!wake.empty()) {
      const auto d = platform::summarize(wake);
      fmt::print("{:<8} {:>10.1f} {:>10.1f} {:>10.1f} {:>10.1f} {:>10.1f} {:>9} {:>8}\n", cpu, d.min / 1e3,
                 d.p50 / 1e3, d.p99 / 1e3, d.p999 / 1e3, d.max / 1e3, d.count, misses);
      latencies.push_back({cpu, d.p99, d.max});
    }
    rows.push_back({{"cpu", run.cpus[id] ? nlohmann::json(*run.cpus[id]) : nullptr},
                    {"wakeup_latency_ns", bench::distribution_json(wake)},
                    {"completion_ns", bench::distribution_json(completion)},
                    {"deadline_misses", misses}});
  }
  nlohmann::json noisiest = nullptr;
  if (const auto index = noisiest_cpu(latencies)) {
    const cpu_latency& worst = latencies[*index];
    fmt::print("noisiest CPU: {} (p99 {:.1f} us; rule: {})\n", worst.cpu, worst.p99_ns / 1e3, kNoisiestRule);
    noisiest = {{"cpu", worst.cpu}, {"p99_ns", worst.p99_ns}, {"max_ns", worst.max_ns}, {"rule", kNoisiestRule}};
  }
  return {{"cpus", rows}, {"noisiest", noisiest}};
}

// Long runs say how far they are, every 5 s, from a thread that sleeps
// otherwise (it is not a participant and does not pace anything).
std::jthread progress_reporter(std::int64_t total_ns) {
  if (total_ns < 10'000'000'000) return {};
  return std::jthread([total_s = static_cast<double>(total_ns) / 1e9](std::stop_token stop) {
    std::mutex mutex;
    std::condition_variable_any tick;
    std::unique_lock lock(mutex);
    const std::int64_t began = platform::now_ns();
    while (!tick.wait_for(lock, stop, std::chrono::seconds(5), [] { return false; }) && !stop.stop_requested())
      fmt::print(stderr, "delay: {:.0f} s of {:.0f} s\n", static_cast<double>(platform::now_ns() - began) / 1e9,
                 total_s);
  });
}

delay_plan check_input(const delay_options& options) {
  delay_plan plan;
  plan.period_ns = parse_duration_ns(options.period, "--period", kSearchFloorNs);
  if (!options.find_period) {
    plan.duration_ns = parse_duration_ns(options.duration, "--duration");
    if (plan.duration_ns < plan.period_ns) throw usage_error("--duration must be at least one --period");
    plan.periods = plan.duration_ns / plan.period_ns;
    if (plan.periods > 100'000'000) throw usage_error("--duration / --period exceeds 100000000 periods");
  }
  if (!options.per_cpu) {
    try {
      plan.kind = platform::parse_placement(options.pin);
    } catch (const std::invalid_argument& e) {
      throw usage_error(std::string("--pin: ") + e.what());
    }
    if (options.compare_pinning && plan.kind == platform::placement::none)
      throw usage_error(
          "--compare-pinning compares a pinned placement with none: give --pin compact, scatter or migrate");
  }
  if (options.fifo) {
    const int low = platform::fifo_min_priority();
    const int high = platform::fifo_max_priority();
    if (*options.fifo < low || *options.fifo > high)
      throw usage_error("--fifo: priority " + std::to_string(*options.fifo) + " is outside " + std::to_string(low) +
                        ".." + std::to_string(high));
  }
  if (!options.no_dma_latency)
    plan.dma_latency_us = static_cast<std::int32_t>(
        options.dma_latency ? whole_microseconds(*options.dma_latency, "--dma-latency", 0, 2'000'000'000) : 0);
  plan.histogram_bound_us = whole_microseconds(options.histogram_bound, "--histogram-bound", 1, 100'000);
  if (options.stop_above) plan.stop_above_ns = parse_duration_ns(*options.stop_above, "--stop-above", 1'000);
  if (options.find_period) {
    if (!options.miss_rate) throw usage_error("--find-period needs --miss-rate R (for example --miss-rate 1e-3)");
    if (!(*options.miss_rate >= kSmallestMissRate && *options.miss_rate < 1.0))
      throw usage_error(fmt::format("--miss-rate: {} is outside [{:g}, 1)", *options.miss_rate, kSmallestMissRate));
    plan.search.miss_rate = *options.miss_rate;
    plan.search.confidence = kSearchConfidence;
    plan.search.trial_periods = options.trial_periods.value_or(0);
    plan.search.start_period_ns = plan.period_ns;
    plan.search.floor_period_ns = kSearchFloorNs;
    plan.search.ceiling_period_ns = kSearchCeilingNs;
    plan.search.tolerance = kSearchTolerance;
    plan.search.budget_ns = parse_duration_ns(options.search_budget, "--search-budget", 1'000'000'000, 86'400'000'000'000);
    if (const std::string problem = probes::period_search_problem(plan.search); !problem.empty())
      throw usage_error("--trial-periods: " + problem);
    if (options.trial_periods && *options.trial_periods > 100'000'000)
      throw usage_error("--trial-periods: at most 100000000 periods");
  }
  if (!options.per_cpu) plan.model = kernels::model_for(options.threads, options.masses);
  // Names and applicability before permissions: the first error is the input's
  // (more threads than the model's equations among them, possible with --masses).
  const std::string problem =
      options.per_cpu ? probes::paced_per_cpu_problem(options.sync, options.layout)
                      : probes::paced_step_problem(options.sync, options.layout, options.threads, plan.model);
  if (!problem.empty()) throw usage_error(problem);
  check_out(options.out);
  if (!options.histogram_file.empty()) {
    try {
      bench::check_result_path(options.histogram_file);
    } catch (const bench::result_path_error& error) {
      throw usage_error(std::string("--histogram-file: ") + error.what());
    }
  }
  return plan;
}

void check_permissions(const delay_options& options) {
  // Permissions, checked on this thread before anything runs: one line each,
  // saying what is missing and how to run without it.
  if (options.fifo) {
    try {
      platform::set_current_thread_fifo(*options.fifo);
      platform::set_current_thread_normal();
    } catch (const platform::scheduling_error& e) {
      throw usage_error(e.what());
    }
  }
  if (options.mlock) {
    try {
      platform::lock_all_memory();
    } catch (const platform::scheduling_error& e) {
      throw usage_error(e.what());
    }
  }
}

struct search_outcome {
  probes::period_search_result search;
  std::optional<probes::paced_result> confirm;  // the confirming run's whole result
};

search_outcome run_search(const delay_plan& plan, probes::paced_step_settings settings,
                          const platform::placement_plan& placement) {
  search_outcome outcome;
  const auto runner = [&](std::int64_t period_ns, std::int64_t periods, std::optional<std::uint64_t> stop_after_misses,
                          bool confirming) {
    settings.pacing.period_ns = period_ns;
    settings.pacing.periods = periods;
    settings.pacing.stop_after_misses = stop_after_misses;
    const std::int64_t began = platform::now_ns();
    probes::paced_result run = probes::run_paced_step(settings, placement);
    probes::trial_outcome trial;
    trial.elapsed_ns = platform::now_ns() - began;
    trial.periods = run.periods;
    trial.misses = run.deadline_misses;
    if (!run.completion_ns.empty()) {
      const auto d = platform::summarize(run.completion_ns);
      trial.completion_p50_ns = d.p50;
      trial.completion_p99_ns = d.p99;
    }
    if (confirming) outcome.confirm = std::move(run);
    return trial;
  };
  const auto observe = [&](const probes::period_trial& trial, bool confirming) {
    fmt::print(stderr, "delay: {} {} us: {} misses in {} periods, bound {:.3g}: {}\n",
               confirming ? "confirming at" : "trial at", us(trial.period_ns), trial.outcome.misses,
               trial.outcome.periods, trial.upper_bound, trial.holds ? "holds" : "fails");
  };
  outcome.search = probes::find_period(plan.search, runner, observe);
  return outcome;
}

// An answer this many times the largest completion p99 of the search's trials
// was not set by the step: a step whose p99 is 150 us does not miss a 1.5 ms
// deadline by its own cost, only when the machine stalls.
constexpr double kStallDominatedFactor = 10.0;

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

nlohmann::json print_search(const search_outcome& outcome, const delay_plan& plan, const std::string& name) {
  const auto& search = outcome.search;
  fmt::print("\nfind-period: the shortest period at which {} misses its deadline at most at rate {:g}\n", name,
             plan.search.miss_rate);
  fmt::print("rule: {}\n", search_rule(plan.search, search.trial_periods));
  fmt::print("{:>5} {:>12} {:>9} {:>7} {:>10} {:>10} {:>8} {:>12} {:>12}\n", "trial", "period us", "periods", "misses",
             "rate", "bound", "verdict", "compl. p50", "compl. p99");
  for (std::size_t index = 0; index < search.trials.size(); ++index) {
    const auto& trial = search.trials[index];
    fmt::print("{:>5} {:>12} {:>9} {:>7} {:>10.3g} {:>10.3g} {:>8} {:>12.1f} {:>12.1f}\n", index + 1,
               us(trial.period_ns), trial.outcome.periods, trial.outcome.misses, trial.miss_rate, trial.upper_bound,
               trial.holds ? "holds" : "fails", trial.outcome.completion_p50_ns / 1e3,
               trial.outcome.completion_p99_ns / 1e3);
  }
  std::string why;
  if (search.stopped_because == "converged")
    why = fmt::format("the bracket closed within {:g} %", 100 * plan.search.tolerance);
  else if (search.stopped_because == "budget")
    why = fmt::format("the search budget ({} s) cut the search: the next trial and the confirming run would not fit",
                      static_cast<double>(plan.search.budget_ns) / 1e9);
  else if (search.stopped_because == "floor")
    why = fmt::format("it held at the shortest period the search tries ({} us)", us(plan.search.floor_period_ns));
  else
    why = fmt::format("it failed at the longest period the search tries ({} us)", us(plan.search.ceiling_period_ns));
  if (search.found_period_ns)
    fmt::print("answer: {} us{} ({})\n", us(*search.found_period_ns),
               search.failed_period_ns ? fmt::format("; {} us failed", us(*search.failed_period_ns)) : "", why);
  else
    fmt::print("answer: none: no period tried held ({})\n", why);
  nlohmann::json confirm = nullptr;
  if (search.confirm) {
    const auto& trial = *search.confirm;
    const bool within = trial.miss_rate <= plan.search.miss_rate;
    fmt::print("confirming run at {} us: {} misses in {} periods, rate {:.3g}: {} the rate {:g}; the {:g} % bound "
               "{:.3g} {}\n",
               us(trial.period_ns), trial.outcome.misses, trial.outcome.periods, trial.miss_rate,
               within ? "within" : "NOT within", plan.search.miss_rate, 100 * plan.search.confidence,
               trial.upper_bound, trial.holds ? "holds too" : "does not hold");
    confirm = trial_json(trial);
    confirm["within_rate"] = within;
  }
  // Whether the step's cost or the machine's stalls set the answer: when the
  // answer is many times every trial's completion p99, the misses that kept
  // shorter periods from holding were rare stalls (a VM's vCPU descheduled for
  // milliseconds), whose rate barely falls with the period; such an answer
  // moves from run to run with the stalls, and the output says so.
  double largest_p99_ns = 0;
  for (const auto& trial : search.trials) largest_p99_ns = std::max(largest_p99_ns, trial.outcome.completion_p99_ns);
  const bool set_by_stalls = search.found_period_ns && largest_p99_ns > 0 &&
                             static_cast<double>(*search.found_period_ns) > kStallDominatedFactor * largest_p99_ns;
  if (set_by_stalls) {
    const double longest_ns = outcome.confirm && !outcome.confirm->completion_ns.empty()
                                  ? platform::summarize(outcome.confirm->completion_ns).max
                                  : 0.0;
    fmt::print("set by stalls: every trial's completion p99 was at most {:.1f} us, the answer is {} us: the misses "
               "that failed shorter periods were rare stalls of the machine{}, not the step's cost; such an answer "
               "moves between runs with the stalls' rate (compare it only with one measured beside it)\n",
               largest_p99_ns / 1e3, us(*search.found_period_ns),
               longest_ns > 0 ? fmt::format(" (the confirming run's longest completion {:.1f} us)", longest_ns / 1e3)
                              : std::string{});
  }
  fmt::print("search time: {:.1f} s of the {:g} s budget (the confirming run included)\n",
             static_cast<double>(search.elapsed_ns) / 1e9, static_cast<double>(plan.search.budget_ns) / 1e9);
  nlohmann::json trials = nlohmann::json::array();
  for (const auto& trial : search.trials) trials.push_back(trial_json(trial));
  return {{"miss_rate", plan.search.miss_rate},
          {"confidence", plan.search.confidence},
          {"rule", search_rule(plan.search, search.trial_periods)},
          {"trial_periods", search.trial_periods},
          {"start_period_ns", plan.search.start_period_ns},
          {"floor_period_ns", plan.search.floor_period_ns},
          {"ceiling_period_ns", plan.search.ceiling_period_ns},
          {"tolerance", plan.search.tolerance},
          {"budget_ns", plan.search.budget_ns},
          {"budget_cut", search.budget_cut},
          {"stopped_because", search.stopped_because},
          {"elapsed_s", static_cast<double>(search.elapsed_ns) / 1e9},
          {"found_period_ns", search.found_period_ns ? nlohmann::json(*search.found_period_ns) : nullptr},
          {"failed_period_ns", search.failed_period_ns ? nlohmann::json(*search.failed_period_ns) : nullptr},
          {"trials", trials},
          {"largest_completion_p99_ns", largest_p99_ns},
          {"set_by_stalls", set_by_stalls},
          {"confirm", confirm}};
}

void run_delay(const delay_options& options, int& result) {
  const delay_plan plan = check_input(options);
  const platform::topology machine = platform::topology::this_machine();
  std::vector<unsigned> cpus;
  if (options.per_cpu) cpus = machine.affinity();
  const unsigned threads = options.per_cpu ? static_cast<unsigned>(cpus.size()) : options.threads;
  const platform::placement_plan pinned_plan =
      platform::plan_placement(machine, options.per_cpu ? platform::placement::none : plan.kind, threads);
  const platform::placement_plan unpinned_plan =
      platform::plan_placement(machine, platform::placement::none, threads);
  check_permissions(options);

  // Idle states: held from here to the end of the measurements.
  idle_setting idle;
  const char* path_override = std::getenv(kDmaLatencyPathVariable);
  idle.path = path_override != nullptr && *path_override != '\0' ? path_override : platform::kDmaLatencyPath;
  idle.requested_us = plan.dma_latency_us;
  std::optional<platform::dma_latency_hold> hold;
  if (plan.dma_latency_us) {
    hold.emplace(*plan.dma_latency_us, idle.path);
    idle.held = hold->held();
    idle.in_force_us = hold->in_force_us();
    idle.problem = hold->problem();
    if (!idle.held)
      fmt::print(stderr, "delay: cannot hold {} at {} us ({}); running without it, idle states not limited\n",
                 idle.path, *plan.dma_latency_us, idle.problem);
  }

  probes::paced_step_settings settings;
  settings.sync = options.sync;
  settings.layout = options.layout;
  settings.threads = threads;
  settings.model = plan.model;
  settings.pacing.period_ns = plan.period_ns;
  settings.pacing.periods = plan.periods;
  settings.pacing.fifo_priority = options.fifo;
  settings.pacing.stop_above_ns = plan.stop_above_ns;

  const std::string pin_name = options.per_cpu ? "per_cpu" : options.pin;
  const std::string name = fmt::format("rk4{}/sync:{}/layout:{}/pin:{}/threads:{}", plan.model.name_segment(),
                                       options.sync, options.layout, pin_name, threads);
  const std::string policy = fmt::format("{}{}", options.fifo ? fmt::format(", SCHED_FIFO {}", *options.fifo) : ", SCHED_OTHER",
                                         options.mlock ? ", memory locked" : "");
  const std::string view =
      options.per_cpu ? "per CPU: one paced thread per CPU, each computing the step alone (like for like with "
                        "cyclictest -S)"
      : threads == 1 ? "one participant computes the step alone (like for like with cyclictest -t1)"
      : plan.model.is_chain()
          ? fmt::format("{}: {} participants share one step, {} between the stages", plan.model.description(),
                        threads, options.sync)
          : fmt::format("the paper's model: {} participants share one step, {} between the stages", threads,
                        options.sync);
  if (!pinned_plan.note.empty()) fmt::print(stderr, "delay: {}\n", pinned_plan.note);

  std::optional<search_outcome> searched;
  probes::paced_result pinned;
  std::optional<probes::paced_result> unpinned;
  std::int64_t period_ns = plan.period_ns;
  if (options.find_period) {
    fmt::print(stderr, "delay: {}: searching the shortest period with a miss rate of at most {:g} (budget {:g} s){}\n",
               name, plan.search.miss_rate, static_cast<double>(plan.search.budget_ns) / 1e9, policy);
    searched = run_search(plan, settings, pinned_plan);
    if (searched->confirm) {
      pinned = std::move(*searched->confirm);
      period_ns = *searched->search.found_period_ns;
    }
  } else {
    fmt::print(stderr, "delay: {} paced at {} us for {} periods ({:.1f} s){}\n", name, us(plan.period_ns),
               plan.periods, static_cast<double>(plan.periods * plan.period_ns) / 1e9, policy);
    {
      const std::jthread progress = progress_reporter(plan.periods * plan.period_ns);
      pinned = options.per_cpu ? probes::run_paced_per_cpu(settings, cpus)
                               : probes::run_paced_step(settings, pinned_plan);
    }
    if (options.compare_pinning) {
      fmt::print(stderr, "delay: the same run unpinned (pin:none) for comparison\n");
      const std::jthread progress = progress_reporter(plan.periods * plan.period_ns);
      unpinned = probes::run_paced_step(settings, unpinned_plan);
    }
  }
  hold.reset();  // the measurements are over: the PM QoS request ends here
  if (options.mlock) platform::unlock_all_memory();

  const bool measured = !pinned.wakeup_ns.empty();
  fmt::print("{}: {} periods of {} us{}\n", name, pinned.periods, us(period_ns), policy);
  fmt::print("{}\n", idle.line());
  fmt::print("view: {}\n", view);
  fmt::print("placement: {}\n", options.per_cpu ? std::string("one thread pinned to each CPU of the affinity set")
                                                : pinned_plan.describe());
  nlohmann::json search_json = nullptr;
  if (searched) search_json = print_search(*searched, plan, name);
  if (searched && !measured) fmt::print("\nno confirming run: nothing to show beyond the trials\n");

  probes::latency_histogram histogram;
  histogram.bound_us = plan.histogram_bound_us;
  nlohmann::json per_cpu_json = nullptr;
  if (measured) {
    print_result(searched ? fmt::format("confirming run at {} us", us(period_ns))
                 : options.compare_pinning ? "pinned (--pin " + options.pin + ")"
                                           : std::string("result"),
                 pinned, period_ns);
    if (options.per_cpu) per_cpu_json = print_per_cpu(pinned, period_ns);
    if (plan.stop_above_ns) print_stop(pinned, *plan.stop_above_ns, period_ns, options.per_cpu);
    histogram = latency_histogram_of(pinned, plan.histogram_bound_us, options.per_cpu);
    std::vector<labelled_samples> series;
    if (options.per_cpu) {
      for (unsigned id = 0; id < pinned.participants; ++id)
        series.push_back({thread_name(pinned, id, true), probes::participant_samples(pinned.wakeup_ns, pinned.participants, id)});
    } else {
      series.push_back({"count", pinned.wakeup_ns});
    }
    fmt::print("\nwake-up latency histogram (1-2-5 buckets; the 1 us buckets up to {} us are in the JSON{})\n{}",
               plan.histogram_bound_us, options.histogram_file.empty() ? "" : " and --histogram-file",
               log_histogram_text(series));
    fmt::print("\nFigure 5: context switches per thread, and the share that crossed cores\n{}",
               pinned.figure5.render());
    if (unpinned) {
      print_result("unpinned (--pin none)", *unpinned, period_ns);
      fmt::print("\nFigure 5, unpinned\n{}", unpinned->figure5.render());
    }
  }

  if (!options.histogram_file.empty()) {
    bench::write_result_file(options.histogram_file, cyclictest_histogram_text(histogram));
    fmt::print(stderr, "delay: wrote {}\n", options.histogram_file);
  }
  if (!options.out.empty()) {
    nlohmann::json document = bench::result_document("delay", machine);
    bench::merge_into_result(document, bench::context_map{{"dma_latency", idle.state()},
                                        {"dma_latency_in_force_us",
                                         idle.in_force_us ? std::to_string(*idle.in_force_us) : "unavailable"},
                                        {"cpuidle_driver", idle.driver},
                                        {"cpuidle_governor", idle.governor}});
    const platform::histogram covering = bench::histogram_of(pinned.wakeup_ns);
    document.update({
        {"name", name},
        {"settings",
         {{"period_ns", period_ns},
          {"duration_s", options.find_period ? nlohmann::json(nullptr)
                                             : nlohmann::json(static_cast<double>(plan.duration_ns) / 1e9)},
          {"sync", options.sync},
          {"layout", options.layout},
          {"pin", pin_name},
          {"threads", threads},
          {"model", plan.model.key()},
          {"equations", plan.model.equations()},
          {"per_cpu", options.per_cpu},
          {"view", view},
          {"fifo_priority", options.fifo ? nlohmann::json(*options.fifo) : nullptr},
          {"mlock", options.mlock},
          {"periods", options.find_period ? pinned.periods : plan.periods},
          {"dma_latency_us", plan.dma_latency_us ? nlohmann::json(*plan.dma_latency_us) : nullptr},
          {"histogram_bound_us", plan.histogram_bound_us},
          {"stop_above_ns", plan.stop_above_ns ? nlohmann::json(*plan.stop_above_ns) : nullptr},
          {"placement", options.per_cpu ? "one thread pinned to each CPU of the affinity set" : pinned_plan.describe()}}},
        {"idle", idle.json()},
        {"periods_measured", pinned.periods},
        {"wakeup_latency_ns", bench::distribution_json(pinned.wakeup_ns)},
        {"completion_ns", bench::distribution_json(pinned.completion_ns)},
        {"deadline_misses", pinned.deadline_misses},
        {"histogram", bench::histogram_json(covering)},
        {"latency_histogram", latency_histogram_json(histogram)},
        {"figure5", figure5_json(pinned.figure5)},
        {"warnings", pinned.errors}});
    if (options.per_cpu) document["per_cpu"] = per_cpu_json;
    if (plan.stop_above_ns) document["stop"] = stop_json(pinned, *plan.stop_above_ns, period_ns, options.per_cpu);
    if (searched) document["find_period"] = search_json;
    if (unpinned) {
      document["figure5_unpinned"] = figure5_json(unpinned->figure5);
      document["unpinned"] = {{"wakeup_latency_ns", bench::distribution_json(unpinned->wakeup_ns)},
                              {"completion_ns", bench::distribution_json(unpinned->completion_ns)},
                              {"deadline_misses", unpinned->deadline_misses}};
    }
    bench::write_result_file(options.out, document.dump(2) + "\n");
    fmt::print(stderr, "delay: wrote {}\n", options.out);
  }
  result = kExitOk;
}

}  // namespace

void add_delay(CLI::App& app, int& result) {
  auto options = std::make_shared<delay_options>();
  auto* command = app.add_subcommand(
      "delay", "Paced real-time run (cyclictest-style): wake-up latency, deadline misses, Figure 5 table");
  command->footer(
      "Views:\n"
      "  default            the paper's model: 4 participants share one RK4 step, std_barrier between the\n"
      "                     stages, pinned compact; what a multi-core HIL model sees\n"
      "  --threads 1        like for like with cyclictest -t1: one paced thread (add --pin compact under\n"
      "                     taskset -c CPU for cyclictest -a CPU)\n"
      "  --per-cpu          like for like with cyclictest -S: one paced thread per CPU of the affinity set,\n"
      "                     each computing the step alone; names the noisiest CPU\n" +
      fmt::format("  --threads T > {}    an s-mass chain (eq. (1)) of one equation per thread, named model:chainS;\n"
                  "                     --masses S chooses the chain (blocks of equations per thread)\n",
                  kernels::kPaperThreadsMax) +
      "Idle states: /dev/cpu_dma_latency is held at 0 us for the run, as cyclictest does, unless\n"
      "--dma-latency or --no-dma-latency says otherwise; the output says which setting was in force.\n"
      "--find-period --miss-rate R: the shortest period whose deadline misses stay at most at rate R,\n"
      "with 95 % confidence (a one-sided Clopper-Pearson bound), found by bisection; --period is where\n" +
      fmt::format("the search starts. When the answer is over {:g}x every trial's completion p99, the misses were\n"
                  "the machine's stalls, not the step's cost, and the output says so (\"set by stalls\").",
                  kStallDominatedFactor));
  command->add_option("--sync", options->sync, "Synchronisation primitive (lockstep list)")->capture_default_str();
  command->add_option("--layout", options->layout, "Data layout (lockstep list)")->capture_default_str();
  auto* pin = command->add_option("--pin", options->pin, "Placement: none, compact, scatter, migrate")
                  ->capture_default_str();
  auto* threads = command->add_option("--threads", options->threads,
                                      fmt::format("Participants sharing the step (1: like cyclictest -t1); up to {} "
                                                  "integrate the paper's two masses, more an s-mass chain",
                                                  kernels::kPaperThreadsMax))
                      ->check(CLI::Range(1, 1024))
                      ->capture_default_str();
  command->add_option("--period", options->period,
                      "Period, with a unit: ns, us, ms, s (--find-period: where the search starts)")
      ->capture_default_str();
  auto* duration =
      command->add_option("--duration", options->duration, "How long to run, with a unit")->capture_default_str();
  command->add_option("--fifo", options->fifo, "Run the participants under SCHED_FIFO at this priority");
  command->add_flag("--mlock", options->mlock, "Lock all memory (mlockall) for the run");
  auto* compare = command->add_flag("--compare-pinning", options->compare_pinning,
                                    "Also run unpinned (pin:none) and show both Figure 5 tables");
  auto* dma = command->add_option("--dma-latency", options->dma_latency,
                                  "Hold /dev/cpu_dma_latency at this latency instead of 0 (a time: 0us, 10us)")
                  ->option_text("TIME");
  auto* no_dma = command->add_flag("--no-dma-latency", options->no_dma_latency,
                                   "Leave /dev/cpu_dma_latency alone (idle states not limited)");
  dma->excludes(no_dma);
  command->add_option("--histogram-bound", options->histogram_bound,
                      "1 us histogram buckets up to this time (cyclictest -h; default 1000us); later wake-ups "
                      "count as overflows")
      ->option_text("TIME");
  command->add_option("--histogram-file", options->histogram_file,
                      "Write the wake-up histogram to FILE in cyclictest's -h text format")
      ->option_text("FILE");
  auto* per_cpu = command->add_flag("--per-cpu", options->per_cpu,
                                    "One paced thread per CPU of the affinity set (cyclictest -S), side by side");
  auto* masses = add_masses_option(*command, options->masses);
  per_cpu->excludes(threads)->excludes(pin)->excludes(compare)->excludes(masses);
  auto* stop_above = command->add_option("--stop-above", options->stop_above,
                                         "End the run at the first wake-up later than this (cyclictest -b)")
                         ->option_text("TIME");
  auto* find = command->add_flag("--find-period", options->find_period,
                                 "Search the shortest period whose deadline-miss rate is at most --miss-rate");
  find->excludes(duration)->excludes(stop_above)->excludes(per_cpu)->excludes(compare);
  auto* rate = command->add_option("--miss-rate", options->miss_rate, "The miss rate --find-period must hold (1e-3)");
  rate->needs(find);
  command->add_option("--search-budget", options->search_budget,
                      "Longest time --find-period may take, the confirming run included (default 120s)")
      ->option_text("TIME")
      ->needs(find);
  command->add_option("--trial-periods", options->trial_periods,
                      "Periods per --find-period trial (default: the fewest that can show the rate)")
      ->needs(find);
  add_out_option(*command, options->out);
  command->callback([options, &result] { run_delay(*options, result); });
}

}  // namespace lockstep::cli
