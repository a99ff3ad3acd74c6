#include "kernels/dopri5_reference.hpp"

#include <boost/numeric/odeint.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace lockstep::kernels {

dopri5_run dopri5_solve(const chain_model& model, std::span<const double> times, const dopri5_observer& observer,
                        double tolerance) {
  namespace odeint = boost::numeric::odeint;
  using state_type = std::vector<double>;
  if (times.empty()) throw std::invalid_argument("dopri5_solve needs at least one time");
  if (!std::is_sorted(times.begin(), times.end())) throw std::invalid_argument("dopri5_solve needs ascending times");
  if (!(tolerance > 0.0)) throw std::invalid_argument("dopri5_solve needs a positive tolerance");

  const std::size_t equations = model.equations();
  const auto system = [&model, equations](const state_type& x, state_type& derivative, double /*time*/) {
    for (std::size_t equation = 0; equation < equations; ++equation) {
      derivative[equation] = model.derivative(equation, x.data());
    }
  };

  dopri5_run run;
  run.tolerance = tolerance;
  std::size_t index = 0;
  const auto record = [&](const state_type& x, double /*time*/) {
    for (double value : x) run.max_abs_state = std::max(run.max_abs_state, std::abs(value));
    if (observer) observer(index, x);
    ++index;
  };

  state_type state = model.initial_state();
  auto stepper = odeint::make_controlled(tolerance, tolerance, odeint::runge_kutta_dopri5<state_type>());
  // The first trial step; odeint shrinks it at once if it is too large.
  const double span = times.back() - times.front();
  const double first_step = span > 0.0 ? span / 1000.0 : 1e-3;
  run.steps = odeint::integrate_times(stepper, system, state, times.begin(), times.end(), first_step, record);
  return run;
}

}  // namespace lockstep::kernels
