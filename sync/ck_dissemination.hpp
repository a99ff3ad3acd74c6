#pragma once
// ck_dissemination: Concurrency Kit's dissemination barrier (libck), through the C shim.
// ceil(log2 n) rounds; in round k participant i signals participant (i + 2^k) mod n and spins on its
// own flag: no shared counter, O(n log n) signals per phase.
// Contract, progress (pure spin), memory ordering and counters: ck_barrier.hpp.
#include <string_view>

#include "sync/ck_barrier.hpp"

namespace lockstep::sync {

class ck_dissemination : public ck_barrier<LOCKSTEP_CK_DISSEMINATION> {
 public:
  static constexpr std::string_view kName = "ck_dissemination";
  static constexpr std::string_view kDescription = "Concurrency Kit dissemination barrier: log2(n) rounds of pairwise flags, no shared counter (pure spin)";
  using ck_barrier::ck_barrier;
};

static_assert(phase_barrier<ck_dissemination>);

}  // namespace lockstep::sync
