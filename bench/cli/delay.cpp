// lockstep delay: the paper's real-time use of its model. The composed RK4
// step of one sync x layout x placement runs paced at a period for a
// duration (the paced probe, bench/probes/paced.hpp: absolute clock_nanosleep per period, as
// cyclictest), optionally under SCHED_FIFO and with memory locked. Reports the
// wake-up latency and the completion time against the deadline as
// distributions, the deadline misses, a histogram, and the paper's Figure 5
// table (context switches per thread, and the share that crossed cores);
// with --compare-pinning the same run unpinned beside it.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <stop_token>
#include <thread>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <span>
#include <utility>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/harness/machine_context.hpp"
#include "bench/harness/result_file.hpp"
#include "bench/harness/result_json.hpp"
#include "bench/probes/paced.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"
#include "platform/scheduling.hpp"
#include "platform/stats.hpp"
#include "platform/thread_accounting.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {
namespace {

namespace probes = bench::probes;

struct delay_options {
  std::string sync = "std_barrier";
  std::string layout = "padded64";
  std::string pin = "compact";
  unsigned threads = 4;
  std::string period = "1ms";
  std::string duration = "10s";
  std::optional<int> fifo;
  bool mlock = false;
  bool compare_pinning = false;
  std::string out;
};

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

void print_distribution(const char* what, const std::vector<double>& samples) {
  if (samples.empty()) {
    fmt::print("{:<22} no samples\n", what);
    return;
  }
  const auto d = platform::summarize(samples);
  fmt::print("{:<22} {:>10.1f} {:>10.1f} {:>10.1f} {:>10.1f} {:>10.1f} {:>9}\n", what, d.min / 1e3, d.p50 / 1e3,
             d.p99 / 1e3, d.p999 / 1e3, d.max / 1e3, d.count);
}

void print_result(const std::string& title, const probes::paced_result& run, std::int64_t period_ns) {
  fmt::print("\n{}\n", title);
  fmt::print("{:<22} {:>10} {:>10} {:>10} {:>10} {:>10} {:>9}\n", "us", "min", "p50", "p99", "p99.9", "max", "count");
  print_distribution("wake-up latency", run.wakeup_ns);
  print_distribution("completion (deadline)", run.completion_ns);
  fmt::print("deadline misses: {} of {} periods (deadline = period = {} us)\n", run.deadline_misses,
             run.completion_ns.size(), static_cast<double>(period_ns) / 1e3);
  for (const auto& error : run.errors) fmt::print("warning: {}\n", error);
  fmt::print("\nFigure 5: context switches per thread, and the share that crossed cores\n{}", run.figure5.render());
}

void run_delay(const delay_options& options, int& result) {
  const std::int64_t period_ns = parse_duration_ns(options.period, "--period", 10'000);
  const std::int64_t duration_ns = parse_duration_ns(options.duration, "--duration");
  if (duration_ns < period_ns) throw usage_error("--duration must be at least one --period");
  const std::int64_t periods = duration_ns / period_ns;
  if (periods > 100'000'000) throw usage_error("--duration / --period exceeds 100000000 periods");

  platform::placement kind{};
  try {
    kind = platform::parse_placement(options.pin);
  } catch (const std::invalid_argument& e) {
    throw usage_error(std::string("--pin: ") + e.what());
  }
  if (options.compare_pinning && kind == platform::placement::none)
    throw usage_error("--compare-pinning compares a pinned placement with none: give --pin compact, scatter or migrate");
  if (options.fifo) {
    const int low = platform::fifo_min_priority();
    const int high = platform::fifo_max_priority();
    if (*options.fifo < low || *options.fifo > high)
      throw usage_error("--fifo: priority " + std::to_string(*options.fifo) + " is outside " + std::to_string(low) +
                        ".." + std::to_string(high));
  }
  // Names and applicability before permissions: the first error is the input's.
  if (const std::string problem = probes::paced_step_problem(options.sync, options.layout, options.threads);
      !problem.empty())
    throw usage_error(problem);
  check_out(options.out);

  const platform::topology machine = platform::topology::this_machine();
  const platform::placement_plan pinned_plan = platform::plan_placement(machine, kind, options.threads);
  const platform::placement_plan unpinned_plan =
      platform::plan_placement(machine, platform::placement::none, options.threads);

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

  probes::paced_step_settings settings;
  settings.sync = options.sync;
  settings.layout = options.layout;
  settings.threads = options.threads;
  settings.pacing.period_ns = period_ns;
  settings.pacing.periods = periods;
  settings.pacing.fifo_priority = options.fifo;

  const auto run_with = [&](const platform::placement_plan& plan) {
    probes::paced_result run;
    // Long runs say how far they are, every 5 s, from a thread that sleeps
    // otherwise (it is not a participant and does not pace anything).
    std::jthread progress;
    if (periods * period_ns >= 10'000'000'000) {
      progress = std::jthread([total_s = static_cast<double>(periods * period_ns) / 1e9](std::stop_token stop) {
        std::mutex mutex;
        std::condition_variable_any tick;
        std::unique_lock lock(mutex);
        const std::int64_t began = platform::now_ns();
        while (!tick.wait_for(lock, stop, std::chrono::seconds(5), [] { return false; }) && !stop.stop_requested())
          fmt::print(stderr, "delay: {:.0f} s of {:.0f} s\n", static_cast<double>(platform::now_ns() - began) / 1e9,
                     total_s);
      });
    }
    run = probes::run_paced_step(settings, plan);
    return run;
  };
  const std::string name = fmt::format("rk4/sync:{}/layout:{}/pin:{}/threads:{}", options.sync, options.layout,
                                       options.pin, options.threads);
  fmt::print(stderr, "delay: {} paced at {} us for {} periods ({:.1f} s){}{}\n", name,
             static_cast<double>(period_ns) / 1e3, periods, static_cast<double>(periods * period_ns) / 1e9,
             options.fifo ? fmt::format(", SCHED_FIFO {}", *options.fifo) : "", options.mlock ? ", memory locked" : "");
  if (!pinned_plan.note.empty()) fmt::print(stderr, "delay: {}\n", pinned_plan.note);
  const probes::paced_result pinned = run_with(pinned_plan);
  std::optional<probes::paced_result> unpinned;
  if (options.compare_pinning) {
    fmt::print(stderr, "delay: the same run unpinned (pin:none) for comparison\n");
    unpinned = run_with(unpinned_plan);
  }
  if (options.mlock) platform::unlock_all_memory();

  fmt::print("{}: {} periods of {} us{}{}\n", name, periods, static_cast<double>(period_ns) / 1e3,
             options.fifo ? fmt::format(", SCHED_FIFO {}", *options.fifo) : ", SCHED_OTHER",
             options.mlock ? ", memory locked" : "");
  fmt::print("placement: {}\n", pinned_plan.describe());
  print_result(options.compare_pinning ? "pinned (--pin " + options.pin + ")" : std::string("result"), pinned,
               period_ns);
  const platform::histogram histogram = bench::histogram_of(pinned.wakeup_ns);
  fmt::print("\nwake-up latency histogram (ns)\n{}", histogram.render());
  if (unpinned) print_result("unpinned (--pin none)", *unpinned, period_ns);

  if (!options.out.empty()) {
    nlohmann::json document = bench::result_document("delay", machine);
    document.update({
        {"name", name},
        {"settings",
         {{"period_ns", period_ns},
          {"duration_s", static_cast<double>(duration_ns) / 1e9},
          {"sync", options.sync},
          {"layout", options.layout},
          {"pin", options.pin},
          {"threads", options.threads},
          {"fifo_priority", options.fifo ? nlohmann::json(*options.fifo) : nullptr},
          {"mlock", options.mlock},
          {"periods", periods},
          {"placement", pinned_plan.describe()}}},
        {"wakeup_latency_ns", bench::distribution_json(pinned.wakeup_ns)},
        {"completion_ns", bench::distribution_json(pinned.completion_ns)},
        {"deadline_misses", pinned.deadline_misses},
        {"histogram", bench::histogram_json(histogram)},
        {"figure5", figure5_json(pinned.figure5)},
        {"warnings", pinned.errors}});
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
  command->add_option("--sync", options->sync, "Synchronisation primitive (lockstep list)")->capture_default_str();
  command->add_option("--layout", options->layout, "Data layout (lockstep list)")->capture_default_str();
  command->add_option("--pin", options->pin, "Placement: none, compact, scatter, migrate")->capture_default_str();
  command->add_option("--threads", options->threads, "Participants (at most the model's 4 equations)")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  command->add_option("--period", options->period, "Period, with a unit: ns, us, ms, s")->capture_default_str();
  command->add_option("--duration", options->duration, "How long to run, with a unit")->capture_default_str();
  command->add_option("--fifo", options->fifo, "Run the participants under SCHED_FIFO at this priority");
  command->add_flag("--mlock", options->mlock, "Lock all memory (mlockall) for the run");
  command->add_flag("--compare-pinning", options->compare_pinning,
                    "Also run unpinned (pin:none) and show both Figure 5 tables");
  add_out_option(*command, options->out);
  command->callback([options, &result] { run_delay(*options, result); });
}

}  // namespace lockstep::cli
