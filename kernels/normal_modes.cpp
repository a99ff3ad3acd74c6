#include "kernels/normal_modes.hpp"

#include <Eigen/Dense>

#include <cassert>
#include <cmath>
#include <stdexcept>

namespace lockstep::kernels {

two_mass_frequencies two_mass_angular_frequencies(const two_mass_params& params) {
  if (auto reason = params.invalid_reason(); !reason.empty()) throw std::invalid_argument(reason);
  // a w^4 - b w^2 + c = 0 with a, b, c > 0 and a positive discriminant
  // (b^2 - 4ac = (m1 C2 - m2 C1)^2 + m2^2 C2^2 + 2 m2 C2 (m1 C2 + m2 C1) > 0).
  const double a = params.m1 * params.m2;
  const double b = params.m1 * params.c2 + params.m2 * (params.c1 + params.c2);
  const double c = params.c1 * params.c2;
  const double half_sum = 0.5 * (b + std::sqrt(b * b - 4.0 * a * c));  // no cancellation: both terms positive
  const double fast_squared = half_sum / a;
  const double slow_squared = c / half_sum;  // Vieta: product of the roots is c / a
  return {std::sqrt(slow_squared), std::sqrt(fast_squared)};
}

two_mass_frequencies equal_two_mass_angular_frequencies(double spring_over_mass) {
  const double root5 = std::sqrt(5.0);
  return {std::sqrt(spring_over_mass * (3.0 - root5) / 2.0), std::sqrt(spring_over_mass * (3.0 + root5) / 2.0)};
}

double normal_mode::amplitude(std::size_t position) const {
  return std::hypot(cos_part.at(position), sin_part.at(position));
}

normal_mode_solution normal_mode_solution::two_mass(const two_mass_params& params) {
  const two_mass_frequencies frequencies = two_mass_angular_frequencies(params);
  // Shapes (1, r_k) from the second row of (K - w^2 M) phi = 0:
  // -C2 phi_1 + (C2 - w^2 m2) phi_2 = 0. C2 - w^2 m2 is never 0 (the first
  // row would then need C2^2 = 0).
  const double slow = frequencies.slow;
  const double fast = frequencies.fast;
  const double ratio_slow = params.c2 / (params.c2 - slow * slow * params.m2);
  const double ratio_fast = params.c2 / (params.c2 - fast * fast * params.m2);
  // x(0) = a_s (1, r_s) + a_f (1, r_f), and the same for x'(0) with w_k b_k.
  const double determinant = ratio_fast - ratio_slow;
  const double a_slow = (params.x1 * ratio_fast - params.x2) / determinant;
  const double a_fast = (params.x2 - params.x1 * ratio_slow) / determinant;
  const double b_slow = (params.v1 * ratio_fast - params.v2) / determinant / slow;
  const double b_fast = (params.v2 - params.v1 * ratio_slow) / determinant / fast;

  normal_mode_solution solution;
  solution.masses_ = 2;
  solution.modes_.push_back({slow, {a_slow, a_slow * ratio_slow}, {b_slow, b_slow * ratio_slow}});
  solution.modes_.push_back({fast, {a_fast, a_fast * ratio_fast}, {b_fast, b_fast * ratio_fast}});
  return solution;
}

normal_mode_solution normal_mode_solution::chain(const chain_params& params) {
  if (auto reason = params.invalid_reason(); !reason.empty()) throw std::invalid_argument(reason);
  const auto count = static_cast<Eigen::Index>(params.masses_count());
  Eigen::MatrixXd stiffness = Eigen::MatrixXd::Zero(count, count);
  Eigen::MatrixXd mass = Eigen::MatrixXd::Zero(count, count);
  for (Eigen::Index j = 0; j < count; ++j) {
    const auto index = static_cast<std::size_t>(j);
    mass(j, j) = params.masses[index];
    // Spring j ties mass j to mass j-1 (spring 0: mass 0 to the wall).
    const double spring = params.springs[index];
    stiffness(j, j) += spring;
    if (j > 0) {
      stiffness(j - 1, j - 1) += spring;
      stiffness(j - 1, j) -= spring;
      stiffness(j, j - 1) -= spring;
    }
  }
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> solver(stiffness, mass);
  if (solver.info() != Eigen::Success) throw std::runtime_error("Eigen's generalized eigensolver did not converge");
  // Phi^T M Phi = I, so the modal coordinates of x are Phi^T M x.
  const Eigen::MatrixXd& shapes = solver.eigenvectors();
  const Eigen::Map<const Eigen::VectorXd> positions(params.positions.data(), count);
  const Eigen::Map<const Eigen::VectorXd> velocities(params.velocities.data(), count);
  const Eigen::VectorXd modal_positions = shapes.transpose() * (mass * positions);
  const Eigen::VectorXd modal_velocities = shapes.transpose() * (mass * velocities);

  normal_mode_solution solution;
  solution.masses_ = params.masses_count();
  for (Eigen::Index k = 0; k < count; ++k) {
    const double frequency_squared = solver.eigenvalues()(k);
    if (!(frequency_squared > 0.0)) throw std::runtime_error("a chain fixed at one end must have positive frequencies");
    normal_mode mode;
    mode.angular_frequency = std::sqrt(frequency_squared);
    const double a = modal_positions(k);
    const double b = modal_velocities(k) / mode.angular_frequency;
    for (Eigen::Index j = 0; j < count; ++j) {
      mode.cos_part.push_back(shapes(j, k) * a);
      mode.sin_part.push_back(shapes(j, k) * b);
    }
    solution.modes_.push_back(std::move(mode));
  }
  return solution;
}

std::vector<double> normal_mode_solution::state_at(double time) const {
  std::vector<double> state(2 * masses_);
  state_at(time, state);
  return state;
}

void normal_mode_solution::state_at(double time, std::span<double> state) const {
  assert(state.size() == 2 * masses_);
  for (double& value : state) value = 0.0;
  for (const normal_mode& mode : modes_) {
    const double frequency = mode.angular_frequency;
    const double cosine = std::cos(frequency * time);
    const double sine = std::sin(frequency * time);
    for (std::size_t j = 0; j < masses_; ++j) {
      state[j] += mode.cos_part[j] * cosine + mode.sin_part[j] * sine;
      state[masses_ + j] += frequency * (mode.sin_part[j] * cosine - mode.cos_part[j] * sine);
    }
  }
}

}  // namespace lockstep::kernels
