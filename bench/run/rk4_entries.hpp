#pragma once
// The RK4 entries and the in-run calibrations.
//
//   c2c/pin:compact/threads:2   one-way core-to-core latency between the first
//                               two PUs of the compact plan (core_to_core.hpp,
//                               CAS ping-pong): counter one_way_ns (median of
//                               the samples), one_way_min_ns, one_way_p99_ns.
//                               The median over repetitions is the run's
//                               c2c_one_way_ns, which vs_c2c divides by.
//   rk4/serial                  the serial staged RK4 (kernels/rk4.hpp) on the
//                               benchmark thread: ns_per_step (real_time),
//                               cpu_ns_per_step (cpu_time), steps_per_batch
//                               as the team entries have them. Its median is
//                               the run's serial_step_ns (vs_serial).
//   rk4/sync:S/layout:L/pin:P/threads:T
//                               the composed step (kernels/parallel_step.hpp)
//                               on a pinned team, batches of steps; counters
//                               at register_rk4_benchmarks below (and in
//                               docs/names-and-counters.md).
//   rk4/model:chainS/...        the same on an s-mass chain, the model of
//                               more than 4 threads or of --masses
//                               (kernels/model_choice.hpp); its vs_serial
//                               divides by rk4/model:chainS/serial.
// Both calibrations are registered first (Google Benchmark runs entries in
// registration order unless told to interleave), but no entry reads them while
// it runs: vs_serial and vs_c2c are derived after the run from the whole run's
// medians (run_book::derive_ratios, and for the file result_json_reporter in reporters.hpp).
#include <string>
#include <utility>
#include <vector>

#include "bench/run/run_book.hpp"
#include "bench/run/team_driver.hpp"

namespace lockstep::bench {

// The step size of every benchmarked RK4 step, in seconds: about 1/1200 of
// the fastest period of the paper's oscillator (2 pi / 51.49 rad/s = 0.122 s),
// so millions of steps stay bounded and never reach denormals or infinities.
inline constexpr double kBenchmarkStepSeconds = 1e-4;

// c2c and rk4/serial, and rk4/model:chainS/serial for every chain the
// selection's thread counts integrate. c2c needs two CPUs in the affinity set; without them it
// is recorded as not applicable in the run book. Returns the specs registered.
std::vector<entry_spec> register_calibration_benchmarks(const run_selection& selection, harness_state& harness);

// rk4/sync:S/layout:L/pin:P/threads:T for every selected combination that
// applies; the others go into the run book's not_applicable list with the
// reason (kernels/parallel_step.hpp: applicable, not_applicable_reason).
// Google Benchmark's real_time and cpu_time are per step (team_driver.hpp,
// before measure_entry): real_time = ns_per_step, cpu_time = cpu_ns_per_step.
// Counters, per step unless named otherwise (summed over the team):
//   ns_per_step          batch time / steps
//   cpu_ns_per_step      participant 0's thread CPU time over the timed
//                        batches / their steps (not summed over the team)
//   steps_per_batch      the steps of one batch (one Google Benchmark
//                        iteration), from the entry's probe
//   sync_ns_per_stage    mean time a participant spent in one stage sync
//                        (the step's sampled instrumentation: the syncs of one
//                        step in kSyncTimingSampleSteps; absent with accounting
//                        off), over the timed batches (the warm-up excluded),
//                        less one clock reading (context clock_read_ns: a timed
//                        span holds the cost of one reading besides the sync)
//   vs_serial            ns_per_step / this run's rk4/serial median
//   vs_c2c               sync_ns_per_stage / this run's c2c one-way median
//   csw_vol_per_kstep, csw_invol_per_kstep, migrations_per_kstep
//                        context switches and migrations of the whole team per
//                        1000 steps (warm-up batch and harness barriers
//                        included); migrations absent when unavailable
//   cross_core_csw_pct   the paper's Figure 5 share (absent when unavailable)
//   futex_waits_per_step the primitive's futex sleeps, summed over the team;
//                        absent for primitives that cannot count them
//                        (sync::primitive_info::counts_futex_waits)
//   timeouts             waits that ended by timeout in the repetition (a count)
//   oversubscribed       1 when the threads outnumber the CPUs
// With settings.accounting off the entries run without instrumentation and
// without accounting (their counters are omitted).
std::vector<entry_spec> register_rk4_benchmarks(const run_selection& selection, harness_state& harness);

// The harness-overhead pair, side by side: overhead/accounting:off/... and
// overhead/accounting:on/... on one combination (seqlock, per_thread,
// compact, 2 threads when selected; else the first selected that applies).
// The summary quotes on / off.
std::vector<entry_spec> register_overhead_pair(const run_selection& selection, harness_state& harness);

// The sides of the crossover sweep's pairs (crossover_sweep.hpp), with
// accounting as asked (block_runner::last_facts): the chain of `masses` masses
// stepped by (sync, layout) on `threads` participants placed by `pin`, as the
// matrix builds a chain's entry (the bare step); empty when a name is not in
// a registry or the pair does not apply there (kernels::not_applicable_reason).
block_runner_factory chain_step_runner(const harness_state& harness, const std::string& sync,
                                       const std::string& layout, platform::placement pin, unsigned threads,
                                       std::size_t masses, bool accounting);
// The machine's ceiling for a split of the same chain: `threads` independent
// serial chains stepped at once, one per participant placed by `pin`, each of
// the masses the partition gives that participant (layouts/partition.hpp, in
// whole masses): the parallel step's blocks with no exchange and no sync, so
// what the machine gives an even split before any sync (a reference: each
// block is a chain of its own, with fixed ends). Empty when
// the chain has fewer masses than threads (the blocks would not be whole
// masses).
block_runner_factory chain_split_runner(const harness_state& harness, platform::placement pin, unsigned threads,
                                        std::size_t masses, bool accounting);
// The serial staged step of the same chain (rk4/model:chainS/serial) on the
// calling thread, unpinned, as the serial entry runs: a warm-up batch, then
// the timed one; accounting on. Every runner the factory makes steps one
// chain, built with the factory: the comparisons of one size (the series and
// the ceiling) divide by one serial step. Built apart, two serial chains of
// 4096 masses ran up to 12 % apart in the same interleaved rounds (10
// instances, 21 rounds, one pinned CPU of the Intel development VM: medians
// 44.5-52.0 us, two of them 10-12 % above the rest, their quartiles shifted
// alike): an effect of the instance, not of the period, which the rounds
// share.
block_runner_factory chain_serial_runner(std::size_t masses);

}  // namespace lockstep::bench
