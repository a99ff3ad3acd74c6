#pragma once
// wait_calibration: the two figures the waiting primitives' budgets are made
// of, measured on this machine once per process instead of compiled in:
//  * what one poll of a spin loop costs (platform/spin_budget.hpp), and
//  * what a futex hand-over costs: FUTEX_WAKE of a thread asleep on another
//    CPU until that thread runs (the "futex round trip" of sync/wait_policy.hpp,
//    the price of sleeping instead of spinning).
// sync/wait_policy.hpp and sync/futex_spin.hpp turn them into polls;
// bench/results/machine_context.cpp records them in every result's context.
//
// The futex round trip: two threads, pinned to two CPUs of the calling
// thread's affinity set when it has two, ping-pong a futex word: each stores
// the next value, calls FUTEX_WAKE and sleeps in FUTEX_WAIT until the other's
// store. Half a round (the waker's call until the woken thread has run and
// stored) is one hand-over. Of up to kFutexRounds rounds after
// kFutexWarmUpRounds, only those in which both FUTEX_WAKE calls found their
// partner asleep count (a partner that had not yet slept would make a cheaper
// hand-over than the one measured). The round trip is their median; the spin
// that covers it (round_trip_spin_ns) lasts their 90th percentile. Why not
// the median: a waiter spins to outlast a partner that is waking up; a spin as
// long as the median wake-up runs out on half of them, and the two then take
// turns sleeping (the cascade sync/wait_policy.hpp describes, seen with a spin
// of 20-25 us against wake-ups of 40 us). The assumed figure this replaces was
// chosen the same way (the development VM's slow-pace p50 and p90, rounded
// up). On that VM, with other builds running: a median hand-over of 19-21 us
// and a 90th percentile of 25-49 us in five probes of 200 rounds.
// Bounded on a loaded machine: every FUTEX_WAIT times out after
// kFutexWaitTimeoutNs, the measurement stops at kFutexCalibrationNs, and with
// fewer than kFutexMinimumHandOvers hand-overs counted (or no thread to run
// them) both figures are kAssumedFutexRoundTripNs, the development VM's, and
// `how` says why.
// The figures are the machine's at start-up: a VM whose pace changes during a
// run (docs/pace.md) can wake its threads slower than it did then; the spins
// then run out more often, which the primitives count (spins_exhausted).
//
// Contract: machine_wait_calibration() measures on its first call (1-60 ms;
// thread-safe: concurrent first callers wait for the one measurement) and
// returns the same figures for the rest of the process. Call it before
// measuring anything, so that it runs outside every timed region; otherwise
// the first waiting primitive built (its constructor) or the first
// machine_context() (bench/results/machine_context.hpp) triggers it.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "platform/cpu_relax.hpp"
#include "platform/spin_budget.hpp"

namespace lockstep::platform {

// The figure used when a futex round trip cannot be measured: the development
// VM's (FUTEX_WAKE to a sleeper on an idle vCPU: the sleeper ran 40-42 us
// after the call began, p90 45-50 us), as sync/wait_policy.hpp assumed it
// before it was measured.
inline constexpr double kAssumedFutexRoundTripNs = 50'000;
// The futex measurement's bounds (see the header).
inline constexpr unsigned kFutexRounds = 200;
inline constexpr unsigned kFutexWarmUpRounds = 10;
inline constexpr std::size_t kFutexMinimumHandOvers = 20;
inline constexpr std::int64_t kFutexWaitTimeoutNs = 5'000'000;
inline constexpr std::int64_t kFutexCalibrationNs = 50'000'000;
// The longest spin a budget of "about one futex round trip" may ask for. A
// hand-over measured slower than this is a loaded machine's scheduling delay
// (a run queue, a timeslice), not the futex's price; spinning that long
// before each sleep would keep a CPU for nothing. 4x the development VM's
// slow-pace figure (kAssumedFutexRoundTripNs); bare metal hands over in a
// few microseconds.
inline constexpr double kLongestRoundTripSpinNs = 200'000;

struct futex_round_trip {
  double ns = kAssumedFutexRoundTripNs;      // the median hand-over, or the assumed figure
  double p90_ns = kAssumedFutexRoundTripNs;  // the 90th percentile hand-over, or the assumed figure
  bool measured = false;
  std::size_t hand_overs = 0;  // how many hand-overs the median is of
  std::string how;             // how it was measured, or why it was not
};

// One futex ping-pong as the header describes, within `budget_ns`.
futex_round_trip measure_futex_round_trip(std::int64_t budget_ns = kFutexCalibrationNs);

struct wait_calibration {
  std::string_view hint = kSpinHintName;  // the instruction one poll issues
  double poll_ns = 0.0;                   // one poll of spin_until: an acquire load and the hint
  futex_round_trip futex;

  // Polls of spin_until that last about `ns` on this machine.
  [[nodiscard]] std::uint32_t polls_lasting(double ns) const noexcept { return platform::polls_lasting(ns, poll_ns); }
  // The time of a spin meant to cover one futex round trip: the 90th
  // percentile hand-over (the header says why), at most kLongestRoundTripSpinNs.
  [[nodiscard]] double round_trip_spin_ns() const noexcept {
    return futex.p90_ns < kLongestRoundTripSpinNs ? futex.p90_ns : kLongestRoundTripSpinNs;
  }
  // The polls of that spin (the dedicated budget of sync/wait_policy.hpp).
  [[nodiscard]] std::uint32_t round_trip_spin_polls() const noexcept { return polls_lasting(round_trip_spin_ns()); }
};

// Measures both figures now (poll cost on platform::now_ns with cpu_relax,
// then the futex round trip).
wait_calibration measure_wait_calibration();

// This process's calibration: measured on the first call, the same after.
const wait_calibration& machine_wait_calibration();

}  // namespace lockstep::platform
