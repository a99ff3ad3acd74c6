#include "kernels/verification.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <stdexcept>

#include "kernels/dopri5_reference.hpp"
#include "kernels/rk4.hpp"

namespace lockstep::kernels {
namespace {

constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
constexpr double kRoundingFactor = 16.0;     // roundings of relative size eps per step, worst case
constexpr double kOrderFitMargin = 100.0;    // truncation must exceed typical rounding by this much

double relative_difference(double value, double reference) { return (value - reference) / reference; }

// max_i sum_k A_ik: the largest amplitude a position can reach.
double amplitude_scale(const normal_mode_solution& solution) {
  double scale = 0.0;
  for (std::size_t position = 0; position < solution.masses_count(); ++position) {
    double sum = 0.0;
    for (const normal_mode& mode : solution.modes()) sum += mode.amplitude(position);
    scale = std::max(scale, sum);
  }
  return scale;
}

verify_check make_check(std::string name, double value, double lower, double upper, std::string basis) {
  const bool passed = std::isfinite(value) && value >= lower && value <= upper;
  return {std::move(name), value, lower, upper, true, passed, std::move(basis)};
}

}  // namespace

std::string verify_settings::invalid_reason() const {
  if (model.is_chain() && model.masses > kMaxVerifyMasses)
    return fmt::format("--masses: verify checks chains of at most {} masses, got {}", kMaxVerifyMasses, model.masses);
  // The parameters' names are the command's flags (--m1, --m2, --c1, --c2);
  // a chain does not use them.
  if (!model.is_chain()) {
    if (auto reason = params.invalid_reason(); !reason.empty()) return "--" + reason;
  }
  if (!std::isfinite(step) || !(step > 0.0)) return fmt::format("--dt must be a positive finite number of seconds, got {}", step);
  if (!std::isfinite(end_time) || !(end_time > 0.0)) {
    return fmt::format("--t-end must be a positive finite number of seconds, got {}", end_time);
  }
  if (step > end_time) return fmt::format("--dt ({}) must not exceed --t-end ({})", step, end_time);
  const double ratio = end_time / step;
  const std::uint64_t most_steps = kMaxVerifyMassSteps / masses();
  if (ratio > static_cast<double>(most_steps)) {
    return fmt::format("--t-end / --dt is {:.0f} steps; verify runs at most {}{} (raise --dt or lower --t-end)", ratio,
                       most_steps, model.is_chain() ? " for " + model.description() : std::string());
  }
  const double whole = std::round(ratio);
  if (std::abs(whole * step - end_time) > 1e-9 * end_time) {
    return fmt::format("--t-end ({}) must be a whole number of --dt ({}) steps", end_time, step);
  }
  if (!std::isfinite(dopri5_tolerance) || !(dopri5_tolerance > 0.0)) {
    return fmt::format("the dopri5 tolerance must be positive, got {}", dopri5_tolerance);
  }
  return {};
}

std::uint64_t verify_settings::steps() const { return static_cast<std::uint64_t>(std::llround(end_time / step)); }

double rk4_amplification_modulus(double theta) {
  // |R(i theta)|^2 = (1 - theta^2/2 + theta^4/24)^2 + (theta - theta^3/6)^2 = 1 - theta^6/72 + theta^8/576.
  const double theta2 = theta * theta;
  const double theta6 = theta2 * theta2 * theta2;
  return std::sqrt(1.0 - theta6 / 72.0 + theta6 * theta2 / 576.0);
}

double rk4_one_step_defect_bound(double theta) {
  // sum_{j>=5} theta^j / j!, summed directly (e^theta minus the first five
  // terms would cancel catastrophically for small theta).
  double term = std::pow(theta, 5) / 120.0;
  double sum = 0.0;
  for (int j = 6; j < 200 && term > sum * kEpsilon * 0.25; ++j) {
    sum += term;
    term *= theta / j;
  }
  return sum;
}

double rk4_truncation_bound(const normal_mode_solution& solution, double step, std::uint64_t steps) {
  const double n = static_cast<double>(steps);
  double bound = 0.0;
  for (std::size_t position = 0; position < solution.masses_count(); ++position) {
    double sum = 0.0;
    for (const normal_mode& mode : solution.modes()) {
      const double theta = mode.angular_frequency * step;
      const double growth = std::pow(std::max(1.0, rk4_amplification_modulus(theta)), n > 0.0 ? n - 1.0 : 0.0);
      sum += mode.amplitude(position) * n * rk4_one_step_defect_bound(theta) * growth;
    }
    bound = std::max(bound, sum);
  }
  return bound;
}

double rk4_rounding_allowance(const normal_mode_solution& solution, std::uint64_t steps) {
  return kRoundingFactor * static_cast<double>(steps) * kEpsilon * amplitude_scale(solution);
}

double rk4_energy_drift_bound(const normal_mode_solution& solution, double step, std::uint64_t steps) {
  const double n = static_cast<double>(steps);
  double bound = 0.0;
  for (const normal_mode& mode : solution.modes()) {
    const double theta = mode.angular_frequency * step;
    const double theta2 = theta * theta;
    const double theta6 = theta2 * theta2 * theta2;
    // |R|^(2n) - 1 = expm1(n log1p(|R|^2 - 1)), without cancellation.
    const double per_step = -theta6 / 72.0 + theta6 * theta2 / 576.0;
    bound = std::max(bound, std::abs(std::expm1(n * std::log1p(per_step))));
  }
  return bound + kRoundingFactor * n * kEpsilon;
}

std::vector<double> uniform_chain_angular_frequencies(std::size_t masses, double spring_over_mass) {
  std::vector<double> frequencies(masses);
  const double scale = 2.0 * std::sqrt(spring_over_mass);
  const double denominator = 2.0 * (2.0 * static_cast<double>(masses) + 1.0);
  for (std::size_t mode = 0; mode < masses; ++mode)
    frequencies[mode] = scale * std::sin((2.0 * static_cast<double>(mode) + 1.0) * std::numbers::pi / denominator);
  return frequencies;
}

namespace {

double max_relative_difference(const std::vector<double>& values, const std::vector<double>& references) {
  double largest = 0.0;
  for (std::size_t index = 0; index < values.size(); ++index)
    largest = std::max(largest, std::abs(relative_difference(values[index], references[index])));
  return largest;
}

std::vector<double> angular_frequencies(const normal_mode_solution& solution) {
  std::vector<double> frequencies;
  for (const normal_mode& mode : solution.modes()) frequencies.push_back(mode.angular_frequency);
  return frequencies;
}

// The paper's two masses: the quadratic's roots beside Eigen's, and in the
// paper's case beside the printed ones.
void check_two_mass_roots(const two_mass_params& params, verify_report& report) {
  root_report& roots = report.roots;
  const two_mass_frequencies computed = two_mass_angular_frequencies(params);
  roots.closed_form = {computed.slow, computed.fast};
  roots.eigen = angular_frequencies(normal_mode_solution::chain(chain_params::from_two_mass(params)));
  roots.closed_form_vs_eigen = max_relative_difference(roots.closed_form, roots.eigen);
  roots.papers_case = params.is_papers_case();
  roots.fast_vs_paper = relative_difference(computed.fast, kPaperFastRoot);
  roots.slow_vs_paper = relative_difference(computed.slow, kPaperSlowRoot);
  // Equal masses and springs: w_fast^2 w_slow^2 = (C/m)^2 (product of the roots of m^2 w^4 - 3 m C w^2 + C^2).
  roots.paper_implied_spring_over_mass = kPaperFastRoot * kPaperSlowRoot;
  roots.spring_over_mass = params.c1 / params.m1;
  report.checks.push_back(make_check(
      "roots: closed form vs Eigen's generalized eigensolver (relative)", roots.closed_form_vs_eigen, 0.0,
      kRootAgreementBound, "two independent computations of the same eigenvalues; double precision leaves ~1e-15"));
  if (roots.papers_case) {
    report.checks.push_back(make_check(
        "roots: computed vs the paper's printed ±51.47j, ±19.66j (relative)",
        std::max(std::abs(roots.fast_vs_paper), std::abs(roots.slow_vs_paper)), 0.0, kPaperRootBound,
        fmt::format("the paper prints four significant digits; its roots fit C/m = {:.1f}, not {}",
                    roots.paper_implied_spring_over_mass, two_mass_params::kPaperSpringOverMass)));
  }
}

// A uniform chain: the sine formula's roots beside Eigen's (the analytic
// solution's own modes). No printed roots to compare with.
void check_uniform_chain_roots(const chain_params& params, const normal_mode_solution& analytic, verify_report& report) {
  root_report& roots = report.roots;
  roots.spring_over_mass = params.springs.front() / params.masses.front();
  roots.closed_form = uniform_chain_angular_frequencies(params.masses_count(), roots.spring_over_mass);
  roots.eigen = angular_frequencies(analytic);
  roots.closed_form_vs_eigen = max_relative_difference(roots.closed_form, roots.eigen);
  report.checks.push_back(make_check(
      "roots: uniform chain's closed form vs Eigen's generalized eigensolver (relative)", roots.closed_form_vs_eigen,
      0.0, kRootAgreementBound,
      "w_k = 2 sqrt(C/m) sin((2k - 1) pi / (2 (2s + 1))) against Eigen's eigenvalues of the same K, M"));
}

// The largest |x_j - y_j| over the first `positions` positions: x_j from a
// state in the numbering of `numbering` (a model: its position_equation(j)),
// y_j the first `positions` values of `reference` (the analytic state,
// positions first, or a trajectory's positions).
template <class Numbering>
double position_error(std::size_t positions, const Numbering& numbering, std::span<const double> state,
                      std::span<const double> reference) {
  double largest = 0.0;
  for (std::size_t position = 0; position < positions; ++position)
    largest = std::max(largest, std::abs(state[numbering.position_equation(position)] - reference[position]));
  return largest;
}

template <class Numbering>
std::vector<double> positions_of(std::size_t positions, const Numbering& numbering, std::span<const double> state) {
  std::vector<double> result(positions);
  for (std::size_t position = 0; position < positions; ++position)
    result[position] = state[numbering.position_equation(position)];
  return result;
}

// The positions of an analytic state (positions first, then velocities).
std::vector<double> analytic_positions(std::size_t positions, std::span<const double> state) {
  return std::vector<double>(state.begin(), state.begin() + static_cast<std::ptrdiff_t>(positions));
}

// One rung of the ladder: RK4 at `refinement` times the given step's
// resolution against the analytic solution. The given step's rung (the
// first) also records the trajectory and the energy drift.
template <oscillator_model Model>
ladder_rung run_rung(const Model& model, const normal_mode_solution& analytic, const verify_settings& settings,
                     unsigned rung_index, const verify_progress& progress, verify_report& report) {
  const std::uint64_t steps = settings.steps();
  const std::size_t positions = analytic.masses_count();
  const std::uint64_t refinement = std::uint64_t{1} << rung_index;
  ladder_rung rung;
  rung.step = settings.step / static_cast<double>(refinement);
  rung.steps = steps * refinement;
  if (progress) {
    progress(fmt::format("RK4 rung {} of {}: h = {:.6g} s, {} steps", rung_index + 1, kLadderRungs, rung.step,
                         rung.steps));
  }
  std::vector<double> exact(model.equations());
  staged_rk4 integrator(model, rung.step);
  const bool given_step = rung_index == 0;
  if (given_step) {
    report.energy.initial = model.energy(integrator.state());
    report.trajectory.reserve(steps + 1);
    analytic.state_at(0.0, exact);
    report.trajectory.push_back(
        {0.0, positions_of(positions, model, integrator.state()), analytic_positions(positions, exact)});
  }
  for (std::uint64_t step = 1; step <= rung.steps; ++step) {
    integrator.step();
    const double time = integrator.time();
    const auto state = integrator.state();
    analytic.state_at(time, exact);
    rung.max_error = std::max(rung.max_error, position_error(positions, model, state, exact));
    if (given_step) {
      report.trajectory.push_back({time, positions_of(positions, model, state), analytic_positions(positions, exact)});
      const double energy = model.energy(state);
      const double drift = report.energy.initial > 0.0 ? (energy - report.energy.initial) / report.energy.initial
                                                       : energy;
      report.energy.max_relative_drift = std::max(report.energy.max_relative_drift, std::abs(drift));
      report.energy.final_relative_drift = drift;
    }
  }
  return rung;
}

// --- The ladder: RK4 against the analytic solution at h, h/2, h/4, h/8.
template <oscillator_model Model>
void check_ladder(const Model& model, const normal_mode_solution& analytic, const verify_settings& settings,
                  const verify_progress& progress, verify_report& report) {
  const double scale = amplitude_scale(analytic);
  for (unsigned rung_index = 0; rung_index < kLadderRungs; ++rung_index) {
    ladder_rung rung = run_rung(model, analytic, settings, rung_index, progress, report);
    rung.truncation_bound = rk4_truncation_bound(analytic, rung.step, rung.steps);
    rung.error_bound = rung.truncation_bound + rk4_rounding_allowance(analytic, rung.steps);
    rung.order_from_previous = report.ladder.empty()
                                   ? std::numeric_limits<double>::quiet_NaN()
                                   : std::log2(report.ladder.back().max_error / rung.max_error);
    const double typical_rounding = std::sqrt(static_cast<double>(rung.steps)) * kEpsilon * scale;
    rung.in_order_fit = rung.truncation_bound >= kOrderFitMargin * typical_rounding && rung.max_error > 0.0;
    report.checks.push_back(make_check(
        fmt::format("RK4 max |error| vs analytic, h = {:.6g} s", rung.step), rung.max_error, 0.0, rung.error_bound,
        "proved from h: sum_k A_k n tail(w_k h) + 16 n eps A (see kernels/verification.hpp)"));
    report.ladder.push_back(rung);
  }
}

// --- Observed order: least-squares slope over the rungs above rounding.
void check_order(verify_report& report) {
  double sum_x = 0.0, sum_y = 0.0, sum_xx = 0.0, sum_xy = 0.0;
  for (const ladder_rung& rung : report.ladder) {
    if (!rung.in_order_fit) continue;
    const double x = std::log(rung.step);
    const double y = std::log(rung.max_error);
    sum_x += x;
    sum_y += y;
    sum_xx += x * x;
    sum_xy += x * y;
    ++report.order_fit_rungs;
  }
  const double fit_count = static_cast<double>(report.order_fit_rungs);
  report.observed_order = report.order_fit_rungs >= 2
                              ? (fit_count * sum_xy - sum_x * sum_y) / (fit_count * sum_xx - sum_x * sum_x)
                              : std::numeric_limits<double>::quiet_NaN();
  verify_check order_check = make_check(
      "observed order of convergence", report.observed_order, kOrderLow, kOrderHigh,
      report.order_fit_rungs >= 2
          ? fmt::format("RK4 is fourth order; least-squares slope over {} rungs above rounding", report.order_fit_rungs)
          : std::string("not measurable: the errors are at rounding level (use a larger --dt)"));
  order_check.checked = report.order_fit_rungs >= 2;
  report.checks.push_back(order_check);
}

// --- dopri5 against the analytic solution and against RK4 at the given step.
void check_dopri5(const chain_model& chain, const normal_mode_solution& analytic, const verify_settings& settings,
                  const verify_progress& progress, verify_report& report) {
  const std::uint64_t steps = settings.steps();
  const std::size_t positions = analytic.masses_count();
  std::vector<double> times(steps + 1);
  for (std::uint64_t index = 0; index <= steps; ++index) times[index] = report.trajectory[index].time;
  dopri5_report& dopri5 = report.dopri5;
  if (progress) progress(fmt::format("dopri5 over {} output times", times.size()));
  std::vector<double> exact_at(chain.equations());
  const dopri5_run run = dopri5_solve(
      chain, times,
      [&](std::size_t index, std::span<const double> state) {
        analytic.state_at(times[index], exact_at);
        dopri5.max_error_vs_analytic =
            std::max(dopri5.max_error_vs_analytic, position_error(positions, chain, state, exact_at));
        dopri5.max_difference_vs_rk4 = std::max(
            dopri5.max_difference_vs_rk4, position_error(positions, chain, state, report.trajectory[index].positions));
      },
      settings.dopri5_tolerance);
  dopri5.steps = run.steps;
  dopri5.tolerance = run.tolerance;
  dopri5.error_bound = static_cast<double>(run.steps) * run.tolerance * (1.0 + 2.0 * run.max_abs_state);
  dopri5.difference_bound = dopri5.error_bound + report.ladder.front().error_bound;
  report.checks.push_back(make_check("dopri5 max |error| vs analytic", dopri5.max_error_vs_analytic, 0.0,
                                     dopri5.error_bound,
                                     "steps x tolerance x (1 + 2 max|state|): accepted local errors, not amplified"));
  report.checks.push_back(make_check(fmt::format("RK4 (h = {:.6g} s) max |difference| vs dopri5", settings.step),
                                     dopri5.max_difference_vs_rk4, 0.0, dopri5.difference_bound,
                                     "the RK4 bound plus the dopri5 bound"));
}

// RK4 against the analytic solution over the ladder, the observed order, the
// energy drift, and dopri5 (on `chain`, the same system as a chain) against
// both: every check after the roots, for either model.
template <oscillator_model Model>
void check_integration(const Model& model, const chain_model& chain, const normal_mode_solution& analytic,
                       const verify_settings& settings, const verify_progress& progress, verify_report& report) {
  check_ladder(model, analytic, settings, progress, report);
  check_order(report);
  // --- Energy drift at the given step.
  report.energy.bound = rk4_energy_drift_bound(analytic, settings.step, settings.steps());
  report.checks.push_back(make_check("energy drift max |E - E0| / E0", report.energy.max_relative_drift, 0.0,
                                     report.energy.bound,
                                     "each mode's energy scales by |R(i w h)|^2 = 1 - (wh)^6/72 + (wh)^8/576 per step"));
  check_dopri5(chain, analytic, settings, progress, report);
}

}  // namespace

verify_report run_verification(const verify_settings& settings, const verify_progress& progress) {
  if (auto reason = settings.invalid_reason(); !reason.empty()) throw std::invalid_argument(reason);
  verify_report report;
  report.settings = settings;
  if (settings.model.is_chain()) {
    const chain_params params = settings.model.chain();
    const chain_model chain(params);
    if (progress) progress(fmt::format("Eigen's normal modes of {}", settings.model.description()));
    const normal_mode_solution analytic = normal_mode_solution::chain(params);
    check_uniform_chain_roots(params, analytic, report);
    check_integration(chain, chain, analytic, settings, progress, report);
  } else {
    const two_mass_params& params = settings.params;
    check_two_mass_roots(params, report);
    check_integration(two_mass_model(params), chain_model(chain_params::from_two_mass(params)),
                      normal_mode_solution::two_mass(params), settings, progress, report);
  }
  report.passed = std::all_of(report.checks.begin(), report.checks.end(),
                              [](const verify_check& check) { return check.passed || !check.checked; });
  return report;
}

}  // namespace lockstep::kernels
