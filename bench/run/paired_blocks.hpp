#pragma once
// The paired comparisons of a run (paired_ratio.hpp says why pairs): which
// ratios the summary prints, and measuring each as alternating short blocks
// after the matrix has run.
//
// Which (plan_comparisons, from the matrix's medians; one place, which the
// summary reads too):
//   false_sharing       per primitive, placement and thread count: the layout
//                       whose writers share lines against the best layout
//                       that isolates them (layouts/registry.hpp: writer_isolation)
//   migration           per primitive and thread count whose unpinned entry
//                       migrated (migrations_per_kstep above 0), on its best pinned
//                       layout: pin:none against pin:compact
//   against_best_other  per placement and thread count, each primitive on its
//                       best layout against the leader (the fastest median) on
//                       its best layout, once per unordered pair; RK4 steps
//                       and bare episodes alike
// How (measure_pairs): both sides of every comparison are built once
// (block_runner); then, in `pairs` rounds, each round takes one pair of every
// comparison in a shuffled order: a pace reading, block A and block B (the
// order alternates, A B then B A, so that a drift within a pair cancels over
// pairs), ratio A / B, a reading. A block is a warm-up batch and a timed
// batch of about `block_ns` (from the entry's own batch size).
// Why rounds: the two blocks of a pair lie a few milliseconds apart, so they
// share the machine's pace; but a comparison's pairs taken back to back lie
// within a tenth of a second, and this VM keeps states that are not in the
// c2c reading (futex_spin's 2-thread step runs 10-25 % faster or slower for
// seconds at a time) for longer than that. Ten pairs from one such moment
// gave intervals of +-3 % around 1.09 in one run and 0.89 in the next. Spread
// over the pairing phase, the pairs sample those states, and the interval
// says how far the ratio moves with them.
#include <cstdint>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/results/paired_ratio.hpp"
#include "bench/run/pace.hpp"
#include "bench/run/ranking.hpp"
#include "bench/run/run_book.hpp"
#include "bench/run/team_driver.hpp"

namespace lockstep::bench {

struct pairing_settings {
  unsigned pairs = 10;               // 0: no paired comparisons
  std::int64_t block_ns = 1'000'000;  // one timed block
  double noise = kDefaultNoise;
  // A comparison stops taking pairs after this long, once it has
  // kMinPairs: a side whose one unit lasts a scheduler quantum (a pure
  // spinner with more threads than CPUs: tens of ms a step) would otherwise
  // take seconds per comparison. Its interval is wide, and says so.
  std::int64_t budget_ns = 200'000'000;
};
inline constexpr unsigned kMinPairs = 3;

// Collapse: a pure spinner with more threads than CPUs waits for a scheduler
// quantum at every stage, and its step lasts tens of milliseconds where the
// best primitive's lasts microseconds (measured on the 2-vCPU development VM:
// ck_* and seqlock at threads:4 took 16-60 ms a step, mailbox 5 us). Such an
// entry says one thing, that it collapses; ranked, paired or coloured beside
// the others it drowns them (ratios of 3,000x, colour scales stretched over
// four decades). An entry collapsed when it ran oversubscribed and its median
// is at least kCollapseFactor times the best median of its kind, model and
// thread count.
inline constexpr double kCollapseFactor = 100.0;
std::set<std::string> find_collapsed(const run_book& book);

// The comparisons the summary prints, from the run's medians (entries that
// measured without error and did not collapse; a comparison needs both
// sides). Each unordered pair is planned once: against_best_other sets every
// primitive of a group against the group's leader (the fastest median), and
// the leader's own line is the inverse of its pair with the runner-up
// (against_best_other_view), so the two directions cannot disagree.
std::vector<comparison> plan_comparisons(const run_book& book);

// One primitive's line in "each primitive against the best other": the pair
// as measured for every primitive but the leader, the inverse of the pair
// with the runner-up for the leader (inverted: true).
struct best_other_view {
  const captured_entry* entry = nullptr;  // this primitive's entry (the numerator)
  const captured_entry* other = nullptr;  // the best other primitive's entry
  const paired_result* pair = nullptr;  // the measured pair (numerator: `entry`, or `other` when inverted)
  bool inverted = false;
  ratio_estimate estimate;  // entry / other
  ratio_verdict verdict = ratio_verdict::unsure;
};
// The name of an against_best_other group ("RK4 step pin:compact threads:4",
// "bare episode pin:none threads:2"): the plan names its comparisons so, and
// the answer finds a group's pairs by it.
std::string against_best_other_group(entry_kind kind, platform::placement pin, unsigned threads);
// Every primitive's line of one against_best_other group, in the order of
// the plan (leader first); empty when the group has no measured pair.
std::vector<best_other_view> against_best_other_views(const run_book& book, const std::string& group);

// Measures every comparison whose sides have block runners; results go to
// book.pairs (a side that stalls gives a result with its failure).
// `progress(round, rounds)` is called after each round (one pair of every
// comparison still taking pairs): comparisons finish together, in the last
// round, so rounds are what measure progress.
void measure_pairs(harness_state& harness, const std::vector<comparison>& plan, const pairing_settings& settings,
                   const std::function<void(std::size_t, std::size_t)>& progress);

// After the trace is analysed: every repetition in the book gets "pace_mode"
// (the mode its before and after readings agree on, or -1), every pair its
// modes; the reading-index counters are removed.
void assign_pace_modes(run_book& book, const pace_modes& modes);

// The result file's "lockstep_pace" and "lockstep_pairs" (the contract with
// reports/; its rows get their pace modes in reporters.cpp).
void write_pace_and_pairs(nlohmann::json& result, const run_book& book, const pace_probe* probe,
                          const pace_modes& modes);

}  // namespace lockstep::bench
