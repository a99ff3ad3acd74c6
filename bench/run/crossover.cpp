// The crossover finder (crossover.hpp).
#include "bench/run/crossover.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>

#include "kernels/rk4.hpp"

namespace lockstep::bench {

namespace {

using speedup_of = std::function<double(const ratio_estimate&)>;

// The index of the last point whose value rises above 1 from at or below 1
// at the point before; empty when the value never rises.
std::optional<std::size_t> last_rise(const std::vector<crossover_point>& points, const speedup_of& value) {
  std::optional<std::size_t> rise;
  for (std::size_t index = 1; index < points.size(); ++index)
    if (value(points[index - 1].speedup) <= 1.0 && value(points[index].speedup) > 1.0) rise = index;
  return rise;
}

// Where the value crosses 1 between points rise - 1 and rise: log value
// linear in log masses.
double interpolated(const std::vector<crossover_point>& points, std::size_t rise, const speedup_of& value) {
  const crossover_point& below = points[rise - 1];
  const crossover_point& above = points[rise];
  const double y0 = std::log(std::max(value(below.speedup), 1e-300));
  const double y1 = std::log(std::max(value(above.speedup), 1e-300));
  const double x0 = std::log(below.masses);
  const double x1 = std::log(above.masses);
  const double fraction = y1 > y0 ? std::clamp(-y0 / (y1 - y0), 0.0, 1.0) : 1.0;
  return std::exp(x0 + fraction * (x1 - x0));
}

bool all_above_one(const std::vector<crossover_point>& points, const speedup_of& value) {
  return std::all_of(points.begin(), points.end(), [&](const crossover_point& point) { return value(point.speedup) > 1.0; });
}

// Which end of S*'s interval end_crossing finds.
enum class interval_end { low, high };

// One end of S*'s interval, from one end of the speedup's: empty when the
// grid does not reach it (the end above 1 from the first point, or not above 1
// at the last point). Where that end rises between measured sizes more than
// one doubling apart (the sizes between had every pair set aside), the
// interpolation is a guess over the gap: the end is the gap's own (the size
// below for the low end, the one above for the high end).
std::optional<double> end_crossing(const std::vector<crossover_point>& points, const speedup_of& value,
                                   interval_end end) {
  if (points.empty() || all_above_one(points, value) || !(value(points.back().speedup) > 1.0)) return std::nullopt;
  const auto rise = last_rise(points, value);
  if (!rise) return std::nullopt;
  const double below = points[*rise - 1].masses;
  const double above = points[*rise].masses;
  if (above > 2.0 * below * (1.0 + 1e-9)) return end == interval_end::low ? below : above;
  return interpolated(points, *rise, value);
}

}  // namespace

std::string_view to_string(crossover_status status) noexcept {
  switch (status) {
    case crossover_status::crossed: return "crossed";
    case crossover_status::crossed_unconfirmed: return "crossed_unconfirmed";
    case crossover_status::none_within_sweep: return "none_within_sweep";
    case crossover_status::always: return "always";
  }
  return "none_within_sweep";
}

crossover_estimate find_crossover(const std::vector<crossover_point>& points) {
  const speedup_of median = [](const ratio_estimate& estimate) { return estimate.median; };
  const speedup_of low = [](const ratio_estimate& estimate) { return estimate.low; };
  const speedup_of high = [](const ratio_estimate& estimate) { return estimate.high; };
  crossover_estimate found;
  if (points.empty()) return found;
  const auto first_confirming = [&](double above) -> std::optional<double> {
    for (const auto& point : points)
      if (point.masses > above && point.speedup.low > 1.0) return point.masses;
    return std::nullopt;
  };
  if (all_above_one(points, median)) {
    found.status = crossover_status::always;
    found.masses = points.front().masses;
    // Below the grid, at most the first point; the interval's upper end is
    // where its low end clears 1.
    found.high = points.front().speedup.low > 1.0 ? std::optional<double>(points.front().masses)
                                                  : end_crossing(points, low, interval_end::high);
    found.confirmed_at = points.front().speedup.low > 1.0 ? std::optional<double>(points.front().masses)
                                                          : first_confirming(points.front().masses);
    return found;
  }
  const auto rise = last_rise(points, median);
  if (!rise) return found;  // none within the sweep
  const double crossing = interpolated(points, *rise, median);
  found.masses = crossing;
  found.low = end_crossing(points, high, interval_end::low);
  found.high = end_crossing(points, low, interval_end::high);
  // The interval holds its estimate (interpolations of three curves on a
  // coarse grid can cross each other).
  if (found.low) found.low = std::min(*found.low, crossing);
  if (found.high) found.high = std::max(*found.high, crossing);
  for (std::size_t index = *rise; index < points.size(); ++index)
    if (!(points[index].speedup.median > 1.0)) {
      found.contradicted_at = points[index].masses;
      break;
    }
  if (!found.contradicted_at) found.confirmed_at = first_confirming(crossing);
  found.status = found.confirmed_at ? crossover_status::crossed : crossover_status::crossed_unconfirmed;
  return found;
}

std::vector<crossover_point> crossover_points(const crossover_series& series) {
  std::vector<crossover_point> points;
  for (const auto& point : series.points)
    if (point.measured()) points.push_back({static_cast<double>(point.masses), point.speedup});
  return points;
}

namespace {

std::string masses_text(double masses) { return fmt::format("{:.0f}", masses); }

// "[1100, 1900]", an open end said in words.
std::string interval_text(const crossover_estimate& found, const crossover_series& series) {
  const auto measured = crossover_points(series);
  const std::string low = found.low ? masses_text(*found.low)
                                    : "below " + masses_text(measured.empty() ? 0.0 : measured.front().masses);
  const std::string high = found.high ? masses_text(*found.high)
                                      : "beyond " + masses_text(measured.empty() ? 0.0 : measured.back().masses);
  return fmt::format("[{}, {}]", low, high);
}

std::string equations_text(double masses, unsigned threads) {
  return fmt::format("{:.0f} equations a thread", 2.0 * masses / static_cast<double>(threads));
}

// Why a series stopped, in words.
std::string stop_words(const std::string& reason) {
  if (reason == "confirmed") return "two points in a row clear of 1";
  if (reason == "budget") return "the sweep's budget ran out";
  if (reason == "largest_size") return "the largest size";
  return reason;
}

// One series in the line, by `name`: the first of a thread count says what
// it means in full, the others follow in short.
std::string series_text(const crossover_series& series, const std::string& name, bool first) {
  const crossover_estimate& found = series.crossover;
  const auto measured = crossover_points(series);
  switch (found.status) {
    case crossover_status::crossed:
      return fmt::format("{} {}from about {} {}{} ({})", name, first ? "pays off " : "",
                         masses_text(*found.masses), first ? "masses " : "", interval_text(found, series),
                         equations_text(*found.masses, series.threads));
    case crossover_status::crossed_unconfirmed: {
      std::string why = "no point above it clears 1 with its whole interval";
      if (found.contradicted_at) {
        for (const auto& point : measured)
          if (point.masses == *found.contradicted_at)
            why = fmt::format("at {} masses it falls back to {:.2f}x [{:.2f}, {:.2f}]", masses_text(point.masses),
                              point.speedup.median, point.speedup.low, point.speedup.high);
      }
      return fmt::format("{} crosses 1 at about {} masses {} ({}), unconfirmed: {}", name,
                         masses_text(*found.masses), interval_text(found, series),
                         equations_text(*found.masses, series.threads), why);
    }
    case crossover_status::always:
      // Sizes below the first measured one that were not measured (every
      // pair set aside) leave S* unknown below it: said, not hidden.
      return fmt::format("{} pays off at every size measured, from {} masses{}", name,
                         masses_text(*found.masses),
                         !series.points.empty() && !series.points.front().measured()
                             ? " (the sizes below were not measured: a CPU taken)"
                             : "");
    case crossover_status::none_within_sweep: break;
  }
  if (measured.empty())
    return fmt::format("{}: nothing measured ({})", name, series.stop_reason.empty() ? "no point" : stop_words(series.stop_reason));
  const auto best = std::max_element(measured.begin(), measured.end(), [](const crossover_point& a, const crossover_point& b) {
    return a.speedup.median < b.speedup.median;
  });
  return fmt::format("{}: none within the sweep up to {} masses (best {:.2f}x [{:.2f}, {:.2f}] at {}; stopped: {})",
                     name, masses_text(measured.back().masses), best->speedup.median, best->speedup.low,
                     best->speedup.high, masses_text(best->masses), stop_words(series.stop_reason));
}

nlohmann::json optional_json(const std::optional<double>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}

// The run's choice at a thread count: its first series when that leads (the
// sweep plans it first), else none.
const crossover_series* leader_at(const crossover_sweep& sweep, unsigned threads) {
  for (const auto& series : sweep.series)
    if (series.threads == threads) return series.leader ? &series : nullptr;
  return nullptr;
}

// The measured point at a size among `points`, or nullptr.
const crossover_sweep_point* measured_at(const std::vector<crossover_sweep_point>& points, std::size_t masses) {
  for (const auto& point : points)
    if (point.masses == masses && point.measured()) return &point;
  return nullptr;
}
const crossover_sweep_point* measured_at(const crossover_series* series, std::size_t masses) {
  return series != nullptr ? measured_at(series->points, masses) : nullptr;
}

// The ceiling's line at one thread count (ceiling_quoted says at which size);
// empty when the ceiling has no measured point.
std::optional<std::string> ceiling_line(const crossover_sweep& sweep, const crossover_ceiling& ceiling) {
  const crossover_sweep_point* at = ceiling_quoted(sweep, ceiling);
  if (at == nullptr) return std::nullopt;
  std::string line = fmt::format(
      "Ceiling at {} threads (pin:{}), {} masses: {} blocks of the chain stepped at once with no exchange and no "
      "sync (what the machine gives an even split) give {:.2f}x [{:.2f}, {:.2f}] the serial "
      "step's speed",
      ceiling.threads, platform::to_string(ceiling.pin), at->masses, ceiling.threads, at->speedup.median, at->speedup.low,
      at->speedup.high);
  // Each primitive that leads here (the choice, and a rival tied with it).
  for (const auto& series : sweep.series) {
    if (series.threads != ceiling.threads || !series.leader) continue;
    if (const crossover_sweep_point* reached = measured_at(&series, at->masses))
      if (const auto share = share_of_ceiling(sweep, *reached))
        line += fmt::format("; {} gives {:.2f}x [{:.2f}, {:.2f}], {:.2f} of it", series.sync, reached->speedup.median,
                            reached->speedup.low, reached->speedup.high, *share);
  }
  return line;
}

nlohmann::json point_json(const crossover_sweep_point& point) {
  return {{"masses", point.masses},
          {"equations_per_thread", point.equations_per_thread()},
          {"serial_ns", point.serial_ns},
          {"speedup", point.speedup.median},
          {"ci_low", point.speedup.low},
          {"ci_high", point.speedup.high},
          {"verdict", point.measured() ? nlohmann::json(to_string(point.verdict)) : nlohmann::json(nullptr)},
          {"pairs", point.pairs},
          {"pairs_set_aside", point.pairs_set_aside},
          {"cpu_taken", point.pairs_set_aside > 0},
          {"cpus_busy", optional_json(point.cpus_busy)},
          {"oversubscribed", point.oversubscribed},
          {"failure", point.failure}};
}

}  // namespace

const crossover_sweep_point* ceiling_quoted(const crossover_sweep& sweep, const crossover_ceiling& ceiling) {
  const crossover_series* leader = leader_at(sweep, ceiling.threads);
  const crossover_sweep_point* quoted = nullptr;
  bool with_leader = false;
  for (const auto& point : ceiling.points) {
    if (!point.measured()) continue;
    const bool here = measured_at(leader, point.masses) != nullptr;
    if (here || !with_leader) quoted = &point;
    with_leader = with_leader || here;
  }
  return quoted;
}

const crossover_sweep_point* ceiling_at(const crossover_sweep& sweep, const crossover_sweep_point& point) {
  for (const auto& ceiling : sweep.ceilings)
    if (ceiling.threads == point.threads) return measured_at(ceiling.points, point.masses);
  return nullptr;
}

std::optional<double> share_of_ceiling(const crossover_sweep& sweep, const crossover_sweep_point& point) {
  const crossover_sweep_point* ceiling = ceiling_at(sweep, point);
  if (ceiling == nullptr || !point.measured() || !(ceiling->speedup.median > 0.0)) return std::nullopt;
  return point.speedup.median / ceiling->speedup.median;
}

std::vector<std::string> crossover_lines(const crossover_sweep& sweep) {
  // threads -> its series, in the sweep's order (the leader first)
  std::map<unsigned, std::vector<const crossover_series*>> by_threads;
  for (const auto& series : sweep.series) by_threads[series.threads].push_back(&series);
  std::vector<std::string> lines;
  for (const auto& [threads, all] : by_threads) {
    std::string line = fmt::format("Crossover at {} threads (pin:{}): ", threads,
                                   platform::to_string(all.front()->pin));
    bool pays_off = false;
    std::size_t set_aside = 0;
    for (std::size_t index = 0; index < all.size(); ++index) {
      const crossover_series& series = *all[index];
      // By its primitive, with its layout when another series here has the
      // same primitive; a rival tied with the choice says so.
      const bool shared = std::count_if(all.begin(), all.end(), [&](const crossover_series* other) {
                            return other->sync == series.sync;
                          }) > 1;
      std::string name = shared ? series.sync + " + " + series.layout : series.sync;
      if (index > 0 && series.leader) name += " (tied with it in the matrix)";
      line += (index == 0 ? "" : "; ") + series_text(series, name, index == 0);
      const auto status = all[index]->crossover.status;
      pays_off = pays_off || status == crossover_status::crossed || status == crossover_status::always;
      for (const auto& point : all[index]->points) set_aside += point.pairs_set_aside;
    }
    if (pays_off) line += "; below that, step serially";
    if (set_aside > 0)
      line += fmt::format(" ({} pairs set aside: another process took a CPU)", set_aside);
    lines.push_back(std::move(line));
    for (const auto& ceiling : sweep.ceilings)
      if (ceiling.threads == threads)
        if (auto said = ceiling_line(sweep, ceiling))
          lines.push_back(std::move(*said));
  }
  return lines;
}

nlohmann::json crossover_json(const crossover_sweep& sweep) {
  nlohmann::json crossovers = nlohmann::json::array();
  for (const auto& series : sweep.series) {
    const crossover_estimate& found = series.crossover;
    nlohmann::json points = nlohmann::json::array();
    for (const auto& point : series.points) {
      std::optional<double> over_model;
      if (point.model_ns && *point.model_ns > 0.0 && point.parallel_ns > 0.0) over_model = point.parallel_ns / *point.model_ns;
      nlohmann::json written = point_json(point);
      written["parallel_ns"] = point.parallel_ns;
      written["model_ns"] = optional_json(point.model_ns);
      written["measured_over_model"] = optional_json(over_model);
      written["of_ceiling"] = optional_json(share_of_ceiling(sweep, point));
      points.push_back(std::move(written));
    }
    const bool crossed = found.masses.has_value();
    crossovers.push_back({{"threads", series.threads},
                          {"pin", std::string(platform::to_string(series.pin))},
                          {"sync", series.sync},
                          {"layout", series.layout},
                          {"leader", series.leader},
                          {"status", to_string(found.status)},
                          {"masses", optional_json(found.masses)},
                          {"ci_low", crossed ? optional_json(found.low) : nlohmann::json(nullptr)},
                          {"ci_high", crossed ? optional_json(found.high) : nlohmann::json(nullptr)},
                          {"equations_per_thread",
                           crossed ? nlohmann::json(2.0 * *found.masses / series.threads) : nlohmann::json(nullptr)},
                          {"confirmed_at", optional_json(found.confirmed_at)},
                          {"contradicted_at", optional_json(found.contradicted_at)},
                          {"stop_reason", series.stop_reason},
                          {"stage_sync_ns", optional_json(series.stage_sync_ns)},
                          {"stage_sync_entry", series.stage_sync_entry},
                          {"stages_per_step", kernels::kRk4Stages},
                          {"points", points}});
  }
  nlohmann::json ceilings = nlohmann::json::array();
  for (const auto& ceiling : sweep.ceilings) {
    nlohmann::json points = nlohmann::json::array();
    for (const auto& point : ceiling.points) {
      nlohmann::json written = point_json(point);
      written["blocks_ns"] = point.parallel_ns;
      points.push_back(std::move(written));
    }
    const crossover_sweep_point* quoted = ceiling_quoted(sweep, ceiling);
    ceilings.push_back({{"threads", ceiling.threads},
                        {"pin", std::string(platform::to_string(ceiling.pin))},
                        {"quoted_masses", quoted != nullptr ? nlohmann::json(quoted->masses) : nlohmann::json(nullptr)},
                        {"points", points}});
  }
  return {{"budget_s", static_cast<double>(sweep.budget_ns) / 1e9},
          {"max_masses", sweep.max_masses},
          {"pairs_per_point", sweep.pairs},
          {"block_ms", static_cast<double>(sweep.block_ns) / 1e6},
          {"spent_s", sweep.spent_s},
          {"stop_reason", sweep.stop_reason},
          {"confidence", kConfidence},
          {"lines", crossover_lines(sweep)},
          {"crossovers", crossovers},
          {"ceilings", ceilings}};
}

}  // namespace lockstep::bench
