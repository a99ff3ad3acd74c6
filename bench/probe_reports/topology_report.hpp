#pragma once
// What hwloc sees on a machine (platform/topology.hpp) and the placement
// plans lockstep would use on it (platform/placement.hpp), and their two
// readings: the text a person reads and the result file
// (docs/result-files.md, kind "topology"). topology_plans derives the plans
// once; topology_text and topology_json only arrange the machine and them.
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "platform/placement.hpp"
#include "platform/topology.hpp"

namespace lockstep::bench {

// Every placement's plan for 1, 2, 4 threads (4 is the paper's case) and the
// number of usable cores, placement after placement.
std::vector<platform::placement_plan> topology_plans(const platform::topology& machine);

// The whole text of the answer (stdout): summary, caches, cores, affinity, plans.
std::string topology_text(const platform::topology& machine, const std::vector<platform::placement_plan>& plans);

// The result file's document (kind "topology"; its own shape, no machine context).
nlohmann::json topology_json(const platform::topology& machine, const std::vector<platform::placement_plan>& plans);

}  // namespace lockstep::bench
