#pragma once
// Bounded runs of a phase_barrier: stop every participant at the same phase,
// so that a run can end on a time budget without leaving anyone waiting.
//
// Why: some primitives may take very long per phase in some regimes: the
// pure-spin ones (kPureSpin) when participants outnumber CPUs (a phase lasts
// until the scheduler preempts a spinner), and win_event_faithful when it loses
// a wake-up (each loss costs its timeout, 1000 ms by default, counted in
// counters.timeouts). A benchmark or test bounds them with a time budget; the
// decision to stop must reach every participant at the same phase, or those
// that continue wait forever for those that stopped.
//
// Protocol (phase_stop): one participant, the leader (id 0), decides before
// it arrives at phase p, by calling request_after(p). Every participant, after
// its arrive_and_wait of phase q returns, asks should_stop_after(q). The
// barrier of phase p orders the leader's request before every participant's
// question after phase p, so all of them stop after phase p; a question after
// an earlier phase q < p can see the request early, but it names p, so nobody
// stops early. The question is "is the named phase at or before mine?", not
// "is it mine?": a barrier that no longer synchronises (win_event_faithful
// after lost wake-ups: its counter is off by one) can let a participant run a
// phase ahead of the leader, and that participant must stop too, not wait out
// timeouts alone for ever.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "sync/concepts.hpp"
#include "sync/team.hpp"

namespace lockstep::sync {

class phase_stop {
 public:
  // Leader only, before arriving at `phase`.
  void request_after(std::uint64_t phase) noexcept {
    // relaxed: the barrier of `phase` orders this store before every reader
    // that asks after `phase` (see the protocol above).
    stop_after_.store(phase, std::memory_order_relaxed);
  }
  // Any participant, after its arrive_and_wait of `phase` returned.
  bool should_stop_after(std::uint64_t phase) const noexcept {
    // relaxed: pairs with request_after through the barrier, as above.
    return stop_after_.load(std::memory_order_relaxed) <= phase;
  }

 private:
  std::atomic<std::uint64_t> stop_after_{std::numeric_limits<std::uint64_t>::max()};
};

struct phase_run_limits {
  std::uint64_t max_phases = 1000;
  // Wall-clock budget; the leader checks it every kClockInterval phases.
  std::chrono::nanoseconds time_budget = std::chrono::seconds(10);
  static constexpr std::uint64_t kClockInterval = 16;
};

struct phase_run_result {
  std::uint64_t phases = 0;          // phases every participant completed
  bool stopped_by_time = false;      // the budget ended the run before max_phases
  std::chrono::nanoseconds elapsed{};  // leader's view, first arrival to last return
  std::vector<participant> participants;  // each with its counters
  sync_counters total() const noexcept {
    sync_counters sum;
    for (const auto& one : participants) sum += one.counters;
    return sum;
  }
};

// Runs `Barrier` with `participants` participants on its team for at most
// limits.max_phases phases or about limits.time_budget, whichever ends first.
// Before each arrival, participant `self` calls work(self, phase) (may be a
// no-op); the barrier is constructed by `make_barrier(participants)`.
// Used by the conformance tests; the bare benchmarks may use it or copy the
// protocol (phase_stop) into their own loop.
template <phase_barrier Barrier, class Work>
phase_run_result run_phases(Barrier& barrier, unsigned participants, phase_run_limits limits, Work&& work) {
  phase_run_result result;
  result.participants.resize(participants);
  for (unsigned id = 0; id < participants; ++id) result.participants[id].id = id;
  phase_stop stop;
  std::uint64_t completed = 0;
  bool stopped_by_time = false;
  std::chrono::nanoseconds elapsed{};
  team_of_t<Barrier> team(participants);
  team.run([&](unsigned id) {
    participant& self = result.participants[id];
    const auto start = std::chrono::steady_clock::now();
    for (std::uint64_t phase = 0;; ++phase) {
      if (id == 0) {
        bool last = phase + 1 >= limits.max_phases;
        if (!last && phase % phase_run_limits::kClockInterval == 0 &&
            std::chrono::steady_clock::now() - start >= limits.time_budget) {
          last = true;
          stopped_by_time = true;  // read after the team joined
        }
        if (last) stop.request_after(phase);
      }
      work(self, phase);
      barrier.arrive_and_wait(self);
      if (stop.should_stop_after(phase)) {
        if (id == 0) {
          completed = phase + 1;
          elapsed = std::chrono::steady_clock::now() - start;
        }
        return;
      }
    }
  });
  result.phases = completed;
  result.stopped_by_time = stopped_by_time;
  result.elapsed = elapsed;
  return result;
}

}  // namespace lockstep::sync
