// lockstep verify: the oscillator model against the analytic normal-mode
// solution and Boost.Odeint's dopri5, with the paper's roots beside the
// computed ones; with --masses S the uniform S-mass chain that threads beyond
// four integrate, against Eigen's normal modes. What is computed and every
// bound: kernels/verification.hpp.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/harness/machine_context.hpp"
#include "bench/harness/result_file.hpp"
#include "platform/topology.hpp"
#include "bench/harness/build_info.hpp"
#include "kernels/verification.hpp"

namespace lockstep::cli {
namespace {

using kernels::verify_report;

struct verify_options {
  kernels::verify_settings settings;
  std::optional<std::size_t> masses;  // --masses S
  std::string step = "1ms";
  std::string end_time = "1s";
  std::string csv_path;
  std::string out;
};

std::string percent(double relative) { return fmt::format("{:+.4f} %", 100.0 * relative); }

std::string root(double frequency, int digits) { return fmt::format("±{:.{}f}j", frequency, digits); }

// The paper's two masses: the parameters, and the roots beside the paper's.
void print_two_mass(const verify_report& report) {
  const auto& settings = report.settings;
  const auto& params = settings.params;
  const auto& roots = report.roots;
  // closed_form and eigen are ascending: {slow (in phase), fast (out of phase)}.
  const double slow = roots.closed_form.front();
  const double fast = roots.closed_form.back();
  fmt::print("Model      m1 = {} kg, m2 = {} kg, C1 = {} N/m, C2 = {} N/m ({})\n", params.m1, params.m2, params.c1,
             params.c2, roots.papers_case ? "the paper's case, C/m = 1012.5 s^-2" : "not the paper's case");
  fmt::print("           x1(0) = {} m, x2(0) = {} m, at rest; RK4 step {} s to t = {} s ({} steps)\n\n", params.x1,
             params.x2, settings.step, settings.end_time, settings.steps());

  fmt::print("Characteristic roots (rad/s)   computed     (as printed)  paper      relative difference\n");
  fmt::print("  fast (out of phase)        {:<12} {:<13} {:<9}  {}\n", root(fast, 4), fmt::format("({})", root(fast, 2)),
             root(kernels::kPaperFastRoot, 2), percent(roots.fast_vs_paper));
  fmt::print("  slow (in phase)            {:<12} {:<13} {:<9}  {}\n", root(slow, 4), fmt::format("({})", root(slow, 2)),
             root(kernels::kPaperSlowRoot, 2), percent(roots.slow_vs_paper));
  fmt::print("  Eigen's generalized eigensolver: ±{:.4f}j, ±{:.4f}j (relative difference {:.1e})\n",
             roots.eigen.back(), roots.eigen.front(), roots.closed_form_vs_eigen);
  fmt::print("  The paper's printed roots correspond to C/m = {:.1f} s^-2 (their product, w_fast * w_slow);\n",
             roots.paper_implied_spring_over_mass);
  fmt::print("  these parameters have C1/m1 = {} s^-2.{}\n\n", roots.spring_over_mass,
             roots.papers_case ? "" : " The paper's roots belong to its own case: shown for reference, not checked.");
}

// "2, -3, 2, -3, ..." (the first few of many values).
std::string first_values(const std::vector<double>& values) {
  constexpr std::size_t kShown = 4;
  std::string text;
  for (std::size_t index = 0; index < std::min(values.size(), kShown); ++index)
    text += fmt::format("{}{}", index == 0 ? "" : ", ", values[index]);
  return values.size() > kShown ? text + ", ..." : text;
}

// A uniform chain: the parameters, and every mode's frequency from the closed
// form beside Eigen's (the slowest and fastest few of a long chain; the JSON
// holds them all).
void print_chain(const verify_report& report) {
  const auto& settings = report.settings;
  const kernels::chain_params params = settings.model.chain();
  const auto& roots = report.roots;
  fmt::print("Model      {}, eq. (1), fixed at one end: every mass {} kg, every spring {} N/m (C/m = {} s^-2)\n",
             settings.model.description(), params.masses.front(), params.springs.front(), roots.spring_over_mass);
  fmt::print("           x(0) = {} m, at rest; RK4 step {} s to t = {} s ({} steps)\n\n",
             first_values(params.positions), settings.step, settings.end_time, settings.steps());

  fmt::print("Angular frequencies (rad/s)    closed form    Eigen          relative difference\n");
  constexpr std::size_t kEnds = 3;  // modes shown at each end of a long chain
  const std::size_t modes = roots.closed_form.size();
  for (std::size_t mode = 0; mode < modes; ++mode) {
    if (modes > 2 * kEnds + 1 && mode >= kEnds && mode < modes - kEnds) {
      if (mode == kEnds) fmt::print("  ... {} more modes (in --out's JSON)\n", modes - 2 * kEnds);
      continue;
    }
    fmt::print("  mode {:<23} {:<14} {:<14} {:.1e}\n", mode + 1, root(roots.closed_form[mode], 4),
               root(roots.eigen[mode], 4),
               std::abs(roots.closed_form[mode] - roots.eigen[mode]) / roots.eigen[mode]);
  }
  fmt::print("  closed form: w_k = 2 sqrt(C/m) sin((2k - 1) pi / (2 (2s + 1))); the paper prints roots only for its\n"
             "  two masses, so there are none to compare with.\n\n");
}

void print_report(const verify_report& report) {
  const auto& model = report.settings.model;
  fmt::print("lockstep verify: {}, RK4 against the analytic solution and dopri5\n\n", model.description());
  if (model.is_chain())
    print_chain(report);
  else
    print_two_mass(report);

  fmt::print("RK4 against the {} (max |x - x_exact| over the run, positions, m)\n",
             model.is_chain() ? "normal-mode solution from Eigen's modes" : "analytic normal-mode solution");
  fmt::print("  {:>12}  {:>9}  {:>11}  {:>11}  {:>7}\n", "step h (s)", "steps", "max error", "bound", "order");
  for (const auto& rung : report.ladder) {
    const std::string order =
        std::isnan(rung.order_from_previous) ? std::string("-") : fmt::format("{:.3f}", rung.order_from_previous);
    fmt::print("  {:>12.6g}  {:>9}  {:>11.3e}  {:>11.3e}  {:>7}{}\n", rung.step, rung.steps, rung.max_error,
               rung.error_bound, order, rung.in_order_fit ? "" : "  (rounding level, not in the fit)");
  }
  if (std::isnan(report.observed_order)) {
    fmt::print("  observed order: not measurable (errors at rounding level)\n\n");
  } else {
    fmt::print("  observed order {:.3f} (least squares over {} rungs; RK4 is fourth order)\n\n", report.observed_order,
               report.order_fit_rungs);
  }

  fmt::print("Energy     E0 = {:.6g} J; max |E - E0| / E0 = {:.3e} (bound {:.3e}); at the end {:+.3e}\n",
             report.energy.initial, report.energy.max_relative_drift, report.energy.bound,
             report.energy.final_relative_drift);
  fmt::print("dopri5     Boost.Odeint runge_kutta_dopri5, tolerance {:.0e}, {} steps:\n", report.dopri5.tolerance,
             report.dopri5.steps);
  fmt::print("           max |error| vs analytic {:.3e} (bound {:.3e}); RK4 vs dopri5 {:.3e} (bound {:.3e})\n\n",
             report.dopri5.max_error_vs_analytic, report.dopri5.error_bound, report.dopri5.max_difference_vs_rk4,
             report.dopri5.difference_bound);

  fmt::print("Checks\n");
  std::size_t failed = 0;
  std::size_t skipped = 0;
  for (const auto& check : report.checks) {
    failed += check.checked && !check.passed ? 1 : 0;
    skipped += check.checked ? 0 : 1;
    const std::string range = check.lower == 0.0 ? fmt::format("<= {:.3g}", check.upper)
                                                 : fmt::format("in [{:.3g}, {:.3g}]", check.lower, check.upper);
    const char* verdict = !check.checked ? "SKIP" : (check.passed ? "PASS" : "FAIL");
    const std::string value = check.checked ? fmt::format("{:.4g}", check.value) : std::string("unmeasured,");
    fmt::print("  {}  {}: {} {}\n        ({})\n", verdict, check.name, value, range, check.basis);
  }
  const std::string skipped_note = skipped == 0 ? std::string() : fmt::format(" ({} skipped: not measurable)", skipped);
  if (failed == 0) {
    fmt::print("\nverify: {}: all {} measurable checks passed{}\n", model.description(),
               report.checks.size() - skipped, skipped_note);
  } else {
    fmt::print("\nverify: {}: {} of {} checks FAILED{}\n", model.description(), failed,
               report.checks.size() - skipped, skipped_note);
  }
}

std::string csv_text(const verify_report& report) {
  fmt::memory_buffer buffer;
  fmt::format_to(std::back_inserter(buffer), "t");
  for (std::size_t mass = 1; mass <= report.settings.masses(); ++mass)
    fmt::format_to(std::back_inserter(buffer), ",x{}", mass);
  fmt::format_to(std::back_inserter(buffer), "\n");
  for (const auto& point : report.trajectory) {
    fmt::format_to(std::back_inserter(buffer), "{}", point.time);
    for (double position : point.positions) fmt::format_to(std::back_inserter(buffer), ",{}", position);
    fmt::format_to(std::back_inserter(buffer), "\n");
  }
  return fmt::to_string(buffer);
}

// NaN has no JSON form: null.
nlohmann::json number(double value) { return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr); }

std::string json_text(const verify_report& report) {
  const auto& settings = report.settings;
  const auto& params = settings.params;
  const auto& roots = report.roots;
  const auto& model = settings.model;
  nlohmann::json json = bench::result_document("verify", platform::topology::this_machine());
  json["model"] = {{"name", model.key()},
                   {"description", model.description()},
                   {"masses", settings.masses()},
                   {"equations", model.equations()}};
  if (model.is_chain()) {
    const kernels::chain_params chain = model.chain();
    json["parameters"] = {{"masses", chain.masses},       {"springs", chain.springs},
                          {"positions_0", chain.positions}, {"velocities_0", chain.velocities},
                          {"dt", settings.step},          {"t_end", settings.end_time},
                          {"steps", settings.steps()},    {"papers_case", false}};
    json["roots"] = {{"closed_form_rad_s", roots.closed_form},
                     {"eigen_rad_s", roots.eigen},
                     {"closed_form_vs_eigen_relative", roots.closed_form_vs_eigen},
                     {"c_over_m", roots.spring_over_mass}};
  } else {
    json["parameters"] = {{"m1", params.m1}, {"m2", params.m2}, {"c1", params.c1},     {"c2", params.c2},
                          {"x1_0", params.x1}, {"x2_0", params.x2}, {"v1_0", params.v1}, {"v2_0", params.v2},
                          {"dt", settings.step}, {"t_end", settings.end_time}, {"steps", settings.steps()},
                          {"papers_case", roots.papers_case}};
    // closed_form and eigen are ascending: {slow, fast}.
    json["roots"] = {
        {"computed_rad_s", {{"fast", roots.closed_form.back()}, {"slow", roots.closed_form.front()}}},
        {"eigen_rad_s", {{"fast", roots.eigen.back()}, {"slow", roots.eigen.front()}}},
        {"closed_form_vs_eigen_relative", roots.closed_form_vs_eigen},
        {"paper_rad_s", {{"fast", kernels::kPaperFastRoot}, {"slow", kernels::kPaperSlowRoot}}},
        {"relative_difference_vs_paper", {{"fast", roots.fast_vs_paper}, {"slow", roots.slow_vs_paper}}},
        {"paper_implied_c_over_m", roots.paper_implied_spring_over_mass},
        {"c_over_m", roots.spring_over_mass}};
  }
  nlohmann::json ladder = nlohmann::json::array();
  for (const auto& rung : report.ladder) {
    ladder.push_back({{"dt", rung.step},
                      {"steps", rung.steps},
                      {"max_error", rung.max_error},
                      {"truncation_bound", rung.truncation_bound},
                      {"bound", rung.error_bound},
                      {"order_from_previous", number(rung.order_from_previous)},
                      {"in_order_fit", rung.in_order_fit}});
  }
  json["ladder"] = ladder;
  json["observed_order"] = number(report.observed_order);
  json["energy"] = {{"initial_j", report.energy.initial},
                    {"max_relative_drift", report.energy.max_relative_drift},
                    {"final_relative_drift", report.energy.final_relative_drift},
                    {"bound", report.energy.bound}};
  json["dopri5"] = {{"method", "boost::numeric::odeint::runge_kutta_dopri5, controlled"},
                    {"tolerance", report.dopri5.tolerance},
                    {"steps", report.dopri5.steps},
                    {"max_error_vs_analytic", report.dopri5.max_error_vs_analytic},
                    {"error_bound", report.dopri5.error_bound},
                    {"max_difference_vs_rk4", report.dopri5.max_difference_vs_rk4},
                    {"difference_bound", report.dopri5.difference_bound}};
  nlohmann::json checks = nlohmann::json::array();
  for (const auto& check : report.checks) {
    checks.push_back({{"name", check.name},
                      {"value", number(check.value)},
                      {"lower", check.lower},
                      {"upper", check.upper},
                      {"checked", check.checked},
                      {"passed", check.passed},
                      {"basis", check.basis}});
  }
  json["checks"] = checks;
  json["passed"] = report.passed;
  return json.dump(2) + "\n";
}

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
  add_masses_option(*command, options->masses)->excludes(m1)->excludes(m2)->excludes(c1)->excludes(c2);
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
    const verify_report report = kernels::run_verification(options->settings, progress);
    print_report(report);
    if (!options->csv_path.empty()) {
      bench::write_result_file(options->csv_path, csv_text(report));
      fmt::print("\ntrajectory written to {}\n", options->csv_path);
    }
    if (!options->out.empty()) {
      bench::write_result_file(options->out, json_text(report));
      fmt::print("figures written to {}\n", options->out);
    }
    result = report.passed ? kExitOk : kExitCheckFailed;
  });
}

}  // namespace lockstep::cli
