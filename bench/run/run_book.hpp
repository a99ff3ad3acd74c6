#pragma once
// The measurement harness behind `lockstep run`, its lowest file: what one
// run selects, what the run has measured so far (each entry as registered,
// bench/results/entry_spec.hpp, with its repetitions; the in-run
// calibrations the entries divide by; the pairs), and how one call of an
// entry drives a team of participants through timed batches. What the run
// derives from the book (the pace modes, the crossover, the answer) lives
// above it (run_result.hpp).
//
// Timing model (every entry but c2c):
//   * Google Benchmark runs each entry with manual time. One benchmark
//     iteration is one *batch*: `units_per_batch` RK4 steps (or barrier
//     episodes) run back to back by the whole team.
//   * The team is created and pinned once per call of the entry function, then
//     runs every batch of that call without leaving its threads: between
//     batches the participants meet at a harness barrier (std::barrier) whose
//     completion step, run by exactly one thread while all others wait, reads
//     the clock and decides whether to go on. So a batch's time runs from the
//     instant the last participant finished the previous batch to the instant
//     the last one finished this batch: start-up, pinning and the accounting
//     snapshots fall outside it; the harness barrier adds one episode per batch
//     (at most a few tenths of a percent with the batch sizes below).
//   * Why manual time and not real time: the benchmark thread only starts and
//     joins the team; what it could time includes thread creation and the
//     wake-up of a sleeping team. Why not CPU time: the work is on other
//     threads, and a spinning wait burns CPU that is not work.
//   * The first batch of every call is a warm-up and is not reported.
//
// Bounds (a stalled combination must not hold the run):
//   * The completion step stops the call when a batch took longer than the
//     stall bound per unit, or when the call has run longer than its budget;
//     the entry is then skipped with the reason (SkipWithError) and the run
//     goes on.
//   * A call can only stop between batches: a primitive that never completes
//     a phase would hold the run; the primitives in sync/ always make progress
//     (pure spinners through preemption, the paper's ThreadWaiter through its
//     timeout), slowly, and the bound catches the slowness.
#include <barrier>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "bench/results/derived_figures.hpp"
#include "bench/results/entry_spec.hpp"
#include "bench/results/paired_ratio.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"

namespace lockstep::bench {

// What one run registers (from `lockstep run`'s filters).
struct run_selection {
  std::vector<std::string> syncs;
  std::vector<std::string> layouts;
  std::vector<platform::placement> pins;
  std::vector<unsigned> threads;
  // --masses (kernels/model_choice.hpp): empty, each thread count's own model.
  std::optional<std::size_t> masses;
};

// How hard the harness works per entry.
struct run_settings {
  // Per-thread accounting (context switches, migrations) and the step's
  // sync-time instrumentation. Off: those counters are absent.
  bool accounting = true;
  // Register the harness-overhead pair (accounting off / on, same
  // combination, side by side).
  bool overhead_pair = true;
  // Repetitions of each side of that pair (0: the run's): the ratio it is
  // read for is a few percent, below the spread of a handful of repetitions.
  int overhead_repetitions = 0;
  // A batch should last about this long: long enough that the harness
  // barrier and two clock reads per batch vanish, short enough that Google
  // Benchmark can fit many batches into its minimum time.
  std::int64_t target_batch_ns = 2'000'000;
  // Timed batches per repetition: the run's minimum time in batches of the
  // target (matrix_run.cpp sets it from --min-time), given to Google
  // Benchmark as the entry's iteration count (team_driver.hpp: size_entry).
  // Left to size the count itself, Google Benchmark spends a first call of
  // one batch and one of ten on each entry and then aims at 1.4 times the
  // minimum time: the default run's repetitions held about 28 batches of
  // 2 ms for a minimum of 40 ms.
  unsigned timed_batches = 20;
  // A step (or episode) slower than this is a stall: four orders of magnitude
  // above any healthy combination (microseconds), below the paper's 1000 ms
  // timeout, so a lost wake-up is caught at its first occurrence.
  std::int64_t stall_unit_ns = 50'000'000;
  // One call of an entry stops after this long (the run goes on).
  std::int64_t call_budget_ns = 3'000'000'000;
};

// An entry's time per unit in the pace modes its repetitions ran in.
struct pace_mode_time {
  int mode = 0;  // an index into the run's pace modes (pace.hpp)
  double median = 0.0;
  std::size_t repetitions = 0;
};
struct pace_mode_times {
  std::vector<pace_mode_time> modes;  // by mode
  std::size_t straddling = 0;         // repetitions that straddled a change of pace
};

// One entry as the run saw it: its spec (as registered: bench/results/entry_spec.hpp),
// its name, and the counters of each repetition (aggregates are recomputed
// from these, never read back).
struct captured_entry {
  entry_spec spec;
  std::string name;  // spec.name(): the entry's identity in the book, the pairs and the file
  std::vector<std::map<std::string, double>> repetitions;
  std::string error;  // non-empty: skipped, with the reason
  // Repetitions that stopped (stalled, lost wake-ups, out of budget) while
  // others were measured: the entry's figures come from the measured ones.
  std::size_t stopped_repetitions = 0;
  std::string stop_reason;  // the first stopped repetition's

  // The median over repetitions of one counter, or empty if no repetition has it.
  std::optional<double> median(std::string_view counter) const;
  // min and max over repetitions (empty as above).
  std::optional<std::pair<double, double>> range(std::string_view counter) const;
  // The median of the entry's time per unit (its spec's time_counter: a step, an episode, a transfer).
  std::optional<double> median_time() const { return median(spec.time_counter()); }
  // The entry's time per unit in each pace mode its repetitions ran in
  // (their "pace_mode" counter, set once the run's trace is analysed: -1, the
  // repetition straddles a change): the one per-mode median, which the
  // summary, the answer and the file's lockstep_pace.entry_medians read.
  // Empty before the analysis.
  pace_mode_times pace_medians() const;
};

// The entries a run registered, by name (the name Google Benchmark reports
// a run under: entry_spec::name).
using registered_entries = std::map<std::string, entry_spec>;

// A combination that was not registered, and why.
struct skipped_combination {
  std::string name;
  std::string reason;
};

// What the run knows so far. Written by the reporter as entries finish (the
// benchmark thread), read by later entries (the same thread).
class run_book {
 public:
  void record(captured_entry entry);
  const std::vector<captured_entry>& entries() const noexcept { return entries_; }
  const captured_entry* find(const std::string& name) const;
  // Visits every repetition's counters (to add what is known after the run).
  template <class Visit>
  void for_each_repetition(Visit&& visit) {
    for (captured_entry& entry : entries_)
      for (auto& repetition : entry.repetitions) visit(repetition);
  }

  // In-run calibrations: medians of c2c/pin:compact/threads:2 (one_way_ns)
  // and rk4/serial (ns_per_step), once they ran.
  std::optional<double> c2c_one_way_ns() const;
  // Each model's step has its own serial calibration (rk4/model:chainS/serial).
  std::optional<double> serial_step_ns(const kernels::model_choice& model = {}) const;
  // Both, for an entry of this model.
  calibrations calibrations_for(const kernels::model_choice& model) const;

  // Adds the derived ratios (derived_figures.hpp: vs_serial, vs_c2c)
  // (sync_ns_per_stage / c2c_one_way_ns) to every repetition of the rk4 and
  // overhead entries, from the whole run's calibrations. Called once, after
  // the run: derived at the end, the ratios do not depend on the order the
  // entries ran in (Google Benchmark's random interleaving may run a
  // calibration's repetitions last), and every entry divides by the same figure.
  void derive_ratios();

  // The median cost of one clock reading on this machine, measured when the
  // run starts (platform::clock_read_cost_ns); taken off every timed sync span.
  double clock_read_ns = 0.0;
  std::vector<skipped_combination> not_applicable;
  std::vector<std::string> notes;  // one line each, for the summary and the context
  bool scaling = false;            // --scaling: the summary shows the curve (scaling.hpp)
  // The comparisons planned after the matrix (paired_blocks.hpp:
  // plan_comparisons), measured or not, and those measured, in plan order.
  std::vector<comparison> planned;
  std::vector<paired_result> pairs;
  double noise = kDefaultNoise;    // the band their verdicts use
  // Entries that collapsed (paired_blocks.hpp: find_collapsed): reported in a
  // line, kept out of rankings, paired comparisons and colour scales.
  std::set<std::string> collapsed;
  unsigned cpus = 0;  // the affinity set the run measured on

 private:
  std::vector<captured_entry> entries_;
};

// The per-call record of the batch driver below.
struct batch_record {
  std::vector<std::int64_t> batch_ns;  // one per timed batch (the warm-up excluded)
  std::uint64_t units_per_batch = 0;
  std::uint64_t units_run = 0;         // every unit, warm-up included
  bool stalled = false;                // a batch exceeded the stall bound per unit
  bool over_budget = false;            // the call ran out of time
  std::int64_t slowest_unit_ns = 0;    // the slowest batch's time per unit
};

// The completion step of the harness barrier: one thread, all others waiting.
// Decides for everyone whether another batch runs; the decision is published
// by the barrier itself (completion happens-before every participant's return
// from arrive_and_wait), so the flag needs no atomic.
//
// `warmed_up`, when given, runs in the completion step that ends the warm-up
// batch: every participant has arrived (its writes happen-before the
// completion) and none has started the first timed batch, so it may read
// what the participants accumulated, without atomics, as the baseline of the
// timed batches. It gets the size of the timed batches to come. It must not
// throw or block.
class batch_clock {
 public:
  batch_clock(unsigned timed_batches, std::uint64_t units_per_batch, const run_settings& settings,
              std::function<void(std::uint64_t units_per_batch)> warmed_up = {})
      : wanted_(timed_batches),
        units_per_batch_(units_per_batch),
        settings_(settings),
        warmed_up_hook_(std::move(warmed_up)) {
    record_.units_per_batch = units_per_batch;
    record_.batch_ns.reserve(timed_batches);
  }

  // Called by the barrier's completion: at the start line, then after every batch.
  void on_all_arrived() noexcept {
    const std::int64_t now = platform::now_ns();
    if (!started_) {
      started_ = true;
      start_ns_ = last_ns_ = now;
      stop_ = wanted_ == 0;
      return;
    }
    const std::int64_t batch = now - last_ns_;
    last_ns_ = now;
    record_.units_run += units_per_batch_;
    const std::int64_t per_unit = batch / static_cast<std::int64_t>(units_per_batch_);
    if (per_unit > record_.slowest_unit_ns) record_.slowest_unit_ns = per_unit;
    if (warmed_up_) {
      record_.batch_ns.push_back(batch);  // capacity reserved: no allocation here
    } else {
      warmed_up_ = true;
      if (warmed_up_hook_) warmed_up_hook_(units_per_batch_);
    }
    if (per_unit > settings_.stall_unit_ns) {
      record_.stalled = true;
      stop_ = true;
    } else if (now - start_ns_ > settings_.call_budget_ns) {
      record_.over_budget = true;
      stop_ = true;
    } else {
      stop_ = record_.batch_ns.size() >= wanted_;
    }
  }

  // Read by every participant after the barrier returns.
  bool stop() const noexcept { return stop_; }
  std::uint64_t units_per_batch() const noexcept { return units_per_batch_; }
  const batch_record& record() const noexcept { return record_; }

 private:
  unsigned wanted_;
  std::uint64_t units_per_batch_;
  const run_settings& settings_;
  std::function<void(std::uint64_t)> warmed_up_hook_;
  batch_record record_;
  bool started_ = false;
  bool warmed_up_ = false;
  bool stop_ = false;
  std::int64_t start_ns_ = 0;
  std::int64_t last_ns_ = 0;
};

struct batch_completion {
  batch_clock* clock;
  void operator()() noexcept { clock->on_all_arrived(); }
};

// The harness barrier: every participant calls run_batches(self-work) and the
// work runs batch by batch until the clock says stop. `work(units)` runs that
// many steps (or episodes) for the calling participant.
class batch_gate {
 public:
  batch_gate(unsigned participants, batch_clock& clock) : clock_(clock), barrier_(participants, {&clock}) {}

  template <class Work>
  void run_batches(Work&& work) {
    barrier_.arrive_and_wait();  // start line
    while (!clock_.stop()) {
      work(clock_.units_per_batch());
      barrier_.arrive_and_wait();
    }
  }

 private:
  batch_clock& clock_;
  std::barrier<batch_completion> barrier_;
};

// How many units a batch should hold, from a probe's time per unit: at
// least one, at most kMaxUnitsPerBatch (a broken clock reading of 0 ns must
// not make a batch endless).
inline constexpr std::uint64_t kMaxUnitsPerBatch = 1'000'000;
std::uint64_t units_for_batch(double unit_ns, const run_settings& settings);

// Splits "a,b,c" into its items (empty items dropped).
std::vector<std::string> split_list(const std::string& text);

}  // namespace lockstep::bench
