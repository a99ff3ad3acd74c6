#pragma once
// The analytic reference: the normal-mode solution of M x'' + K x = 0.
//
// Every undamped linear oscillator is a sum of independent modes,
//     x(t) = sum_k phi_k (a_k cos(w_k t) + b_k sin(w_k t)),
// where w_k^2 and phi_k solve the generalized eigenproblem K phi = w^2 M phi
// and a_k, b_k come from x(0) and x'(0). Two ways to get them:
//
//  * two masses, closed form: det(K - w^2 M) = 0 is the quadratic
//        m1 m2 w^4 - (m1 C2 + m2 (C1 + C2)) w^2 + C1 C2 = 0
//    (the paper's m^2 l^4 + 3 m C l^2 + C^2 = 0 with l = ±j w when the masses
//    and springs are equal: w^2 = (C/m)(3 ± sqrt 5)/2), solved without
//    cancellation, with mode shapes (1, C2 / (C2 - w^2 m2));
//  * s masses: Eigen's GeneralizedSelfAdjointEigenSolver on the chain's
//    tridiagonal K and diagonal M (modes M-orthonormal).
//
// Not on a measured path; allocates freely.
#include <cstddef>
#include <span>
#include <vector>

#include "kernels/oscillator.hpp"

namespace lockstep::kernels {

// The two angular frequencies of the two-mass system, rad/s (the roots are ±j w).
struct two_mass_frequencies {
  double slow = 0.0;  // the in-phase mode
  double fast = 0.0;  // the out-of-phase mode
};

// Closed form, from the quadratic above (stable: the smaller root of w^2 is
// taken as the product of the roots over the larger).
[[nodiscard]] two_mass_frequencies two_mass_angular_frequencies(const two_mass_params& params);

// The paper's equal-mass, equal-spring formula w = sqrt(C/m (3 ± sqrt 5)/2),
// for one value of C/m (s^-2).
[[nodiscard]] two_mass_frequencies equal_two_mass_angular_frequencies(double spring_over_mass);

// One normal mode: its angular frequency and its contribution to each position,
// shape_i * (a cos(w t) + b sin(w t)) = cos_part[i] cos(w t) + sin_part[i] sin(w t).
struct normal_mode {
  double angular_frequency = 0.0;  // rad/s
  std::vector<double> cos_part;    // phi_i a, m
  std::vector<double> sin_part;    // phi_i b, m
  // sqrt(a^2 + b^2) * |phi_i|: the amplitude of this mode in position i, m.
  [[nodiscard]] double amplitude(std::size_t position) const;
};

class normal_mode_solution {
 public:
  // Closed form for the paper's two masses.
  [[nodiscard]] static normal_mode_solution two_mass(const two_mass_params& params);
  // Eigen's generalized self-adjoint eigensolver, for any chain (s >= 1).
  [[nodiscard]] static normal_mode_solution chain(const chain_params& params);

  [[nodiscard]] std::size_t masses_count() const noexcept { return masses_; }
  // Modes in ascending angular frequency.
  [[nodiscard]] const std::vector<normal_mode>& modes() const noexcept { return modes_; }

  // The state at time t: the positions, then the velocities (the two-mass
  // model's numbering; a chain numbers mass by mass, chain_model::position_equation).
  [[nodiscard]] std::vector<double> state_at(double time) const;
  void state_at(double time, std::span<double> state) const;

 private:
  std::size_t masses_ = 0;
  std::vector<normal_mode> modes_;
};

}  // namespace lockstep::kernels
