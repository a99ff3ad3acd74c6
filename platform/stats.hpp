#pragma once
// Distributions of nanosecond samples: percentiles and a fixed-bucket
// histogram, shared by `lockstep c2c`, `lockstep delay` and the matrix.
//
// Percentiles: platform/statistics.hpp's quantile (linear interpolation
// between closest ranks, numpy's default), so p50 is the usual median (the
// mean of the two middle samples when n is even) and every percentile lies
// between two observed samples. The report tool (numpy) computes the same
// values from the same samples.
//
// Histogram: bucket i counts samples in [first + i w, first + (i + 1) w);
// samples below `first` and at or above `first + buckets w` are counted apart
// (below(), above()), never dropped and never folded into an end bucket.
//
// Mean: the compensated sum (compensated_sum) over the count.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "platform/statistics.hpp"

namespace lockstep::platform {

// What every distribution in lockstep reports (the keys of the result JSON:
// min, p50, p99, p999, max, count; mean for convenience).
struct distribution {
  std::size_t count = 0;
  double min = 0;
  double p50 = 0;
  double p99 = 0;
  double p999 = 0;
  double max = 0;
  double mean = 0;
};

// The sum of samples in double, compensated (Neumaier's improvement of
// Kahan's summation): the rounding error of every addition is carried in a
// second double and added back at the end, so the result is within about one
// ulp of the exact sum whatever the count (a plain double sum drifts by up to
// one ulp per addition). It replaces a long double sum: long double is the
// 80-bit x87 format on x86-64 but a 128-bit software float on AArch64, slower
// and rounded differently, so the same samples gave two means. This uses IEEE
// double additions, subtractions, fabs and comparisons only (no product a
// compiler could fuse into a multiply-add), so x86-64 (SSE2) and AArch64 give
// the same bits for the same samples.
template <class Sample>
double compensated_sum(std::span<const Sample> samples) noexcept {
  double sum = 0.0;
  double carried = 0.0;  // the low-order parts the additions rounded away
  for (const Sample& sample : samples) {
    const auto value = static_cast<double>(sample);
    const double next = sum + value;
    carried += std::fabs(sum) >= std::fabs(value) ? (sum - next) + value : (value - next) + sum;
    sum = next;
  }
  return sum + carried;
}

template <class Sample>
distribution summarize_sorted(std::span<const Sample> sorted) {
  if (sorted.empty()) throw std::invalid_argument("a distribution of no samples");
  distribution result;
  result.count = sorted.size();
  result.min = static_cast<double>(sorted.front());
  result.max = static_cast<double>(sorted.back());
  result.p50 = quantile_of_sorted(sorted, 0.50);
  result.p99 = quantile_of_sorted(sorted, 0.99);
  result.p999 = quantile_of_sorted(sorted, 0.999);
  result.mean = compensated_sum(sorted) / static_cast<double>(sorted.size());
  return result;
}

// Sorts its own copy. Throws std::invalid_argument on no samples: there is no
// honest number to give, so the caller must say "no samples" itself.
template <class Sample>
distribution summarize(std::vector<Sample> samples) {
  std::sort(samples.begin(), samples.end());
  return summarize_sorted(std::span<const Sample>(samples));
}

class histogram {
 public:
  // `buckets` buckets of `bucket_ns` each, the first starting at `first_ns`.
  histogram(std::int64_t first_ns, std::int64_t bucket_ns, std::size_t buckets)
      : first_ns_(first_ns), bucket_ns_(bucket_ns), counts_(buckets, 0) {
    if (bucket_ns <= 0) throw std::invalid_argument("histogram bucket width must be positive");
    if (buckets == 0) throw std::invalid_argument("histogram needs at least one bucket");
  }

  // Buckets of a round width (1, 2 or 5 times a power of ten ns) that cover
  // [min, max] of these samples in at most `max_buckets` buckets; first_ns is
  // min rounded down to the width. Samples are not added.
  template <class Sample>
  static histogram covering(std::span<const Sample> samples, std::size_t max_buckets = 50) {
    if (samples.empty() || max_buckets == 0) return histogram(0, 1, 1);
    const auto [low_it, high_it] = std::minmax_element(samples.begin(), samples.end());
    const auto low = static_cast<std::int64_t>(std::floor(static_cast<double>(*low_it)));
    const auto high = static_cast<std::int64_t>(std::floor(static_cast<double>(*high_it)));
    std::int64_t width = 1;
    for (std::int64_t decade = 1;; decade *= 10) {
      bool found = false;
      for (std::int64_t factor : {1, 2, 5}) {
        width = decade * factor;
        const std::int64_t first = floor_to(low, width);
        if (static_cast<std::size_t>((high - first) / width + 1) <= max_buckets) {
          found = true;
          break;
        }
      }
      if (found) break;
    }
    const std::int64_t first = floor_to(low, width);
    return histogram(first, width, static_cast<std::size_t>((high - first) / width + 1));
  }

  void add(std::int64_t sample_ns) noexcept {
    if (sample_ns < first_ns_) {
      ++below_;
      return;
    }
    const auto index = static_cast<std::uint64_t>((sample_ns - first_ns_) / bucket_ns_);
    if (index >= counts_.size()) {
      ++above_;
      return;
    }
    ++counts_[index];
  }
  void add(double sample_ns) noexcept { add(static_cast<std::int64_t>(std::floor(sample_ns))); }

  std::int64_t first_ns() const noexcept { return first_ns_; }
  std::int64_t bucket_ns() const noexcept { return bucket_ns_; }
  std::size_t bucket_count() const noexcept { return counts_.size(); }
  const std::vector<std::uint64_t>& counts() const noexcept { return counts_; }
  std::uint64_t below() const noexcept { return below_; }
  std::uint64_t above() const noexcept { return above_; }
  std::uint64_t total() const noexcept {
    std::uint64_t sum = below_ + above_;
    for (std::uint64_t count : counts_) sum += count;
    return sum;
  }
  // Lower edge of bucket i in ns.
  std::int64_t bucket_start(std::size_t index) const noexcept {
    return first_ns_ + static_cast<std::int64_t>(index) * bucket_ns_;
  }

  // Text rendering: one line per non-empty bucket (plus the below/above lines
  // when non-zero): "  [  1200,   1300) ns  ######## 123", bars scaled to
  // `bar_width` characters for the largest count.
  std::string render(std::size_t bar_width = 50) const {
    std::uint64_t largest = std::max(below_, above_);
    for (std::uint64_t count : counts_) largest = std::max(largest, count);
    std::string text;
    const auto bar = [&](std::uint64_t count) {
      const std::size_t length =
          largest == 0 ? 0 : static_cast<std::size_t>((count * bar_width + largest - 1) / largest);
      return std::string(length, '#');
    };
    const auto line = [&](const std::string& label, std::uint64_t count) {
      std::string row = "  " + label;
      if (row.size() < 32) row.append(32 - row.size(), ' ');
      row += bar(count);
      row += ' ';
      row += std::to_string(count);
      row += '\n';
      text += row;
    };
    if (below_ != 0) line("< " + std::to_string(first_ns_) + " ns", below_);
    for (std::size_t index = 0; index < counts_.size(); ++index) {
      if (counts_[index] == 0) continue;
      line("[" + std::to_string(bucket_start(index)) + ", " + std::to_string(bucket_start(index + 1)) + ") ns",
           counts_[index]);
    }
    if (above_ != 0) line(">= " + std::to_string(bucket_start(counts_.size())) + " ns", above_);
    return text;
  }

 private:
  static std::int64_t floor_to(std::int64_t value, std::int64_t width) noexcept {
    const std::int64_t quotient = value / width;
    return (value % width != 0 && value < 0 ? quotient - 1 : quotient) * width;
  }

  std::int64_t first_ns_;
  std::int64_t bucket_ns_;
  std::vector<std::uint64_t> counts_;
  std::uint64_t below_ = 0;
  std::uint64_t above_ = 0;
};

}  // namespace lockstep::platform
