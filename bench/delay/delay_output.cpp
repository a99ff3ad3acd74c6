// delay's histograms and per-CPU verdict (delay_output.hpp).
#include "bench/delay/delay_output.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace lockstep::bench {

std::string cyclictest_histogram_text(const bench::probes::latency_histogram& histogram) {
  std::string text = "# Histogram\n";
  for (std::int64_t bucket = 0; bucket < histogram.bound_us; ++bucket) {
    text += fmt::format("{:06d}", bucket);
    for (std::size_t column = 0; column < histogram.columns.size(); ++column)
      text += fmt::format("{}{:06d}", column == 0 ? " " : "\t",
                          histogram.columns[column].counts[static_cast<std::size_t>(bucket)]);
    text += '\n';
  }
  const auto summary = [&](const char* label, int width, auto value_of) {
    text += label;
    for (const auto& column : histogram.columns) text += fmt::format(" {:0{}d}", value_of(column), width);
    text += '\n';
  };
  using column_type = bench::probes::latency_histogram_column;
  summary("# Total:", 9, [](const column_type& column) { return column.in_buckets(); });
  summary("# Min Latencies:", 5, [](const column_type& column) { return column.min_us; });
  summary("# Avg Latencies:", 5, [](const column_type& column) { return column.avg_us; });
  summary("# Max Latencies:", 5, [](const column_type& column) { return column.max_us; });
  summary("# Histogram Overflows:", 5, [](const column_type& column) { return column.overflow; });
  text += "# Histogram Overflow at cycle number:\n";
  for (std::size_t column = 0; column < histogram.columns.size(); ++column) {
    const auto& thread = histogram.columns[column];
    text += fmt::format("# Thread {}:", column);
    for (std::int64_t period : thread.overflow_periods) text += fmt::format(" {:05d}", period);
    if (thread.overflow > thread.overflow_periods.size())
      text += fmt::format(" # {:05d} others", thread.overflow - thread.overflow_periods.size());
    text += '\n';
  }
  text += '\n';
  return text;
}

nlohmann::json latency_histogram_json(const bench::probes::latency_histogram& histogram) {
  nlohmann::json columns = nlohmann::json::array();
  for (const auto& column : histogram.columns) {
    columns.push_back({{"name", column.name},
                       {"cpu", column.cpu ? nlohmann::json(*column.cpu) : nullptr},
                       {"counts", column.counts},
                       {"overflow", column.overflow},
                       {"samples", column.samples},
                       {"min_us", column.min_us},
                       {"avg_us", column.avg_us},
                       {"max_us", column.max_us}});
  }
  return {{"bucket_us", 1}, {"bound_us", histogram.bound_us}, {"columns", columns}};
}

namespace {

// The lower edges, in ns, of the 1-2-5 buckets: 0, 1 us, 2 us, 5 us, 10 us, ...
std::int64_t log_edge_ns(std::size_t index) {
  if (index == 0) return 0;
  static constexpr std::int64_t kMantissa[] = {1, 2, 5};
  std::int64_t decade = 1000;
  for (std::size_t step = (index - 1) / 3; step > 0; --step) decade *= 10;
  return kMantissa[(index - 1) % 3] * decade;
}

std::size_t log_bucket_of(double sample_ns) {
  std::size_t index = 0;
  while (index < 60 && sample_ns >= static_cast<double>(log_edge_ns(index + 1))) ++index;
  return index;
}

std::string us_label(std::int64_t ns) {
  return ns % 1000 == 0 ? fmt::format("{}", ns / 1000) : fmt::format("{:.1f}", static_cast<double>(ns) / 1e3);
}

}  // namespace

std::string log_histogram_text(const std::vector<labelled_samples>& series, std::size_t bar_width) {
  const bool several = series.size() > 1;
  std::vector<std::vector<std::uint64_t>> counts(series.size());
  std::vector<std::uint64_t> all;
  std::uint64_t total = 0;
  for (std::size_t column = 0; column < series.size(); ++column) {
    for (double sample : series[column].samples_ns) {
      const std::size_t bucket = log_bucket_of(std::max(sample, 0.0));
      if (counts[column].size() <= bucket) counts[column].resize(bucket + 1, 0);
      if (all.size() <= bucket) all.resize(bucket + 1, 0);
      ++counts[column][bucket];
      ++all[bucket];
      ++total;
    }
  }
  if (total == 0) return "  no samples\n";
  std::size_t first = 0;
  while (all[first] == 0) ++first;
  const std::uint64_t largest = *std::max_element(all.begin(), all.end());

  std::string text = fmt::format("  {:>17}", "us");
  for (const auto& one : series) text += fmt::format(" {:>9}", one.name.substr(0, 9));
  if (several) text += fmt::format(" {:>9}", "all");
  text += fmt::format(" {:>7} {:>7}  log10(1 + count)\n", "share", "cumul.");
  std::uint64_t running = 0;
  for (std::size_t bucket = first; bucket < all.size(); ++bucket) {
    running += all[bucket];
    text += fmt::format("  [{:>6}, {:>6})", us_label(log_edge_ns(bucket)), us_label(log_edge_ns(bucket + 1)));
    for (std::size_t column = 0; column < series.size(); ++column)
      text += fmt::format(" {:>9}", bucket < counts[column].size() ? counts[column][bucket] : 0);
    if (several) text += fmt::format(" {:>9}", all[bucket]);
    const double share = 100.0 * static_cast<double>(all[bucket]) / static_cast<double>(total);
    const double cumulative = 100.0 * static_cast<double>(running) / static_cast<double>(total);
    const auto length = static_cast<std::size_t>(
        std::ceil(static_cast<double>(bar_width) * std::log10(1.0 + static_cast<double>(all[bucket])) /
                  std::log10(1.0 + static_cast<double>(largest))));
    text += fmt::format(" {:>6.2f}% {:>6.2f}%  {}\n", share, cumulative, std::string(length, '#'));
  }
  return text;
}

std::optional<std::size_t> noisiest_cpu(const std::vector<cpu_latency>& cpus) {
  if (cpus.empty()) return std::nullopt;
  std::size_t noisiest = 0;
  for (std::size_t index = 1; index < cpus.size(); ++index) {
    const cpu_latency& a = cpus[index];
    const cpu_latency& b = cpus[noisiest];
    if (a.p99_ns > b.p99_ns || (a.p99_ns == b.p99_ns && a.max_ns > b.max_ns) ||
        (a.p99_ns == b.p99_ns && a.max_ns == b.max_ns && a.cpu < b.cpu))
      noisiest = index;
  }
  return noisiest;
}

}  // namespace lockstep::bench
