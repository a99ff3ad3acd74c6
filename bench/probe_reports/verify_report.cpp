// The verification's two readings, as text and as a result file (verify_report.hpp).
#include "bench/probe_reports/verify_report.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iterator>

#include "bench/results/machine_context.hpp"

namespace lockstep::bench {

namespace {

using kernels::verify_report;

std::string percent(double relative) { return fmt::format("{:+.4f} %", 100.0 * relative); }

std::string root(double frequency, int digits) { return fmt::format("±{:.{}f}j", frequency, digits); }

// The paper's two masses: the parameters, and the roots beside the paper's.
void two_mass_text(std::string& text, const verify_report& report) {
  const auto& settings = report.settings;
  const auto& params = settings.params;
  const auto& roots = report.roots;
  // closed_form and eigen are ascending: {slow (in phase), fast (out of phase)}.
  const double slow = roots.closed_form.front();
  const double fast = roots.closed_form.back();
  text +=
      fmt::format("Model      m1 = {} kg, m2 = {} kg, C1 = {} N/m, C2 = {} N/m ({})\n", params.m1, params.m2, params.c1,
                  params.c2, roots.papers_case ? "the paper's case, C/m = 1012.5 s^-2" : "not the paper's case");
  text += fmt::format("           x1(0) = {} m, x2(0) = {} m, at rest; RK4 step {} s to t = {} s ({} steps)\n\n",
                      params.x1, params.x2, settings.step, settings.end_time, settings.steps());

  text += fmt::format("Characteristic roots (rad/s)   computed     (as printed)  paper      relative difference\n");
  text +=
      fmt::format("  fast (out of phase)        {:<12} {:<13} {:<9}  {}\n", root(fast, 4),
                  fmt::format("({})", root(fast, 2)), root(kernels::kPaperFastRoot, 2), percent(roots.fast_vs_paper));
  text +=
      fmt::format("  slow (in phase)            {:<12} {:<13} {:<9}  {}\n", root(slow, 4),
                  fmt::format("({})", root(slow, 2)), root(kernels::kPaperSlowRoot, 2), percent(roots.slow_vs_paper));
  text += fmt::format("  Eigen's generalized eigensolver: ±{:.4f}j, ±{:.4f}j (relative difference {:.1e})\n",
                      roots.eigen.back(), roots.eigen.front(), roots.closed_form_vs_eigen);
  text += fmt::format("  The paper's printed roots correspond to C/m = {:.1f} s^-2 (their product, w_fast * w_slow);\n",
                      roots.paper_implied_spring_over_mass);
  text += fmt::format(
      "  these parameters have C1/m1 = {} s^-2.{}\n\n", roots.spring_over_mass,
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
void chain_text(std::string& text, const verify_report& report) {
  const auto& settings = report.settings;
  const kernels::chain_params params = settings.model.chain();
  const auto& roots = report.roots;
  text +=
      fmt::format("Model      {}, eq. (1), fixed at one end: every mass {} kg, every spring {} N/m (C/m = {} s^-2)\n",
                  settings.model.description(), params.masses.front(), params.springs.front(), roots.spring_over_mass);
  text += fmt::format("           x(0) = {} m, at rest; RK4 step {} s to t = {} s ({} steps)\n\n",
                      first_values(params.positions), settings.step, settings.end_time, settings.steps());

  text += fmt::format("Angular frequencies (rad/s)    closed form    Eigen          relative difference\n");
  constexpr std::size_t kEnds = 3;  // modes shown at each end of a long chain
  const std::size_t modes = roots.closed_form.size();
  for (std::size_t mode = 0; mode < modes; ++mode) {
    if (modes > 2 * kEnds + 1 && mode >= kEnds && mode < modes - kEnds) {
      if (mode == kEnds) text += fmt::format("  ... {} more modes (in --out's JSON)\n", modes - 2 * kEnds);
      continue;
    }
    text += fmt::format("  mode {:<23} {:<14} {:<14} {:.1e}\n", mode + 1, root(roots.closed_form[mode], 4),
                        root(roots.eigen[mode], 4),
                        std::abs(roots.closed_form[mode] - roots.eigen[mode]) / roots.eigen[mode]);
  }
  text += fmt::format(
      "  closed form: w_k = 2 sqrt(C/m) sin((2k - 1) pi / (2 (2s + 1))); the paper prints roots only for its\n"
      "  two masses, so there are none to compare with.\n\n");
}

}  // namespace

std::string verify_text(const verify_report& report) {
  std::string text;
  const auto& model = report.settings.model;
  text += fmt::format("lockstep verify: {}, RK4 against the analytic solution and dopri5\n\n", model.description());
  if (model.is_chain())
    chain_text(text, report);
  else
    two_mass_text(text, report);

  text += fmt::format("RK4 against the {} (max |x - x_exact| over the run, positions, m)\n",
                      model.is_chain() ? "normal-mode solution from Eigen's modes" : "analytic normal-mode solution");
  text += fmt::format("  {:>12}  {:>9}  {:>11}  {:>11}  {:>7}\n", "step h (s)", "steps", "max error", "bound", "order");
  for (const auto& rung : report.ladder) {
    const std::string order =
        std::isnan(rung.order_from_previous) ? std::string("-") : fmt::format("{:.3f}", rung.order_from_previous);
    text += fmt::format("  {:>12.6g}  {:>9}  {:>11.3e}  {:>11.3e}  {:>7}{}\n", rung.step, rung.steps, rung.max_error,
                        rung.error_bound, order, rung.in_order_fit ? "" : "  (rounding level, not in the fit)");
  }
  if (std::isnan(report.observed_order)) {
    text += fmt::format("  observed order: not measurable (errors at rounding level)\n\n");
  } else {
    text += fmt::format("  observed order {:.3f} (least squares over {} rungs; RK4 is fourth order)\n\n",
                        report.observed_order, report.order_fit_rungs);
  }

  text += fmt::format("Energy     E0 = {:.6g} J; max |E - E0| / E0 = {:.3e} (bound {:.3e}); at the end {:+.3e}\n",
                      report.energy.initial, report.energy.max_relative_drift, report.energy.bound,
                      report.energy.final_relative_drift);
  text += fmt::format("dopri5     Boost.Odeint runge_kutta_dopri5, tolerance {:.0e}, {} steps:\n",
                      report.dopri5.tolerance, report.dopri5.steps);
  text +=
      fmt::format("           max |error| vs analytic {:.3e} (bound {:.3e}); RK4 vs dopri5 {:.3e} (bound {:.3e})\n\n",
                  report.dopri5.max_error_vs_analytic, report.dopri5.error_bound, report.dopri5.max_difference_vs_rk4,
                  report.dopri5.difference_bound);

  text += fmt::format("Checks\n");
  std::size_t failed = 0;
  std::size_t skipped = 0;
  for (const auto& check : report.checks) {
    failed += check.checked && !check.passed ? 1 : 0;
    skipped += check.checked ? 0 : 1;
    const std::string range = check.lower == 0.0 ? fmt::format("<= {:.3g}", check.upper)
                                                 : fmt::format("in [{:.3g}, {:.3g}]", check.lower, check.upper);
    const char* verdict = !check.checked ? "SKIP" : (check.passed ? "PASS" : "FAIL");
    const std::string value = check.checked ? fmt::format("{:.4g}", check.value) : std::string("unmeasured,");
    text += fmt::format("  {}  {}: {} {}\n        ({})\n", verdict, check.name, value, range, check.basis);
  }
  const std::string skipped_note = skipped == 0 ? std::string() : fmt::format(" ({} skipped: not measurable)", skipped);
  if (failed == 0) {
    text += fmt::format("\nverify: {}: all {} measurable checks passed{}\n", model.description(),
                        report.checks.size() - skipped, skipped_note);
  } else {
    text += fmt::format("\nverify: {}: {} of {} checks FAILED{}\n", model.description(), failed,
                        report.checks.size() - skipped, skipped_note);
  }
  return text;
}

std::string verify_csv(const verify_report& report) {
  fmt::memory_buffer buffer;
  fmt::format_to(std::back_inserter(buffer), "t");
  // RK4's positions, then the analytic solution's at the same time (the
  // report draws them against each other and computes neither).
  for (std::size_t mass = 1; mass <= report.settings.masses(); ++mass)
    fmt::format_to(std::back_inserter(buffer), ",x{}", mass);
  for (std::size_t mass = 1; mass <= report.settings.masses(); ++mass)
    fmt::format_to(std::back_inserter(buffer), ",exact_x{}", mass);
  fmt::format_to(std::back_inserter(buffer), "\n");
  for (const auto& point : report.trajectory) {
    fmt::format_to(std::back_inserter(buffer), "{}", point.time);
    for (double position : point.positions) fmt::format_to(std::back_inserter(buffer), ",{}", position);
    for (double position : point.exact) fmt::format_to(std::back_inserter(buffer), ",{}", position);
    fmt::format_to(std::back_inserter(buffer), "\n");
  }
  return fmt::to_string(buffer);
}

namespace {

// NaN has no JSON form: null.
nlohmann::json number(double value) { return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr); }

}  // namespace

nlohmann::json verify_json(const verify_report& report, const platform::topology& machine) {
  const auto& settings = report.settings;
  const auto& params = settings.params;
  const auto& roots = report.roots;
  const auto& model = settings.model;
  nlohmann::json json = result_document("verify", machine);
  json["model"] = {{"name", model.key()},
                   {"description", model.description()},
                   {"masses", settings.masses()},
                   {"equations", model.equations()}};
  if (model.is_chain()) {
    const kernels::chain_params chain = model.chain();
    json["parameters"] = {
        {"masses", chain.masses},           {"springs", chain.springs}, {"positions_0", chain.positions},
        {"velocities_0", chain.velocities}, {"dt", settings.step},      {"t_end", settings.end_time},
        {"steps", settings.steps()},        {"papers_case", false}};
    json["roots"] = {{"closed_form_rad_s", roots.closed_form},
                     {"eigen_rad_s", roots.eigen},
                     {"closed_form_vs_eigen_relative", roots.closed_form_vs_eigen},
                     {"c_over_m", roots.spring_over_mass}};
  } else {
    json["parameters"] = {{"m1", params.m1},           {"m2", params.m2},
                          {"c1", params.c1},           {"c2", params.c2},
                          {"x1_0", params.x1},         {"x2_0", params.x2},
                          {"v1_0", params.v1},         {"v2_0", params.v2},
                          {"dt", settings.step},       {"t_end", settings.end_time},
                          {"steps", settings.steps()}, {"papers_case", roots.papers_case}};
    // closed_form and eigen are ascending: {slow, fast}.
    json["roots"] = {{"computed_rad_s", {{"fast", roots.closed_form.back()}, {"slow", roots.closed_form.front()}}},
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
  return json;
}

}  // namespace lockstep::bench
