// lockstep delay: the paper's real-time use of its model. The composed RK4
// step of one sync x layout x placement runs paced at a period for a
// duration (the paced probe, bench/probes/paced.hpp: absolute clock_nanosleep
// per period, as cyclictest), optionally under SCHED_FIFO and with memory
// locked, with /dev/cpu_dma_latency held at 0 as cyclictest holds it.
// The measurement is bench/probes/delay.hpp's, what it means and how it reads
// bench/delay/delay_report.hpp's; this file is the command: its options,
// their checks, that call and the two readings.
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

#include <cstdint>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/delay/delay_report.hpp"
#include "bench/results/result_file.hpp"
#include "bench/delay/delay_output.hpp"
#include "bench/probes/delay.hpp"
#include "bench/probes/latency_histogram.hpp"
#include "bench/probes/paced.hpp"
#include "bench/probes/period_search.hpp"
#include "kernels/model_choice.hpp"
#include "platform/idle_states.hpp"
#include "platform/placement.hpp"
#include "platform/scheduling.hpp"
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
  bool no_record = false;
  bool recording_cost = false;
};

std::int64_t whole_microseconds(const std::string& text, const std::string& option, std::int64_t min_us,
                                std::int64_t max_us) {
  const std::int64_t ns = parse_duration_ns(text, option, min_us * 1000, max_us * 1000);
  if (ns % 1000 != 0) throw usage_error(option + ": '" + text + "' is not a whole number of microseconds");
  return ns / 1000;
}

probes::delay_settings check_input(const delay_options& options) {
  probes::delay_settings plan;
  plan.sync = options.sync;
  plan.layout = options.layout;
  plan.pin = options.pin;
  plan.threads = options.threads;
  plan.fifo_priority = options.fifo;
  plan.mlock = options.mlock;
  plan.compare_pinning = options.compare_pinning;
  plan.per_cpu = options.per_cpu;
  plan.find_period = options.find_period;
  plan.recording = options.no_record        ? probes::step_recording::off
                   : options.recording_cost ? probes::step_recording::alternate_blocks
                                            : probes::step_recording::every_period;
  const char* path_override = std::getenv(kDmaLatencyPathVariable);
  plan.dma_latency_path =
      path_override != nullptr && *path_override != '\0' ? path_override : platform::kDmaLatencyPath;
  plan.period_ns = parse_duration_ns(options.period, "--period", kSearchFloorNs);
  if (!options.find_period) {
    plan.duration_ns = parse_duration_ns(options.duration, "--duration");
    if (plan.duration_ns < plan.period_ns) throw usage_error("--duration must be at least one --period");
    plan.periods = plan.duration_ns / plan.period_ns;
    if (plan.periods > 100'000'000) throw usage_error("--duration / --period exceeds 100000000 periods");
  }
  if (!options.per_cpu) {
    check_name(options.pin, placement_names(), "--pin: unknown value");
    try {
      plan.kind = platform::parse_placement(options.pin);
    } catch (const std::invalid_argument& e) {
      throw usage_error(std::string("--pin: ") + e.what());
    }
    if (options.compare_pinning && plan.kind == platform::placement::none)
      throw usage_error(
          "--compare-pinning compares a pinned placement with none: give --pin compact, compact_smt, scatter or "
          "migrate");
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
  check_name(options.sync, sync_names(), "--sync: unknown value");
  check_name(options.layout, layout_names(), "--layout: unknown value");
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

void run_delay(const delay_options& options, int& result) {
  const probes::delay_settings settings = check_input(options);
  const platform::topology machine = platform::topology::this_machine();
  check_permissions(options);
  const probes::delay_measurement measured = probes::measure_delay(
      settings, machine, [](const std::string& line) { fmt::print(stderr, "{}\n", line); });
  if (options.mlock) platform::unlock_all_memory();

  const bench::delay_analysis analysis = bench::analyse_delay(measured);
  fmt::print("{}", bench::delay_text(measured, analysis, !options.histogram_file.empty()));
  if (!options.histogram_file.empty()) {
    bench::write_result_file(options.histogram_file, bench::cyclictest_histogram_text(analysis.histogram));
    fmt::print(stderr, "delay: wrote {}\n", options.histogram_file);
  }
  if (!options.out.empty()) {
    bench::write_result_file(options.out, bench::delay_json(measured, analysis, machine).dump(2) + "\n");
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
      "Why late: every period is recorded (per participant and stage: arrival and departure at the sync, its\n"
      "CPU; per period: run-queue wait, switches, faults, per-CPU interrupts), and each step above the median\n"
      "is split along its critical path into compute, run-queue wait, migration, page faults, interrupts,\n"
      "wake-up latency and machine stall (time no guest event explains); the tail's table and the latest\n"
      "steps are printed, --recording-cost prices the record as a pair.\n"
      "--find-period --miss-rate R: the shortest period whose deadline misses stay at most at rate R,\n"
      "with 95 % confidence (a one-sided Clopper-Pearson bound), found by bisection; --period is where\n" +
      fmt::format("the search starts. When the answer is over {:g}x every trial's completion p99, the misses were\n"
                  "the machine's stalls, not the step's cost, and the output says so (\"set by stalls\").",
                  bench::kStallDominatedFactor));
  command->add_option("--sync", options->sync, "Synchronisation primitive (lockstep list)")->capture_default_str();
  command->add_option("--layout", options->layout, "Data layout (lockstep list)")->capture_default_str();
  auto* pin = command->add_option("--pin", options->pin, "Placement: none, compact, compact_smt, scatter, migrate")
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
  auto* masses = add_masses_option(*command, options->masses, "thread");
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
  auto* no_record = command->add_flag("--no-record", options->no_record,
                                      "Keep no per-step record (no causes for the late steps)");
  auto* cost = command->add_flag("--recording-cost", options->recording_cost,
                                 "Record every other block of 250 periods and print what the record costs (a pair: "
                                 "completion with it against without, in one run)");
  no_record->excludes(cost);
  cost->excludes(find)->excludes(per_cpu);
  add_out_option(*command, options->out);
  command->callback([options, &result] { run_delay(*options, result); });
}

}  // namespace lockstep::cli
