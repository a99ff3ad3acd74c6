#pragma once
// What a core-to-core measurement (bench/probes/core_to_core.hpp, pairs
// planned by bench/probes/c2c_pairs.hpp) means, and its two readings: the
// text a person reads and the result file (docs/result-files.md, kind "c2c").
// analyse_c2c derives every figure once (each pair's hwloc relation and
// one-way distribution, each method's matrix of medians); c2c_text and
// c2c_json only arrange them.
#include <nlohmann/json.hpp>

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "bench/probes/c2c_pairs.hpp"
#include "bench/probes/core_to_core.hpp"
#include "platform/stats.hpp"
#include "platform/topology.hpp"

namespace lockstep::bench {

// One method's matrix: the median one-way latency of each measured pair, under
// (a, b) and (b, a) alike.
struct c2c_matrix {
  c2c::method how = c2c::method::cas;
  std::map<std::pair<int, int>, double> median_ns;
};

struct c2c_analysis {
  std::vector<std::string> relations;           // per measured pair, hwloc's label (platform/topology.hpp)
  std::vector<std::pair<int, int>> nodes;       // per measured pair, its CPUs' NUMA nodes (kNoObject: none)
  std::vector<platform::distribution> one_way;  // per measured pair
  std::vector<c2c_matrix> matrices;             // per method, in the order asked
};

// Every figure the readings print or write, derived once.
c2c_analysis analyse_c2c(const std::vector<c2c::pair_latency>& results, const std::vector<c2c::method>& methods,
                         const platform::topology& machine);

// The table of every pair and one matrix per method (stdout); `cpus` are the
// matrix's rows and columns.
std::string c2c_text(const c2c::c2c_settings& settings, const std::vector<int>& cpus,
                     const std::vector<c2c::pair_latency>& results, const c2c_analysis& analysis);

// The result file's document (kind "c2c"), the machine context included.
nlohmann::json c2c_json(const probes::c2c_plan& plan, const c2c::c2c_settings& settings,
                        const std::vector<c2c::pair_latency>& results, const c2c_analysis& analysis,
                        const platform::topology& machine);

}  // namespace lockstep::bench
