#pragma once
// The falseshare probe: false sharing priced directly. Pinned threads each
// increment their own counter; the counters sit `stride` bytes apart in one
// page, and the stride is swept. Below the line size the writers share a line
// and every write needs the line back from another core; at 64 bytes they
// share a 128-byte pair (what adjacent-line prefetchers fetch together); from
// 128 bytes they share nothing.
//
// Contract: measure_false_sharing blocks for about
//   repeats x strides x window
// and leaves the caller's affinity untouched. It throws std::runtime_error
// when a writer cannot be pinned to its CPU (naming it) or the counter page
// cannot be mapped.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace lockstep::bench::probes {

struct falseshare_settings {
  std::vector<int> cpus;             // one writer pinned to each (>= 2)
  std::vector<std::size_t> strides;  // bytes between neighbouring counters, multiples of 8
  std::int64_t window_ns = 100'000'000;  // how long the writers write per measurement
  int repeats = 5;                   // measurements per stride
  // Called before each repeat (0-based) of all strides.
  std::function<void(int repeat)> on_repeat;
};

struct stride_cost {
  std::size_t stride_bytes = 0;
  bool shares_line = false;       // stride < platform::kCacheLine
  bool shares_line_pair = false;  // stride < platform::kPrefetchPair
  // ns per write, one sample per writer per repeat; a writer that was not
  // scheduled during a window has no sample (its cost is unknown, not infinite).
  std::vector<double> ns_per_write;
  // Per repeat: the mean over the writers that were scheduled (empty when
  // none was). The strides of one repeat ran a few windows apart, so a
  // ratio of two strides within a repeat is a pair (paired_ratio.hpp).
  std::vector<std::optional<double>> repeat_mean_ns;
};

// Repeats outermost: a slow phase of a loaded machine spreads over every
// stride instead of landing on one.
std::vector<stride_cost> measure_false_sharing(const falseshare_settings& settings);

}  // namespace lockstep::bench::probes
