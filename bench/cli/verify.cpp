// lockstep verify: the oscillator model against the analytic normal-mode
// solution and Boost.Odeint's dopri5, with the paper's roots beside the
// computed ones; with --masses S the uniform S-mass chain that threads beyond
// four integrate, against Eigen's normal modes. What is computed and every
// bound: kernels/verification.hpp; its readings (text, CSV, result file):
// bench/probe_reports/verify_report.hpp. This file is the options, their checks,
// that call and the readings.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cstdio>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/results/result_file.hpp"
#include "platform/topology.hpp"
#include "bench/probe_reports/verify_report.hpp"
#include "kernels/verification.hpp"

namespace lockstep::cli {
namespace {

struct verify_options {
  kernels::verify_settings settings;
  std::optional<std::size_t> masses;  // --masses S
  std::string step = "1ms";
  std::string end_time = "1s";
  std::string csv_path;
  std::string out;
};

}  // namespace

void add_verify(CLI::App& app, int& result) {
  auto options = std::make_shared<verify_options>();
  auto* command = app.add_subcommand(
      "verify",
      "Check the oscillator model: roots beside the paper's, RK4 against the analytic solution over a ladder of\n"
      "steps (observed order), energy drift, agreement with Boost.Odeint's dopri5. --masses S checks the uniform\n"
      "S-mass chain instead (against Eigen's normal modes). Exit 0 when every error is within its stated bound,\n"
      "1 when not, 2 on bad input.");
  auto& settings = options->settings;
  auto* m1 = command->add_option("--m1", settings.params.m1, "mass 1 (kg)")->capture_default_str();
  auto* m2 = command->add_option("--m2", settings.params.m2, "mass 2 (kg)")->capture_default_str();
  auto* c1 = command->add_option("--c1", settings.params.c1, "spring 1, wall to mass 1 (N/m)")->capture_default_str();
  auto* c2 = command->add_option("--c2", settings.params.c2, "spring 2, mass 1 to mass 2 (N/m)")->capture_default_str();
  // The chain is the uniform one (the paper's masses and springs): the
  // two-mass parameters do not describe it.
  add_masses_option(*command, options->masses, "")->excludes(m1)->excludes(m2)->excludes(c1)->excludes(c2);
  command->add_option("--dt", options->step, "RK4 step, with a unit (e.g. 1ms); the ladder also runs dt/2, dt/4, dt/8")
      ->capture_default_str();
  command->add_option("--t-end", options->end_time, "end time, with a unit (e.g. 1s), a whole number of steps")
      ->capture_default_str();
  command->add_option("--csv", options->csv_path,
                      "Write the trajectory t,x1,x2 at --dt (the paper's Figure 2 data) to FILE (atomically)")
      ->option_text("FILE");
  add_out_option(*command, options->out, "the figures and checks as JSON");
  command->callback([options, &result] {
    if (options->masses) options->settings.model = kernels::model_choice{*options->masses};
    options->settings.step = parse_duration_seconds(options->step, "--dt");
    options->settings.end_time = parse_duration_seconds(options->end_time, "--t-end");
    if (auto reason = options->settings.invalid_reason(); !reason.empty()) throw usage_error(reason);
    check_out(options->out);
    if (!options->csv_path.empty()) {
      try {
        bench::check_result_path(options->csv_path);
      } catch (const bench::result_path_error& error) {
        throw usage_error(std::string("--csv: ") + error.what());
      }
    }
    // Progress on stderr only when the run is long (over about a second in a
    // release build): the steps of all rungs, each costing the analytic
    // solution's s^2 (4 for the two masses).
    constexpr std::uint64_t kLongRunSteps = 2'000'000;
    const std::uint64_t masses = options->settings.masses();
    kernels::verify_progress progress;
    if (options->settings.steps() * ((1U << kernels::kLadderRungs) - 1) * masses * masses / 4 > kLongRunSteps) {
      progress = [](const std::string& line) { fmt::print(stderr, "verify: {}\n", line); };
    }
    const kernels::verify_report report = kernels::run_verification(options->settings, progress);
    fmt::print("{}", bench::verify_text(report));
    if (!options->csv_path.empty()) {
      bench::write_result_file(options->csv_path, bench::verify_csv(report));
      fmt::print("\ntrajectory written to {}\n", options->csv_path);
    }
    if (!options->out.empty()) {
      bench::write_result_file(options->out,
                                bench::verify_json(report, platform::topology::this_machine()).dump(2) + "\n");
      fmt::print("figures written to {}\n", options->out);
    }
    result = report.passed ? kExitOk : kExitCheckFailed;
  });
}

}  // namespace lockstep::cli
