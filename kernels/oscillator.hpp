#pragma once
// The coupled harmonic oscillator of Al-Oraiqat ("Parallel implementation of
// the coupled harmonic oscillator", IJEST) in first-order form, as the
// per-equation derivative functions that the staged RK4 (rk4.hpp) and the
// parallel step evaluate.
//
// Two models, one contract (oscillator_model below):
//
//  * two_mass_model: the paper's eq. (2),
//        m1 x1'' + C1 x1 - C2 (x2 - x1) = 0,   m2 x2'' + C2 (x2 - x1) = 0,
//    with x3 = x1', x4 = x2' (the paper's D(1)..D(4)):
//        D1 = x3                       reads x3
//        D2 = x4                       reads x4
//        D3 = (C2 (x2 - x1) - C1 x1)/m1 reads x1, x2
//        D4 = C2 (x1 - x2) / m2         reads x1, x2
//
//  * chain_model: the paper's eq. (1), M x'' + K x = 0, for s masses in a line,
//    the first tied to a fixed wall by spring C_1, mass j tied to mass j-1 by
//    spring C_j, the last mass free. 2s equations: positions first, then
//    velocities (for s = 2 this is exactly the two-mass numbering).
//        D_j     = x_{s+j}                                       reads x_{s+j}
//        D_{s+j} = (C_j (x_{j-1} - x_j) + C_{j+1} (x_{j+1} - x_j)) / m_j
//                                                 reads x_{j-1}, x_j, x_{j+1}
//    (x_0 is the wall, C_{s+1} does not exist: the tridiagonal neighbours).
//
// The paper's case (the defaults): m1 = m2 = m, C1 = C2 = C, C/m = 1012.5 s^-2,
// x1(0) = 2, x2(0) = -3, velocities 0. The paper prints m = 2 g and
// C = 20,25 kN/M; in SI units those would give C/m = 20250 / 0.002 = 1.0e7 s^-2,
// whose roots (about 5.1e3 rad/s) are not the ones the paper prints. The roots
// it prints, ±51.47j and ±19.66j rad/s, fix C/m at 1012.5 s^-2 (to the paper's
// rounding), so lockstep takes m = 0.02 kg and C = 20.25 N/m: the paper's
// digits, with the ratio its own roots imply (docs/design.md, The workload).
//
// Cost: the derivative is on the measured path of every benchmark. It is
// allocation-free, reads only the stage inputs it depends on, and uses
// coefficients (C/m) divided once at construction, so an evaluation is at most
// two subtractions, two multiplications and one addition.
//
// Floating-point contract: every function here is a fixed sequence of IEEE
// operations on its inputs (lockstep::kernels is compiled with
// -ffp-contract=off, so no fused multiply-add changes the rounding). The same
// inputs give the same bits on any thread, which is what makes the parallel
// step bitwise identical to the serial one.
#include <array>
#include <cassert>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace lockstep::kernels {

// Something a derivative can read stage inputs from by equation index:
// a pointer, std::array, std::vector, std::span, or a view that computes the
// stage input on demand (rk4_stage_inputs in rk4.hpp).
template <class Values>
concept stage_values = requires(const Values& values, std::size_t equation) {
  { values[equation] } -> std::convertible_to<double>;
};

// The equations one equation reads (at most three in every model here).
// A dataflow synchronisation waits only for the producers of these.
struct dependency_set {
  static constexpr std::size_t kCapacity = 3;
  std::array<std::size_t, kCapacity> equations{};
  std::size_t count = 0;

  [[nodiscard]] const std::size_t* begin() const noexcept { return equations.data(); }
  [[nodiscard]] const std::size_t* end() const noexcept { return equations.data() + count; }
  [[nodiscard]] std::size_t size() const noexcept { return count; }
  [[nodiscard]] bool contains(std::size_t equation) const noexcept {
    for (std::size_t dependency : *this) {
      if (dependency == equation) return true;
    }
    return false;
  }
  friend bool operator==(const dependency_set& a, const dependency_set& b) noexcept {
    if (a.count != b.count) return false;
    for (std::size_t index = 0; index < a.count; ++index) {
      if (a.equations[index] != b.equations[index]) return false;
    }
    return true;
  }
};

// What the staged RK4 and the parallel step need from a model.
//   equations()            the number of first-order equations n (state size)
//   derivative(i, y)       D_i evaluated at the stage inputs y (reads only dependencies(i))
//   dependencies(i)        the equations D_i reads, ascending
//   initial_state()        x(0), n values
//   energy(x)              kinetic + potential energy of state x (J)
template <class Model>
concept oscillator_model = std::copy_constructible<Model> &&
    requires(const Model& model, std::size_t equation, const double* values, std::span<const double> state) {
      { model.equations() } -> std::convertible_to<std::size_t>;
      { model.derivative(equation, values) } -> std::same_as<double>;
      { model.dependencies(equation) } -> std::same_as<dependency_set>;
      { model.initial_state() } -> std::same_as<std::vector<double>>;
      { model.energy(state) } -> std::same_as<double>;
    };

// ---------------------------------------------------------------------------
// The paper's two masses.

// Masses (kg), springs (N/m) and the initial state. The defaults are the
// paper's case (see the top of this file for where 0.02 kg and 20.25 N/m come from).
struct two_mass_params {
  static constexpr double kPaperMass = 0.02;         // kg
  static constexpr double kPaperSpring = 20.25;      // N/m; C/m = 1012.5 s^-2
  static constexpr double kPaperSpringOverMass = 1012.5;  // s^-2, fixed by the paper's roots

  double m1 = kPaperMass;
  double m2 = kPaperMass;
  double c1 = kPaperSpring;
  double c2 = kPaperSpring;
  double x1 = 2.0;   // x1(0), m
  double x2 = -3.0;  // x2(0), m
  double v1 = 0.0;   // x1'(0) = x3(0), m/s
  double v2 = 0.0;   // x2'(0) = x4(0), m/s

  // Empty when the parameters describe an oscillator; otherwise one line that
  // says which value is wrong ("m1 must be a positive finite number, got -1").
  [[nodiscard]] std::string invalid_reason() const;

  // The paper's case exactly (equal masses, equal springs, C/m = 1012.5 s^-2)?
  // Only then are the paper's printed roots the ones to compare with.
  [[nodiscard]] bool is_papers_case() const noexcept;
};

class two_mass_model {
 public:
  static constexpr std::size_t kEquations = 4;

  // Throws std::invalid_argument with invalid_reason() when the parameters
  // are not an oscillator.
  explicit two_mass_model(const two_mass_params& params = {})
      : params_(checked(params)),
        c1_over_m1_(params.c1 / params.m1),
        c2_over_m1_(params.c2 / params.m1),
        c2_over_m2_(params.c2 / params.m2) {}

  [[nodiscard]] static constexpr std::size_t equations() noexcept { return kEquations; }

  // D1..D4 (equation 0..3) one at a time, for a thread that owns one equation.
  // y holds the stage inputs y1..y4 (0-based); each reads only its dependencies.
  template <stage_values Values>
  [[nodiscard]] static double d1(const Values& y) noexcept { return y[2]; }
  template <stage_values Values>
  [[nodiscard]] static double d2(const Values& y) noexcept { return y[3]; }
  template <stage_values Values>
  [[nodiscard]] double d3(const Values& y) const noexcept {
    const double y1 = y[0];
    const double y2 = y[1];
    // Operation order fixed: (C2/m1)(y2 - y1) - (C1/m1) y1.
    return c2_over_m1_ * (y2 - y1) - c1_over_m1_ * y1;
  }
  template <stage_values Values>
  [[nodiscard]] double d4(const Values& y) const noexcept {
    const double y1 = y[0];
    const double y2 = y[1];
    return c2_over_m2_ * (y1 - y2);
  }

  // D_{equation+1} at the stage inputs y: the same operations as d1..d4.
  template <stage_values Values>
  [[nodiscard]] double derivative(std::size_t equation, const Values& y) const noexcept {
    switch (equation) {
      case 0: return d1(y);
      case 1: return d2(y);
      case 2: return d3(y);
      case 3: return d4(y);
      default: break;
    }
    assert(false && "two_mass_model has equations 0..3");
    return std::numeric_limits<double>::quiet_NaN();
  }

  // D1 <- x3, D2 <- x4, D3 <- x1, x2, D4 <- x1, x2 (0-based indices).
  [[nodiscard]] static dependency_set dependencies(std::size_t equation) noexcept {
    switch (equation) {
      case 0: return {{2, 0, 0}, 1};
      case 1: return {{3, 0, 0}, 1};
      case 2: return {{0, 1, 0}, 2};
      case 3: return {{0, 1, 0}, 2};
      default: break;
    }
    assert(false && "two_mass_model has equations 0..3");
    return {};
  }

  [[nodiscard]] std::vector<double> initial_state() const {
    return {params_.x1, params_.x2, params_.v1, params_.v2};
  }

  // 1/2 m1 x3^2 + 1/2 m2 x4^2 + 1/2 C1 x1^2 + 1/2 C2 (x2 - x1)^2.
  [[nodiscard]] double energy(std::span<const double> state) const noexcept {
    assert(state.size() == kEquations);
    const double stretch = state[1] - state[0];
    return 0.5 * (params_.m1 * state[2] * state[2] + params_.m2 * state[3] * state[3] +
                  params_.c1 * state[0] * state[0] + params_.c2 * stretch * stretch);
  }

  [[nodiscard]] const two_mass_params& params() const noexcept { return params_; }

 private:
  static const two_mass_params& checked(const two_mass_params& params) {
    if (auto reason = params.invalid_reason(); !reason.empty()) throw std::invalid_argument(reason);
    return params;
  }

  two_mass_params params_;
  double c1_over_m1_;
  double c2_over_m1_;
  double c2_over_m2_;
};

// ---------------------------------------------------------------------------
// s masses in a chain fixed at one end (eq. (1)).

struct chain_params {
  std::vector<double> masses;      // m_1..m_s, kg
  std::vector<double> springs;     // C_1..C_s, N/m; C_1 ties mass 1 to the wall
  std::vector<double> positions;   // x_j(0), m
  std::vector<double> velocities;  // x_j'(0), m/s

  // s equal masses and springs (the paper's by default), displaced like the
  // paper's two masses: 2, -3, 2, -3, ... m, at rest.
  [[nodiscard]] static chain_params uniform(std::size_t masses_count,
                                            double mass = two_mass_params::kPaperMass,
                                            double spring = two_mass_params::kPaperSpring);
  // The two-mass parameters as a chain of two.
  [[nodiscard]] static chain_params from_two_mass(const two_mass_params& params);

  [[nodiscard]] std::size_t masses_count() const noexcept { return masses.size(); }
  [[nodiscard]] std::string invalid_reason() const;
};

class chain_model {
 public:
  // Throws std::invalid_argument with invalid_reason() when the parameters
  // are not an oscillator.
  explicit chain_model(chain_params params);

  [[nodiscard]] std::size_t equations() const noexcept { return 2 * masses_; }
  [[nodiscard]] std::size_t masses_count() const noexcept { return masses_; }

  // D_{equation+1} at the stage inputs y. For s = 2 it performs exactly the
  // operations of two_mass_model::derivative (same bits).
  template <stage_values Values>
  [[nodiscard]] double derivative(std::size_t equation, const Values& y) const noexcept {
    assert(equation < 2 * masses_);
    if (equation < masses_) return y[masses_ + equation];
    const std::size_t mass = equation - masses_;
    const double here = y[mass];
    const double left_over_mass = left_over_mass_[mass];
    const double right_over_mass = right_over_mass_[mass];
    // Operation order fixed, and chosen so that s = 2 reproduces two_mass_model:
    //   first mass:   (C_2/m_1)(y_2 - y_1) - (C_1/m_1) y_1       (the wall is at 0)
    //   middle mass:  (C_j/m_j)(y_{j-1} - y_j) + (C_{j+1}/m_j)(y_{j+1} - y_j)
    //   last mass:    (C_s/m_s)(y_{s-1} - y_s)
    //   single mass:  -(C_1/m_1) y_1
    if (mass == 0) {
      if (masses_ == 1) return -(left_over_mass * here);
      return right_over_mass * (y[1] - here) - left_over_mass * here;
    }
    const double from_left = left_over_mass * (y[mass - 1] - here);
    if (mass + 1 == masses_) return from_left;
    return from_left + right_over_mass * (y[mass + 1] - here);
  }

  // Positions read their velocity; velocity j reads positions j-1, j, j+1
  // (those that exist), ascending.
  [[nodiscard]] dependency_set dependencies(std::size_t equation) const noexcept {
    assert(equation < 2 * masses_);
    dependency_set set;
    if (equation < masses_) {
      set.equations[set.count++] = masses_ + equation;
      return set;
    }
    const std::size_t mass = equation - masses_;
    if (mass > 0) set.equations[set.count++] = mass - 1;
    set.equations[set.count++] = mass;
    if (mass + 1 < masses_) set.equations[set.count++] = mass + 1;
    return set;
  }

  [[nodiscard]] std::vector<double> initial_state() const;
  [[nodiscard]] double energy(std::span<const double> state) const noexcept;
  [[nodiscard]] const chain_params& params() const noexcept { return params_; }

 private:
  chain_params params_;
  std::size_t masses_;
  std::vector<double> left_over_mass_;   // C_j / m_j
  std::vector<double> right_over_mass_;  // C_{j+1} / m_j (0 for the last mass)
};

// The equations outside [first, last) that the block [first, last) reads:
// what a thread owning that block must receive before each stage. Ascending,
// no duplicates. Not on the measured path (allocates).
template <oscillator_model Model>
[[nodiscard]] std::vector<std::size_t> block_dependencies(const Model& model, std::size_t first,
                                                          std::size_t last) {
  std::vector<bool> needed(model.equations(), false);
  for (std::size_t equation = first; equation < last; ++equation) {
    for (std::size_t dependency : model.dependencies(equation)) {
      if (dependency < first || dependency >= last) needed[dependency] = true;
    }
  }
  std::vector<std::size_t> result;
  for (std::size_t equation = 0; equation < needed.size(); ++equation) {
    if (needed[equation]) result.push_back(equation);
  }
  return result;
}

static_assert(oscillator_model<two_mass_model>);
static_assert(oscillator_model<chain_model>);

}  // namespace lockstep::kernels
