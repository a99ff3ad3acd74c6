// The scaling curve (scaling.hpp).
#include "bench/run/scaling.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <map>
#include <set>

#include "bench/results/derived_figures.hpp"
#include "kernels/model_choice.hpp"

namespace lockstep::bench {

namespace {

// The placement the sweep held: compact when the run measured it, else the
// first one its rk4 entries name.
std::optional<platform::placement> held_pin(const run_book& book) {
  std::optional<platform::placement> first;
  for (const auto& entry : book.entries()) {
    if (entry.spec.kind != entry_kind::rk4 || !entry.error.empty()) continue;
    if (entry.spec.pin == platform::placement::compact) return entry.spec.pin;
    if (!first) first = entry.spec.pin;
  }
  return first;
}

}  // namespace

scaling_curve scaling_of(const run_book& book) {
  scaling_curve curve;
  const std::optional<platform::placement> pin = held_pin(book);
  if (pin) curve.pin = platform::to_string(*pin);
  // The sync time per stage where the run instrumented its steps; the step
  // time only when no entry has it (--no-accounting). An entry without it in
  // an instrumented run is left off the curve, not allowed to switch it.
  curve.counter = "ns_per_step";
  for (const auto& entry : book.entries())
    if (entry.spec.kind == entry_kind::rk4 && entry.error.empty() && entry.median("sync_ns_per_stage"))
      curve.counter = "sync_ns_per_stage";
  std::map<std::pair<std::string, unsigned>, scaling_point> best;
  std::set<unsigned> counts;
  for (const auto& entry : book.entries()) {
    if (entry.spec.kind != entry_kind::rk4 || !entry.error.empty() || entry.spec.pin != pin) continue;
    const auto figure = entry.median(curve.counter);
    if (!figure) continue;
    const unsigned threads = entry.spec.threads;
    counts.insert(threads);
    auto& point = best[{entry.spec.sync, threads}];
    const double current = curve.counter == "ns_per_step" ? point.ns_per_step : point.sync_ns_per_stage;
    if (!point.layout.empty() && current <= *figure) continue;
    point = {entry.spec.sync, threads, entry.spec.layout, entry.spec.model.name(),
             entry.median("sync_ns_per_stage").value_or(0.0), entry.median("ns_per_step").value_or(0.0),
             0.0, 0.0, entry.median("oversubscribed").value_or(0.0) > 0.5};
    const auto range = entry.range(curve.counter).value_or(std::pair{*figure, *figure});
    point.lowest = range.first;
    point.highest = range.second;
  }
  curve.threads.assign(counts.begin(), counts.end());
  for (auto& [key, point] : best) curve.points.push_back(std::move(point));
  if (curve.threads.size() < 2) return curve;
  const unsigned largest = curve.threads.back();
  std::map<std::string, std::size_t> measured_counts;
  for (const auto& point : curve.points) ++measured_counts[point.sync];
  std::optional<double> lowest;
  for (const auto& point : curve.points) {
    if (point.threads != largest || measured_counts[point.sync] != curve.threads.size()) continue;
    const double figure = curve.counter == "ns_per_step" ? point.ns_per_step : point.sync_ns_per_stage;
    if (!lowest || figure < *lowest) {
      lowest = figure;
      curve.best = point.sync;
    }
  }
  return curve;
}

std::string render_scaling(const scaling_curve& curve) {
  if (curve.threads.size() < 2) return {};
  const auto figure_of = [&](const scaling_point& point) {
    return curve.counter == "ns_per_step" ? point.ns_per_step : point.sync_ns_per_stage;
  };
  std::set<unsigned> oversubscribed;
  for (const auto& point : curve.points)
    if (point.oversubscribed) oversubscribed.insert(point.threads);
  std::string out = fmt::format(
      "\nScaling (pin:{}; {} against threads, each primitive on its best layout at each count; * oversubscribed: "
      "more threads than CPUs):\n  {:<22}",
      curve.pin, curve.counter == "ns_per_step" ? "step time" : "sync time per stage", "primitive");
  for (const unsigned threads : curve.threads)
    out += fmt::format(" {:>11}", std::to_string(threads) + (oversubscribed.count(threads) > 0 ? "*" : ""));
  out += "\n";
  std::map<std::string, std::map<unsigned, const scaling_point*>> rows;
  for (const auto& point : curve.points) rows[point.sync][point.threads] = &point;
  for (const auto& [sync, by_threads] : rows) {
    out += fmt::format("  {:<22}", sync);
    for (const unsigned threads : curve.threads) {
      const auto found = by_threads.find(threads);
      out += fmt::format(" {:>11}", found == by_threads.end() ? "-" : format_ns(figure_of(*found->second)));
    }
    out += "\n";
  }
  if (curve.best) {
    const unsigned first = curve.threads.front();
    const unsigned last = curve.threads.back();
    const scaling_point* at_first = rows[*curve.best][first];
    const scaling_point* at_last = rows[*curve.best][last];
    // The runner-up at the largest count, for how much the best leads by.
    const scaling_point* runner_up = nullptr;
    for (const auto& [sync, by_threads] : rows) {
      const auto found = by_threads.find(last);
      if (sync == *curve.best || found == by_threads.end() || by_threads.size() != curve.threads.size()) continue;
      if (runner_up == nullptr || figure_of(*found->second) < figure_of(*runner_up)) runner_up = found->second;
    }
    out += fmt::format("Scales best: {} ({} at {} threads{}, {:.1f}x its {}-thread figure, on layout {}", *curve.best,
                       format_ns(figure_of(*at_last)), last, at_last->oversubscribed ? ", oversubscribed" : "",
                       figure_of(*at_last) / figure_of(*at_first), first, at_last->layout);
    if (runner_up != nullptr) {
      out += fmt::format("; next {} at {}, {:.2f}x", runner_up->sync, format_ns(figure_of(*runner_up)),
                         figure_of(*runner_up) / figure_of(*at_last));
      if (runner_up->lowest <= at_last->highest)
        out += fmt::format(", within the spread of the repetitions ({}..{} against {}..{}): this run does not separate them",
                           format_ns(at_last->lowest), format_ns(at_last->highest), format_ns(runner_up->lowest),
                           format_ns(runner_up->highest));
    }
    out += ")\n";
  }
  return out;
}

nlohmann::json scaling_json(const scaling_curve& curve, std::optional<double> c2c_one_way_ns) {
  nlohmann::json points = nlohmann::json::array();
  for (const auto& point : curve.points)
    points.push_back({{"sync", point.sync},
                      {"threads", point.threads},
                      {"layout", point.layout},
                      {"model", point.model.empty() ? kernels::kTwoMassKey : point.model},
                      {"sync_ns_per_stage", point.sync_ns_per_stage},
                      {"ns_per_step", point.ns_per_step},
                      {"repetitions_min", point.lowest},  // of the counter
                      {"repetitions_max", point.highest},
                      {"oversubscribed", point.oversubscribed}});
  nlohmann::json result{{"pin", curve.pin}, {"counter", curve.counter}, {"threads", curve.threads},
                        {"points", points}};
  result["best"] = curve.best ? nlohmann::json(*curve.best) : nlohmann::json(nullptr);
  result["c2c_one_way_ns"] = c2c_one_way_ns ? nlohmann::json(*c2c_one_way_ns) : nlohmann::json(nullptr);
  return result;
}

}  // namespace lockstep::bench
