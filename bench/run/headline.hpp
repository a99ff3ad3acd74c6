#pragma once
// The answer of a run, first and short: what `lockstep run` prints last, what
// the report prints first (reports/ reads it from the result file's
// "lockstep_headline"), derived once, here, from the run book.
//
// What it says (at most kHeadlineLines lines of at most about 120 characters):
//   * for each model, thread count and placement measured, the combination
//     to use: the primitive and layout whose step the paired comparisons put
//     first, its step time with its spread over repetitions, its stage
//     synchronisation in one-way core-to-core transfers (vs_c2c); then the
//     runner-up and std::barrier against it, as paired ratios with their
//     intervals and verdicts (the paper's question: what synchronisation
//     costs here);
//   * what false sharing costs: the known-answer probe (two writers on one
//     line against two lines apart, lockstep falseshare's measurement, short)
//     and how many primitives showed a penalty in the step;
//   * what migration costs: the migrate probe's forced move and refill, and
//     how often the unpinned entries actually migrated; never a ratio of two
//     entries neither of which migrated;
//   * the machine's pace, what was left out (collapsed entries, not
//     applicable combinations, stalls) one line each, and where the results
//     are and how to read and compare them.
//
// Which combination is first: the leader by median unless its paired
// comparison with the runner-up calls the runner-up faster ("gain"): pairs
// are measured side by side, medians a minute apart on a machine that
// changes pace. A pair within noise or unsure keeps the leader and says so.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/results/paired_ratio.hpp"
#include "platform/stats.hpp"

namespace lockstep::bench {

class run_book;

inline constexpr std::size_t kHeadlineLines = 25;

// One other primitive set against the chosen one: other / chosen, paired.
struct headline_rival {
  std::string entry;
  std::string sync;
  ratio_estimate estimate;  // the other's step over the chosen one's
  ratio_verdict verdict = ratio_verdict::unsure;
};

// The combination to use at one model, thread count and placement.
struct headline_choice {
  std::string model;  // the entry's model field; empty: the paper's two-mass system
  unsigned threads = 0;
  std::string pin;
  std::string entry;
  std::string sync;
  std::string layout;
  double ns_per_step = 0.0;
  double spread_pct = 0.0;          // half the min..max range over repetitions, of the median
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
  std::optional<headline_rival> runner_up;
  std::optional<headline_rival> baseline;  // kBaselinePrimitive against the choice
};

// The known answers measured beside the matrix (matrix_run.cpp, briefly):
// the figures a user checks the step's own ratios against.
struct false_sharing_probe {
  std::string cpus;                 // "0,1"
  std::size_t sharing_stride = 0;   // bytes between the two writers' counters
  std::size_t apart_stride = 0;
  ratio_estimate estimate;          // ns per write, sharing / apart, paired per repeat
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
  std::optional<false_sharing_probe> false_sharing;
  std::string false_sharing_unavailable;  // why not, when absent
  std::optional<migration_probe> migration;
  std::string migration_unavailable;
};

struct run_headline {
  std::vector<headline_choice> choices;
  std::vector<std::string> collapsed;  // entry names
  known_answers probes;
  std::vector<std::string> lines;      // the text, at most kHeadlineLines lines
};

// `cpus`: the affinity set's size; `result_path`: where the JSON went.
run_headline make_headline(const run_book& book, const known_answers& probes, unsigned cpus,
                           const std::string& result_path);

// The lines, each ending in a newline.
std::string headline_text(const run_headline& headline);

// The result file's "lockstep_headline" (docs/schemas/run.schema.json).
nlohmann::json headline_json(const run_headline& headline);

}  // namespace lockstep::bench
