#pragma once
// `lockstep run` as one call: the matrix the selection names, measured with
// Google Benchmark (its runner and lockstep's reporters), then the paired
// comparisons and the pace trace, written into one result file. The command
// (bench/cli/run.cpp) turns its options into a matrix_request and prints what
// comes back (summary.hpp renders the run's result); the policy of a mode (how
// long an entry runs, how many pairs, how long a comparison may take) lives
// here, with the measured reasons for its numbers.
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/results/result_file.hpp"
#include "bench/run/crossover_sweep.hpp"
#include "bench/run/run_book.hpp"
#include "bench/run/run_plan.hpp"
#include "bench/run/run_result.hpp"
#include "platform/topology.hpp"

namespace lockstep::bench {

// The mode's defaults (bench/run/run_book.hpp, run_settings): how long each entry runs.
inline constexpr int kDefaultRepetitions = 5;
inline constexpr int kQuickRepetitions = 3;
inline constexpr const char* kDefaultMinTime = "40ms";
inline constexpr const char* kQuickMinTime = "5ms";
// Paired comparisons (paired_blocks.hpp): pairs per comparison and the timed
// block. Blocks of about 1 ms (0.5 ms quick) put both sides of a pair within
// a few milliseconds of each other; the development VM keeps a pace for
// seconds at least, so a pair straddles a change rarely (the trace says when).
inline constexpr int kDefaultPairs = 10;
inline constexpr int kQuickPairs = 6;
inline constexpr std::int64_t kDefaultBlockNs = 1'000'000;
inline constexpr std::int64_t kQuickBlockNs = 500'000;
// A comparison's time budget (after its first kMinPairs pairs): about 60 ms
// buys the default pairs of two fast sides; 174 comparisons of the default
// matrix then fit in about half a minute.
inline constexpr std::int64_t kDefaultPairBudgetNs = 150'000'000;
inline constexpr std::int64_t kQuickPairBudgetNs = 50'000'000;


// A request that cannot run (a Google Benchmark flag it does not know, a flag
// that would take over the result file); what() is one line for the user.
class matrix_request_error : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

struct matrix_request {
  run_selection selection;
  bool quick = false;                // the quick mode's defaults
  int repetitions = 0;               // 0: the mode's default
  std::int64_t min_time_ns = 0;      // 0: the mode's default
  bool accounting = true;            // per-thread accounting and sync-time instrumentation
  bool scaling = false;              // the thread sweep (its JSON block and summary)
  bool interleave = true;            // Google Benchmark's random interleaving
  int pairs = -1;                    // pairs per paired comparison; -1: the mode's default
  double noise = kDefaultNoise;      // the noise band (a fraction)
  std::vector<std::string> benchmark_flags;  // Google Benchmark's own, after --
  // --crossover: the sweep after the matrix (crossover_sweep.hpp); empty: none.
  std::optional<crossover_settings> crossover;
  int run_index = 0;                 // --runs: this run's index, 1..runs (0: a run on its own)
  int runs = 0;                      // --runs: how many runs the group holds (0: a run on its own)
};

// --plan: what the run would measure and how long it would take, from the
// entries registered exactly as a run registers them; nothing is measured.
std::string plan_text(const matrix_request& request, const platform::topology& machine);

// Measures the matrix, the paired comparisons and the pace trace (and with
// --crossover the sweep), makes the answer, writes the result into
// `result_file` (committed) and returns what the summary renders. Throws
// matrix_request_error before measuring anything on a request that cannot run.
run_result run_matrix(const matrix_request& request, const platform::topology& machine,
                      atomic_result_file& result_file);

}  // namespace lockstep::bench
