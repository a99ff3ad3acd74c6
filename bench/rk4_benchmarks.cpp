// The RK4 entries and the in-run calibrations (rk4_benchmarks.hpp).
#include "bench/rk4_benchmarks.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <exception>
#include <vector>

#include "bench/core_to_core.hpp"
#include "kernels/oscillator.hpp"
#include "kernels/rk4.hpp"
#include "platform/clock.hpp"
#include "platform/stats.hpp"

namespace lockstep::bench {

namespace {

// One repetition of c2c: a few measure_pair calls (each starts and joins its
// own two pinned threads), all samples pooled.
void c2c_entry(benchmark::State& state, unsigned cpu_a, unsigned cpu_b) {
  c2c::pair_request request;
  request.cpu_a = static_cast<int>(cpu_a);
  request.cpu_b = static_cast<int>(cpu_b);
  request.how = c2c::method::cas;
  // 200 samples of 100 round trips: about 4 ms per call at 100 ns one-way,
  // enough for a stable median; the p99 shows preemptions.
  request.samples = 200;
  request.rounds_per_sample = 100;
  request.warmup_rounds = 1000;
  std::vector<double> pooled;
  try {
    for (auto _ : state) {
      const std::vector<double> samples = c2c::measure_pair(request);
      pooled.insert(pooled.end(), samples.begin(), samples.end());
    }
  } catch (const std::exception& error) {
    state.SkipWithError(error.what());
    return;
  }
  const platform::distribution one_way = platform::summarize(std::move(pooled));
  state.counters["one_way_ns"] = one_way.p50;
  state.counters["one_way_min_ns"] = one_way.min;
  state.counters["one_way_p99_ns"] = one_way.p99;
}

// rk4/serial: batches of steps on the benchmark thread, timed by hand so that
// the batch loop matches the parallel entries'.
void serial_entry(benchmark::State& state, harness_state& harness) {
  const kernels::two_mass_model model;
  kernels::staged_rk4<kernels::two_mass_model> rk4(model, kBenchmarkStepSeconds);
  const std::string name = "rk4/serial";
  auto batch_size = harness.units_per_batch.find(name);
  if (batch_size == harness.units_per_batch.end()) {
    constexpr std::uint64_t kProbeSteps = 1000;
    const std::int64_t start = platform::now_ns();
    rk4.run(kProbeSteps);
    const double per_step = static_cast<double>(platform::now_ns() - start) / kProbeSteps;
    batch_size = harness.units_per_batch.emplace(name, units_for_batch(per_step, harness.settings)).first;
  }
  const std::uint64_t steps = batch_size->second;
  rk4.run(steps);  // warm-up batch, as the parallel entries have
  std::int64_t total_ns = 0;
  std::uint64_t batches = 0;
  for (auto _ : state) {
    const std::int64_t start = platform::now_ns();
    rk4.run(steps);
    const std::int64_t batch_ns = platform::now_ns() - start;
    state.SetIterationTime(static_cast<double>(batch_ns) * 1e-9);
    total_ns += batch_ns;
    ++batches;
  }
  benchmark::DoNotOptimize(rk4.state().data());
  state.counters["ns_per_step"] =
      static_cast<double>(total_ns) / (static_cast<double>(batches) * static_cast<double>(steps));
}

}  // namespace

std::vector<std::string> register_calibration_benchmarks(harness_state& harness) {
  std::vector<std::string> registered;
  const entry_spec c2c_spec{entry_kind::c2c, {}, {}, platform::placement::compact, 2};
  const platform::placement_plan plan = platform::plan_placement(*harness.machine, platform::placement::compact, 2);
  const auto pu_a = plan.pu_at(0);
  const auto pu_b = plan.pu_at(1);
  if (pu_a && pu_b && *pu_a != *pu_b) {
    const unsigned cpu_a = *pu_a;
    const unsigned cpu_b = *pu_b;
    benchmark::RegisterBenchmark(c2c_spec.name().c_str(),
                                 [cpu_a, cpu_b](benchmark::State& state) { c2c_entry(state, cpu_a, cpu_b); })
        ->Iterations(3)
        ->UseRealTime()
        ->Unit(benchmark::kMicrosecond);
    registered.push_back(c2c_spec.name());
  } else {
    harness.book->not_applicable.push_back(
        {c2c_spec.name(), "needs two CPUs in the affinity set; vs_c2c is omitted in this run"});
  }
  benchmark::RegisterBenchmark("rk4/serial", [&harness](benchmark::State& state) { serial_entry(state, harness); })
      ->UseManualTime()
      ->Unit(benchmark::kNanosecond);
  registered.push_back("rk4/serial");
  return registered;
}

}  // namespace lockstep::bench
