// The pace trace and its modes (pace.hpp).
#include "bench/run/pace.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <numeric>

#include "bench/results/derived_figures.hpp"
#include "bench/probes/core_to_core.hpp"
#include "kernels/oscillator.hpp"
#include "kernels/rk4.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"
#include "platform/statistics.hpp"
#include "platform/stats.hpp"

namespace lockstep::bench {

namespace {

// A reading's c2c part: 15 samples of 40 round trips after 100 warm-up
// rounds, the median sample. About 1300 round trips: 65 us at 25 ns one-way,
// 0.7 ms at 270 ns, plus starting and joining two pinned threads.
std::optional<double> read_c2c(const std::vector<unsigned>& cpus) {
  if (cpus.size() < 2) return std::nullopt;
  c2c::pair_request request;
  request.cpu_a = static_cast<int>(cpus[0]);
  request.cpu_b = static_cast<int>(cpus[1]);
  request.how = c2c::method::cas;
  request.samples = 15;
  request.rounds_per_sample = 40;
  request.warmup_rounds = 100;
  try {
    return platform::summarize(c2c::measure_pair(request)).p50;
  } catch (const std::exception&) {
    return std::nullopt;  // the pair cannot be pinned now: no figure, never a made-up one
  }
}

// A reading's serial part: 7 chunks of 32 steps on the calling thread, the
// median chunk (a preempted chunk lands at the top).
double read_serial() {
  static const kernels::two_mass_model model;
  // The benchmark's step size (rk4_entries.hpp): bounded over millions of steps.
  static kernels::staged_rk4<kernels::two_mass_model> rk4(model, 1e-4);
  constexpr std::uint64_t kSteps = 32;
  std::vector<double> chunks;
  rk4.run(kSteps);  // warm the code and the state
  for (int chunk = 0; chunk < 7; ++chunk) {
    const std::int64_t start = platform::now_ns();
    rk4.run(kSteps);
    chunks.push_back(static_cast<double>(platform::now_ns() - start) / kSteps);
  }
  return platform::median(chunks);
}

}  // namespace

pace_modes find_modes(const std::vector<pace_reading>& trace) {
  pace_modes found;
  found.mode_of.assign(trace.size(), -1);
  found.has_c2c = !trace.empty() && std::all_of(trace.begin(), trace.end(),
                                                 [](const pace_reading& reading) { return reading.c2c_ns.has_value(); });
  const auto key = [&](std::size_t index) {
    return found.has_c2c ? *trace[index].c2c_ns : trace[index].serial_ns;
  };
  std::vector<std::size_t> order;
  for (std::size_t index = 0; index < trace.size(); ++index)
    if (key(index) > 0.0 && std::isfinite(key(index))) order.push_back(index);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return key(a) < key(b); });

  // Clusters of sorted neighbours no more than kModeGap apart.
  std::vector<std::vector<std::size_t>> clusters;
  for (std::size_t position = 0; position < order.size(); ++position) {
    if (position == 0 || key(order[position]) > kModeGap * key(order[position - 1])) clusters.emplace_back();
    clusters.back().push_back(order[position]);
  }
  for (const auto& cluster : clusters) {
    if (cluster.size() < kMinModeReadings) continue;  // outliers: mode -1
    const int mode = static_cast<int>(found.modes.size());
    std::vector<double> c2c;
    std::vector<double> serial;
    for (std::size_t index : cluster) {
      found.mode_of[index] = mode;
      if (trace[index].c2c_ns) c2c.push_back(*trace[index].c2c_ns);
      serial.push_back(trace[index].serial_ns);
    }
    found.modes.push_back({c2c.empty() ? 0.0 : platform::median(c2c), platform::median(serial), 0.0, cluster.size()});
  }

  // Time: each reading stands for the span to the next one (the last for
  // the median span), given to the mode of the nearest earlier reading that
  // has one. Changes: consecutive moded readings in different modes.
  std::vector<double> spans(trace.size(), 0.0);
  for (std::size_t index = 0; index + 1 < trace.size(); ++index)
    spans[index] = std::max(0.0, trace[index + 1].t_s - trace[index].t_s);
  if (trace.size() >= 2) spans.back() = platform::median(std::span<const double>(spans.data(), spans.size() - 1));
  double total = 0.0;
  int current = -1;
  for (std::size_t index = 0; index < trace.size(); ++index) {
    const int mode = found.mode_of[index];
    if (mode >= 0) {
      if (current >= 0 && mode != current) ++found.changes;
      current = mode;
    }
    if (current >= 0) {
      found.modes[static_cast<std::size_t>(current)].share += spans[index];
      total += spans[index];
    }
  }
  for (auto& mode : found.modes) mode.share = total > 0.0 ? mode.share / total : 1.0 / static_cast<double>(found.modes.size());
  return found;
}

int agreed_mode(const pace_modes& modes, std::size_t before, std::size_t after) {
  if (before >= modes.mode_of.size() || after >= modes.mode_of.size()) return -1;
  const int mode = modes.mode_of[before];
  return mode == modes.mode_of[after] ? mode : -1;
}

std::string pace_modes::summary() const {
  if (modes.empty()) return "no pace readings";
  std::string text;
  for (const pace_mode& mode : modes) {
    text += text.empty() ? (has_c2c ? "c2c " : "serial step ") : ", ";
    text += fmt::format("{} for {:.0f} % of the run", format_ns(has_c2c ? mode.c2c_ns : mode.serial_ns),
                        100.0 * mode.share);
  }
  if (modes.size() == 1) return text + " (one mode: the pace held)";
  return text + fmt::format("; {} change{}", changes, changes == 1 ? "" : "s");
}

pace_probe::pace_probe(const platform::topology& machine) : start_ns_(platform::now_ns()) {
  const platform::placement_plan plan = platform::plan_placement(machine, platform::placement::compact, 2);
  const auto a = plan.pu_at(0);
  const auto b = plan.pu_at(1);
  if (a && b && *a != *b) cpus_ = {*a, *b};
}

std::size_t pace_probe::take() {
  pace_reading reading;
  reading.c2c_ns = read_c2c(cpus_);
  reading.serial_ns = read_serial();
  last_ns_ = platform::now_ns();
  reading.t_s = static_cast<double>(last_ns_ - start_ns_) * 1e-9;
  trace_.push_back(reading);
  return trace_.size() - 1;
}

std::size_t pace_probe::latest_or_take(std::int64_t fresh_ns) {
  if (!trace_.empty() && platform::now_ns() - last_ns_ <= fresh_ns) return trace_.size() - 1;
  return take();
}

std::string pace_probe::reference() const {
  std::string text = "serial RK4 step (7 chunks of 32 steps, the median chunk)";
  if (cpus_.size() == 2)
    text = fmt::format("one-way core-to-core latency between CPUs {} and {} (CAS ping-pong, median of 15 samples of "
                       "40 round trips), and the ",
                       cpus_[0], cpus_[1]) +
           text;
  return text + fmt::format("; modes: clusters of readings more than {:.1f}x apart, of {} readings or more", kModeGap,
                            kMinModeReadings);
}

nlohmann::json pace_json(const pace_probe& probe, const pace_modes& modes) {
  nlohmann::json readings = nlohmann::json::array();
  for (std::size_t index = 0; index < probe.trace().size(); ++index) {
    const pace_reading& reading = probe.trace()[index];
    readings.push_back({{"t_s", reading.t_s},
                        {"c2c_ns", reading.c2c_ns ? nlohmann::json(*reading.c2c_ns) : nlohmann::json(nullptr)},
                        {"serial_ns", reading.serial_ns},
                        {"mode", index < modes.mode_of.size() ? modes.mode_of[index] : -1}});
  }
  nlohmann::json found = nlohmann::json::array();
  for (std::size_t index = 0; index < modes.modes.size(); ++index) {
    const pace_mode& mode = modes.modes[index];
    found.push_back({{"mode", index},
                     {"c2c_ns", mode.c2c_ns},
                     {"serial_ns", mode.serial_ns},
                     {"share", mode.share},
                     {"readings", mode.readings}});
  }
  return {{"reference", probe.reference()}, {"cpus", probe.cpus()},    {"readings", readings},
          {"modes", found},                 {"changes", modes.changes}, {"summary", modes.summary()}};
}

}  // namespace lockstep::bench
