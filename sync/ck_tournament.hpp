#pragma once
// ck_tournament: Concurrency Kit's tournament barrier (libck), through the C shim.
// Statically paired rounds: losers signal their winner and spin on their own flag, the champion
// starts a wake-up that winners pass back down the bracket.
// Contract, progress (pure spin), memory ordering and counters: ck_barrier.hpp.
#include <string_view>

#include "sync/ck_barrier.hpp"

namespace lockstep::sync {

class ck_tournament : public ck_barrier<LOCKSTEP_CK_TOURNAMENT> {
 public:
  static constexpr std::string_view kName = "ck_tournament";
  static constexpr std::string_view kDescription = "Concurrency Kit tournament barrier: static bracket, losers spin on their own flag (pure spin)";
  using ck_barrier::ck_barrier;
};

static_assert(phase_barrier<ck_tournament>);

}  // namespace lockstep::sync
