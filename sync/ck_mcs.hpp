#pragma once
// ck_mcs: Concurrency Kit's MCS barrier (libck), through the C shim.
// Mellor-Crummey and Scott's tree barrier: arrival up a 4-ary tree of child-not-ready flags, wake-up down
// a binary tree; every participant spins only on its own node.
// Contract, progress (pure spin), memory ordering and counters: ck_barrier.hpp.
#include <string_view>

#include "sync/ck_barrier.hpp"

namespace lockstep::sync {

class ck_mcs : public ck_barrier<LOCKSTEP_CK_MCS> {
 public:
  static constexpr std::string_view kName = "ck_mcs";
  static constexpr std::string_view kDescription = "Concurrency Kit MCS tree barrier: 4-ary arrival tree, binary wake-up tree, local spinning (pure spin)";
  using ck_barrier::ck_barrier;
};

static_assert(phase_barrier<ck_mcs>);

}  // namespace lockstep::sync
