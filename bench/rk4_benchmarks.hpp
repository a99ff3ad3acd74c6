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
//                               benchmark thread: ns_per_step. Its median is
//                               the run's serial_step_ns (vs_serial).
//   rk4/sync:S/layout:L/pin:P/threads:T
//                               the composed step (kernels/parallel_step.hpp)
//                               on a pinned team, batches of steps; counters
//                               in DESIGN.md (see register_rk4_benchmarks).
// Both calibrations are registered first, so that Google Benchmark (which runs
// entries in registration order) has measured them when the RK4 entries need them.
#include <string>
#include <vector>

#include "bench/harness.hpp"
#include "bench/harness_team.hpp"

namespace lockstep::bench {

// The step size of every benchmarked RK4 step, in seconds: about 1/1200 of
// the fastest period of the paper's oscillator (2 pi / 51.49 rad/s = 0.122 s),
// so millions of steps stay bounded and never reach denormals or infinities.
inline constexpr double kBenchmarkStepSeconds = 1e-4;

// c2c and rk4/serial. c2c needs two CPUs in the affinity set; without them it
// is recorded as not applicable in the run book. Returns the names registered.
std::vector<std::string> register_calibration_benchmarks(harness_state& harness);

}  // namespace lockstep::bench
