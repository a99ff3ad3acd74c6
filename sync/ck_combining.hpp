#pragma once
// ck_combining: Concurrency Kit's software combining tree barrier (libck), through the C shim.
// Participants in leaf groups of two (the shim's choice) count up a tree of groups; the last of a
// group climbs to the parent, then flips the group's sense on the way back.
// Contract, progress (pure spin), memory ordering and counters: ck_barrier.hpp.
#include <string_view>

#include "sync/ck_barrier.hpp"

namespace lockstep::sync {

class ck_combining : public ck_barrier<LOCKSTEP_CK_COMBINING> {
 public:
  static constexpr std::string_view kName = "ck_combining";
  static constexpr std::string_view kDescription = "Concurrency Kit combining-tree barrier, leaf groups of two (pure spin)";
  using ck_barrier::ck_barrier;
};

static_assert(phase_barrier<ck_combining>);

}  // namespace lockstep::sync
