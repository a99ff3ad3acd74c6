#pragma once
// Where a run's results go: the progress reporter (stderr) that also feeds the
// run book, and Google Benchmark's JSON of the result file.
#include <benchmark/benchmark.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstddef>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "bench/results/derived_figures.hpp"
#include "bench/run/pace.hpp"
#include "bench/run/run_book.hpp"

namespace lockstep::bench {

// Google Benchmark's display reporter for `lockstep run`: records every
// entry's repetitions in the run book (how later entries read the in-run
// calibrations) and prints progress on stderr, nothing on stdout (the
// summary goes there at the end).
//
// Progress: with random interleaving (the default) an entry is complete only
// when its last repetition ran, which for most entries is near the end, so a
// count of complete entries says little until late. The time left is the
// plan's estimate (run_plan.hpp: estimate_run) less the time elapsed, until
// half of the entries are complete; from then on, the rate at which they
// complete. A line at most every kProgressEvery, from tick() (called after
// every call of an entry) or from a completed entry, and one at the end.
class progress_reporter : public benchmark::BenchmarkReporter {
 public:
  // `registered`: every entry's spec by its name, as registration recorded
  // them (Google Benchmark reports a run by the name alone).
  progress_reporter(run_book& book, const registered_entries& registered, std::size_t expected_entries,
                    double planned_s);

  bool ReportContext(const Context& context) override;
  void ReportRuns(const std::vector<Run>& runs) override;
  // After every call of an entry: a progress line when one is due.
  void tick();

  std::size_t finished() const noexcept { return finished_; }

 private:
  void line(bool force);

  run_book& book_;
  const registered_entries& registered_;
  std::size_t expected_;
  double planned_s_;
  std::size_t finished_ = 0;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_line_;
};
inline constexpr std::chrono::seconds kProgressEvery{10};

// "about 1 min 20 s left" from the plan's estimate and what is done: the
// estimate less the time elapsed while fewer than half of `total` are done,
// the observed rate after; past the estimate, "a little past the estimate".
std::string time_left(double elapsed_s, double planned_s, std::size_t done, std::size_t total);

// Google Benchmark's JSON of the run, the "context" and "benchmarks" of the
// result file, written once, when the run is over, from the runs Google
// Benchmark reported and lockstep completed in their typed form:
//   * Google Benchmark appends "/manual_time", "/real_time", "/iterations:N"
//     and "/repeats:N" to a name when an entry uses them; lockstep's names
//     carry only key:value segments (the timing is stated once, in the
//     context's lockstep_timing);
//   * a row with an ns_per_step or ns_per_episode counter (the team entries
//     and rk4/serial: team_driver.hpp, before measure_entry) gets it as its
//     real_time, and its cpu_ns_per_step or cpu_ns_per_episode as its
//     cpu_time: a repetition's own value, an aggregate row the counter's
//     aggregate (Google Benchmark computes both with the same statistic);
//   * the composed step's rows get vs_serial and vs_c2c from the whole run's
//     calibrations (derived_figures.hpp; either may be absent, and so then is
//     its ratio). Dividing by a constant scales a mean, a median and a
//     standard deviation alike; a coefficient of variation does not change,
//     so a cv row's ratio is its counter's cv;
//   * an iteration row gets its pace mode (pace.hpp: agreed_mode of the
//     readings around it) in place of the readings' indices, which leave
//     every row (an aggregate of a mode index or of readings means nothing);
//   * non-finite counter values (an all-zero counter's cv aggregate) are
//     omitted: Google Benchmark would write NaN, which no JSON parser accepts.
// Google Benchmark's JSONReporter writes its own fields (the format its
// tools/compare.py reads, as the installed version writes it; writing them
// again here would make a second writer of Google Benchmark's format); what
// a run cannot hold as the file states it, its entry's spec as values
// ("lockstep_entry") and its pace mode as an integer, run_document adds to
// the rows of that text, parsed once in memory; matrix_run.cpp adds
// lockstep's sections.
//
// Google Benchmark accepts a file reporter only with --benchmark_out, whose
// stream it opens and hands over before the run; this reporter keeps its own
// text instead (matrix_run.cpp passes /dev/null), so the result file is
// written whole, once, by atomic_result_file.
class result_json_reporter : public benchmark::JSONReporter {
 public:
  // Google Benchmark's context (its date is the run's start), kept as text.
  bool ReportContext(const Context& context) override;
  // Kept, to be completed and written by run_document.
  void ReportRuns(const std::vector<Run>& runs) override;
  void Finalize() override {}

  // The completed runs in Google Benchmark's JSON, each row with its
  // "lockstep_entry"; no "benchmarks" when no run was reported
  // (--benchmark_list_tests). Call once, when the run is over.
  nlohmann::json run_document(const run_book& book, const registered_entries& registered,
                              const pace_modes& modes);

 private:
  std::ostringstream text_;
  std::vector<Run> runs_;
};

// The run's name without Google Benchmark's suffixes (see above).
std::string plain_name(const benchmark::BenchmarkReporter::Run& run);

}  // namespace lockstep::bench
