#pragma once
// The figures lockstep derives from measured ones, each computed here and
// only here: the run book (summary), the result JSON and the progress lines
// all call these.
//
//   vs_serial  = ns_per_step / the run's serial step (rk4/serial median)
//   vs_c2c     = sync_ns_per_stage / the run's core-to-core one-way latency
//                (c2c/pin:compact/threads:2 median)
// Both only on the composed step's entries (rk4/sync:..., overhead/...:
// entry_spec::is_parallel_step, bench/results/entry_spec.hpp).
// vs_c2c_paired divides by the latency measured in the entry's own call
// (rk4_entries.cpp) and is measured, not derived after the run.
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "platform/format.hpp"

namespace lockstep::bench {

// The run's calibrations (medians), either of which may be missing.
struct calibrations {
  std::optional<double> c2c_one_way_ns;
  std::optional<double> serial_step_ns;
};

struct derived_ratio {
  std::string name;     // "vs_serial", "vs_c2c"
  std::string counter;  // what it divides: "ns_per_step", "sync_ns_per_stage"
  double value = 0.0;
};

// The derived ratios of one row of counters, each present only when its
// counter and its calibration are (and the calibration is positive).
std::vector<derived_ratio> derived_ratios(const std::map<std::string, double>& counters, const calibrations& run);

// "12.3 ns", "4.56 us", "7.89 ms": platform/format.hpp's, the one nanosecond
// formatter of the C++ side.
using platform::format_ns;

}  // namespace lockstep::bench
