#pragma once
// One rank's part of the distributed RK4 step: its block of equations, the
// four stages, the exchange between them (exchange.hpp), the same arithmetic
// as the serial step (kernels/rk4.hpp), so its block is the serial trajectory
// bit for bit.
//
//   rank_step<Model> step(model, dt, block, exchange);
//   step.reset();                      collective: x_0, step 0
//   step.run(steps, hooks);            untimed: no clock on the path
//   step.run_timed(steps, record, hooks)
//                                      each share() timed: its arrival (the
//                                      clock when the rank entered it) and how
//                                      long it took, into record (sized by the caller);
//                                      prepare() and the arithmetic are outside it
//   step.own_block()                   x_n of the rank's block
// hooks.heartbeat, when set, is stored every step (relaxed: the watchdog only
// needs to see it move); hooks.waiting, when set, is true while the rank is in
// share() (waiting for other ranks: the watchdog tells a rank that stopped
// from ranks that wait for it); hooks.at_step, when set, is called with the step
// number before each step (fault injection for the tests).
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "distributed/exchange.hpp"
#include "kernels/oscillator.hpp"
#include "kernels/rk4.hpp"
#include "layouts/partition.hpp"
#include "platform/clock.hpp"

namespace lockstep::distributed {

struct step_hooks {
  std::atomic<std::uint64_t>* heartbeat = nullptr;
  std::atomic<bool>* waiting = nullptr;
  std::function<void(std::uint64_t step)> at_step;
};

// What run_timed records: one entry per stage, index step * 4 + s.
struct stage_record {
  std::vector<std::int64_t> arrival_ns;  // platform::now_ns when the rank entered share()
  std::vector<std::int64_t> latency_ns;  // how long share() took
  void resize(std::uint64_t steps) {
    arrival_ns.assign(steps * kernels::kRk4Stages, 0);
    latency_ns.assign(steps * kernels::kRk4Stages, 0);
  }
};

template <kernels::oscillator_model Model>
class rank_step {
 public:
  rank_step(const Model& model, double dt, layouts::equation_block block, exchange& values)
      : model_(model), coefficients_(dt), block_(block), values_(&values), last_stage_(model.equations(), 0.0) {}

  void reset() {
    values_->reset(model_.initial_state());
    parity_ = 0;
    steps_taken_ = 0;
  }

  void run(std::uint64_t steps, const step_hooks& hooks) { loop<false>(steps, nullptr, hooks); }
  void run_timed(std::uint64_t steps, stage_record& record, const step_hooks& hooks) {
    loop<true>(steps, &record, hooks);
  }

  [[nodiscard]] std::vector<double> own_block() const {
    const double* x = values_->state(parity_);
    return std::vector<double>(x + block_.first, x + block_.last);
  }
  [[nodiscard]] std::uint64_t steps_taken() const noexcept { return steps_taken_; }

 private:
  template <bool Timed>
  void loop(std::uint64_t steps, stage_record* record, const step_hooks& hooks) {
    for (std::uint64_t done = 0; done < steps; ++done) {
      if (hooks.heartbeat != nullptr) hooks.heartbeat->store(steps_taken_, std::memory_order_relaxed);
      if (hooks.at_step) hooks.at_step(steps_taken_);
      const double* const x = values_->state(parity_);
      for (unsigned stage = 0; stage < kernels::kRk4Stages; ++stage) {
        const std::uint64_t global_stage = steps_taken_ * kernels::kRk4Stages + stage;
        values_->prepare(global_stage);
        const double* const previous = stage == 0 ? x : values_->stage(stage - 1);
        double* const current = stage < 3 ? values_->stage(stage) : last_stage_.data();
        for (std::size_t equation = block_.first; equation < block_.last; ++equation)
          current[equation] = kernels::rk4_stage_derivative(model_, coefficients_, stage, equation, x, previous);
        if (stage == 3) {
          double* const next = values_->next_state(parity_);
          const double* const k0 = values_->stage(0);
          const double* const k1 = values_->stage(1);
          const double* const k2 = values_->stage(2);
          for (std::size_t equation = block_.first; equation < block_.last; ++equation)
            next[equation] = kernels::rk4_update(coefficients_, x[equation], k0[equation], k1[equation], k2[equation],
                                                 current[equation]);
        }
        if (hooks.waiting != nullptr) hooks.waiting->store(true, std::memory_order_relaxed);
        if constexpr (Timed) {
          const std::int64_t arrival = platform::now_ns();
          values_->share(global_stage);
          const std::size_t index = done * kernels::kRk4Stages + stage;
          record->arrival_ns[index] = arrival;
          record->latency_ns[index] = platform::now_ns() - arrival;
        } else {
          values_->share(global_stage);
        }
        if (hooks.waiting != nullptr) hooks.waiting->store(false, std::memory_order_relaxed);
      }
      parity_ ^= 1U;
      ++steps_taken_;
    }
  }

  Model model_;
  kernels::rk4_coefficients coefficients_;
  layouts::equation_block block_;
  exchange* values_;
  std::vector<double> last_stage_;  // k_3 of the block (nobody else reads it)
  unsigned parity_ = 0;
  std::uint64_t steps_taken_ = 0;
};

}  // namespace lockstep::distributed
