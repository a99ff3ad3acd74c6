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
//    spring C_j, the last mass free. 2s equations, numbered mass by mass: the
//    position of mass j (1-based) is equation 2j-1, its velocity equation 2j
//    (0-based: 2(j-1) and 2(j-1)+1), so the state reads x_1, v_1, x_2, v_2, ...
//        D_{2j-1} = v_j                                          reads v_j
//        D_{2j}   = (C_j (x_{j-1} - x_j) + C_{j+1} (x_{j+1} - x_j)) / m_j
//                                                 reads x_{j-1}, x_j, x_{j+1}
//    (x_0 is the wall, C_{s+1} does not exist: the tridiagonal neighbours).
//    Why mass by mass and not the two-mass numbering (positions, then
//    velocities): a contiguous run of equations is then a run of whole masses,
//    so a participant that owns a block of equations owns its masses'
//    positions and velocities, computes both, and reads from its neighbours
//    only the two positions at its block's ends (layouts/partition.hpp cuts
//    chains between masses). In the two-mass numbering the same ownership is
//    two ranges per participant, and every layout, channel message and MPI
//    window would have to handle two; a contiguous block stays one range for
//    all of them and for the step's loop. The arithmetic of every equation is
//    the same in either numbering; only the index of each value changes
//    (position_equation, velocity_equation).
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
// two subtractions, two multiplications and one addition. A block of
// equations is evaluated by evaluate_derivatives (below): the chain's
// derivatives() walks whole masses without a branch per equation; every
// value is the one derivative() gives, bit for bit.
//
// Floating-point contract: every function here is a fixed sequence of IEEE
// operations on its inputs (lockstep::kernels is compiled with
// -ffp-contract=off, so no fused multiply-add changes the rounding). The same
// inputs give the same bits on any thread, which is what makes the parallel
// step bitwise identical to the serial one.
#include <algorithm>
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
//   block_grain()          how many consecutive equations one owner keeps
//                          together when the participants are no more than
//                          n / block_grain() (layouts/partition.hpp): 1 for
//                          the paper's two masses (split one equation per
//                          thread, as the paper does), 2 for a chain (a
//                          mass's position and velocity); it must divide n
//   initial_state()        x(0), n values
//   energy(x)              kinetic + potential energy of state x (J)
// Optional: derivatives(first, last, y, out), out[i - first] = D_i(y) for i in
// [first, last), the same bits as derivative(i, y) (evaluate_derivatives
// calls it when the model has it, else derivative() one equation at a time).
template <class Model>
concept oscillator_model = std::copy_constructible<Model> &&
    requires(const Model& model, std::size_t equation, const double* values, std::span<const double> state) {
      { model.equations() } -> std::convertible_to<std::size_t>;
      { model.derivative(equation, values) } -> std::same_as<double>;
      { model.dependencies(equation) } -> std::same_as<dependency_set>;
      { model.block_grain() } -> std::convertible_to<std::size_t>;
      { model.initial_state() } -> std::same_as<std::vector<double>>;
      { model.energy(state) } -> std::same_as<double>;
    };

// out[i - first] = D_i(y) for every i in [first, last): the model's own block
// evaluation when it has one (derivatives()), else derivative() per equation.
// The staged RK4 and the parallel step both evaluate through here, so they
// spend the same per equation.
template <class Model, stage_values Values>
inline void evaluate_derivatives(const Model& model, std::size_t first, std::size_t last, const Values& y,
                                 double* out) noexcept {
  if constexpr (requires { model.derivatives(first, last, y, out); }) {
    model.derivatives(first, last, y, out);
  } else {
    for (std::size_t equation = first; equation < last; ++equation) out[equation - first] = model.derivative(equation, y);
  }
}

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
  // Split one equation at a time, as the paper splits its four over 1..4 threads.
  [[nodiscard]] static constexpr std::size_t block_grain() noexcept { return 1; }
  // Where mass `mass` (0 or 1) has its position and velocity: x1, x2, x3 = x1', x4 = x2'.
  [[nodiscard]] static constexpr std::size_t position_equation(std::size_t mass) noexcept { return mass; }
  [[nodiscard]] static constexpr std::size_t velocity_equation(std::size_t mass) noexcept { return 2 + mass; }

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
  // A mass's position and velocity stay with one owner (its two equations).
  [[nodiscard]] static constexpr std::size_t block_grain() noexcept { return 2; }
  // Where mass `mass` (0-based) has its position and velocity: mass by mass.
  [[nodiscard]] static constexpr std::size_t position_equation(std::size_t mass) noexcept { return 2 * mass; }
  [[nodiscard]] static constexpr std::size_t velocity_equation(std::size_t mass) noexcept { return 2 * mass + 1; }

  // D_{equation+1} at the stage inputs y. For s = 2 it performs exactly the
  // operations of two_mass_model::derivative (same bits, other indices).
  template <stage_values Values>
  [[nodiscard]] double derivative(std::size_t equation, const Values& y) const noexcept {
    assert(equation < 2 * masses_);
    if (equation % 2 == 0) return y[equation + 1];
    const std::size_t mass = equation / 2;
    const double here = y[position_equation(mass)];
    const double left_over_mass = left_over_mass_[mass];
    const double right_over_mass = right_over_mass_[mass];
    // Operation order fixed, and chosen so that s = 2 reproduces two_mass_model:
    //   first mass:   (C_2/m_1)(y_2 - y_1) - (C_1/m_1) y_1       (the wall is at 0)
    //   middle mass:  (C_j/m_j)(y_{j-1} - y_j) + (C_{j+1}/m_j)(y_{j+1} - y_j)
    //   last mass:    (C_s/m_s)(y_{s-1} - y_s)
    //   single mass:  -(C_1/m_1) y_1
    // (y_j: the position of mass j); middle_velocity holds the middle case.
    if (mass == 0) {
      if (masses_ == 1) return -(left_over_mass * here);
      return right_over_mass * (y[position_equation(1)] - here) - left_over_mass * here;
    }
    if (mass + 1 == masses_) return left_over_mass * (y[position_equation(mass - 1)] - here);
    return middle_velocity(left_over_mass, right_over_mass, y[position_equation(mass - 1)], here,
                           y[position_equation(mass + 1)]);
  }

  // out[i - first] = derivative(i, y) for i in [first, last), bit for bit,
  // without a branch per equation: the masses strictly inside the chain and
  // wholly inside [first, last) go through one loop (the middle-mass
  // formula); a block's partial masses (a block may start on a velocity or
  // end on a position when there are more participants than masses) and the
  // chain's two end masses go through derivative().
  template <stage_values Values>
  void derivatives(std::size_t first, std::size_t last, const Values& y, double* out) const noexcept {
    assert(first <= last && last <= 2 * masses_);
    // Whole masses [whole_first, whole_last) of the block, then those of them
    // strictly inside the chain (masses 1 .. s-2).
    const std::size_t whole_first = (first + 1) / 2;
    const std::size_t whole_last = last / 2;
    const std::size_t inner_first = std::max<std::size_t>(whole_first, 1);
    const std::size_t inner_last = std::min(whole_last, masses_ - 1);
    if (inner_first >= inner_last) {
      for (std::size_t equation = first; equation < last; ++equation) out[equation - first] = derivative(equation, y);
      return;
    }
    for (std::size_t equation = first; equation < 2 * inner_first; ++equation)
      out[equation - first] = derivative(equation, y);
    for (std::size_t mass = inner_first; mass < inner_last; ++mass) {
      out[2 * mass - first] = y[2 * mass + 1];
      out[2 * mass + 1 - first] =
          middle_velocity(left_over_mass_[mass], right_over_mass_[mass], y[2 * mass - 2], y[2 * mass], y[2 * mass + 2]);
    }
    for (std::size_t equation = 2 * inner_last; equation < last; ++equation)
      out[equation - first] = derivative(equation, y);
  }

  // Positions read their velocity; velocity j reads positions j-1, j, j+1
  // (those that exist), ascending.
  [[nodiscard]] dependency_set dependencies(std::size_t equation) const noexcept {
    assert(equation < 2 * masses_);
    dependency_set set;
    if (equation % 2 == 0) {
      set.equations[set.count++] = equation + 1;
      return set;
    }
    const std::size_t mass = equation / 2;
    if (mass > 0) set.equations[set.count++] = position_equation(mass - 1);
    set.equations[set.count++] = position_equation(mass);
    if (mass + 1 < masses_) set.equations[set.count++] = position_equation(mass + 1);
    return set;
  }

  [[nodiscard]] std::vector<double> initial_state() const;
  [[nodiscard]] double energy(std::span<const double> state) const noexcept;
  [[nodiscard]] const chain_params& params() const noexcept { return params_; }

 private:
  // The middle-mass velocity derivative, in derivative()'s operation order.
  [[nodiscard]] static double middle_velocity(double left_over_mass, double right_over_mass, double left, double here,
                                              double right) noexcept {
    const double from_left = left_over_mass * (left - here);
    return from_left + right_over_mass * (right - here);
  }

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
