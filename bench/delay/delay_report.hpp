#pragma once
// What a delay measurement (bench/probes/delay.hpp) means, and its two
// readings: the text a person reads and the result file
// (docs/result-files.md, kind "delay"). Google Benchmark keeps its runner
// apart from its reporters in the same way: analyse_delay derives every
// figure once; delay_text and delay_json only arrange them. The late steps'
// causes are attribution.hpp's, their text and JSON attribution_output.hpp's.
#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bench/delay/attribution.hpp"
#include "bench/probes/delay.hpp"
#include "bench/probes/latency_histogram.hpp"
#include "platform/stats.hpp"
#include "platform/topology.hpp"

namespace lockstep::bench {

// An answer this many times the largest completion p99 of the search's trials
// was not set by the step: a step whose p99 is 150 us does not miss a 1.5 ms
// deadline by its own cost, only when the machine stalls.
inline constexpr double kStallDominatedFactor = 10.0;

// One CPU of a --per-cpu run.
struct per_cpu_row {
  std::optional<unsigned> cpu;  // where its thread woke for its first period
  unsigned shown_cpu = 0;       // the CPU's number, or the participant's where unknown
  std::vector<double> wakeup_ns;
  platform::distribution wakeup;  // of wakeup_ns (empty: count 0)
  std::vector<double> completion_ns;
  std::uint64_t deadline_misses = 0;  // its completions above the period
  std::uint64_t skipped_periods = 0;  // periods of the schedule its thread skipped after its overruns
};

// Steps that outgrew their period. The paced run re-anchors its schedule
// after each (bench/probes/paced.hpp): the next step waits for the next
// period boundary and the periods between are skipped, so the latencies stay
// per period; this says how far the step and the period are apart.
struct overrun_reading {
  std::int64_t steps = 0;             // steps kept (independent participants: all of theirs)
  std::uint64_t overran = 0;          // of them, those whose completion passed the period
  std::uint64_t skipped_periods = 0;  // periods no step ran in
  std::int64_t periods = 0;           // periods of the schedule: steps + skipped
  // 1 for a team (one schedule); independent participants (--per-cpu) keep
  // a schedule each, and steps, overran, skipped and periods add theirs up.
  unsigned schedules = 1;
  std::int64_t period_ns = 0;
  double completion_p50_ns = 0;
  double completion_max_ns = 0;
  // The median completion is longer than the period: the step does not fit
  // (rather than some steps that overran now and then).
  bool step_exceeds_period = false;
};

// The run's overruns, or empty when no step overran.
std::optional<overrun_reading> overrun_of(const probes::paced_result& run, std::int64_t period_ns);

// The line that names them, the first of the run's result: "overrun: the
// step does not fit the period: its completion p50 is 6612.3 us against a
// period of 1000 us (6.6 periods); 2143 of 2143 steps overran, and 12857 of
// the 15000 periods were skipped (...)".
std::string overrun_line(const overrun_reading& overrun);

// The search's conclusions (--find-period).
struct search_reading {
  double largest_completion_p99_ns = 0;  // over every trial
  // The answer was many times every trial's completion p99
  // (kStallDominatedFactor): the misses that failed shorter periods were rare
  // stalls of the machine, not the step's cost.
  bool set_by_stalls = false;
  std::optional<bool> confirm_within_rate;        // the confirming run's rate at most the asked one
  double confirm_longest_completion_ns = 0;       // 0: no confirming run
};

struct delay_analysis {
  std::optional<overrun_reading> overrun;           // the run's (pinned, or the confirming run)
  std::optional<overrun_reading> unpinned_overrun;  // --compare-pinning's unpinned run's
  probes::latency_histogram histogram;  // 1 us buckets per participant
  std::vector<per_cpu_row> per_cpu;     // --per-cpu only
  std::optional<std::size_t> noisiest;  // index into per_cpu, by kNoisiestRule
  std::optional<search_reading> search;
  std::optional<delay_causes> causes;          // the run's record, attributed
  std::optional<delay_causes> trial_causes;    // --find-period: the failed trial nearest the answer
};

// Every figure the readings print or write, derived once.
delay_analysis analyse_delay(const probes::delay_measurement& measured);

// The search's rule in words, as printed and written.
std::string search_rule(const probes::period_search_settings& search, std::int64_t trial_periods);

// The whole text of the run's answer (stdout). `histogram_file`: whether the
// 1 us buckets also went to --histogram-file.
std::string delay_text(const probes::delay_measurement& measured, const delay_analysis& analysis,
                       bool histogram_file);

// The result file's document (kind "delay"), the machine context included.
nlohmann::json delay_json(const probes::delay_measurement& measured, const delay_analysis& analysis,
                          const platform::topology& machine);

}  // namespace lockstep::bench
