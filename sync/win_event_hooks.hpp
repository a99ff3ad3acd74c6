#pragma once
// Test seams for the ThreadWaiter-style barriers (win_event_faithful,
// win_event): a hook called in the window the paper's code is vulnerable in,
// after a participant's InterlockedDecrement and before its wait. The default
// does nothing and compiles away; the deterministic lost-wake-up test supplies
// one that parks a participant there until the phase has been released.
#include "sync/concepts.hpp"

namespace lockstep::sync {

template <class Hooks>
concept thread_waiter_hooks = requires(Hooks& hooks, participant& self) { hooks.after_decrement(self); };

struct no_hooks {
  void after_decrement(participant& /*self*/) noexcept {}
};

}  // namespace lockstep::sync
