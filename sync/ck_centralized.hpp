#pragma once
// ck_centralized: Concurrency Kit's centralized barrier (libck), through the C shim.
// One shared counter and a global sense word: every arrival increments the counter, the last one
// resets it and flips the sense that every waiter spins on.
// Contract, progress (pure spin), memory ordering and counters: ck_barrier.hpp.
#include <string_view>

#include "sync/ck_barrier.hpp"

namespace lockstep::sync {

class ck_centralized : public ck_barrier<LOCKSTEP_CK_CENTRALIZED> {
 public:
  static constexpr std::string_view kName = "ck_centralized";
  static constexpr std::string_view kDescription = "Concurrency Kit centralized sense-reversing barrier: one counter, everyone spins on one sense word (pure spin)";
  using ck_barrier::ck_barrier;
};

static_assert(phase_barrier<ck_centralized>);

}  // namespace lockstep::sync
