#pragma once
// The measurement behind `lockstep delay`: the paced RK4 step (paced.hpp) of
// one sync x layout x placement, run for a number of periods, or searched for
// the shortest period that holds a miss rate (period_search.hpp), with
// /dev/cpu_dma_latency held for the run as cyclictest holds it. Settings in
// (checked by the command), a delay_measurement out; what it means and how it
// reads is bench/delay/delay_report.hpp's.
//
// Views: the paper's model (participants share one step, a primitive between
// the stages); one participant (like for like with `cyclictest -t1`); per
// CPU (one paced thread on each CPU of the affinity set, `cyclictest -S`).
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "bench/probes/latency_histogram.hpp"
#include "bench/probes/paced.hpp"
#include "bench/probes/period_search.hpp"
#include "kernels/model_choice.hpp"
#include "platform/placement.hpp"
#include "platform/topology.hpp"

namespace lockstep::bench::probes {

// Everything a delay measurement needs, checked before it starts.
struct delay_settings {
  std::string sync = "std_barrier";
  std::string layout = "padded64";
  std::string pin = "compact";  // its name, as written; `kind` is what it means
  platform::placement kind = platform::placement::compact;
  unsigned threads = 4;          // participants (per CPU: replaced by the CPUs of the affinity set)
  kernels::model_choice model;   // what the team integrates (kernels::model_for)
  std::int64_t period_ns = 0;
  std::int64_t duration_ns = 0;  // 0 with find_period
  std::int64_t periods = 0;      // duration / period; 0 with find_period
  std::optional<int> fifo_priority;
  bool mlock = false;            // memory locked by the command for the run (recorded, not done here)
  bool compare_pinning = false;  // also run unpinned
  bool per_cpu = false;
  std::optional<std::int32_t> dma_latency_us;  // empty: --no-dma-latency
  std::string dma_latency_path;                // the PM QoS file the hold opens
  std::int64_t histogram_bound_us = kDefaultHistogramBoundUs;
  std::optional<std::int64_t> stop_above_ns;
  bool find_period = false;
  period_search_settings search;  // with find_period
  // The per-step record of the run (paced.hpp): every period by default (the
  // late steps' causes), alternate blocks for --recording-cost (its cost as
  // a pair), off with --no-record. With find_period every trial records.
  step_recording recording = step_recording::every_period;
};

// The idle-state setting in force for the run.
struct idle_setting {
  std::optional<std::int32_t> requested_us;  // empty: --no-dma-latency
  bool held = false;
  std::optional<std::int32_t> in_force_us;
  std::string path;
  std::string problem;  // why the hold failed, when it did
  std::string driver;
  std::string governor;
  std::string clocksource;
};

// A trial's outcome as the search saw it, with the confirming run whole.
struct delay_search {
  period_search_result search;
  std::optional<paced_result> confirm;  // the confirming run's whole result
  // The run of the trial at search.failed_period_ns (the failed period next
  // to the answer), whole: its misses are the ones the answer avoids.
  std::optional<paced_result> failed_trial;
};

struct delay_measurement {
  delay_settings settings;  // as run: threads is the participants' count
  std::string name;         // rk4[/model:...]/sync:/layout:/pin:/threads:
  std::string view;         // the view in words
  std::string placement;    // the placement plan in words
  std::string policy;       // ", SCHED_OTHER" / ", SCHED_FIFO P", then ", memory locked" when it was
  idle_setting idle;
  std::int64_t period_ns = 0;  // the period of `pinned`: --period, or the search's answer
  paced_result pinned;         // the run (with find_period: the confirming run, or empty)
  std::optional<paced_result> unpinned;  // with compare_pinning
  std::optional<delay_search> searched;  // with find_period
};

// What a run tells the period search (period_search.hpp): the periods of its
// schedule, and its misses, the steps that overran their period and the
// periods skipped after them (each a period whose deadline passed without its
// step done: paced.hpp); the completion's p50 and p99.
trial_outcome trial_of(const paced_result& run, std::int64_t elapsed_ns);

// A whole number of nanoseconds as microseconds, as delay prints them
// ("1000", "12.5"): the one rule of the command's text and progress lines.
std::string microseconds_text(std::int64_t ns);

// Lines of progress for a person (stderr): what starts, each trial, how far
// a long run is.
using delay_progress = std::function<void(const std::string& line)>;

// Runs the measurement `settings` describe on `machine`. Holds the idle-state
// setting from the start to the end of the measurements.
delay_measurement measure_delay(const delay_settings& settings, const platform::topology& machine,
                                const delay_progress& progress);

}  // namespace lockstep::bench::probes
