#pragma once
// Where a parallel step starts to pay off: the crossover S*, from a sweep of
// the chain's model size S (masses) on a doubling grid, each point a paired
// speedup serial step / parallel step with its bootstrap interval
// (bench/results/paired_ratio.hpp). A pure function of the points: nothing
// here measures (crossover_sweep.hpp does).
//
// The rule (find_crossover):
//   * the speedup crosses 1 at the last rise of the median above 1 (a noisy
//     curve may rise and fall back before it); S* is interpolated between the
//     two grid points that bracket it, log speedup linear in log S;
//   * the interval of S*: the same crossing of the interval's ends. Where the
//     low end crosses 1 is the interval's upper end (from there on the whole
//     interval is above 1), where the high end crosses 1 its lower end (below
//     it the whole interval is below 1). An end that crosses between measured
//     sizes more than one doubling apart (those between set aside) is the
//     size measured on that side of the gap. An end the grid does not reach is
//     open (empty): the high end above 1 from the first point, or the low end
//     never above 1 within the sweep;
//   * confirmed: a measured point above S* has its whole interval above 1
//     (confirmed_at, the first such point). Otherwise the crossing is
//     unconfirmed: no point above it cleared 1 with its whole interval, or a
//     point above it fell back to a median at or below 1 (contradicted_at);
//   * none within the sweep: the median never rises above 1 (or there are no
//     points);
//   * always: every median above 1, from the first point on: S* lies below the
//     grid, and `masses` is the first point (an upper bound).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/results/paired_ratio.hpp"
#include "platform/placement.hpp"

namespace lockstep::bench {

// One point of the sweep: the model size and the paired speedup there.
struct crossover_point {
  double masses = 0.0;
  ratio_estimate speedup;  // serial step / parallel step: median, low, high
};

enum class crossover_status { crossed, crossed_unconfirmed, none_within_sweep, always };
std::string_view to_string(crossover_status status) noexcept;

struct crossover_estimate {
  crossover_status status = crossover_status::none_within_sweep;
  std::optional<double> masses;   // S*: where the median crosses 1 (always: the first point)
  std::optional<double> low;      // where the interval's high end crosses 1; empty: below the grid
  std::optional<double> high;     // where the interval's low end crosses 1; empty: beyond the sweep
  std::optional<double> confirmed_at;     // the first point above S* whose whole interval is above 1
  std::optional<double> contradicted_at;  // the first point above S* whose median is not above 1
};

// `points` in ascending masses (the doubling grid); masses and speedups above 0.
crossover_estimate find_crossover(const std::vector<crossover_point>& points);

// What the sweep measured (crossover_sweep.hpp measures it): per series, a
// primitive on its layout at one thread count and placement, the points of
// the doubling grid.
struct crossover_sweep_point {
  std::size_t masses = 0;
  unsigned threads = 1;
  double serial_ns = 0.0;    // the serial step: median over the pairs kept
  double parallel_ns = 0.0;  // the parallel step: likewise
  ratio_estimate speedup;    // serial / parallel, paired: median and interval
  ratio_verdict verdict = ratio_verdict::unsure;
  std::size_t pairs = 0;            // pairs kept
  std::size_t pairs_set_aside = 0;  // pairs in which another process took a CPU (block_facts)
  std::optional<double> cpus_busy;  // the parallel side's threads' CPU time / wall time, median
  bool oversubscribed = false;      // more threads than CPUs: preemptions are the team's own, not flagged
  // The model beside it: serial_ns / threads + stages per step x the stage
  // sync the run measured for this primitive at this thread count.
  std::optional<double> model_ns;
  std::string failure;  // non-empty: no speedup measured here, and why
  [[nodiscard]] bool measured() const noexcept { return failure.empty() && pairs > 0; }
  [[nodiscard]] double equations_per_thread() const noexcept {
    return 2.0 * static_cast<double>(masses) / static_cast<double>(threads);
  }
};

struct crossover_series {
  unsigned threads = 2;
  platform::placement pin = platform::placement::compact;
  std::string sync;
  std::string layout;
  // The run's choice at this thread count, or the rival its pair could not
  // tell from it (answer_choice::tied); false: the baseline (std::barrier).
  bool leader = true;
  // The stage sync the model takes: the run's sync_ns_per_stage (median) of
  // this primitive's entry at this thread count, placement and layout, and
  // that entry; empty when the run did not measure it (accounting off).
  std::optional<double> stage_sync_ns;
  std::string stage_sync_entry;
  std::vector<crossover_sweep_point> points;
  std::string stop_reason;
  crossover_estimate crossover;  // find_crossover of the points measured
};

// The machine's ceiling at one thread count and placement (the sweep
// measures it beside the series): at each size, the serial step against T
// independent blocks of the chain stepped at once (crossover_sweep_point with
// parallel_ns the blocks' time and speedup serial / blocks; model_ns empty):
// the parallel step's blocks with no exchange and no sync: what the machine
// gives an even split before any sync is paid. Below T it is the machine
// (unequal CPUs, shared caches and memory, a per-step cost that does not
// halve), not the synchronisation. A reference, not a bound: each block is a
// chain of its own (fixed ends where the step's block has neighbours), built
// apart from the step's arrays, and its pairs are not the series' pairs.
// The blocks' time is the slowest block's own stepping time
// (rk4_entries.cpp, split_block_runner says why not the batch clock).
struct crossover_ceiling {
  unsigned threads = 2;
  platform::placement pin = platform::placement::compact;
  std::vector<crossover_sweep_point> points;
};

struct crossover_sweep {
  std::int64_t budget_ns = 0;
  std::size_t max_masses = 0;
  unsigned pairs = 0;        // pairs per point asked
  std::int64_t block_ns = 0;
  double spent_s = 0.0;
  std::string stop_reason;   // why the sweep as a whole ended
  std::vector<crossover_series> series;
  std::vector<crossover_ceiling> ceilings;  // one per thread count swept (none in a sweep without them)
};

// The ceiling's point the answer quotes: the largest size where both it and
// the thread count's leader were measured (the ceiling's largest measured
// when the leader has none there); nullptr when none was measured.
const crossover_sweep_point* ceiling_quoted(const crossover_sweep& sweep, const crossover_ceiling& ceiling);
// The ceiling's point at a series point's size and thread count, when it was
// measured (nullptr otherwise).
const crossover_sweep_point* ceiling_at(const crossover_sweep& sweep, const crossover_sweep_point& point);
// The share of the ceiling a series point reached: its speedup over the
// ceiling's at the same size (medians); empty where either is not measured.
std::optional<double> share_of_ceiling(const crossover_sweep& sweep, const crossover_sweep_point& point);

// The points a finder reads: the measured ones of a series.
std::vector<crossover_point> crossover_points(const crossover_series& series);

// The answer's crossover lines: per thread count the crossover's ("Crossover at 2
// threads (pin:compact): mailbox pays off from about 1450 masses [1100, 1900]
// (1450 equations a thread); std_barrier from about 2900 [...]; below that,
// step serially"), then the ceiling's where one was measured ("Ceiling at 2
// threads (pin:compact), 4096 masses: ... give 1.98x [1.92, 2.02] the serial
// step's speed; mailbox gives 1.93x [1.78, 2.06], 0.98 of it").
std::vector<std::string> crossover_lines(const crossover_sweep& sweep);

// The result file's "lockstep_crossover" (docs/schemas/run.schema.json).
nlohmann::json crossover_json(const crossover_sweep& sweep);

}  // namespace lockstep::bench
