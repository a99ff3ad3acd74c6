#pragma once
// What `lockstep verify` computes, and what the kernel tests check: the staged
// RK4 of the model against the analytic normal-mode solution and against
// Boost.Odeint's dopri5, with every bound stated and derived. The model is the
// paper's two-mass system (any masses and springs), or with `--masses S` the
// uniform S-mass chain of eq. (1) (kernels::chain_params::uniform: the
// paper's masses and springs, displaced 2, -3, 2, ... m), the model that
// threads beyond four integrate (kernels/model_choice.hpp).
//
// The bounds (all on the positions x1..xs, in metres, maximum over every step
// of the run and every mass; n = steps, h = step, theta_k = w_k h, A_ik =
// amplitude of mode k in position i, eps = 2^-52):
//
//  * Roots. A closed form against Eigen's generalized eigensolver (two
//    independent computations of the same eigenvalues): relative difference
//    <= 1e-9. Two masses: the quadratic (kernels/normal_modes.hpp). The
//    uniform chain fixed at one end: K / C is tridiagonal (2, ..., 2, 1 on
//    the diagonal, -1 beside it), whose eigenvalues are
//    4 sin^2((2k - 1) pi / (2 (2s + 1))), so w_k = 2 sqrt(C/m) sin((2k - 1) pi
//    / (2 (2s + 1))), k = 1..s (s = 2: the paper's w^2 = (C/m)(3 ± sqrt 5)/2).
//    Only in the paper's two-mass case, the computed roots against the
//    paper's printed ±51.47j, ±19.66j: relative difference <= 0.1% (the paper
//    prints four significant digits; the two differ by about 0.04% because the
//    printed roots fit C/m = w_fast * w_slow of about 1011.9 s^-2, not 1012.5).
//    A chain has no printed roots to compare with.
//
//  * RK4 error, proved from h. RK4 applied to x' = J x multiplies each mode's
//    complex amplitude per step by R(i theta) = 1 + z + z^2/2 + z^3/6 + z^4/24
//    (z = i theta), where the exact solution multiplies it by e^{i theta}. So
//    after n steps |R^n - e^{i n theta}| <= n |R - e^{i theta}| max(1, |R|)^(n-1),
//    and |R - e^{i theta}| <= sum_{j>=5} theta^j / j! (the tail of the series).
//    Hence |x_i - x_i,exact| <= sum_k A_ik n tail(theta_k) max(1,|R_k|)^(n-1)
//    + 16 n eps max_i sum_k A_ik (rounding: a few roundings of relative size
//    eps per step, accumulated linearly as the worst case).
//
//  * Observed order: the least-squares slope of log(max error) against log(h)
//    over the ladder h, h/2, h/4, h/8, using the rungs whose truncation bound is
//    at least 100 times the typical rounding error sqrt(n) eps amplitude
//    (below that the error is rounding, not truncation, and rounding would
//    move a pair's slope by more than 0.015). Must lie in [3.9, 4.1] (RK4 is
//    fourth order; with theta <= 0.05 the next term moves the slope by less
//    than 0.01). When fewer than two rungs are above rounding (a very small
//    --dt) the order is not measurable: the check is reported as skipped, not
//    passed, and does not decide the exit status.
//
//  * Energy drift, |E(t) - E(0)| / E(0): each mode's energy is multiplied by
//    |R(i theta_k)|^2 = 1 - theta^6/72 + theta^8/576 per step, and the modes'
//    energies add, so the drift is at most max_k |1 - |R_k|^(2n)| + 16 n eps.
//
//  * dopri5 against the analytic solution: every accepted step's error
//    estimate is within tolerance (1 + |x| + h |x'|) per component, and the
//    conservative system does not amplify errors, so the global error is at
//    most steps * tolerance * (1 + 2 max|state|) (a conservative a-priori bound;
//    dopri5's propagated fifth-order solution is more accurate than the
//    fourth-order estimate that the control uses).
//
//  * RK4 against dopri5: at most the sum of the two bounds above.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "kernels/model_choice.hpp"
#include "kernels/normal_modes.hpp"
#include "kernels/oscillator.hpp"

namespace lockstep::kernels {

// The paper's printed roots, ±j w (rad/s).
inline constexpr double kPaperFastRoot = 51.47;
inline constexpr double kPaperSlowRoot = 19.66;

inline constexpr double kRootAgreementBound = 1e-9;   // closed form vs Eigen, relative
inline constexpr double kPaperRootBound = 1e-3;       // computed vs the paper's printed roots, relative
inline constexpr double kOrderLow = 3.9;
inline constexpr double kOrderHigh = 4.1;
inline constexpr unsigned kLadderRungs = 4;           // step, step/2, step/4, step/8
// The coarsest rung's steps (end time / step) times the masses: verify keeps
// that trajectory (every position at every step) and evaluates the analytic
// solution, s modes for each of s positions, at every step of every rung.
// 1,000,000 steps of the two masses; a chain of s masses s / 2 times fewer.
inline constexpr std::uint64_t kMaxVerifyMassSteps = 2'000'000;
// The longest chain verify checks: Eigen's dense eigensolver costs s^3, and
// every evaluation of the analytic solution s^2.
inline constexpr std::size_t kMaxVerifyMasses = 512;

struct verify_settings {
  // The paper's two-mass system with `params` (the default), or a uniform
  // chain of model.masses (model.chain(); `params` is then not used).
  model_choice model{};
  two_mass_params params{};  // the paper's case by default
  double step = 1e-3;        // s: w_fast h = 0.05 in the paper's case, well inside RK4's asymptotic range
  double end_time = 1.0;     // s: about 8 periods of the fast mode, 3 of the slow one
  double dopri5_tolerance = 1e-12;

  // Empty when the settings can run; otherwise one line saying what is wrong.
  [[nodiscard]] std::string invalid_reason() const;
  // end_time / step, rounded (the settings require it to be a whole number).
  [[nodiscard]] std::uint64_t steps() const;
  // The masses whose positions are checked: 2, or the chain's.
  [[nodiscard]] std::size_t masses() const noexcept { return model.equations() / 2; }
};

// The uniform chain's angular frequencies, ascending, rad/s (the closed form
// above; `masses` equal masses m and springs C, spring_over_mass = C / m).
[[nodiscard]] std::vector<double> uniform_chain_angular_frequencies(std::size_t masses, double spring_over_mass);

// RK4's per-step amplification of a mode of angular frequency w at step h,
// theta = w h: |R(i theta)| and the bound on |R(i theta) - e^{i theta}|.
[[nodiscard]] double rk4_amplification_modulus(double theta);
[[nodiscard]] double rk4_one_step_defect_bound(double theta);
// The bounds stated above, for a normal-mode solution after `steps` steps of size `step`.
[[nodiscard]] double rk4_truncation_bound(const normal_mode_solution& solution, double step, std::uint64_t steps);
[[nodiscard]] double rk4_rounding_allowance(const normal_mode_solution& solution, std::uint64_t steps);
[[nodiscard]] double rk4_energy_drift_bound(const normal_mode_solution& solution, double step, std::uint64_t steps);

struct verify_check {
  std::string name;
  double value = 0.0;
  double lower = 0.0;  // the check holds when lower <= value <= upper
  double upper = 0.0;
  bool checked = true;  // false: the figure could not be measured (then `passed` is false and does not count)
  bool passed = false;
  std::string basis;  // where the bound comes from, or why it could not be checked
};

struct root_report {
  // Angular frequencies, ascending, rad/s (the roots are ±j w): for two
  // masses {slow (in phase), fast (out of phase)}.
  std::vector<double> closed_form;  // from the parameters (above)
  std::vector<double> eigen;        // Eigen's generalized eigensolver on the same K, M
  double closed_form_vs_eigen = 0.0;  // max relative difference
  // The paper's printed roots: for the two-mass system only.
  bool papers_case = false;           // only then are the paper's roots the ones to compare with
  double fast_vs_paper = 0.0;         // (computed - paper) / paper
  double slow_vs_paper = 0.0;
  double paper_implied_spring_over_mass = 0.0;  // w_fast * w_slow of the printed roots (Vieta, equal masses and springs)
  double spring_over_mass = 0.0;                // C1/m1 of the parameters
};

struct ladder_rung {
  double step = 0.0;
  std::uint64_t steps = 0;
  double max_error = 0.0;         // max over steps and positions of |x_rk4 - x_analytic|, m
  double truncation_bound = 0.0;  // proved from h
  double error_bound = 0.0;       // truncation bound + rounding allowance
  double order_from_previous = 0.0;  // log2(error(2h) / error(h)); NaN for the first rung
  bool in_order_fit = false;
};

struct energy_report {
  double initial = 0.0;               // J
  double max_relative_drift = 0.0;    // max over the run of |E - E0| / E0, at the given step
  double final_relative_drift = 0.0;  // signed, (E(end) - E0) / E0
  double bound = 0.0;
};

struct dopri5_report {
  std::size_t steps = 0;
  double tolerance = 0.0;
  double max_error_vs_analytic = 0.0;  // positions, m
  double error_bound = 0.0;
  double max_difference_vs_rk4 = 0.0;  // positions, m, RK4 at the given step
  double difference_bound = 0.0;
};

struct trajectory_point {
  double time = 0.0;
  std::vector<double> positions;  // x1..xs, m: RK4's
  std::vector<double> exact;      // x1..xs, m: the analytic solution at the same time
};

struct verify_report {
  verify_settings settings;
  root_report roots;
  std::vector<ladder_rung> ladder;
  double observed_order = 0.0;  // NaN when fewer than two rungs are above rounding
  std::size_t order_fit_rungs = 0;
  energy_report energy;
  dopri5_report dopri5;
  std::vector<trajectory_point> trajectory;  // RK4 at the given step, t = 0 .. end
  std::vector<verify_check> checks;
  bool passed = false;  // every check that could be measured passed
};

// One line of progress ("RK4 rung 2 of 4: h = ..."), for long runs.
using verify_progress = std::function<void(const std::string& line)>;

// Runs everything. Throws std::invalid_argument with settings.invalid_reason()
// when the settings cannot run. `progress`, when given, hears of each phase.
[[nodiscard]] verify_report run_verification(const verify_settings& settings, const verify_progress& progress = {});

}  // namespace lockstep::kernels
