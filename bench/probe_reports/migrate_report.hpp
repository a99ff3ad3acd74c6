#pragma once
// What a migration measurement (bench/probes/migrate.hpp) means, and its two
// readings: the text a person reads and the result file (docs/result-files.md,
// kind "migrate"). analyse_migrate derives every figure once (the two CPUs'
// hwloc relation, each series' distribution); migrate_text and migrate_json
// only arrange them.
#include <nlohmann/json.hpp>

#include <string>

#include "bench/probes/migrate.hpp"
#include "platform/stats.hpp"
#include "platform/topology.hpp"

namespace lockstep::bench {

struct migrate_analysis {
  std::string relation;  // of settings.from and settings.to in hwloc's tree (platform/topology.hpp)
  platform::distribution move;
  platform::distribution stay;
  platform::distribution refill;
  platform::distribution first_pass;
  platform::distribution next_pass;
};

// Every figure the readings print or write, derived once.
migrate_analysis analyse_migrate(const probes::migrate_settings& settings, const probes::migrate_result& samples,
                                 const platform::topology& machine);

// The whole text of the answer (stdout).
std::string migrate_text(const probes::migrate_settings& settings, const migrate_analysis& analysis);

// The result file's document (kind "migrate"), the machine context included.
nlohmann::json migrate_json(const probes::migrate_settings& settings, const probes::migrate_result& samples,
                            const migrate_analysis& analysis, const platform::topology& machine);

}  // namespace lockstep::bench
