// Progress and the run book's feed, and Google Benchmark's JSON of the result file (reporters.hpp).
#include "bench/run/reporters.hpp"

#include "bench/run/run_plan.hpp"
#include "bench/run/team_driver.hpp"

#include "bench/results/derived_figures.hpp"
#include "bench/results/entry_spec.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <fmt/core.h>

#include <array>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <initializer_list>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <stdexcept>

namespace lockstep::bench {


std::string plain_name(const benchmark::BenchmarkReporter::Run& run) {
  benchmark::BenchmarkName name = run.run_name;
  name.iterations.clear();
  name.repetitions.clear();  // "/repeats:N", on an entry with its own repetition count
  name.time_type.clear();
  return name.str();
}

namespace {

using Run = benchmark::BenchmarkReporter::Run;

// The time per unit in place of the batch's (an iteration is a batch:
// team_driver.hpp, before measure_entry), from the counter that holds it
// (for an aggregate, the counter's aggregate). JSONReporter writes a time as
// accumulated_time * multiplier / iterations, and a percentage aggregate
// (cv) as it is.
void set_times_per_unit(Run& run) {
  const bool percentage = run.run_type == Run::RT_Aggregate && run.aggregate_unit == benchmark::kPercentage;
  const auto per_unit = [&](std::initializer_list<const char*> counter_names, double& accumulated) {
    for (const char* counter_name : counter_names) {
      const auto counter = run.counters.find(counter_name);
      if (counter == run.counters.end() || !std::isfinite(counter->second.value)) continue;
      accumulated = percentage ? counter->second.value
                               : counter->second.value * 1e-9 * static_cast<double>(run.iterations);
      return;
    }
  };
  per_unit({"ns_per_step", "ns_per_episode"}, run.real_accumulated_time);
  // The CPU time per unit in place of the benchmark thread's own (which
  // only replayed the batch times).
  per_unit({"cpu_ns_per_step", "cpu_ns_per_episode"}, run.cpu_accumulated_time);
}

// vs_serial and vs_c2c on a composed step's row (run_book::derive_ratios
// does the same on the book's repetitions).
void set_derived_ratios(Run& run, const calibrations& calibration) {
  std::map<std::string, double> counters;
  for (const auto& [key, counter] : run.counters) counters[key] = counter.value;
  const bool coefficient_of_variation =
      run.run_type == Run::RT_Aggregate && run.aggregate_unit == benchmark::kPercentage;
  for (const derived_ratio& ratio : derived_ratios(counters, calibration))
    run.counters[ratio.name] = coefficient_of_variation ? counters.at(ratio.counter) : ratio.value;
}

// An iteration row's pace mode from the readings around it (empty for an
// aggregate: a mode of a mode index or of readings means nothing); the
// readings' indices leave every row.
std::optional<int> take_pace_mode(Run& run, const pace_modes& modes) {
  const auto before = run.counters.find(std::string(kPaceBeforeCounter));
  const auto after = run.counters.find(std::string(kPaceAfterCounter));
  std::optional<int> mode;
  if (run.run_type == Run::RT_Iteration && before != run.counters.end() && after != run.counters.end())
    mode = agreed_mode(modes, static_cast<std::size_t>(before->second.value),
                       static_cast<std::size_t>(after->second.value));
  run.counters.erase(std::string(kPaceBeforeCounter));
  run.counters.erase(std::string(kPaceAfterCounter));
  return mode;
}

// The "cv" aggregate of a counter that is 0 in every repetition is 0/0;
// Google Benchmark would write it as NaN, which is not JSON. Omitted.
void drop_non_finite(Run& run) {
  for (auto counter = run.counters.begin(); counter != run.counters.end();) {
    if (std::isfinite(counter->second.value)) {
      ++counter;
    } else {
      counter = run.counters.erase(counter);
    }
  }
}

}  // namespace

bool result_json_reporter::ReportContext(const Context& context) {
  // Google Benchmark pointed the streams at --benchmark_out's file: the text
  // stays here instead, until run_document.
  SetOutputStream(&text_);
  SetErrorStream(&text_);
  return JSONReporter::ReportContext(context);
}

void result_json_reporter::ReportRuns(const std::vector<Run>& runs) {
  runs_.insert(runs_.end(), runs.begin(), runs.end());
}

nlohmann::json result_json_reporter::run_document(const run_book& book, const registered_entries& registered,
                                                  const pace_modes& modes) {
  // Per run: its spec and its pace mode, which a run's counters (doubles,
  // as Google Benchmark writes them) cannot hold as the file states them.
  std::vector<std::pair<const entry_spec*, std::optional<int>>> rows;
  for (Run& run : runs_) {
    const auto spec = registered.find(plain_name(run));
    run.run_name.iterations.clear();
    run.run_name.repetitions.clear();
    run.run_name.time_type.clear();
    set_times_per_unit(run);
    if (spec != registered.end() && spec->second.is_parallel_step())
      set_derived_ratios(run, book.calibrations_for(spec->second.model));
    rows.emplace_back(spec == registered.end() ? nullptr : &spec->second, take_pace_mode(run, modes));
    drop_non_finite(run);
  }
  JSONReporter::ReportRuns(runs_);
  JSONReporter::Finalize();
  nlohmann::json document = nlohmann::json::parse(text_.str());
  // JSONReporter writes one row per run, in order.
  if (!document.contains("benchmarks") || document["benchmarks"].size() != rows.size()) return document;
  for (std::size_t index = 0; index < rows.size(); ++index) {
    nlohmann::json& row = document["benchmarks"][index];
    if (rows[index].first != nullptr) row["lockstep_entry"] = entry_json(*rows[index].first);
    if (rows[index].second) row["pace_mode"] = *rows[index].second;
  }
  return document;
}

progress_reporter::progress_reporter(run_book& book, const registered_entries& registered,
                                     std::size_t expected_entries, double planned_s)
    : book_(book),
      registered_(registered),
      expected_(expected_entries),
      planned_s_(planned_s),
      start_(std::chrono::steady_clock::now()),
      last_line_(start_) {}

std::string time_left(double elapsed_s, double planned_s, std::size_t done, std::size_t total) {
  if (total == 0 || done >= total) return "done";
  double left = planned_s - elapsed_s;
  if (2 * done >= total && done > 0)
    left = elapsed_s / static_cast<double>(done) * static_cast<double>(total - done);
  if (left < 1.0) return fmt::format("a little past the estimate of {}", format_seconds(planned_s));
  return "about " + format_seconds(left) + " left";
}

void progress_reporter::tick() {
  if (std::chrono::steady_clock::now() - last_line_ >= kProgressEvery) line(false);
}

void progress_reporter::line(bool force) {
  const auto now = std::chrono::steady_clock::now();
  if (!force && now - last_line_ < kProgressEvery) return;
  last_line_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const std::size_t total = std::max(expected_, finished_);
  fmt::print(stderr, "  {} elapsed, {} of {} entries complete, matrix: {}\n", format_seconds(elapsed), finished_, total,
             time_left(elapsed, planned_s_, finished_, total));
  std::fflush(stderr);
}

bool progress_reporter::ReportContext(const Context& /*context*/) { return true; }

void progress_reporter::ReportRuns(const std::vector<Run>& runs) {
  // Google Benchmark reports an entry's repetitions, then (separately) its
  // aggregates; the book recomputes aggregates, so only the first call counts.
  const bool any_repetition = std::any_of(runs.begin(), runs.end(), [](const Run& run) {
    return run.run_type == Run::RT_Iteration;
  });
  if (!any_repetition) return;
  captured_entry entry;
  // Repetitions carry their own name; aggregates are recomputed from them.
  for (const Run& run : runs) {
    if (run.run_type != Run::RT_Iteration) continue;
    entry.name = plain_name(run);
    if (run.error_occurred) {
      if (entry.error.empty()) entry.error = run.error_message;
      ++entry.stopped_repetitions;
      continue;
    }
    std::map<std::string, double> counters;
    for (const auto& [key, counter] : run.counters) counters[key] = counter.value;
    entry.repetitions.push_back(std::move(counters));
  }
  // The spec as registered: every run Google Benchmark reports is one of ours.
  entry.spec = registered_.at(entry.name);
  // Some repetitions measured, some stopped: the entry counts as measured
  // (its medians come from the measured ones), with its stopped repetitions
  // counted and their reason kept (the summary and the answer name it).
  if (!entry.error.empty() && !entry.repetitions.empty()) {
    entry.stop_reason = std::move(entry.error);
    entry.error.clear();
  } else {
    entry.stopped_repetitions = 0;  // every repetition stopped: the entry is skipped, with its error
  }
  ++finished_;
  line(finished_ >= expected_);
  book_.record(std::move(entry));
}

}  // namespace lockstep::bench
