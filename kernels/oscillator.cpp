#include "kernels/oscillator.hpp"

#include <fmt/core.h>

#include <utility>

namespace lockstep::kernels {
namespace {

// Empty when value is a positive finite number; otherwise the complaint.
std::string positive_finite_reason(const std::string& name, double value) {
  if (std::isfinite(value) && value > 0.0) return {};
  return fmt::format("{} must be a positive finite number, got {}", name, value);
}

std::string finite_reason(const std::string& name, double value) {
  if (std::isfinite(value)) return {};
  return fmt::format("{} must be a finite number, got {}", name, value);
}

}  // namespace

std::string two_mass_params::invalid_reason() const {
  for (const auto& [name, value] : {std::pair{"m1", m1}, {"m2", m2}, {"c1", c1}, {"c2", c2}}) {
    if (auto reason = positive_finite_reason(name, value); !reason.empty()) return reason;
  }
  for (const auto& [name, value] : {std::pair{"x1(0)", x1}, {"x2(0)", x2}, {"v1(0)", v1}, {"v2(0)", v2}}) {
    if (auto reason = finite_reason(name, value); !reason.empty()) return reason;
  }
  return {};
}

bool two_mass_params::is_papers_case() const noexcept {
  const auto close = [](double a, double b) { return std::abs(a - b) <= 1e-12 * std::abs(b); };
  return close(m1, m2) && close(c1, c2) && close(c1 / m1, kPaperSpringOverMass) && x1 == 2.0 && x2 == -3.0 &&
         v1 == 0.0 && v2 == 0.0;
}

chain_params chain_params::uniform(std::size_t masses_count, double mass, double spring) {
  chain_params params;
  params.masses.assign(masses_count, mass);
  params.springs.assign(masses_count, spring);
  params.velocities.assign(masses_count, 0.0);
  params.positions.resize(masses_count);
  for (std::size_t index = 0; index < masses_count; ++index) params.positions[index] = index % 2 == 0 ? 2.0 : -3.0;
  return params;
}

chain_params chain_params::from_two_mass(const two_mass_params& params) {
  return {{params.m1, params.m2}, {params.c1, params.c2}, {params.x1, params.x2}, {params.v1, params.v2}};
}

std::string chain_params::invalid_reason() const {
  const std::size_t count = masses.size();
  if (count == 0) return "a chain needs at least one mass";
  if (springs.size() != count || positions.size() != count || velocities.size() != count) {
    return fmt::format("a chain of {} masses needs {} springs, positions and velocities (got {}, {}, {})", count,
                       count, springs.size(), positions.size(), velocities.size());
  }
  for (std::size_t index = 0; index < count; ++index) {
    if (auto reason = positive_finite_reason(fmt::format("m{}", index + 1), masses[index]); !reason.empty()) {
      return reason;
    }
    if (auto reason = positive_finite_reason(fmt::format("c{}", index + 1), springs[index]); !reason.empty()) {
      return reason;
    }
    if (auto reason = finite_reason(fmt::format("x{}(0)", index + 1), positions[index]); !reason.empty()) {
      return reason;
    }
    if (auto reason = finite_reason(fmt::format("v{}(0)", index + 1), velocities[index]); !reason.empty()) {
      return reason;
    }
  }
  return {};
}

chain_model::chain_model(chain_params params) : params_(std::move(params)), masses_(params_.masses.size()) {
  if (auto reason = params_.invalid_reason(); !reason.empty()) throw std::invalid_argument(reason);
  left_over_mass_.resize(masses_);
  right_over_mass_.resize(masses_);
  for (std::size_t mass = 0; mass < masses_; ++mass) {
    left_over_mass_[mass] = params_.springs[mass] / params_.masses[mass];
    right_over_mass_[mass] = mass + 1 < masses_ ? params_.springs[mass + 1] / params_.masses[mass] : 0.0;
  }
}

std::vector<double> chain_model::initial_state() const {
  std::vector<double> state(2 * masses_);
  for (std::size_t mass = 0; mass < masses_; ++mass) {
    state[position_equation(mass)] = params_.positions[mass];
    state[velocity_equation(mass)] = params_.velocities[mass];
  }
  return state;
}

double chain_model::energy(std::span<const double> state) const noexcept {
  assert(state.size() == 2 * masses_);
  double kinetic = 0.0;
  double potential = 0.0;
  for (std::size_t mass = 0; mass < masses_; ++mass) {
    const double velocity = state[velocity_equation(mass)];
    const double stretch = state[position_equation(mass)] - (mass == 0 ? 0.0 : state[position_equation(mass - 1)]);
    kinetic += params_.masses[mass] * velocity * velocity;
    potential += params_.springs[mass] * stretch * stretch;
  }
  return 0.5 * (kinetic + potential);
}

}  // namespace lockstep::kernels
