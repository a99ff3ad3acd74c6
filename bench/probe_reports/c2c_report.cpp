// What a core-to-core measurement means, as text and as a result file (c2c_report.hpp).
#include "bench/probe_reports/c2c_report.hpp"

#include <fmt/core.h>

#include "bench/results/machine_context.hpp"
#include "bench/results/result_json.hpp"

namespace lockstep::bench {

c2c_analysis analyse_c2c(const std::vector<c2c::pair_latency>& results, const std::vector<c2c::method>& methods,
                         const platform::topology& machine) {
  c2c_analysis analysis;
  for (const auto& r : results) {
    analysis.relations.emplace_back(
        platform::to_string(machine.relation(static_cast<unsigned>(r.a), static_cast<unsigned>(r.b))));
    analysis.one_way.push_back(platform::summarize(r.one_way_ns));
  }
  for (c2c::method how : methods) {
    c2c_matrix matrix{how, {}};
    for (std::size_t i = 0; i < results.size(); ++i) {
      const auto& r = results[i];
      if (r.how == how) matrix.median_ns[{r.a, r.b}] = matrix.median_ns[{r.b, r.a}] = analysis.one_way[i].p50;
    }
    analysis.matrices.push_back(std::move(matrix));
  }
  return analysis;
}

namespace {

std::string matrix_text(const std::vector<int>& cpus, const c2c_matrix& matrix) {
  std::string text = fmt::format("\nmedian {}, ns ({}):\n{:>6}",
                                 matrix.how == c2c::method::stage ? "stage time" : "one-way latency",
                                 c2c::to_string(matrix.how), "");
  for (int cpu : cpus) text += fmt::format(" {:>7}", cpu);
  text += "\n";
  for (int row : cpus) {
    text += fmt::format("{:>6}", row);
    for (int col : cpus) {
      const auto found = matrix.median_ns.find({row, col});
      if (row == col)
        text += fmt::format(" {:>7}", "-");
      else if (found == matrix.median_ns.end())
        text += fmt::format(" {:>7}", ".");  // not sampled
      else
        text += fmt::format(" {:>7.1f}", found->second);
    }
    text += "\n";
  }
  return text;
}

}  // namespace

std::string c2c_text(const c2c::c2c_settings& settings, const std::vector<int>& cpus,
                     const std::vector<c2c::pair_latency>& results, const c2c_analysis& analysis) {
  std::string text = fmt::format("one-way latency = round trip / 2, {} samples of {} round trips per pair\n",
                                 settings.samples, settings.rounds_per_sample);
  for (const c2c::method how : settings.methods)
    if (how == c2c::method::stage)
      text += "stage: both threads write their own line, then wait for the other's (a two-thread stage sync at "
              "its least); both lines cross at once, so its ideal is one one-way latency\n";
  text += fmt::format("{:>5} {:>5}  {:<18} {:<10} {:>9} {:>9} {:>9}\n", "cpu", "cpu", "relation", "method", "min ns",
                      "p50 ns", "p99 ns");
  for (std::size_t i = 0; i < results.size(); ++i) {
    const auto& r = results[i];
    const platform::distribution& one_way = analysis.one_way[i];
    text += fmt::format("{:>5} {:>5}  {:<18} {:<10} {:>9.1f} {:>9.1f} {:>9.1f}\n", r.a, r.b, analysis.relations[i],
                        c2c::to_string(r.how), one_way.min, one_way.p50, one_way.p99);
  }
  for (const c2c_matrix& matrix : analysis.matrices) text += matrix_text(cpus, matrix);
  return text;
}

nlohmann::json c2c_json(const probes::c2c_plan& plan, const c2c::c2c_settings& settings,
                        const std::vector<c2c::pair_latency>& results, const c2c_analysis& analysis,
                        const platform::topology& machine) {
  nlohmann::json document = result_document("c2c", machine);
  document["sampled"] = plan.sampled;
  document["pairs_total"] = plan.all_pairs;
  document["samples_per_pair"] = settings.samples;
  document["rounds_per_sample"] = settings.rounds_per_sample;
  document["pairs"] = nlohmann::json::array();
  for (std::size_t i = 0; i < results.size(); ++i) {
    const auto& r = results[i];
    document["pairs"].push_back({{"a", r.a},
                                 {"b", r.b},
                                 {"relation", analysis.relations[i]},
                                 {"method", c2c::to_string(r.how)},
                                 {"one_way_ns", distribution_json(r.one_way_ns)},
                                 {"samples", r.one_way_ns.size()}});
  }
  return document;
}

}  // namespace lockstep::bench
