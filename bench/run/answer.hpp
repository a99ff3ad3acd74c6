#pragma once
// The answer of a run, first and short: what `lockstep run` prints last, what
// the report prints first (reports/ reads it from the result file's
// "lockstep_answer"), made once, here, when the run is over, from the run
// book and the choices (choose_combinations: made once too, after the pairs;
// --crossover plans its series from the same choices, crossover_sweep.hpp).
//
// What it says (at most kAnswerLines lines, each whole: the terminal wraps
// them at 120 columns, the result file and the report keep them as they are):
//   * first, the best combination of the run and its step against the serial
//     step of the same model (best_choice);
//   * with --crossover, per thread count swept, from what model size the
//     parallel step pays off (crossover.hpp: crossover_lines);
//   * for each model, thread count and placement measured, the combination
//     to use: the primitive and layout whose step the paired comparisons put
//     first, its step time with its spread over repetitions, its stage
//     synchronisation in one-way core-to-core transfers (vs_c2c); then the
//     runner-up and std::barrier against it, as paired ratios with their
//     intervals and verdicts (the paper's question: what synchronisation
//     costs here);
//   * what false sharing costs: the known-answer probe per access pattern
//     (two threads' words on one line against 128 bytes apart, lockstep
//     falseshare's measurement, short), which patterns the step's layouts
//     exercise, and how many of the step's groups showed a penalty;
//   * what migration costs: the migrate probe's forced move and refill, and
//     how often the unpinned entries actually migrated; never a ratio of two
//     entries neither of which migrated;
//   * the machine's pace, what was left out (collapsed entries, not
//     applicable combinations, stalls) one line each, and where the results
//     are and how to read and compare them.
//
// Which combination is first: the one its pair with the runner-up puts first
// (the median leader, unless the pair's whole interval says the runner-up
// was faster side by side): pairs are measured side by side, medians a
// minute apart on a machine that changes pace. So the choice is never one
// its own pair calls slower. A pair that cannot tell the two apart (within
// noise, or unsure: the interval straddles an edge of the band) is a tie,
// and the line names both.
//
// Before the per-group lines, one line answers first: the fastest choice of
// the run (which thread count and placement) and its step against the serial
// step of the same model (best_choice). No pair compares choices across
// thread counts or placements, so one whose repetitions overlap the fastest's
// (its fastest repetition no slower than the fastest choice's slowest) is
// named beside it as a tie.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/results/paired_ratio.hpp"
#include "kernels/model_choice.hpp"
#include "platform/placement.hpp"
#include "platform/stats.hpp"

namespace lockstep::bench {

class run_book;
struct crossover_sweep;
struct pace_modes;

inline constexpr std::size_t kAnswerLines = 25;

// One other primitive set against the chosen one: the other's step over the
// chosen one's, paired (above 1: the other is slower).
struct answer_rival {
  std::string entry;
  std::string sync;
  std::string layout;
  ratio_estimate estimate;  // the other's step over the chosen one's
  ratio_verdict verdict = ratio_verdict::unsure;
};

// The combination to use at one model, thread count and placement.
struct answer_choice {
  kernels::model_choice model;  // the entry's model
  unsigned threads = 0;
  platform::placement pin = platform::placement::compact;
  std::string entry;
  std::string sync;
  std::string layout;
  double ns_per_step = 0.0;
  // The fastest and the slowest repetition's step (the median's when the
  // entry has none): whether two choices' repetitions overlap, and the spread.
  double fastest_ns = 0.0;
  double slowest_ns = 0.0;
  // Half the min..max range over repetitions, of the median.
  [[nodiscard]] double spread_pct() const noexcept {
    return ns_per_step > 0.0 ? (slowest_ns - fastest_ns) / 2.0 / ns_per_step * 100.0 : 0.0;
  }
  // The pace modes its repetitions ran in (run_book.hpp: by_pace_mode; 0
  // before the trace is analysed) and whether one straddled a change: a
  // spread over two paces is the machine's, not the combination's.
  std::size_t paces = 0;
  bool straddles_pace_change = false;
  std::optional<double> vs_c2c;     // stage sync in one-way core-to-core transfers
  // The CPUs the team kept busy: team_cpu_ns_per_step / ns_per_step (medians).
  std::optional<double> cpus_busy;
  bool oversubscribed = false;
  // "paired": the pair with the runner-up keeps the median order or puts
  // the runner-up first; "medians": no pair was measured (--pairs 0).
  std::string basis;
  std::string median_leader;        // the entry first by median (differs from `entry` when the pair overturned it)
  // The pair with the runner-up could not tell the two apart (within noise
  // or unsure): both are named, the pair's side first.
  bool tied = false;
  std::optional<answer_rival> runner_up;
  std::optional<answer_rival> baseline;  // kBaselinePrimitive against the choice
};

// The known answers measured beside the matrix (known_answers.cpp, briefly):
// the figures a user checks the step's own ratios against.
// One access pattern's false sharing (bench/probes/falseshare.hpp).
struct false_sharing_probe {
  std::string pattern;              // its name in probes::all_access_patterns
  std::string cpus;                 // "0,1"
  std::size_t sharing_stride = 0;   // bytes between the two threads' words
  std::size_t apart_stride = 0;
  ratio_estimate estimate;          // ns per access, sharing / apart, paired per repeat
  ratio_verdict verdict = ratio_verdict::unsure;
  std::size_t pairs = 0;
};
struct migration_probe {
  std::string cpus;                 // "0->1"
  std::size_t bytes = 0;            // the working set refilled after a move
  platform::distribution move;      // setaffinity until running on the other CPU
  platform::distribution refill;    // first pass after the move minus the next
};
struct known_answers {
  // Per access pattern measured, in the probe's table order (a pattern whose
  // penalty could not be paired is absent).
  std::vector<false_sharing_probe> false_sharing;
  std::string false_sharing_relation;     // hwloc's word for the probe's two CPUs ("shared L3"); empty: unknown
  std::string false_sharing_unavailable;  // why not, when none
  std::optional<migration_probe> migration;
  std::string migration_unavailable;
};

// A choice of another thread count or placement that the run does not
// separate from the best: no pair compares choices across groups, and their
// repetitions' ranges (median +- spread) overlap.
struct tied_choice {
  unsigned threads = 0;
  platform::placement pin = platform::placement::compact;
  std::string entry;
  double ns_per_step = 0.0;
};

// The run's best choice against the serial step of its model (medians of
// the two entries; vs_serial is the one derived figure, derived_figures.hpp).
// The best is the lowest median; the choices as good as far as the run can
// tell are named beside it (`level`), so that a tie is said as a tie.
struct best_choice {
  kernels::model_choice model;
  unsigned threads = 0;
  platform::placement pin = platform::placement::compact;
  std::string entry;
  double ns_per_step = 0.0;
  std::optional<double> serial_ns_per_step;
  std::optional<double> vs_serial;  // the choice's step / the serial step
  std::vector<tied_choice> level;  // by median
};

// An entry that lost repetitions to a stop (a stall, a lost wake-up, the
// call's budget): measured from the rest, named in the answer.
struct stopped_entry {
  std::string entry;
  std::size_t repetitions_stopped = 0;
  std::size_t repetitions = 0;  // measured and stopped
  std::string reason;
};

struct run_answer {
  // The fastest choice of the run's first model (the paper's two-mass system when measured).
  std::optional<best_choice> best;
  std::vector<answer_choice> choices;
  std::vector<stopped_entry> stopped;
  std::vector<std::string> collapsed;  // entry names
  known_answers probes;
  // --crossover: per thread count swept the crossover's line and the ceiling's (crossover.hpp:
  // crossover_lines), also among `lines`, after the answer-first line.
  std::vector<std::string> crossover;
  std::vector<std::string> lines;      // the text, at most kAnswerLines lines
};

// The combination to use per model, thread count and placement (the
// ranking's groups, in its order: bench/run/ranking.hpp), from the run's
// medians and pairs. Call once the pairs are measured and the pace modes
// assigned (the choice's paces read each repetition's mode).
std::vector<answer_choice> choose_combinations(const run_book& book);

// What the answer is made from besides the book and the choices.
struct answer_sources {
  known_answers probes;
  unsigned cpus = 0;             // the affinity set's size
  std::string result_path;       // where the JSON went
  const pace_modes* pace = nullptr;            // the run's pace modes, when the trace was analysed
  const crossover_sweep* crossover = nullptr;  // --crossover's sweep
};

// The answer: the best choice, the choices, what was left out, in at most
// kAnswerLines lines.
run_answer make_answer(const run_book& book, std::vector<answer_choice> choices, const answer_sources& sources);

// The lines for a terminal, each wrapped (below) at 120 columns; the result
// file and the report keep every line whole.
std::string answer_text(const run_answer& answer);

// A line wrapped at a word to `width` columns, ending in a newline;
// continuation lines are indented 4 past the line's own indent, and a word
// longer than the width stays whole (nothing is ever cut).
std::string wrapped(const std::string& line, std::size_t width);

// The result file's "lockstep_answer" (docs/schemas/run.schema.json; files
// before it call it "lockstep_headline").
nlohmann::json answer_json(const run_answer& answer);

}  // namespace lockstep::bench
