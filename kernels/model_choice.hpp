#pragma once
// Which oscillator a team of T threads integrates: the one place that decides
// (lockstep run, delay, verify and --plan all ask here).
//
//   T <= 4, no --masses   the paper's two-mass system (4 equations): T threads
//                         split its four derivative equations, as the paper does
//   T > 4,  no --masses   an s-mass chain (eq. (1), 2s equations) with one
//                         equation per thread: s = T / 2; an odd T takes the
//                         smallest chain it can split, s = (T + 1) / 2, so one
//                         thread owns two equations
//   --masses S            an S-mass chain whatever T (blocks of 2S / T
//                         equations per thread); T > 2S cannot split it
//
// In names the model is a key:value segment after the entry's kind,
// `rk4/model:chain16/sync:...`; the two-mass system has no segment, so files
// written before chains existed name the same entries the same way.
#include <cstddef>
#include <optional>
#include <string>

#include "kernels/oscillator.hpp"

namespace lockstep::kernels {

// The paper's two masses give four first-order equations.
inline constexpr unsigned kPaperThreadsMax = 4;

// How JSON names the paper's system where a model is recorded (settings,
// scaling points); a chain is its name(), "chain16".
inline constexpr const char* kTwoMassKey = "two_mass";

struct model_choice {
  std::size_t masses = 0;  // 0: the paper's two-mass system; else an s-mass chain

  [[nodiscard]] bool is_chain() const noexcept { return masses != 0; }
  [[nodiscard]] std::size_t equations() const noexcept { return is_chain() ? 2 * masses : two_mass_model::kEquations; }
  // "chain16", or "" for the paper's system.
  [[nodiscard]] std::string name() const { return is_chain() ? "chain" + std::to_string(masses) : std::string{}; }
  // "chain16", or "two_mass" (kTwoMassKey): what JSON records as the model.
  [[nodiscard]] std::string key() const { return is_chain() ? name() : std::string(kTwoMassKey); }
  // "/model:chain16", or "" for the paper's system: what a name inserts.
  [[nodiscard]] std::string name_segment() const { return is_chain() ? "/model:" + name() : std::string{}; }
  // "the paper's two-mass system" or "a chain of 16 masses (32 equations)".
  [[nodiscard]] std::string description() const {
    return is_chain() ? "a chain of " + std::to_string(masses) + " masses (" + std::to_string(equations()) + " equations)"
                      : std::string("the paper's two-mass system");
  }
  // The chain's parameters (uniform: the paper's masses and springs,
  // displaced 2, -3, 2, ... m); only for a chain.
  [[nodiscard]] chain_params chain() const { return chain_params::uniform(masses); }

  friend bool operator==(const model_choice&, const model_choice&) = default;
};

// The model T threads integrate, given --masses (nullopt: not given).
[[nodiscard]] inline model_choice model_for(unsigned threads, std::optional<std::size_t> masses = std::nullopt) {
  if (masses) return model_choice{*masses};
  if (threads <= kPaperThreadsMax) return model_choice{};
  return model_choice{(static_cast<std::size_t>(threads) + 1) / 2};
}

}  // namespace lockstep::kernels
