// The measurement behind `lockstep delay` (delay.hpp).
#include "bench/probes/delay.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stop_token>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "platform/clock.hpp"
#include "platform/idle_states.hpp"
#include "platform/stats.hpp"

namespace lockstep::bench::probes {

namespace {

// Long runs say how far they are, every 5 s, from a thread that sleeps
// otherwise (it is not a participant and does not pace anything): the
// periods of the schedule behind the run, in seconds (never past the
// duration), and the overruns so far.
std::jthread progress_reporter(std::int64_t periods, std::int64_t period_ns, const paced_progress& run,
                               const delay_progress& progress) {
  if (periods * period_ns < 10'000'000'000) return {};
  return std::jthread([periods, period_ns, &run, &progress](std::stop_token stop) {
    std::mutex mutex;
    std::condition_variable_any tick;
    std::unique_lock lock(mutex);
    const auto seconds = [period_ns](std::int64_t count) { return static_cast<double>(count * period_ns) / 1e9; };
    while (!tick.wait_for(lock, stop, std::chrono::seconds(5), [] { return false; }) && !stop.stop_requested()) {
      // Relaxed: see paced_progress.
      const std::int64_t behind = std::min(run.periods.load(std::memory_order_relaxed), periods);
      const std::uint64_t overran = run.overran.load(std::memory_order_relaxed);
      progress(fmt::format("delay: {:.0f} s of {:.0f} s{}", seconds(behind), seconds(periods),
                           overran == 0 ? std::string()
                                        : fmt::format(" ({} steps overran the period, {} periods skipped)", overran,
                                                      run.skipped.load(std::memory_order_relaxed))));
    }
  });
}

delay_search run_search(const delay_settings& settings, paced_step_settings step,
                        const platform::placement_plan& placement, const delay_progress& progress) {
  delay_search outcome;
  std::vector<std::pair<std::int64_t, paced_result>> failed_runs;  // runs with misses, by period
  const auto runner = [&](std::int64_t period_ns, std::int64_t periods, std::optional<std::uint64_t> stop_after_misses,
                          bool confirming) {
    step.pacing.period_ns = period_ns;
    step.pacing.periods = periods;
    step.pacing.stop_after_misses = stop_after_misses;
    const std::int64_t began = platform::now_ns();
    paced_result run = run_paced_step(step, placement);
    const trial_outcome trial = trial_of(run, platform::now_ns() - began);
    if (confirming)
      outcome.confirm = std::move(run);
    else if (trial.misses > 0)
      failed_runs.emplace_back(period_ns, std::move(run));
    return trial;
  };
  const auto observe = [&](const period_trial& trial, bool confirming) {
    progress(fmt::format("delay: {} {} us: {} misses in {} periods, bound {:.3g}: {}",
                         confirming ? "confirming at" : "trial at", microseconds_text(trial.period_ns),
                         trial.outcome.misses, trial.outcome.periods, trial.upper_bound,
                         trial.holds ? "holds" : "fails"));
  };
  outcome.search = find_period(settings.search, runner, observe);
  if (outcome.search.failed_period_ns)
    for (auto& [period_ns, run] : failed_runs)
      if (period_ns == *outcome.search.failed_period_ns) outcome.failed_trial = std::move(run);
  return outcome;
}

std::string view_of(const delay_settings& settings, unsigned threads) {
  if (settings.per_cpu)
    return "per CPU: one paced thread per CPU, each computing the step alone (like for like with cyclictest -S)";
  if (threads == 1) return "one participant computes the step alone (like for like with cyclictest -t1)";
  if (settings.model.is_chain())
    return fmt::format("{}: {} participants share one step, {} between the stages", settings.model.description(),
                       threads, settings.sync);
  return fmt::format("the paper's model: {} participants share one step, {} between the stages", threads,
                     settings.sync);
}

}  // namespace

trial_outcome trial_of(const paced_result& run, std::int64_t elapsed_ns) {
  trial_outcome trial;
  trial.elapsed_ns = elapsed_ns;
  trial.periods = run.periods_scheduled;
  trial.skipped = run.skipped_periods;
  trial.misses = run.deadline_misses + run.skipped_periods;
  if (!run.completion_ns.empty()) {
    const auto d = platform::summarize(run.completion_ns);
    trial.completion_p50_ns = d.p50;
    trial.completion_p99_ns = d.p99;
  }
  return trial;
}

std::string microseconds_text(std::int64_t ns) { return fmt::format("{:g}", static_cast<double>(ns) / 1e3); }

delay_measurement measure_delay(const delay_settings& requested, const platform::topology& machine,
                                const delay_progress& progress) {
  delay_measurement result;
  result.settings = requested;
  delay_settings& settings = result.settings;
  std::vector<unsigned> cpus;
  if (settings.per_cpu) {
    cpus = machine.affinity();
    settings.threads = static_cast<unsigned>(cpus.size());
    settings.pin = "per_cpu";
  }
  const platform::placement_plan pinned_plan = platform::plan_placement(
      machine, settings.per_cpu ? platform::placement::none : settings.kind, settings.threads);
  const platform::placement_plan unpinned_plan =
      platform::plan_placement(machine, platform::placement::none, settings.threads);

  // Idle states: held from here to the end of the measurements.
  idle_setting& idle = result.idle;
  idle.path = settings.dma_latency_path;
  idle.requested_us = settings.dma_latency_us;
  idle.driver = platform::cpuidle_driver();
  idle.governor = platform::cpuidle_governor();
  idle.clocksource = platform::clocksource();
  std::optional<platform::dma_latency_hold> hold;
  if (settings.dma_latency_us) {
    hold.emplace(*settings.dma_latency_us, idle.path);
    idle.held = hold->held();
    idle.in_force_us = hold->in_force_us();
    idle.problem = hold->problem();
    if (!idle.held)
      progress(fmt::format("delay: cannot hold {} at {} us ({}); running without it, idle states not limited",
                           idle.path, *settings.dma_latency_us, idle.problem));
  }

  paced_step_settings step;
  step.sync = settings.sync;
  step.layout = settings.layout;
  step.threads = settings.threads;
  step.model = settings.model;
  step.pacing.period_ns = settings.period_ns;
  step.pacing.periods = settings.periods;
  step.pacing.fifo_priority = settings.fifo_priority;
  step.pacing.stop_above_ns = settings.stop_above_ns;
  step.pacing.recording = settings.per_cpu ? step_recording::off : settings.recording;

  result.name = fmt::format("rk4{}/sync:{}/layout:{}/pin:{}/threads:{}", settings.model.name_segment(), settings.sync,
                            settings.layout, settings.pin, settings.threads);
  result.view = view_of(settings, settings.threads);
  result.placement =
      settings.per_cpu ? std::string("one thread pinned to each CPU of the affinity set") : pinned_plan.describe();
  result.policy =
      fmt::format("{}{}", settings.fifo_priority ? fmt::format(", SCHED_FIFO {}", *settings.fifo_priority)
                                                 : ", SCHED_OTHER",
                  settings.mlock ? ", memory locked" : "");
  if (!pinned_plan.note.empty()) progress(fmt::format("delay: {}", pinned_plan.note));

  result.period_ns = settings.period_ns;
  if (settings.find_period) {
    progress(fmt::format("delay: {}: searching the shortest period with a miss rate of at most {:g} (budget {:g} s){}",
                         result.name, settings.search.miss_rate,
                         static_cast<double>(settings.search.budget_ns) / 1e9, result.policy));
    result.searched = run_search(settings, step, pinned_plan, progress);
    if (result.searched->confirm) {
      result.pinned = *result.searched->confirm;
      result.period_ns = *result.searched->search.found_period_ns;
    }
  } else {
    progress(fmt::format("delay: {} paced at {} us for {} periods ({:.1f} s){}", result.name,
                         microseconds_text(settings.period_ns), settings.periods,
                         static_cast<double>(settings.periods * settings.period_ns) / 1e9, result.policy));
    {
      paced_progress so_far;
      step.pacing.progress = &so_far;
      const std::jthread reporter = progress_reporter(settings.periods, settings.period_ns, so_far, progress);
      result.pinned = settings.per_cpu ? run_paced_per_cpu(step, cpus) : run_paced_step(step, pinned_plan);
    }
    if (settings.compare_pinning) {
      progress("delay: the same run unpinned (pin:none) for comparison");
      step.pacing.recording = step_recording::off;
      paced_progress so_far;
      step.pacing.progress = &so_far;
      const std::jthread reporter = progress_reporter(settings.periods, settings.period_ns, so_far, progress);
      result.unpinned = run_paced_step(step, unpinned_plan);
    }
    step.pacing.progress = nullptr;
  }
  return result;  // the hold ends here: the PM QoS request lasts the measurements
}

}  // namespace lockstep::bench::probes
