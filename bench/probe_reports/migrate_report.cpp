// What a migration measurement means, as text and as a result file (migrate_report.hpp).
#include "bench/probe_reports/migrate_report.hpp"

#include <fmt/core.h>

#include "bench/results/machine_context.hpp"
#include "bench/results/result_json.hpp"

namespace lockstep::bench {

migrate_analysis analyse_migrate(const probes::migrate_settings& settings, const probes::migrate_result& samples,
                                 const platform::topology& machine) {
  migrate_analysis analysis;
  analysis.relation = std::string(platform::to_string(machine.relation(settings.from, settings.to)));
  analysis.move = platform::summarize(samples.move_ns);
  analysis.stay = platform::summarize(samples.stay_ns);
  analysis.refill = platform::summarize(samples.refill_ns);
  analysis.first_pass = platform::summarize(samples.first_pass_ns);
  analysis.next_pass = platform::summarize(samples.next_pass_ns);
  return analysis;
}

namespace {

std::string row(const char* what, const platform::distribution& d) {
  return fmt::format("{:<34} {:>10.0f} {:>10.0f} {:>10.0f} {:>10.0f}\n", what, d.min, d.p50, d.p99, d.max);
}

}  // namespace

std::string migrate_text(const probes::migrate_settings& settings, const migrate_analysis& analysis) {
  std::string text =
      fmt::format("forced migration between CPU {} and CPU {} ({}), working set {} bytes, {} migrations\n",
                  settings.from, settings.to, analysis.relation, settings.bytes, settings.repeats);
  text += fmt::format("{:<34} {:>10} {:>10} {:>10} {:>10}\n", "ns", "min", "median", "p99", "max");
  text += row("move (setaffinity until there)", analysis.move);
  text += row("  baseline: setaffinity, no move", analysis.stay);
  text += row("refill (first pass - next pass)", analysis.refill);
  text += row("  first pass after the move", analysis.first_pass);
  text += row("  next pass (lines local)", analysis.next_pass);
  text += fmt::format("one migration ~ {:.0f} ns move + {:.0f} ns refill (medians)\n", analysis.move.p50,
                      analysis.refill.p50);
  return text;
}

nlohmann::json migrate_json(const probes::migrate_settings& settings, const probes::migrate_result& samples,
                            const migrate_analysis& analysis, const platform::topology& machine) {
  nlohmann::json document = result_document("migrate", machine);
  document["settings"] = {{"from", settings.from},
                          {"to", settings.to},
                          {"relation", analysis.relation},
                          {"bytes", settings.bytes},
                          {"repeats", settings.repeats}};
  document["move_ns"] = distribution_json(samples.move_ns);
  document["setaffinity_no_move_ns"] = distribution_json(samples.stay_ns);
  document["refill_ns"] = distribution_json(samples.refill_ns);
  document["first_pass_ns"] = distribution_json(samples.first_pass_ns);
  document["next_pass_ns"] = distribution_json(samples.next_pass_ns);
  return document;
}

}  // namespace lockstep::bench
