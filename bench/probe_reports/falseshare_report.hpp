#pragma once
// What a false-sharing measurement (bench/probes/falseshare.hpp) means, and
// its two readings: the text a person reads and the result file
// (docs/result-files.md, kind "falseshare"). analyse_falseshare derives every
// figure once (per access pattern, each stride's distribution and the paired
// penalty of sharing a line against sharing nothing); falseshare_text and
// falseshare_json only arrange them. falseshare_answer_of words the answer,
// for this command's last line and for the run's answer
// (bench/run/answer.cpp), so that both say the same thing the same way.
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

// The known answer, paired: the smallest stride whose words share a line
// against the smallest that shares nothing, a ratio per repeat (both ran
// within one repeat, a few windows apart).
struct falseshare_penalty {
  std::size_t sharing_stride_bytes = 0;
  std::size_t apart_stride_bytes = 0;
  std::vector<double> ratios;  // one per repeat both strides had a mean in
  ratio_estimate estimate;
  ratio_verdict verdict = ratio_verdict::unsure;
};

// What one pattern's penalty says about the machine, by its verdict (the one
// rule, platform/statistics.hpp):
//   pays    penalty: the whole interval above the noise band
//   hidden  within noise, or gain (one line no slower than apart): this core
//           hides false sharing for the pattern
//   unsure  the interval straddles an edge of the band
enum class falseshare_reading { pays, hidden, unsure };
falseshare_reading reading_of(ratio_verdict verdict) noexcept;

struct pattern_analysis {
  std::size_t pattern = 0;  // index in probes::all_access_patterns
  // Per stride, in the measurement's order; none when no thread was
  // scheduled during any window.
  std::vector<std::optional<platform::distribution>> ns_per_access;
  std::optional<falseshare_penalty> penalty;  // when both strides exist and paired at least once
};

struct falseshare_analysis {
  std::vector<pattern_analysis> patterns;  // in the measurement's order
};

// Every figure the readings print or write, derived once.
falseshare_analysis analyse_falseshare(const std::vector<probes::pattern_cost>& costs);

// One pattern's penalty, as an answer states it.
struct pattern_figure {
  std::size_t pattern = 0;  // index in probes::all_access_patterns
  ratio_estimate estimate;
  ratio_verdict verdict = ratio_verdict::unsure;
};

// What the answer cites when no pattern pays: the CPUs, how hwloc relates
// them, and (a run only) the one-way core-to-core latency it measured.
struct falseshare_evidence {
  std::string cpus;                       // "0,1"
  std::string relation;                   // "shared L3"; empty: unknown
  std::optional<double> c2c_one_way_ns;
};

// The answer in parts, for a caller to join on one line or wrap at the
// seams: each pattern's figure ("atomic read-modify-writes 4.61x [4.12,
// 4.90] penalty"), those that pay first (the larger first), then the unsure,
// then the hidden (the table's order among equals); and the conclusion:
//   some pay, some hidden   "this core hides it for plain stores and ..."
//   none pays, some hidden  "no pattern pays: " and what that means, with the evidence
//   every one pays          "every pattern measured pays"
// with "unsure for ..." added for the unsure ones.
struct falseshare_answer {
  std::vector<std::string> figures;
  std::string conclusion;
};
falseshare_answer falseshare_answer_of(std::vector<pattern_figure> figures, const falseshare_evidence& evidence);

// hwloc's word for how two CPUs relate ("shared L3"), or empty when there are
// not exactly two or the topology does not know them.
std::string cpus_relation(const platform::topology& machine, const std::vector<int>& cpus);

// The whole text of the answer (stdout); `window_text` is the window as asked
// (e.g. "50ms"). Its last line is the answer.
std::string falseshare_text(const probes::falseshare_settings& settings, const std::string& window_text,
                            const std::vector<probes::pattern_cost>& costs, const falseshare_analysis& analysis,
                            const falseshare_evidence& evidence);

// The result file's document (kind "falseshare"), the machine context included.
nlohmann::json falseshare_json(const probes::falseshare_settings& settings,
                               const std::vector<probes::pattern_cost>& costs, const falseshare_analysis& analysis,
                               const falseshare_evidence& evidence, const platform::topology& machine);

}  // namespace lockstep::bench
