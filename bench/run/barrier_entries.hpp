#pragma once
// The bare `barrier/sync:S/pin:P/threads:T` entries: episodes of one
// primitive alone, no RK4 work, on a pinned team.
//
// One unit is one episode: every participant calls arrive_and_wait once
// (channels run as barriers through channel_barrier: every participant
// publishes and receives from all others). Counters, per episode unless
// named otherwise (Google Benchmark's real_time is ns_per_episode, its
// cpu_time cpu_ns_per_episode: team_driver.hpp, before measure_entry):
//   ns_per_episode                 time of one episode (batch time / episodes)
//   cpu_ns_per_episode             participant 0's thread CPU time over the
//                                  timed batches / their episodes
//   episodes_per_batch             the episodes of one batch (one Google
//                                  Benchmark iteration), from the probe
//   futex_waits_per_episode, futex_wakes_per_episode, yields_per_episode,
//   spins_exhausted_per_episode    the primitive's own counters, summed over
//                                  the team; absent for the primitives
//                                  that cannot count them
//                                  (sync::primitive_info::counts_futex_waits)
//   timeouts                       waits that ended by timeout in this
//                                  repetition (a count: lost wake-ups)
//   oversubscribed                 1 when threads outnumber the CPUs
#include <string>
#include <vector>

#include "bench/run/run_book.hpp"
#include "bench/run/team_driver.hpp"

namespace lockstep::bench {

// Registers one entry per selected (sync, pin, threads); returns their specs.
// Unknown names must have been rejected before (bench/cli/run.cpp validates them).
std::vector<entry_spec> register_barrier_benchmarks(const run_selection& selection, harness_state& harness);

}  // namespace lockstep::bench
