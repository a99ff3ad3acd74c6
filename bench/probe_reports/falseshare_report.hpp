#pragma once
// What a false-sharing measurement (bench/probes/falseshare.hpp) means, and
// its two readings: the text a person reads and the result file
// (docs/result-files.md, kind "falseshare"). analyse_falseshare derives every
// figure once (each stride's distribution, the paired penalty of sharing a
// line against sharing nothing); falseshare_text and falseshare_json only
// arrange them.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "bench/results/paired_ratio.hpp"
#include "bench/probes/falseshare.hpp"
#include "platform/stats.hpp"
#include "platform/topology.hpp"

namespace lockstep::bench {

// The known answer, paired: the smallest stride whose writers share a line
// against the smallest that shares nothing, a ratio per repeat (both ran
// within one repeat, a few windows apart).
struct falseshare_penalty {
  std::size_t sharing_stride_bytes = 0;
  std::size_t apart_stride_bytes = 0;
  std::vector<double> ratios;  // one per repeat both strides had a mean in
  ratio_estimate estimate;
  ratio_verdict verdict = ratio_verdict::unsure;
};

struct falseshare_analysis {
  // Per stride, in the measurement's order; none when no writer was scheduled
  // during any window.
  std::vector<std::optional<platform::distribution>> ns_per_write;
  std::optional<falseshare_penalty> penalty;  // when both strides exist and paired at least once
};

// Every figure the readings print or write, derived once.
falseshare_analysis analyse_falseshare(const std::vector<probes::stride_cost>& costs);

// The whole text of the answer (stdout); `window_text` is the window as asked
// (e.g. "50ms").
std::string falseshare_text(const probes::falseshare_settings& settings, const std::string& window_text,
                            const std::vector<probes::stride_cost>& costs, const falseshare_analysis& analysis);

// The result file's document (kind "falseshare"), the machine context included.
nlohmann::json falseshare_json(const probes::falseshare_settings& settings,
                               const std::vector<probes::stride_cost>& costs, const falseshare_analysis& analysis,
                               const platform::topology& machine);

}  // namespace lockstep::bench
