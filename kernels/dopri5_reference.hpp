#pragma once
// The independent numerical reference: Boost.Odeint's Dormand-Prince 5(4)
// (runge_kutta_dopri5, the method of MATLAB's ode45, which the paper used),
// adaptive, with tight tolerances.
//
// It integrates the same first-order system (the chain model's derivative; a
// two-mass system is the chain of two, bit for bit) but shares nothing else
// with the staged RK4: other stages, other weights, its own step control.
// Not on a measured path; allocates freely.
#include <cstddef>
#include <functional>
#include <span>
#include <vector>

#include "kernels/oscillator.hpp"

namespace lockstep::kernels {

struct dopri5_run {
  std::size_t steps = 0;       // accepted steps
  double tolerance = 0.0;      // absolute and relative error tolerance per step
  double max_abs_state = 0.0;  // the largest |state component| seen at the requested times
};

// Called at every requested time with its index and the state (positions, velocities).
using dopri5_observer = std::function<void(std::size_t index, std::span<const double> state)>;

inline constexpr double kDopri5Tolerance = 1e-12;

// Integrates from the model's initial state at times.front() (ascending
// times) and hands the state at every time to the observer. The controlled
// stepper accepts a step when its error estimate e_i satisfies, for every
// component, |e_i| <= tolerance (1 + |x_i| + h |x_i'|) (odeint's default
// error checker with equal absolute and relative tolerances).
dopri5_run dopri5_solve(const chain_model& model, std::span<const double> times, const dopri5_observer& observer,
                        double tolerance = kDopri5Tolerance);

}  // namespace lockstep::kernels
