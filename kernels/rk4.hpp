#pragma once
// The classical fourth-order Runge-Kutta step, written as four explicit stages
// over per-equation derivatives, so that one thread can compute one equation
// (or one block of equations) of a stage and the parallel result is bitwise
// identical to the serial one.
//
// One step of size h from x (n equations, 0-based stages s = 0..3):
//
//     stage input   y_{s,j} = x_j                          for s = 0
//                   y_{s,j} = x_j + (c_s h) k_{s-1,j}      for s = 1, 2, 3
//                                with c_s h = h/2, h/2, h  (rk4_stage_input)
//     stage value   k_{s,i} = D_i(y_s)                     (model.derivative)
//     update        x_i    <- x_i + (h/6) (((k_{0,i} + 2 k_{1,i}) + 2 k_{2,i}) + k_{3,i})
//                                                          (rk4_update)
//
// Bitwise determinism, the correctness oracle of every parallel combination
// (docs/design.md, The determinism oracle): the three functions below are the ONLY arithmetic
// of a step besides the model's derivative. Each is a fixed sequence of IEEE
// double operations in the order written above:
//   * c_s h is computed once per step size (rk4_coefficients): h * 0.5 (exact)
//     and h; h/6 is computed once as h / 6.0. Never recompute them per thread
//     in another way (h / 2 and h * 0.5 agree, h / 6 and h * (1.0 / 6) do not).
//   * stage 0 performs no arithmetic (y = x exactly, even for -0.0 or when the
//     previous k is garbage or infinite).
//   * lockstep::kernels is compiled with -ffp-contract=off: no fused
//     multiply-add may merge x + (c h) k or x + (h/6) sum, whichever
//     translation unit inlines these functions.
// A parallel step that feeds these functions the same x and k values, and
// calls model.derivative(i, y) with y holding the same stage inputs (computed
// by rk4_stage_input, by whichever thread), produces the same bits as
// staged_rk4 below. Where a stage input is computed (by its producer once, or
// by each consumer) does not matter: the same inputs give the same result.
//
// For a thread that owns a block of equations, the pattern per step is:
//     for s in 0..3:
//         for i in block and block_dependencies(model, first, last):
//             y[i] = rk4_stage_input(coefficients, s, x[i], k[s-1][i])
//         k[s][block] = evaluate_derivatives(model, first, last, y)
//         publish k[s][block]; synchronise (all threads, or the producers of
//         block_dependencies(model, first, last))
//     for i in block: x[i] = rk4_update(coefficients, x[i], k[0][i], k[1][i], k[2][i], k[3][i])
// where x and k[s-1] are read through the layout (kernels/parallel_step.hpp).
// rk4_stage_inputs below computes y on demand instead, for a caller that
// reads a few inputs once each.
#include <array>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

#include "kernels/oscillator.hpp"

namespace lockstep::kernels {

inline constexpr unsigned kRk4Stages = 4;

// The step size and the products of it that the stages use, computed once so
// that every thread uses the same bits.
class rk4_coefficients {
 public:
  // Throws std::invalid_argument unless the step is positive and finite.
  explicit rk4_coefficients(double step)
      : step_(checked(step)), half_step_(step * 0.5), sixth_step_(step / 6.0) {}

  [[nodiscard]] double step() const noexcept { return step_; }
  // c_s h for s = 0..3: 0, h/2, h/2, h (the classical RK4 nodes).
  [[nodiscard]] double stage_scale(unsigned stage) const noexcept {
    assert(stage < kRk4Stages);
    return stage == 0 ? 0.0 : (stage == 3 ? step_ : half_step_);
  }
  // h/6, the weight of k_0 and k_3 in the update (k_1 and k_2 enter doubled).
  [[nodiscard]] double sixth_step() const noexcept { return sixth_step_; }

 private:
  static double checked(double step) {
    if (!(step > 0.0) || !std::isfinite(step)) throw std::invalid_argument("the RK4 step must be positive and finite");
    return step;
  }

  double step_;
  double half_step_;
  double sixth_step_;
};

// y_{s,j}: the stage input of element j at stage s, from x_j and k_{s-1,j}.
// k_previous is not read at stage 0 (pass anything, e.g. 0.0).
[[nodiscard]] inline double rk4_stage_input(const rk4_coefficients& coefficients, unsigned stage, double x,
                                            double k_previous) noexcept {
  if (stage == 0) return x;
  return x + coefficients.stage_scale(stage) * k_previous;
}

// x_i + (h/6)(((k0 + 2 k1) + 2 k2) + k3): the end-of-step update of element i.
// Multiplying by 2 is exact, so the additions' order, fixed here, is what
// decides the rounding.
[[nodiscard]] inline double rk4_update(const rk4_coefficients& coefficients, double x, double k0, double k1,
                                       double k2, double k3) noexcept {
  double weighted = k0 + 2.0 * k1;
  weighted = weighted + 2.0 * k2;
  weighted = weighted + k3;
  return x + coefficients.sixth_step() * weighted;
}

// The stage inputs y_s as a stage_values view that computes y_{s,j} on
// demand from any indexable x and k_{s-1} (arrays, spans, layout accessors).
// Pass it to model.derivative(i, view).
template <stage_values States, stage_values Derivatives>
struct rk4_stage_inputs {
  const rk4_coefficients& coefficients;
  unsigned stage;
  const States& x;
  const Derivatives& k_previous;  // read only for stage > 0

  [[nodiscard]] double operator[](std::size_t equation) const noexcept {
    if (stage == 0) return x[equation];
    return rk4_stage_input(coefficients, stage, x[equation], k_previous[equation]);
  }
};

// k_{s,i} for one equation: what a thread owning equation i computes at stage s.
template <oscillator_model Model, stage_values States, stage_values Derivatives>
[[nodiscard]] inline double rk4_stage_derivative(const Model& model, const rk4_coefficients& coefficients,
                                                 unsigned stage, std::size_t equation, const States& x,
                                                 const Derivatives& k_previous) noexcept {
  return model.derivative(equation, rk4_stage_inputs<States, Derivatives>{coefficients, stage, x, k_previous});
}

// The serial staged RK4: the reference every parallel combination must match
// bit for bit, and the `rk4/serial` benchmark. step() allocates nothing.
template <oscillator_model Model>
class staged_rk4 {
 public:
  // Starts from the model's initial state.
  staged_rk4(const Model& model, double step) : staged_rk4(model, step, model.initial_state()) {}

  // Starts from `initial` (model.equations() values).
  staged_rk4(const Model& model, double step, std::span<const double> initial)
      : model_(model),
        coefficients_(step),
        equations_(model_.equations()),
        state_(initial.begin(), initial.end()),
        stage_inputs_(equations_, 0.0) {
    if (state_.size() != equations_) throw std::invalid_argument("the initial state must hold one value per equation");
    for (auto& values : stage_values_) values.assign(equations_, 0.0);
  }

  // One RK4 step: four stages, each computing every equation from the stage
  // inputs of the previous one, then the update.
  void step() noexcept {
    for (unsigned stage = 0; stage < kRk4Stages; ++stage) {
      const std::vector<double>& previous = stage_values_[stage == 0 ? 0 : stage - 1];
      for (std::size_t element = 0; element < equations_; ++element) {
        stage_inputs_[element] = rk4_stage_input(coefficients_, stage, state_[element], previous[element]);
      }
      // Every equation's derivative, through the same evaluation the
      // parallel step uses for its block (evaluate_derivatives).
      const double* const inputs = stage_inputs_.data();
      evaluate_derivatives(model_, 0, equations_, inputs, stage_values_[stage].data());
    }
    for (std::size_t element = 0; element < equations_; ++element) {
      state_[element] = rk4_update(coefficients_, state_[element], stage_values_[0][element],
                                   stage_values_[1][element], stage_values_[2][element], stage_values_[3][element]);
    }
    ++steps_taken_;
  }

  void run(std::uint64_t steps) noexcept {
    for (std::uint64_t done = 0; done < steps; ++done) step();
  }

  [[nodiscard]] std::span<const double> state() const noexcept { return state_; }
  // k_s of the last step (all zero before the first).
  [[nodiscard]] std::span<const double> stage_derivatives(unsigned stage) const noexcept {
    assert(stage < kRk4Stages);
    return stage_values_[stage];
  }
  [[nodiscard]] std::uint64_t steps_taken() const noexcept { return steps_taken_; }
  // steps_taken * h (a product, not a running sum, so it does not drift).
  [[nodiscard]] double time() const noexcept {
    return static_cast<double>(steps_taken_) * coefficients_.step();
  }
  [[nodiscard]] const rk4_coefficients& coefficients() const noexcept { return coefficients_; }
  [[nodiscard]] const Model& model() const noexcept { return model_; }

 private:
  Model model_;
  rk4_coefficients coefficients_;
  std::size_t equations_;
  std::vector<double> state_;
  std::vector<double> stage_inputs_;
  std::array<std::vector<double>, kRk4Stages> stage_values_;
  std::uint64_t steps_taken_ = 0;
};

}  // namespace lockstep::kernels
