// The known answers beside the matrix (known_answers.hpp).
#include "bench/run/known_answers.hpp"

#include <fmt/core.h>

#include <exception>

#include "bench/probe_reports/falseshare_report.hpp"
#include "bench/probe_reports/migrate_report.hpp"
#include "bench/probes/falseshare.hpp"
#include "bench/probes/migrate.hpp"
#include "platform/cache_line.hpp"
#include "platform/placement.hpp"

namespace lockstep::bench {

// falseshare's patterns at its two strides (one line, 8 bytes apart, against
// 128 bytes apart: no shared line nor shared prefetch pair) on the pinned
// pair, and migrate's forced moves between those two CPUs. Four patterns x
// two strides of 4 ms (3 ms quick) over 9 repeats (7 quick) cost about 0.3 s
// (0.17 s); 60 moves (30 quick) a few ms.
known_answers measure_known_answers(const platform::topology& machine, bool quick) {
  known_answers answers;
  const platform::placement_plan pair = platform::plan_placement(machine, platform::placement::compact, 2);
  if (pair.oversubscribed || pair.wrapped || !pair.entries[0].pu || !pair.entries[1].pu ||
      *pair.entries[0].pu == *pair.entries[1].pu) {
    answers.false_sharing_unavailable = answers.migration_unavailable = "fewer than two CPUs to pin two threads on";
    return answers;
  }
  const unsigned first = *pair.entries[0].pu;
  const unsigned second = *pair.entries[1].pu;
  try {
    probes::falseshare_settings settings;
    settings.cpus = {static_cast<int>(first), static_cast<int>(second)};
    settings.patterns = probes::plan_patterns({8, platform::kPrefetchPair});
    settings.window_ns = quick ? 3'000'000 : 4'000'000;
    settings.repeats = quick ? 7 : 9;
    const falseshare_analysis analysis = analyse_falseshare(probes::measure_false_sharing(settings));
    answers.false_sharing_relation = cpus_relation(machine, settings.cpus);
    for (const pattern_analysis& pattern : analysis.patterns) {
      if (!pattern.penalty) continue;
      answers.false_sharing.push_back(false_sharing_probe{std::string(probes::all_access_patterns[pattern.pattern].name),
                                                          fmt::format("{},{}", first, second),
                                                          pattern.penalty->sharing_stride_bytes,
                                                          pattern.penalty->apart_stride_bytes,
                                                          pattern.penalty->estimate,
                                                          pattern.penalty->verdict,
                                                          pattern.penalty->ratios.size()});
    }
    if (answers.false_sharing.empty()) answers.false_sharing_unavailable = "no repeat scheduled both threads";
  } catch (const std::exception& error) {
    answers.false_sharing_unavailable = error.what();
  }
  try {
    probes::migrate_settings settings;
    settings.from = first;
    settings.to = second;
    settings.repeats = quick ? 30 : 60;
    const probes::migrate_result result = probes::measure_migration(settings);
    const migrate_analysis analysis = analyse_migrate(settings, result, machine);
    answers.migration = migration_probe{fmt::format("{}<->{}", first, second), settings.bytes, analysis.move,
                                        analysis.refill};
  } catch (const std::exception& error) {
    answers.migration_unavailable = error.what();
  }
  return answers;
}

}  // namespace lockstep::bench
