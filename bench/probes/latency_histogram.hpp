#pragma once
// Wake-up latency histograms as cyclictest keeps them (-h US): one column per
// thread, 1 us buckets from 0 up to a bound, and an overflow count.
//
// A sample of `ns` nanoseconds falls in bucket floor(ns / 1000) (cyclictest
// takes its latencies in whole microseconds, truncated, and uses the value as
// the bucket index); a sample of bound_us or more counts as an overflow and
// its period index is remembered, the first bound_us of them, as cyclictest
// lists them. min, avg and max are over every sample of the column, the
// overflows included, in whole microseconds (avg: the mean of the truncated
// values, truncated), as cyclictest prints them.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace lockstep::bench::probes {

// cyclictest's -h default is none; lockstep's: long enough for the tail of a
// 1 ms period (the default period) on a VM, short enough to read.
inline constexpr std::int64_t kDefaultHistogramBoundUs = 1000;

struct latency_histogram_column {
  std::string name;                  // "worker 0", "cpu 1"
  std::optional<unsigned> cpu;       // where the thread ran (per-CPU runs; a team's first period)
  std::vector<std::uint64_t> counts;  // bound_us buckets: counts[i] holds [i us, i + 1 us)
  std::uint64_t overflow = 0;        // samples of bound_us or more
  std::vector<std::int64_t> overflow_periods;  // the first bound_us periods that overflowed
  std::uint64_t samples = 0;         // every sample (the buckets' total + overflow)
  std::int64_t min_us = 0;
  std::int64_t avg_us = 0;
  std::int64_t max_us = 0;

  std::uint64_t in_buckets() const noexcept { return samples - overflow; }
};

struct latency_histogram {
  std::int64_t bound_us = kDefaultHistogramBoundUs;
  std::vector<latency_histogram_column> columns;
};

// One column from one thread's samples, in period order (index = period).
inline latency_histogram_column histogram_column(const std::vector<double>& samples_ns, std::int64_t bound_us,
                                                 std::string name, std::optional<unsigned> cpu = std::nullopt) {
  if (bound_us <= 0) throw std::invalid_argument("the histogram bound must be at least 1 us");
  latency_histogram_column column;
  column.name = std::move(name);
  column.cpu = cpu;
  column.counts.assign(static_cast<std::size_t>(bound_us), 0);
  std::int64_t sum_us = 0;
  for (std::size_t period = 0; period < samples_ns.size(); ++period) {
    // Truncated to whole microseconds; a latency is never negative (an
    // absolute sleep does not return early), a negative one would be a clock
    // fault and is kept in bucket 0 rather than dropped.
    const auto us = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor(samples_ns[period] / 1000.0)));
    if (column.samples == 0) {
      column.min_us = us;
      column.max_us = us;
    }
    column.min_us = std::min(column.min_us, us);
    column.max_us = std::max(column.max_us, us);
    sum_us += us;
    ++column.samples;
    if (us >= bound_us) {
      ++column.overflow;
      if (column.overflow_periods.size() < static_cast<std::size_t>(bound_us))
        column.overflow_periods.push_back(static_cast<std::int64_t>(period));
    } else {
      ++column.counts[static_cast<std::size_t>(us)];
    }
  }
  column.avg_us = column.samples == 0 ? 0 : sum_us / static_cast<std::int64_t>(column.samples);
  return column;
}

}  // namespace lockstep::bench::probes
