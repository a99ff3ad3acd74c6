#pragma once
// What `lockstep delay` prints and writes besides its distributions: the
// histogram in cyclictest's -h text format, the terminal histogram on
// logarithmic buckets, the per-CPU table and its noisiest CPU.
//
// cyclictest's -h format (rt-tests; checked against `cyclictest -q -D 1 -h
// 100 -t 2 --histfile=F` output), one column per thread:
//   # Histogram
//   000000 000012\t000003            bucket in us (%06d), then each thread's count
//   ...                               (%06lu; the first after a space, the
//                                      others after a tab), buckets 0..bound-1
//   # Total: 000000997 000001000      samples in the buckets, per thread (%09llu)
//   # Min Latencies: 00017 00016      us, per thread (%05lu)
//   # Avg Latencies: 00021 00019
//   # Max Latencies: 00058 01358
//   # Histogram Overflows: 00000 00002
//   # Histogram Overflow at cycle number:
//   # Thread 0:
//   # Thread 1: 00017 00981          the first `bound` cycles (periods) that
//                                     overflowed (%05lu each), then
//                                     " # %05d others" when there were more
//   (an empty line)
#include <nlohmann/json.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "bench/probes/latency_histogram.hpp"

namespace lockstep::bench {

// The histogram in cyclictest's -h text format (above).
std::string cyclictest_histogram_text(const probes::latency_histogram& histogram);

// {"bucket_us": 1, "bound_us", "columns": [{"name", "cpu", "counts" (bound_us
// numbers), "overflow", "samples", "min_us", "avg_us", "max_us"}]}.
nlohmann::json latency_histogram_json(const probes::latency_histogram& histogram);

struct labelled_samples {
  std::string name;
  std::vector<double> samples_ns;
};

// The terminal histogram: buckets with 1-2-5 edges in microseconds ([0, 1),
// [1, 2), [2, 5), [5, 10), [10, 20), ...), so that the bulk spreads over a
// few rows and every tail sample keeps a row of its own scale; rows from the
// first to the last non-empty bucket. One count column per series (and an
// "all" column when there are several), the share of all samples and its
// cumulative share, and a bar whose length grows with log10(1 + count), so a
// bucket of one sample still shows.
std::string log_histogram_text(const std::vector<labelled_samples>& series, std::size_t bar_width = 40);

// One CPU's line of the per-CPU table.
struct cpu_latency {
  unsigned cpu = 0;
  double p99_ns = 0;
  double max_ns = 0;
};

// The rule that names the noisiest CPU, in words (printed and written).
inline constexpr const char* kNoisiestRule =
    "the highest p99 wake-up latency; ties: the higher max, then the lower CPU number";
// The index (into `cpus`) of the noisiest CPU by kNoisiestRule; empty for none.
std::optional<std::size_t> noisiest_cpu(const std::vector<cpu_latency>& cpus);

}  // namespace lockstep::bench
