// Stall reasons and accounting counters (team_driver.hpp).
#include "bench/run/team_driver.hpp"

#include "bench/run/pace.hpp"
#include "platform/statistics.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>

namespace lockstep::bench {

namespace {

std::string format_ms(std::int64_t ns) { return fmt::format("{:.1f} ms", static_cast<double>(ns) / 1e6); }

}  // namespace

std::string stall_reason(const call_result& result, const char* unit, bool pure_spin, bool may_lose_wakeups,
                         const platform::placement_plan& plan, const run_settings& settings) {
  std::string why;
  if (result.batches.stalled) {
    why = fmt::format("stalled: one {} took {} (bound {})", unit, format_ms(result.batches.slowest_unit_ns),
                      format_ms(settings.stall_unit_ns));
  } else {
    why = fmt::format("bounded: the call ran out of its {} budget after {} {}s", format_ms(settings.call_budget_ns),
                      result.batches.units_run, unit);
  }
  const unsigned cpus = static_cast<unsigned>(plan.affinity.size());
  if (result.sync_totals.timeouts > 0) {
    why += fmt::format(": lost wake-ups ({} waits ended by timeout)", result.sync_totals.timeouts);
  } else if (pure_spin && plan.oversubscribed) {
    why += fmt::format(": pure-spin primitive with {} threads on {} CPUs", plan.threads, cpus);
  } else if (may_lose_wakeups) {
    why += ": the primitive can lose wake-ups";
  } else if (plan.oversubscribed) {
    why += fmt::format(": {} threads on {} CPUs", plan.threads, cpus);
  }
  return why;
}

// Two calls of entries rarely lie more than this apart (the benchmark thread
// only reports and registers between them), so the reading taken after one
// call serves as the reading before the next.
constexpr std::int64_t kFreshReadingNs = 50'000'000;

long pace_reading_before(harness_state& harness) {
  return harness.pace == nullptr ? -1 : static_cast<long>(harness.pace->latest_or_take(kFreshReadingNs));
}

void size_entry(benchmark::internal::Benchmark& entry, const sync::primitive_info* primitive, unsigned threads,
                const harness_state& harness) {
  const bool collapse_foreseen =
      primitive != nullptr && primitive->pure_spin && harness.machine != nullptr &&
      platform::is_oversubscribed(threads, static_cast<unsigned>(harness.machine->affinity().size()));
  if (collapse_foreseen) {
    entry.Repetitions(kBriefRepetitions);
    entry.Iterations(std::min(kBriefBatches, harness.settings.timed_batches));
  } else {
    entry.Iterations(harness.settings.timed_batches);
  }
}

long pace_reading_after(harness_state& harness) {
  if (harness.after_call) harness.after_call();
  return harness.pace == nullptr ? -1 : static_cast<long>(harness.pace->take());
}

void set_pace_counters(benchmark::State& state, const harness_state& harness, long before, long after) {
  if (harness.pace == nullptr || before < 0 || after < 0) return;
  const auto& trace = harness.pace->trace();
  const pace_reading& first = trace.at(static_cast<std::size_t>(before));
  const pace_reading& last = trace.at(static_cast<std::size_t>(after));
  if (first.c2c_ns && last.c2c_ns) state.counters["pace_c2c_ns"] = (*first.c2c_ns + *last.c2c_ns) / 2.0;
  state.counters["pace_serial_ns"] = (first.serial_ns + last.serial_ns) / 2.0;
  state.counters[std::string(kPaceBeforeCounter)] = static_cast<double>(before);
  state.counters[std::string(kPaceAfterCounter)] = static_cast<double>(after);
}

double median_unit_ns(const batch_record& record) {
  if (record.batch_ns.empty() || record.units_per_batch == 0) return 0.0;
  const std::vector<double> batch_ns(record.batch_ns.begin(), record.batch_ns.end());
  return platform::median(batch_ns) / static_cast<double>(record.units_per_batch);
}

double ns_per_unit(const call_result& result) {
  std::int64_t total = 0;
  for (std::int64_t batch : result.batches.batch_ns) total += batch;
  const double units =
      static_cast<double>(result.batches.batch_ns.size()) * static_cast<double>(result.batches.units_per_batch);
  return units > 0.0 ? static_cast<double>(total) / units : 0.0;
}

void set_accounting_counters(benchmark::State& state, const call_result& result, const std::string& unit) {
  if (!result.accounting || result.batches.units_run == 0) return;
  const platform::thread_counters& total = *result.accounting;
  const double per_k = 1000.0 / static_cast<double>(result.batches.units_run);
  state.counters["csw_vol_per_k" + unit] = static_cast<double>(total.voluntary_switches) * per_k;
  state.counters["csw_invol_per_k" + unit] = static_cast<double>(total.involuntary_switches) * per_k;
  if (total.migrations) {
    state.counters["migrations_per_k" + unit] = static_cast<double>(*total.migrations) * per_k;
    // A percentage of no switches is no number: omitted, like unavailable ones.
    if (const auto share = platform::cross_core_switch_percent(total); share && std::isfinite(*share))
      state.counters["cross_core_csw_pct"] = *share;
  }
}

}  // namespace lockstep::bench
