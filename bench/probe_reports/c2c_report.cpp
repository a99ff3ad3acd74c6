// What a core-to-core measurement means, as text and as a result file (c2c_report.hpp).
#include "bench/probe_reports/c2c_report.hpp"

#include <fmt/core.h>

#include <algorithm>

#include "bench/results/machine_context.hpp"
#include "bench/results/result_json.hpp"

namespace lockstep::bench {

c2c_analysis analyse_c2c(const std::vector<c2c::pair_latency>& results, const std::vector<c2c::method>& methods,
                         const platform::topology& machine) {
  c2c_analysis analysis;
  for (const auto& r : results) {
    const auto cpu_a = static_cast<unsigned>(r.a);
    const auto cpu_b = static_cast<unsigned>(r.b);
    analysis.relations.emplace_back(platform::to_string(machine.relation(cpu_a, cpu_b)));
    analysis.nodes.emplace_back(machine.pu(cpu_a).numa, machine.pu(cpu_b).numa);
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

// Columns of the matrix side by side: at most this many, so that no line is
// wider than 120 columns (6 for the row's CPU, 7 a column); a machine of more
// CPUs gets the matrix in blocks of columns, each with every row.
constexpr std::size_t kMatrixColumns = 16;

std::string matrix_text(const std::vector<int>& cpus, const c2c_matrix& matrix) {
  std::string text = fmt::format("\nmedian {}, ns ({}):\n",
                                 matrix.how == c2c::method::stage ? "stage time" : "one-way latency",
                                 c2c::to_string(matrix.how));
  for (std::size_t first = 0; first < cpus.size(); first += kMatrixColumns) {
    const std::size_t last = std::min(cpus.size(), first + kMatrixColumns);
    if (first > 0) text += "\n";
    text += fmt::format("{:>6}", "");
    for (std::size_t column = first; column < last; ++column) text += fmt::format(" {:>6}", cpus[column]);
    text += "\n";
    for (int row : cpus) {
      text += fmt::format("{:>6}", row);
      for (std::size_t column = first; column < last; ++column) {
        const int col = cpus[column];
        const auto found = matrix.median_ns.find({row, col});
        if (row == col)
          text += fmt::format(" {:>6}", "-");
        else if (found == matrix.median_ns.end())
          text += fmt::format(" {:>6}", ".");  // not sampled
        else
          text += fmt::format(" {:>6.1f}", found->second);
      }
      text += "\n";
    }
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
  std::vector<std::string> relations;
  std::size_t relation_width = 18;
  for (std::size_t i = 0; i < results.size(); ++i) {
    relations.push_back(probes::pair_words(analysis.relations[i], analysis.nodes[i].first, analysis.nodes[i].second));
    relation_width = std::max(relation_width, relations.back().size());
  }
  text += fmt::format("{:>5} {:>5}  {:<{}} {:<10} {:>9} {:>9} {:>9}\n", "cpu", "cpu", "relation", relation_width,
                      "method", "min ns", "p50 ns", "p99 ns");
  for (std::size_t i = 0; i < results.size(); ++i) {
    const auto& r = results[i];
    const platform::distribution& one_way = analysis.one_way[i];
    text += fmt::format("{:>5} {:>5}  {:<{}} {:<10} {:>9.1f} {:>9.1f} {:>9.1f}\n", r.a, r.b, relations[i],
                        relation_width, c2c::to_string(r.how), one_way.min, one_way.p50, one_way.p99);
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
  // Every label the file may hold, closest first, so that a reader ranks
  // pairs by the file (the report's heat map orders CPUs by it).
  document["relations_closest_first"] = nlohmann::json::array();
  for (platform::pu_relation relation : platform::kRelationsClosestFirst)
    document["relations_closest_first"].push_back(std::string(platform::to_string(relation)));
  document["pairs"] = nlohmann::json::array();
  const auto node_json = [](int node) { return node == platform::kNoObject ? nlohmann::json(nullptr) : nlohmann::json(node); };
  for (std::size_t i = 0; i < results.size(); ++i) {
    const auto& r = results[i];
    document["pairs"].push_back({{"a", r.a},
                                 {"b", r.b},
                                 {"relation", analysis.relations[i]},
                                 {"numa_nodes", {node_json(analysis.nodes[i].first), node_json(analysis.nodes[i].second)}},
                                 {"method", c2c::to_string(r.how)},
                                 {"one_way_ns", distribution_json(r.one_way_ns)},
                                 {"samples", r.one_way_ns.size()}});
  }
  return document;
}

}  // namespace lockstep::bench
