// The references and the RK4 against them: roots, the normal-mode solution
// (closed form and Eigen), dopri5, convergence order, energy drift, and the
// s-mass chain against Eigen's modes. Every bound here is derived from h
// (kernels/verification.hpp), not tuned.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <string>
#include <vector>

#include "kernels/dopri5_reference.hpp"
#include "kernels/model_choice.hpp"
#include "kernels/normal_modes.hpp"
#include "kernels/oscillator.hpp"
#include "kernels/rk4.hpp"
#include "kernels/verification.hpp"

namespace {

using namespace lockstep::kernels;

double relative(double value, double reference) { return std::abs(value - reference) / std::abs(reference); }

// Max over steps and positions of |RK4 - analytic|, for any model whose
// analytic solution is given.
template <class Model>
double max_position_error(const Model& model, const normal_mode_solution& analytic, double step,
                          std::uint64_t steps) {
  staged_rk4 integrator(model, step);
  std::vector<double> exact(model.equations());
  double error = 0.0;
  for (std::uint64_t done = 0; done < steps; ++done) {
    integrator.step();
    analytic.state_at(integrator.time(), exact);
    for (std::size_t position = 0; position < analytic.masses_count(); ++position) {
      error = std::max(error, std::abs(integrator.state()[model.position_equation(position)] - exact[position]));
    }
  }
  return error;
}

TEST(References, RootsMatchTheClosedFormAndThePaper) {
  const two_mass_params params;
  const two_mass_frequencies computed = two_mass_angular_frequencies(params);
  // sqrt(C/m (3 ± sqrt 5) / 2), written out independently here.
  const double spring_over_mass = 1012.5;
  EXPECT_LE(relative(computed.fast, std::sqrt(spring_over_mass * (3.0 + std::sqrt(5.0)) / 2.0)), 1e-9);
  EXPECT_LE(relative(computed.slow, std::sqrt(spring_over_mass * (3.0 - std::sqrt(5.0)) / 2.0)), 1e-9);
  const two_mass_frequencies formula = equal_two_mass_angular_frequencies(spring_over_mass);
  EXPECT_LE(relative(computed.fast, formula.fast), 1e-9);
  EXPECT_LE(relative(computed.slow, formula.slow), 1e-9);
  // The rounded values docs/design.md states, and the paper's printed ones (within 0.1%).
  EXPECT_NEAR(computed.fast, 51.49, 0.005);
  EXPECT_NEAR(computed.slow, 19.67, 0.005);
  EXPECT_LE(relative(computed.fast, kPaperFastRoot), 1e-3);
  EXPECT_LE(relative(computed.slow, kPaperSlowRoot), 1e-3);
  // The paper's printed roots fit C/m = w_fast w_slow, about 1011.9, not 1012.5.
  EXPECT_NEAR(kPaperFastRoot * kPaperSlowRoot, 1011.9, 0.05);
}

TEST(References, ClosedFormRootsMatchEigenForUnequalMassesAndSprings) {
  for (const two_mass_params& params : {two_mass_params{}, two_mass_params{.m1 = 0.05, .m2 = 0.01, .c1 = 3.0, .c2 = 70.0},
                                        two_mass_params{.m1 = 7.0, .m2 = 0.002, .c1 = 1e4, .c2 = 0.5}}) {
    const two_mass_frequencies closed = two_mass_angular_frequencies(params);
    const normal_mode_solution eigen = normal_mode_solution::chain(chain_params::from_two_mass(params));
    EXPECT_LE(relative(closed.slow, eigen.modes()[0].angular_frequency), 1e-9);
    EXPECT_LE(relative(closed.fast, eigen.modes()[1].angular_frequency), 1e-9);
  }
}

TEST(References, ClosedFormAndEigenSolutionsAgreeAndMeetTheInitialState) {
  const two_mass_params params{.m1 = 0.03, .m2 = 0.02, .c1 = 25.0, .c2 = 15.0, .x1 = 2.0, .x2 = -3.0, .v1 = 1.5, .v2 = -4.0};
  const normal_mode_solution closed = normal_mode_solution::two_mass(params);
  const normal_mode_solution eigen = normal_mode_solution::chain(chain_params::from_two_mass(params));
  const std::vector<double> initial = closed.state_at(0.0);
  EXPECT_NEAR(initial[0], 2.0, 1e-12);
  EXPECT_NEAR(initial[1], -3.0, 1e-12);
  EXPECT_NEAR(initial[2], 1.5, 1e-12);
  EXPECT_NEAR(initial[3], -4.0, 1e-12);
  const two_mass_model model(params);
  const double energy = model.energy(initial);
  for (double time : {0.0, 0.013, 0.5, 1.0, 7.25}) {
    const std::vector<double> a = closed.state_at(time);
    const std::vector<double> b = eigen.state_at(time);
    for (std::size_t index = 0; index < a.size(); ++index) EXPECT_NEAR(a[index], b[index], 1e-10) << "t = " << time;
    EXPECT_LE(relative(model.energy(a), energy), 1e-12) << "the exact solution conserves energy";
  }
  // It solves the equations: x'' from central differences of the velocity = D3, D4.
  const double time = 0.37;
  const double delta = 1e-6;
  const std::vector<double> before = closed.state_at(time - delta);
  const std::vector<double> after = closed.state_at(time + delta);
  const std::vector<double> now = closed.state_at(time);
  EXPECT_NEAR((after[2] - before[2]) / (2 * delta), model.derivative(2, now.data()), 1e-4);
  EXPECT_NEAR((after[3] - before[3]) / (2 * delta), model.derivative(3, now.data()), 1e-4);
}

TEST(References, AmplificationFactorAndItsDefectBound) {
  for (double theta : {1e-3, 0.01, 0.05, 0.3, 1.0, 2.5, 3.0}) {
    const std::complex<double> z(0.0, theta);
    const std::complex<double> r = 1.0 + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0;
    EXPECT_NEAR(rk4_amplification_modulus(theta), std::abs(r), 1e-14) << theta;
    const double defect = std::abs(r - std::exp(z));
    EXPECT_GE(rk4_one_step_defect_bound(theta) * (1 + 1e-9) + 1e-16, defect) << theta;
    if (theta >= 0.01 && theta <= 1.0) {  // in the range RK4 is used in, the tail is nearly the defect
      EXPECT_LE(rk4_one_step_defect_bound(theta), 1.5 * defect) << "a bound that is not vacuous";
    }
  }
}

TEST(References, Rk4MatchesAnalyticWithinTheBoundFromH) {
  for (const two_mass_params& params : {two_mass_params{}, two_mass_params{.m1 = 0.05, .m2 = 0.01, .c1 = 3.0, .c2 = 70.0}}) {
    const two_mass_model model(params);
    const normal_mode_solution analytic = normal_mode_solution::two_mass(params);
    for (double step : {2e-3, 1e-3, 5e-4}) {
      const auto steps = static_cast<std::uint64_t>(std::llround(1.0 / step));
      const double error = max_position_error(model, analytic, step, steps);
      const double bound = rk4_truncation_bound(analytic, step, steps) + rk4_rounding_allowance(analytic, steps);
      EXPECT_LE(error, bound) << "h = " << step;
      EXPECT_GE(error, 0.5 * bound) << "h = " << step << ": the bound should be close to attained";
    }
  }
}

TEST(References, PapersCaseVerificationPasses) {
  const verify_report report = run_verification(verify_settings{});
  EXPECT_TRUE(report.passed);
  for (const verify_check& check : report.checks) {
    EXPECT_TRUE(check.checked) << check.name;
    EXPECT_TRUE(check.passed) << check.name << ": " << check.value << " not in [" << check.lower << ", " << check.upper << "]";
  }
  EXPECT_TRUE(report.roots.papers_case);
  EXPECT_GE(report.observed_order, 3.9);
  EXPECT_LE(report.observed_order, 4.1);
  ASSERT_EQ(report.ladder.size(), kLadderRungs);
  for (const ladder_rung& rung : report.ladder) EXPECT_LE(rung.max_error, rung.error_bound);
  EXPECT_LE(report.energy.max_relative_drift, report.energy.bound);
  EXPECT_GT(report.energy.max_relative_drift, 0.0);
  EXPECT_LT(report.energy.final_relative_drift, 0.0) << "RK4 loses energy on an oscillator (|R| < 1)";
  EXPECT_LE(report.dopri5.max_error_vs_analytic, report.dopri5.error_bound);
  EXPECT_LE(report.dopri5.max_error_vs_analytic, 1e-9) << "dopri5 with tolerance 1e-12 is far more accurate than RK4";
  EXPECT_LE(report.dopri5.max_difference_vs_rk4, report.dopri5.difference_bound);
  EXPECT_EQ(report.trajectory.size(), 1001U);
  EXPECT_NEAR(report.roots.paper_implied_spring_over_mass, 1011.9, 0.05);
}

TEST(References, ObservedOrderIsFourForOtherParameters) {
  verify_settings settings;
  settings.params = {.m1 = 0.05, .m2 = 0.01, .c1 = 3.0, .c2 = 70.0};
  settings.step = 5e-4;
  settings.end_time = 0.5;
  const verify_report report = run_verification(settings);
  EXPECT_TRUE(report.passed);
  EXPECT_FALSE(report.roots.papers_case);
  EXPECT_GE(report.observed_order, 3.9);
  EXPECT_LE(report.observed_order, 4.1);
}

TEST(References, TooCoarseAStepFailsTheOrderCheck) {
  verify_settings settings;
  settings.step = 0.05;  // w_fast h = 2.6: outside RK4's asymptotic range
  const verify_report report = run_verification(settings);
  EXPECT_FALSE(report.passed);
}

TEST(References, RoundingLevelOrderIsSkippedNotFaked) {
  verify_settings settings;
  settings.step = 1e-5;
  settings.end_time = 0.02;
  const verify_report report = run_verification(settings);
  EXPECT_TRUE(std::isnan(report.observed_order));
  const auto order = std::find_if(report.checks.begin(), report.checks.end(),
                                  [](const verify_check& check) { return check.name.find("order") != std::string::npos; });
  ASSERT_NE(order, report.checks.end());
  EXPECT_FALSE(order->checked);
  EXPECT_FALSE(order->passed);
}

TEST(References, ChainMatchesEigensModesWithinTheBoundFromH) {
  for (std::size_t masses : {1U, 3U, 6U}) {
    chain_params params = chain_params::uniform(masses);
    params.masses.back() = 0.035;  // not all alike
    params.springs.front() = 31.0;
    const chain_model chain(params);
    const normal_mode_solution analytic = normal_mode_solution::chain(params);
    ASSERT_EQ(analytic.modes().size(), masses);
    const double fastest = analytic.modes().back().angular_frequency;
    const double step = 0.05 / fastest;  // w h = 0.05 for the fastest mode
    const std::uint64_t steps = 2000;
    std::vector<double> errors;
    for (double h : {step, step / 2}) {
      const double error = max_position_error(chain, analytic, h, steps * (h == step ? 1 : 2));
      EXPECT_LE(error, rk4_truncation_bound(analytic, h, steps * (h == step ? 1 : 2)) +
                           rk4_rounding_allowance(analytic, steps * (h == step ? 1 : 2)))
          << masses << " masses";
      errors.push_back(error);
    }
    const double order = std::log2(errors[0] / errors[1]);
    EXPECT_GE(order, 3.9) << masses << " masses";
    EXPECT_LE(order, 4.1) << masses << " masses";
  }
}

TEST(References, ChainEnergyDriftIsBounded) {
  const chain_params params = chain_params::uniform(5);
  const chain_model chain(params);
  const normal_mode_solution analytic = normal_mode_solution::chain(params);
  const double step = 0.05 / analytic.modes().back().angular_frequency;
  const std::uint64_t steps = 4000;
  staged_rk4 integrator(chain, step);
  const double initial = chain.energy(integrator.state());
  double drift = 0.0;
  for (std::uint64_t done = 0; done < steps; ++done) {
    integrator.step();
    drift = std::max(drift, std::abs(chain.energy(integrator.state()) - initial) / initial);
  }
  EXPECT_LE(drift, rk4_energy_drift_bound(analytic, step, steps));
  EXPECT_GT(drift, 0.0);
}

TEST(References, Dopri5MatchesEigensModesOnAChain) {
  const chain_params params = chain_params::uniform(6);
  const chain_model chain(params);
  const normal_mode_solution analytic = normal_mode_solution::chain(params);
  std::vector<double> times;
  for (int index = 0; index <= 200; ++index) times.push_back(index * 0.005);
  double error = 0.0;
  std::size_t observed = 0;
  std::vector<double> exact(chain.equations());
  const dopri5_run run = dopri5_solve(chain, times, [&](std::size_t index, std::span<const double> state) {
    EXPECT_EQ(index, observed++);
    analytic.state_at(times[index], exact);
    for (std::size_t position = 0; position < 6; ++position)
      error = std::max(error, std::abs(state[chain.position_equation(position)] - exact[position]));
  });
  EXPECT_EQ(observed, times.size());
  EXPECT_GT(run.steps, 0U);
  EXPECT_LE(error, static_cast<double>(run.steps) * run.tolerance * (1.0 + 2.0 * run.max_abs_state));
  EXPECT_LE(error, 1e-8);
}

// The uniform chain's closed form: for two masses it is the paper's
// w^2 = (C/m)(3 -+ sqrt 5)/2, and for any s it is what Eigen finds.
TEST(References, UniformChainClosedFormMatchesThePapersFormulaAndEigen) {
  const double spring_over_mass = two_mass_params::kPaperSpringOverMass;
  const std::vector<double> two = uniform_chain_angular_frequencies(2, spring_over_mass);
  const two_mass_frequencies paper = equal_two_mass_angular_frequencies(spring_over_mass);
  ASSERT_EQ(two.size(), 2U);
  EXPECT_NEAR(two[0], paper.slow, 1e-12 * paper.slow);
  EXPECT_NEAR(two[1], paper.fast, 1e-12 * paper.fast);
  for (std::size_t masses : {1U, 5U, 17U}) {
    const normal_mode_solution eigen = normal_mode_solution::chain(chain_params::uniform(masses));
    const std::vector<double> closed_form = uniform_chain_angular_frequencies(masses, spring_over_mass);
    ASSERT_EQ(closed_form.size(), masses);
    for (std::size_t mode = 0; mode < masses; ++mode)
      EXPECT_NEAR(closed_form[mode], eigen.modes()[mode].angular_frequency, 1e-9 * closed_form[mode])
          << masses << " masses, mode " << mode;
  }
}

TEST(References, UniformChainVerificationPasses) {
  verify_settings settings;
  settings.model = model_choice{5};
  const verify_report report = run_verification(settings);
  EXPECT_TRUE(report.passed);
  for (const verify_check& check : report.checks) {
    EXPECT_TRUE(check.checked) << check.name;
    EXPECT_TRUE(check.passed) << check.name << ": " << check.value << " not in [" << check.lower << ", " << check.upper << "]";
    EXPECT_EQ(check.name.find("paper"), std::string::npos) << check.name << ": no printed roots for a chain";
  }
  EXPECT_FALSE(report.roots.papers_case);
  EXPECT_EQ(report.roots.closed_form.size(), 5U);
  ASSERT_EQ(report.trajectory.size(), 1001U);
  EXPECT_EQ(report.trajectory.front().positions, (std::vector<double>{2.0, -3.0, 2.0, -3.0, 2.0}));
  EXPECT_GE(report.observed_order, 3.9);
  EXPECT_LE(report.observed_order, 4.1);
}

// A chain's trajectory holds every position: the step budget shrinks with the masses.
TEST(References, ChainStepBudgetShrinksWithTheMasses) {
  verify_settings settings;
  settings.model = model_choice{kMaxVerifyMasses};
  EXPECT_TRUE(settings.invalid_reason().empty()) << settings.invalid_reason();
  settings.model = model_choice{kMaxVerifyMasses + 1};
  EXPECT_NE(settings.invalid_reason().find("--masses"), std::string::npos);
  settings.model = model_choice{100};
  settings.step = 1e-5;  // 100,000 steps of 100 masses
  EXPECT_NE(settings.invalid_reason().find("at most " + std::to_string(kMaxVerifyMassSteps / 100)), std::string::npos)
      << settings.invalid_reason();
  settings.params.c2 = -1.0;  // not the chain's: not checked
  settings.step = 1e-3;
  EXPECT_TRUE(settings.invalid_reason().empty()) << settings.invalid_reason();
}

TEST(References, SettingsRejectBadInput) {
  EXPECT_TRUE(verify_settings{}.invalid_reason().empty());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double infinity = std::numeric_limits<double>::infinity();
  for (double step : {0.0, -1e-3, nan, infinity, 2.0, 0.3}) {
    verify_settings settings;
    settings.step = step;
    EXPECT_FALSE(settings.invalid_reason().empty()) << step;
    EXPECT_THROW((void)run_verification(settings), std::invalid_argument);
  }
  verify_settings settings;
  settings.params.c2 = -1.0;
  EXPECT_NE(settings.invalid_reason().find("--c2"), std::string::npos);
  settings = {};
  settings.end_time = 1e9;
  EXPECT_NE(settings.invalid_reason().find("at most"), std::string::npos);
}

}  // namespace
