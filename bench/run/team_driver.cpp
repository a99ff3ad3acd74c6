// One call of an entry (measure_entry), stall reasons and accounting counters (team_driver.hpp).
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

std::string stall_reason(const call_result& result, std::string_view unit, bool pure_spin, bool may_lose_wakeups,
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

void set_accounting_counters(benchmark::State& state, const call_result& result, entry_unit unit_kind) {
  const std::string unit(to_string(unit_kind));
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


namespace {

// One call of an entry as measure_entry drives it: the ways a call ends
// early (a skip, a flagged repetition, a stop, a placement failure), the
// batch-size probe, the timed call and what Google Benchmark is given.
class entry_measurement {
 public:
  entry_measurement(entry_call& call, const call_runner& run)
      : call_(call),
        run_(run),
        settings_(call.harness.settings),
        measured_before_(call.harness.measured.count(call.name) > 0),
        stall_key_((call.primitive != nullptr ? std::string(call.primitive->name) : call.name) + " threads:" +
                   std::to_string(call.plan.threads)) {}

  // Whether a stop already known for this entry or its primitive ends this
  // call at once (the reason given to Google Benchmark).
  bool known_stop() {
    harness_state& harness = call_.harness;
    if (const auto known = harness.stalled.find(call_.name); known != harness.stalled.end()) {
      if (measured_before_) return flag_measured_entry(call_result{}, "an earlier call stopped: " + known->second);
      return skip(known->second);
    }
    if (!measured_before_ && call_.primitive != nullptr) {
      const unsigned stalls = harness.stalls_of_sync[stall_key_];
      if (stalls >= harness.stalls_before_skipping_sync) {
        const std::string reason =
            "skipped: " + stall_key_ + " already stalled in " + std::to_string(stalls) + " entries of this run";
        harness.stalled[call_.name] = reason;
        return skip(reason);
      }
    }
    return false;
  }

  // The units per batch of this entry: its probe's, or a fresh probe's;
  // nothing when the probe stopped (the call has then ended, the reason given).
  std::optional<std::uint64_t*> batch_size();
  // The timed call, re-sized while its batches are far too short; nothing
  // when it stopped (as above).
  std::optional<call_result> timed_call(std::uint64_t& units_per_batch);
  // Google Benchmark's iterations (the batches' times) and the per-unit counters.
  void report(const call_result& result);

 private:
  // Every early end of a call returns true: the call has ended.
  bool skip(const std::string& reason) {
    call_.state.SkipWithError(reason.c_str());
    return true;
  }

  // Google Benchmark requires every repetition of an entry to report the same
  // iteration count (it aborts otherwise), and a skipped call reports none.
  // So once a repetition of this entry was measured, a later call that stops
  // early still walks all its iterations, then is flagged as an error, which
  // keeps it out of the aggregates; its times are not a measurement.
  // Google Benchmark 1.7.1 also computes an entry's aggregates from its first
  // repetition's statistics list, which it leaves uninitialised when that
  // repetition was flagged (google/benchmark#1406): a flagged first
  // repetition followed by two measured ones read a wild pointer and crashed
  // the run (exit 139). A call flagged while Google Benchmark still sizes the
  // first repetition becomes that repetition, so no later call may measure:
  // once a call of an entry stopped, every later call of it stops too, and
  // either every repetition is flagged or the first one was measured.
  bool flag_measured_entry(const call_result& result, const std::string& reason) {
    std::vector<std::int64_t> times = result.batches.batch_ns;
    std::int64_t filler = result.batches.slowest_unit_ns * static_cast<std::int64_t>(result.batches.units_per_batch);
    if (!times.empty()) filler = std::llround(platform::median(std::vector<double>(times.begin(), times.end())));
    std::size_t batch = 0;
    for (auto _ : call_.state) {
      call_.state.SetIterationTime(static_cast<double>(batch < times.size() ? times[batch] : filler) * 1e-9);
      ++batch;
    }
    const std::string message = reason + " (this repetition stopped after " + std::to_string(times.size()) + " of " +
                                std::to_string(batch) + " batches; its times are not a measurement)";
    return skip(message);
  }

  // A stall (one unit beyond the bound) says something about the primitive;
  // running out of the call's budget only about this call.
  bool record_stop(const call_result& result) {
    const bool pure_spin = call_.primitive != nullptr && call_.primitive->pure_spin;
    const bool may_lose_wakeups = call_.primitive != nullptr && call_.primitive->may_lose_wakeups;
    const std::string reason =
        stall_reason(result, to_string(call_.unit), pure_spin, may_lose_wakeups, call_.plan, settings_);
    call_.harness.stalled[call_.name] = reason;
    if (measured_before_) return flag_measured_entry(result, reason);
    if (result.batches.stalled && call_.primitive != nullptr) ++call_.harness.stalls_of_sync[stall_key_];
    return skip(reason);
  }

  bool record_placement_failure(const call_result& result) {
    const std::string reason = "cannot place the team: " + result.failure;
    call_.harness.stalled[call_.name] = reason;
    if (measured_before_) return flag_measured_entry(result, reason);
    return skip(reason);
  }

  // A call that could not place its team, or stopped early (or, timed, ran
  // fewer batches than `wanted`), ends the entry's call.
  bool ended(const call_result& result, std::size_t wanted = 0) {
    if (!result.failure.empty()) return record_placement_failure(result);
    if (result.batches.stalled || result.batches.over_budget || result.batches.batch_ns.size() < wanted)
      return record_stop(result);
    return false;
  }

  entry_call& call_;
  const call_runner& run_;
  const run_settings& settings_;
  const bool measured_before_;
  const std::string stall_key_;
  long pace_before_ = -1;  // the timed call's pace readings (team_driver.hpp: pace_reading_before)
  long pace_after_ = -1;
};

std::optional<std::uint64_t*> entry_measurement::batch_size() {
  harness_state& harness = call_.harness;
  if (const auto known = harness.units_per_batch.find(call_.name); known != harness.units_per_batch.end())
    return &known->second;
  // The first probe (8 batches of one unit) can land on a slow moment, or
  // weigh the harness barrier's own cost (a sleeping team's wake-up) in
  // its unit, and settle on batches far shorter than the target: the
  // entry's figure is then mostly the harness's. So the size is checked
  // by batches of the size it chose, and grown by what they fell short,
  // up to kRegrowths times; batches still under a quarter of the target
  // are flagged (harness.short_batches), not hidden. The median, not the
  // fastest batch: sized from the fastest, an entry whose steps run at two
  // speeds (win_event) took batches many times the target, and the default
  // run twice as long. The timed call below catches what a slow probe
  // still gets wrong.
  //
  // A unit that alone outlasts the target makes a batch of one unit
  // whatever the probe says, so a first batch of one unit that does is
  // the whole probe: an oversubscribed pure spinner (tens of ms a step)
  // spent about eleven units, most of a second, on a probe whose answer
  // was known after one; collapsed entries took half of the quick run.
  constexpr unsigned kProbeBatches = 8;
  constexpr unsigned kCheckBatches = 3;
  constexpr int kRegrowths = 3;
  call_result first = run_(1, 1, false, {});
  if (ended(first)) return std::nullopt;
  const bool slow_unit = median_unit_ns(first.batches) >= static_cast<double>(settings_.target_batch_ns);
  const call_result probe = slow_unit ? std::move(first) : run_(kProbeBatches, 1, false, {});
  if (ended(probe)) return std::nullopt;
  std::uint64_t units = units_for_batch(median_unit_ns(probe.batches), settings_);
  bool short_batch = false;
  for (int regrowth = 0; regrowth <= kRegrowths && !slow_unit; ++regrowth) {
    const call_result check = run_(kCheckBatches, units, false, {});
    if (ended(check)) return std::nullopt;
    const double batch_ns = median_unit_ns(check.batches) * static_cast<double>(units);
    short_batch = batch_ns < static_cast<double>(settings_.target_batch_ns) / 4.0;
    if (batch_ns >= static_cast<double>(settings_.target_batch_ns) / 2.0 || units >= kMaxUnitsPerBatch) break;
    units = units_for_batch(median_unit_ns(check.batches), settings_);
  }
  if (short_batch) harness.short_batches.insert(call_.name);
  return &harness.units_per_batch.emplace(call_.name, units).first->second;
}

std::optional<call_result> entry_measurement::timed_call(std::uint64_t& units_per_batch) {
  const auto wanted =
      static_cast<unsigned>(std::min<benchmark::IterationCount>(call_.state.max_iterations, 1'000'000));
  // The size can still be wrong by orders of magnitude: an unpinned team's
  // probe and checks, while the scheduler still places its new threads on
  // one CPU, took 10-100x a step and settled on ~20 steps per batch instead
  // of ~30,000; every later call and every paired block of the entry then
  // read 1.4-2.4x slow (mailbox's 2-thread bare step at pin:none, in 2 of 8
  // processes). A timed call whose median batch is under kShortBatch of the
  // target is re-sized from its own median and run again, before Google
  // Benchmark sees it, up to kResizes times; a re-size only grows the batch
  // (at least doubling it) and keeps the call within a quarter of its budget.
  constexpr double kShortBatch = 1.0 / 8.0;
  constexpr int kResizes = 2;
  call_result result;
  for (int resize = 0;; ++resize) {
    pace_before_ = pace_reading_before(call_.harness);
    result = run_(wanted, units_per_batch, call_.accounting, call_.warmed_up);
    pace_after_ = pace_reading_after(call_.harness);
    if (ended(result, wanted)) return std::nullopt;
    const double unit_ns = median_unit_ns(result.batches);
    const double target = static_cast<double>(settings_.target_batch_ns);
    const double batch_ns = unit_ns * static_cast<double>(result.batches.units_per_batch);
    if (batch_ns >= target / 4.0) call_.harness.short_batches.erase(call_.name);
    if (resize == kResizes || unit_ns <= 0.0 || batch_ns >= target * kShortBatch) break;
    const double affordable = static_cast<double>(settings_.call_budget_ns) / 4.0 / (unit_ns * wanted);
    const auto units = std::min(units_for_batch(unit_ns, settings_),
                                static_cast<std::uint64_t>(std::min(affordable, double(kMaxUnitsPerBatch))));
    if (units < 2 * units_per_batch) break;
    units_per_batch = units;
  }
  return result;
}

void entry_measurement::report(const call_result& result) {
  benchmark::State& state = call_.state;
  call_.harness.measured.insert(call_.name);
  set_pace_counters(state, call_.harness, pace_before_, pace_after_);
  if (call_.harness.short_batches.count(call_.name) > 0) state.counters["short_batches"] = 1.0;
  // A batch's time (team_driver.hpp, before measure_entry): Google Benchmark
  // sizes the next repetition's iterations by it; the JSON reporter writes it
  // per unit.
  const double units = static_cast<double>(result.batches.units_per_batch);
  std::size_t batch = 0;
  for (auto _ : state) {
    state.SetIterationTime(static_cast<double>(result.batches.batch_ns[batch]) * 1e-9);
    ++batch;
  }
  const std::string unit_name(to_string(call_.unit));
  state.counters[unit_name + "s_per_batch"] = units;
  const double units_timed = static_cast<double>(result.batches.batch_ns.size()) * units;
  if (result.lead_cpu_ns >= 0)
    state.counters["cpu_ns_per_" + unit_name] = static_cast<double>(result.lead_cpu_ns) / units_timed;
  if (result.team_cpu_ns >= 0)
    state.counters["team_cpu_ns_per_" + unit_name] = static_cast<double>(result.team_cpu_ns) / units_timed;
}

}  // namespace

std::optional<call_result> measure_entry(entry_call& call, const call_runner& run) {
  entry_measurement measurement(call, run);
  if (measurement.known_stop()) return std::nullopt;
  const std::optional<std::uint64_t*> units_per_batch = measurement.batch_size();
  if (!units_per_batch) return std::nullopt;
  std::optional<call_result> result = measurement.timed_call(**units_per_batch);
  if (result) measurement.report(*result);
  return result;
}

}  // namespace lockstep::bench
