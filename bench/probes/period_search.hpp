#pragma once
// The shortest period that holds: `lockstep delay --find-period --miss-rate R`.
//
// The question a real-time engineer asks of a paced step (a sync x layout x
// placement x threads): what is the shortest period at which it misses its
// deadline (the end of its period) at most at rate R? The search answers it
// with trials: a trial runs the paced step for n periods at one period P and
// counts the misses m: the periods whose deadline passed without their step
// done, i.e. each step that overran its period and each period the schedule
// skipped after it (it re-anchors at the next period boundary: paced.hpp).
// A period shorter than the step is a miss in every period.
//
// Verdict of a trial (the stated confidence): P holds when the one-sided
// Clopper-Pearson upper confidence bound on the miss rate, at confidence c
// (0.95 unless told), is at most R: the exact binomial bound, the p at which
// seeing m or fewer misses in n periods has probability 1 - c. With m = 0 it
// is 1 - (1 - c)^(1/n), about 3/n at 95 % (the "rule of three"), so a trial
// can only hold if n >= ln(1 - c) / ln(1 - R) (minimum_trial_periods: 2995
// periods for R = 1e-3); that is the default trial length, and a longer one
// (trial_periods) allows some misses (at n = 10 / R, up to 4).
//
// A trial that has already seen more misses than a hold allows
// (allowed_misses: 0 at the default length) cannot hold any more: the
// search asks the runner to end it there, so failing trials (most of them,
// and the long ones) cost a fraction of their length. The confirming run
// always runs its whole length, so that its rate is measured, not bounded.
//
// Search: the first trial at start_period; while every trial held, halve; while
// every trial failed, double; once one period failed and a longer one held,
// bisect on a logarithmic scale (the geometric mean, rounded to the
// resolution) until held / failed <= 1 + tolerance or the two are one
// resolution apart. The answer is the shortest period that held. It assumes
// the miss rate does not rise as the period grows; a machine that changes pace
// (a VM) can break that for a trial, so a confirming run at the answer repeats
// it, and both verdicts are reported.
//
// Budget: the trials and the confirming run together take at most budget_ns.
// Before each trial the search estimates its length (n x P + the median
// completion seen so far + the lead) and the confirming run's (the same at
// the shortest period that held so far, or P), and stops when both would not fit:
// the result then says the budget cut the search. The search never goes below
// floor_period or above ceiling_period, and says when it stopped at either.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace lockstep::bench::probes {

// The one-sided Clopper-Pearson upper bound on a rate, from `misses` in
// `periods` trials, at `confidence` in (0, 1): the p with
// P(X <= misses | periods, p) = 1 - confidence; 1 when misses == periods.
// Throws std::invalid_argument for periods == 0 or misses > periods.
double miss_rate_upper_bound(std::uint64_t misses, std::uint64_t periods, double confidence);

// The fewest periods with which zero misses can show a rate of at most
// `miss_rate` at `confidence`: ceil(ln(1 - confidence) / ln(1 - miss_rate)).
std::int64_t minimum_trial_periods(double miss_rate, double confidence);

// The most misses in `periods` periods that still hold `miss_rate` at
// `confidence` (-1 when even none would not).
std::int64_t allowed_misses(std::int64_t periods, double miss_rate, double confidence);

struct period_search_settings {
  double miss_rate = 1e-3;  // R
  double confidence = 0.95;
  std::int64_t trial_periods = 0;  // 0: minimum_trial_periods
  std::int64_t start_period_ns = 1'000'000;
  std::int64_t floor_period_ns = 10'000;
  std::int64_t ceiling_period_ns = 1'000'000'000;
  double tolerance = 0.05;
  std::int64_t resolution_ns = 1'000;  // every period tried is a multiple of this
  std::int64_t budget_ns = 120'000'000'000;
  std::int64_t lead_ns = 20'000'000;  // each run's start-up (paced_settings::lead_ns), for the estimates
};

// What a trial run reports back to the search.
struct trial_outcome {
  std::int64_t periods = 0;  // periods of the schedule run
  // Periods among them whose deadline passed without their step done: the
  // steps that overran, and the periods skipped after them (paced.hpp).
  std::uint64_t misses = 0;
  std::uint64_t skipped = 0;  // of which skipped
  double completion_p50_ns = 0;
  double completion_p99_ns = 0;
  std::int64_t elapsed_ns = 0;  // the run's own length, counted against the budget
};

struct period_trial {
  std::int64_t period_ns = 0;
  trial_outcome outcome;
  double miss_rate = 0;     // misses / periods
  double upper_bound = 0;   // miss_rate_upper_bound at the confidence
  bool holds = false;       // upper_bound <= R
};

struct period_search_result {
  std::int64_t trial_periods = 0;
  std::vector<period_trial> trials;              // in the order run (the confirming run not included)
  std::optional<std::int64_t> found_period_ns;   // the shortest period that held
  // The longest period that failed below found_period_ns (none held: the
  // longest that failed).
  std::optional<std::int64_t> failed_period_ns;
  std::optional<period_trial> confirm;           // the confirming run at found_period_ns
  bool budget_cut = false;
  // "converged", "budget", "floor" (held at floor_period), "ceiling" (failed at ceiling_period)
  std::string stopped_because;
  std::int64_t elapsed_ns = 0;  // every run, the confirming one included
};

// Runs a trial: the paced step at `period_ns` for `periods` periods, ended
// early (when set) once `stop_after_misses` periods have missed.
// `confirming` is true for the last call, the confirming run (never ended early).
using trial_runner = std::function<trial_outcome(std::int64_t period_ns, std::int64_t periods,
                                                 std::optional<std::uint64_t> stop_after_misses, bool confirming)>;
// Called after each trial (for progress lines); may be empty.
using trial_observer = std::function<void(const period_trial&, bool confirming)>;

// The search above. Throws std::invalid_argument for settings that cannot
// search (a rate outside (0, 1), a confidence outside (0, 1), trial_periods
// below minimum_trial_periods, floor > ceiling, a start outside them, a
// non-positive resolution, tolerance or budget).
period_search_result find_period(const period_search_settings& settings, const trial_runner& run,
                                 const trial_observer& observe = {});

// Why these settings cannot search (the messages find_period throws), or empty.
std::string period_search_problem(const period_search_settings& settings);

}  // namespace lockstep::bench::probes
