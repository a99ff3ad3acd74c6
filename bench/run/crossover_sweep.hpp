#pragma once
// `lockstep run --crossover`: after the matrix, from what model size a
// parallel step pays off here (crossover.hpp finds it in what this measures).
//
// Which series: for each thread count above 1 the run measured, at
// pin:compact (or the run's first placement there when compact was not
// measured), the run's choice at that thread count (the answer's, on its
// layout), the rival tied with it when the answer names a tie (both lead:
// a tie at the matrix's size says nothing of other sizes), and std::barrier,
// the C++20 baseline (sync::kBaselinePrimitive), on its best layout there
// (the lowest median); the baseline once when it is the choice or the rival.
//
// How: S = 2, 4, 8, ... masses (kernels/model_choice.hpp: the chain, as
// --masses S builds it), at each S the chain's parallel step of every series
// still going paired with the serial step of the same chain
// (rk4/model:chainS/serial) by the run's paired machinery (paired_blocks.hpp:
// measure_pairs, a comparison of kind crossover: serial / parallel, the
// speedup), in rounds of alternating blocks. The sides run with accounting
// on: a pair in which another process took a CPU of either side (its threads
// waited on a run queue for more than 1 % of the block: paired_blocks.cpp,
// kCpuTakenShare) is set aside and counted, never averaged in; a point with
// more threads than CPUs is marked oversubscribed instead, without that check
// (its waits are its own team's).
//
// When a series stops: two points in a row with the whole interval above 1
// (the crossover confirmed; with through_masses, not before that size), the
// largest size (max_masses), or the sweep's
// budget (whichever comes first; the budget covers the whole sweep, every
// series, and is checked before each size).
//
// The machine's ceiling beside the series (crossover.hpp, crossover_ceiling):
// at each size where a series of a thread count was measured, one more pair
// in the same rounds, the serial step against the chain's blocks stepped at
// once on the series' placement with no exchange and no sync
// (rk4_entries.hpp, chain_split_runner): what the machine gives an even split
// with no sync to pay.
//
// The model beside each point: serial_ns / threads + kernels::kRk4Stages x the
// stage sync the run measured for the series' entry at its thread count
// (its sync_ns_per_stage median, rk4_entries.hpp), the step of a perfectly
// shared chain whose synchronisation costs what the matrix measured.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "bench/run/crossover.hpp"
#include "bench/run/answer.hpp"
#include "bench/run/paired_blocks.hpp"
#include "bench/run/run_book.hpp"
#include "bench/run/team_driver.hpp"

namespace lockstep::bench {

// The sweep's defaults: at most 2 minutes on the 2-vCPU development VM, up
// to 65536 masses (131072 equations; a serial step of about a millisecond
// there), 48 pairs of 4 ms blocks per point. With 16, the leader's speedup
// interval at 4096 masses on 2 threads was 9-13 % of its median wide in two
// runs of four and 37-59 % in the other two (low ends 1.43 and 0.95 under
// medians of 1.50 and 1.35: the VM changed pace during the point); with 48 it
// was 5-15 % wide in five runs interleaved with those, for about 3x the
// sweep's time (31-35 s through 4096 masses instead of 10-13 s).
inline constexpr std::int64_t kCrossoverBudgetNs = 120'000'000'000;
inline constexpr std::size_t kCrossoverMaxMasses = 65536;
inline constexpr std::size_t kCrossoverFirstMasses = 2;  // the paper's two masses
inline constexpr unsigned kCrossoverPairs = 48;
inline constexpr std::int64_t kCrossoverBlockNs = 4'000'000;
// A point whose interval is wider than this share of its median takes another
// batch of `pairs` pairs, up to kCrossoverMoreBatches more (the estimate over
// all of them): the VM changing pace during a point widens it, and a later
// batch in a steadier spell narrows it. Interleaved on the AMD guest, three
// runs each way through 4096 masses on 2 threads: a series' median interval
// width over its points 5-10 % of the median with the batches, 12-29 %
// without (widest points 13-29 % against 39-83 %); the sweep took 52-68 s
// instead of 44-47 s.
inline constexpr double kCrossoverWideShare = 0.10;
inline constexpr unsigned kCrossoverMoreBatches = 2;
// Points in a row whose whole interval is above 1 that stop a series.
inline constexpr unsigned kCrossoverClearPoints = 2;

struct crossover_settings {
  std::int64_t budget_ns = kCrossoverBudgetNs;
  std::size_t max_masses = kCrossoverMaxMasses;
  // A series confirmed below this size goes on up to it (0: it stops once
  // confirmed): the speedup at a size of interest, measured the same way.
  std::size_t through_masses = 0;
  unsigned pairs = kCrossoverPairs;
  std::int64_t block_ns = kCrossoverBlockNs;
  double noise = kDefaultNoise;
};

// Whether a measured pair's interval is wider than kCrossoverWideShare of
// its median: the sweep then takes another batch of its pairs.
bool interval_too_wide(const paired_result& pair);
// A later batch of the same comparison added to `into`: its pairs (kept and
// set aside) appended, the estimate and verdict made again over them all.
void add_batch(paired_result& into, const paired_result& more, double noise);

// The series (above) from the run book and the answer's choices; the
// points are empty.
std::vector<crossover_series> plan_crossover_series(const run_book& book, const std::vector<answer_choice>& choices);

// For --plan: the series a run of these thread counts would sweep (up to three a
// thread count above 1) and the ceilings beside them (one a thread count),
// and its time: every series to the largest size (a series that confirms its
// crossover stops earlier), at most the budget.
double estimate_crossover_s(std::size_t series, std::size_t ceilings, const crossover_settings& settings);

// Measures the series (the harness's block runners and units are added to);
// `progress(masses, elapsed_s)` after each size.
crossover_sweep sweep_crossovers(harness_state& harness, std::vector<crossover_series> series,
                                 const crossover_settings& settings,
                                 const std::function<void(std::size_t, double)>& progress);

}  // namespace lockstep::bench
