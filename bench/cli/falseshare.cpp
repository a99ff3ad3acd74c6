// lockstep falseshare: false sharing priced directly (the falseshare probe,
// bench/probes/falseshare.hpp): pinned writers, counters `stride` bytes apart.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/harness/machine_context.hpp"
#include "bench/harness/paired_ratio.hpp"
#include "bench/harness/result_file.hpp"
#include "bench/harness/result_json.hpp"
#include "bench/probes/falseshare.hpp"
#include "platform/stats.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {
namespace {

struct falseshare_options {
  int threads = 2;
  std::string cores;
  std::string strides = "8,16,32,64,128,256";
  // Nine repeats of 50 ms windows: nine pairs for the penalty's interval in
  // the same 2.7 s that five repeats of 100 ms took.
  std::string window = "50ms";
  int repeats = 9;
  std::string out;
};

void run_falseshare(const falseshare_options& options, int& result) {
  bench::probes::falseshare_settings settings;
  for (long long stride : parse_number_list(options.strides, "--strides", 8, 4096)) {
    if (stride % 8 != 0) throw usage_error(fmt::format("--strides: {} is not a multiple of 8", stride));
    settings.strides.push_back(static_cast<std::size_t>(stride));
  }
  settings.window_ns = parse_duration_ns(options.window, "--window", 1'000'000, 60'000'000'000);
  settings.repeats = options.repeats;
  const platform::topology machine = platform::topology::this_machine();
  std::vector<int> cpus = usable_cpus(machine, false);
  if (!options.cores.empty())
    cpus = restrict_to(usable_cpus(machine, true), parse_cpu_list(options.cores, "--cores"), "--cores");
  if (cpus.size() < static_cast<std::size_t>(options.threads))
    throw usage_error(fmt::format("--threads {} needs as many usable CPUs, found {} (each writer is pinned to its "
                                  "own CPU)",
                                  options.threads, cpus.size()));
  cpus.resize(static_cast<std::size_t>(options.threads));
  settings.cpus = cpus;
  check_out(options.out);

  settings.on_repeat = [&](int repeat) {
    fmt::print(stderr, "falseshare: repeat {}/{} ({} strides x {})\n", repeat + 1, settings.repeats,
               settings.strides.size(), options.window);
  };
  std::vector<bench::probes::stride_cost> costs;
  try {
    costs = bench::probes::measure_false_sharing(settings);
  } catch (const std::runtime_error& e) {
    throw usage_error(std::string(e.what()) + "; choose usable CPUs with --cores");
  }

  std::string cpu_text;
  for (int cpu : cpus) cpu_text += (cpu_text.empty() ? "" : ",") + std::to_string(cpu);
  fmt::print("false sharing: {} writers pinned to CPUs {}, counters `stride` bytes apart\n", cpus.size(), cpu_text);
  fmt::print("time per write, ns ({} repeats x {} threads, {} each)\n", settings.repeats, cpus.size(), options.window);
  fmt::print("{:>7}  {:<28} {:>9} {:>9} {:>9} {:>8}\n", "stride", "writers share", "min", "median", "max", "samples");
  for (const auto& cost : costs) {
    if (cost.ns_per_write.empty()) {
      fmt::print("{:>7}  no writer was scheduled during any window (machine overloaded)\n", cost.stride_bytes);
      continue;
    }
    const auto d = platform::summarize(cost.ns_per_write);
    const char* sharing = cost.shares_line ? "a 64-byte line" : cost.shares_line_pair ? "a 128-byte pair, not a line"
                                                                                       : "nothing";
    fmt::print("{:>7}  {:<28} {:>9.2f} {:>9.2f} {:>9.2f} {:>8}\n", cost.stride_bytes, sharing, d.min, d.p50, d.max,
               d.count);
  }

  // The known answer, paired: the smallest stride whose writers share a line
  // against the smallest that shares nothing, a ratio per repeat (both ran
  // within one repeat, a few windows apart).
  nlohmann::json penalty;
  const auto sharing = std::find_if(costs.begin(), costs.end(), [](const auto& cost) { return cost.shares_line; });
  const auto apart = std::find_if(costs.begin(), costs.end(),
                                  [](const auto& cost) { return !cost.shares_line && !cost.shares_line_pair; });
  if (sharing != costs.end() && apart != costs.end()) {
    std::vector<double> ratios;
    for (std::size_t repeat = 0; repeat < sharing->repeat_mean_ns.size() && repeat < apart->repeat_mean_ns.size();
         ++repeat)
      if (sharing->repeat_mean_ns[repeat] && apart->repeat_mean_ns[repeat] && *apart->repeat_mean_ns[repeat] > 0.0)
        ratios.push_back(*sharing->repeat_mean_ns[repeat] / *apart->repeat_mean_ns[repeat]);
    if (!ratios.empty()) {
      const bench::ratio_estimate estimate = bench::bootstrap_median(ratios);
      const bench::ratio_verdict verdict = bench::verdict_of(estimate);
      fmt::print("false-sharing penalty, stride {} / stride {} paired per repeat: {:.2f}x [{:.2f}, {:.2f}] {} ({} "
                 "pairs, {:.0f} % bootstrap interval, noise band {:.0f} %)\n",
                 sharing->stride_bytes, apart->stride_bytes, estimate.median, estimate.low, estimate.high,
                 bench::to_string(verdict), ratios.size(), 100.0 * bench::kConfidence, 100.0 * bench::kDefaultNoise);
      penalty = {{"a_stride_bytes", sharing->stride_bytes},
                 {"b_stride_bytes", apart->stride_bytes},
                 {"ratios", ratios},
                 {"median", estimate.median},
                 {"ci_low", estimate.low},
                 {"ci_high", estimate.high},
                 {"confidence", bench::kConfidence},
                 {"noise", bench::kDefaultNoise},
                 {"verdict", bench::to_string(verdict)}};
    }
  }

  if (!options.out.empty()) {
    nlohmann::json document = bench::result_document("falseshare", machine);
    if (!penalty.is_null()) document["penalty"] = penalty;
    document["settings"] = {{"threads", options.threads},
                            {"cpus", cpus},
                            {"window_ns", settings.window_ns},
                            {"repeats", settings.repeats}};
    document["strides"] = nlohmann::json::array();
    for (const auto& cost : costs)
      document["strides"].push_back({{"stride_bytes", cost.stride_bytes},
                                     {"share_line", cost.shares_line},
                                     {"share_line_pair", cost.shares_line_pair},
                                     {"ns_per_write", bench::distribution_json(cost.ns_per_write)}});
    bench::write_result_file(options.out, document.dump(2) + "\n");
    fmt::print(stderr, "falseshare: wrote {}\n", options.out);
  }
  result = kExitOk;
}

}  // namespace

void add_falseshare(CLI::App& app, int& result) {
  auto options = std::make_shared<falseshare_options>();
  auto* command = app.add_subcommand(
      "falseshare", "False sharing priced directly: pinned threads write counters `stride` bytes apart, 8..256");
  command->add_option("--threads", options->threads, "Writers, each pinned to its own CPU")
      ->check(CLI::Range(2, 1024))
      ->capture_default_str();
  command->add_option("--cores", options->cores, "CPUs for the writers, e.g. 0,1 (default: one PU per core)");
  command->add_option("--strides", options->strides, "Strides in bytes (multiples of 8, 8..4096)")
      ->capture_default_str();
  command->add_option("--window", options->window, "How long the writers write per measurement, with a unit")
      ->capture_default_str();
  command->add_option("--repeats", options->repeats, "Measurements per stride")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  add_out_option(*command, options->out);
  command->callback([options, &result] { run_falseshare(*options, result); });
}

}  // namespace lockstep::cli
