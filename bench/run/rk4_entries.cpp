// The RK4 entries and the in-run calibrations (rk4_entries.hpp).
#include "bench/run/rk4_entries.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <exception>
#include <memory>
#include <optional>
#include <vector>

#include "bench/probes/core_to_core.hpp"
#include "kernels/model_choice.hpp"
#include "kernels/oscillator.hpp"
#include "kernels/parallel_step.hpp"
#include "kernels/rk4.hpp"
#include "layouts/partition.hpp"
#include "layouts/registry.hpp"
#include "platform/cache_line.hpp"
#include "platform/clock.hpp"
#include "platform/stats.hpp"
#include "sync/registry.hpp"
#include "sync/team.hpp"

namespace lockstep::bench {

namespace {

// One repetition of c2c: a few measure_pair calls (each starts and joins its
// own two pinned threads), all samples pooled. Once a repetition failed, the
// later ones fail too (team_driver.hpp, measure_entry, says why).
void c2c_entry(benchmark::State& state, harness_state& harness, unsigned cpu_a, unsigned cpu_b) {
  const std::string name = entry_spec::c2c_calibration().name();
  if (const auto failed = harness.stalled.find(name); failed != harness.stalled.end()) {
    state.SkipWithError(("an earlier repetition failed: " + failed->second).c_str());
    return;
  }
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
    harness.stalled[name] = error.what();
    state.SkipWithError(error.what());
    return;
  }
  const platform::distribution one_way = platform::summarize(std::move(pooled));
  state.counters["one_way_ns"] = one_way.p50;
  state.counters["one_way_min_ns"] = one_way.min;
  state.counters["one_way_p99_ns"] = one_way.p99;
}

// The model an entry integrates (kernels/model_choice.hpp): the paper's two
// masses, or the chain its spec names.
template <class Model>
Model model_of(const entry_spec& spec) {
  if constexpr (std::is_same_v<Model, kernels::chain_model>)
    return kernels::chain_model(spec.model.chain());
  else
    return Model{};
}

// Calls register_entry.template operator()<Model>() with the model type of
// `choice`: the one place the harness turns a model choice into a type.
template <class Register>
decltype(auto) with_model(const kernels::model_choice& choice, Register&& register_entry) {
  if (choice.is_chain()) return register_entry.template operator()<kernels::chain_model>();
  return register_entry.template operator()<kernels::two_mass_model>();
}

// rk4/serial (rk4/model:chainS/serial): batches of steps on the benchmark
// thread, timed by hand so that the batch loop matches the parallel entries',
// and reported as they are (team_driver.hpp, before measure_entry): an
// iteration's manual time is its batch's time, written per step by the JSON
// reporter; cpu_ns_per_step is the benchmark thread's CPU time per step over
// the timed batches.
template <class Model>
void serial_entry(benchmark::State& state, harness_state& harness, const entry_spec spec) {
  const Model model = model_of<Model>(spec);
  kernels::staged_rk4<Model> rk4(model, kBenchmarkStepSeconds);
  const std::string name = spec.name();
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
  const std::int64_t cpu_start = thread_cpu_ns();
  for (auto _ : state) {
    const std::int64_t start = platform::now_ns();
    rk4.run(steps);
    const std::int64_t batch_ns = platform::now_ns() - start;
    state.SetIterationTime(static_cast<double>(batch_ns) * 1e-9);
    total_ns += batch_ns;
    ++batches;
  }
  const std::int64_t cpu_end = thread_cpu_ns();
  benchmark::DoNotOptimize(rk4.state().data());
  const double steps_timed = static_cast<double>(batches) * static_cast<double>(steps);
  state.counters["ns_per_step"] = static_cast<double>(total_ns) / steps_timed;
  state.counters["steps_per_batch"] = static_cast<double>(steps);
  if (cpu_start >= 0 && cpu_end >= cpu_start)
    state.counters["cpu_ns_per_step"] = static_cast<double>(cpu_end - cpu_start) / steps_timed;
}

// Two pinned participants on two CPUs (the vs_c2c goal's case): the one-way
// core-to-core latency between exactly those CPUs, measured right after the
// entry's timed batches (a few hundred microseconds), and vs_c2c_paired =
// sync_ns_per_stage / it. A VM can change pace for seconds at a time (the
// development VM's one-way latency moved between about 25 and 115 ns within a
// run, its 2-thread steps with it), so the run's calibration, measured minutes
// earlier, may belong to another pace; this one belongs to the same. vs_c2c
// (the run's) stays, for comparing runs.
void add_paired_c2c(benchmark::State& state, const platform::placement_plan& plan, unsigned threads) {
  if (threads != 2) return;  // before pu_at(1): a plan of one thread has no thread 1
  const auto pu_a = plan.pu_at(0);
  const auto pu_b = plan.pu_at(1);
  const auto sync_stage = state.counters.find("sync_ns_per_stage");
  const bool fixed_pair = plan.kind == platform::placement::compact || plan.kind == platform::placement::scatter;
  if (!fixed_pair || !pu_a || !pu_b || *pu_a == *pu_b || sync_stage == state.counters.end()) return;
  c2c::pair_request request;
  request.cpu_a = static_cast<int>(*pu_a);
  request.cpu_b = static_cast<int>(*pu_b);
  request.how = c2c::method::cas;
  request.samples = 21;
  request.rounds_per_sample = 50;
  request.warmup_rounds = 200;
  try {
    const double one_way = platform::summarize(c2c::measure_pair(request)).p50;
    if (one_way > 0.0) {
      state.counters["c2c_paired_ns"] = one_way;
      state.counters["vs_c2c_paired"] = sync_stage->second.value / one_way;
    }
  } catch (const std::exception&) {
    // Could not pin the pair (the affinity set changed): the counters are
    // omitted, never made up; vs_c2c still divides by the run's figure.
  }
}

// One call of an RK4 entry: the composed step on a pinned team.
template <class Sync, class Layout, class Model, kernels::sync_timing Timing>
void rk4_entry(benchmark::State& state, harness_state& harness, const entry_spec spec) {
  constexpr bool kInstrumented = Timing != kernels::sync_timing::off;
  constexpr sync::primitive_info info = sync::info_of<Sync>();
  affinity_guard restore_caller;  // omp_team runs participant 0 on the benchmark thread
  const platform::placement_plan plan = platform::plan_placement(*harness.machine, spec.pin, spec.threads);
  const Model model = model_of<Model>(spec);
  kernels::parallel_rk4<Sync, Layout, Model, Timing> step(model, kBenchmarkStepSeconds, spec.threads);
  sync::team_of_t<Sync> team(spec.threads);
  std::vector<participant_slot> slots(spec.threads);
  auto steps = [&step](sync::participant& self, std::uint64_t count) { step.run(self, count); };
  // The sync time the timed batches start from: read when the warm-up batch
  // ends (the team waiting at the harness barrier), so that the warm-up's
  // cold caches and first faults stay out of sync_ns_per_stage.
  // The sampling period is set there too, from this call's batch size: about
  // kSampledStepsPerBatch sampled steps per batch, never fewer than one step
  // in kSyncTimingSampleSteps. A slow step (few per batch) is then timed often
  // enough to be measured at all, and its clock readings (8 per sampled step)
  // stay a tiny share of it; a fast one keeps the default period.
  kernels::stage_sync_time sync_before{};
  entry_call call{state, harness, spec.name(), sync::find_primitive(info.name), plan, kInstrumented, spec.unit(),
                  [&](std::uint64_t units) {
                    if constexpr (Timing == kernels::sync_timing::sampled) {
                      constexpr std::uint64_t kSampledStepsPerBatch = 8;
                      step.set_sync_sample_period(std::clamp<std::uint64_t>(units / kSampledStepsPerBatch, 1,
                                                                            kernels::kSyncTimingSampleSteps));
                    }
                    sync_before = step.sync_time();
                  }};
  const auto result = measure_entry(call, team_call_runner(team, slots, plan, harness.settings, steps));
  if (!result) return;

  const double steps_run = static_cast<double>(std::max<std::uint64_t>(result->batches.units_run, 1));
  const double step_ns = ns_per_unit(*result);
  state.counters["ns_per_step"] = step_ns;  // vs_serial is derived after the run (run_book::derive_ratios)
  if constexpr (kInstrumented) {
    const kernels::stage_sync_time timed = step.sync_time().since(sync_before);
    if (timed.syncs > 0) {
      // A timed span holds one clock reading's own cost besides the sync (the
      // end of the first reading and the start of the second: what two
      // back-to-back readings are apart), so the run's measured reading cost
      // is taken off each span. vs_c2c is derived after the run
      // (run_book::derive_ratios), from the whole run's calibration.
      const double sync_per_stage =
          static_cast<double>(timed.nanoseconds) / static_cast<double>(timed.syncs) - harness.book->clock_read_ns;
      state.counters["sync_ns_per_stage"] = sync_per_stage;
      // The step per participant, split in three (docs/names-and-counters.md):
      // compute, waiting for others (the mean waiting of the split syncs) and
      // synchronisation proper, the rest of the four syncs. Waiting is the
      // difference of two arrival readings, so it holds no clock reading's
      // cost; the release part has it taken off with sync_ns_per_stage. All
      // three or none: without enough split syncs (kernels::waiting_ns_per_stage)
      // they are omitted, never a made-up 0.
      if (const auto waiting_per_stage = kernels::waiting_ns_per_stage(timed)) {
        constexpr double kStages = kernels::kRk4Stages;
        const double waiting = kStages * *waiting_per_stage;
        state.counters["compute_ns_per_step"] = std::max(step_ns - kStages * sync_per_stage, 0.0);
        state.counters["waiting_ns_per_step"] = waiting;
        state.counters["release_ns_per_step"] = kStages * sync_per_stage - waiting;
      }
    }
  }
  set_accounting_counters(state, *result, spec.unit());
  if constexpr (info.counts_futex_waits)  // else unavailable: omitted, never a 0 nobody counted
    state.counters["futex_waits_per_step"] = static_cast<double>(result->sync_totals.futex_waits) / steps_run;
  state.counters["timeouts"] = static_cast<double>(result->sync_totals.timeouts);
  state.counters["oversubscribed"] = plan.oversubscribed ? 1.0 : 0.0;

  if constexpr (kInstrumented) add_paired_c2c(state, plan, spec.threads);

  // The overhead pair's "on" side measures its "off" side too, in the same
  // call, right after: the same plan, batch size and batch count, on a fresh
  // step and team without instrumentation or accounting. The two times of a
  // repetition are then a fraction of a second apart, so their ratio
  // (overhead_ratio) survives a machine that changes pace during the run,
  // which two entries measured one after the other do not (the development
  // VM's 2-thread steps moved between about 280 ns and 1.1 us for seconds).
  if constexpr (kInstrumented) {
    if (spec.kind == entry_kind::overhead) {
      kernels::parallel_rk4<Sync, Layout, Model, kernels::sync_timing::off> bare(
          model, kBenchmarkStepSeconds, spec.threads);
      sync::team_of_t<Sync> bare_team(spec.threads);
      std::vector<participant_slot> bare_slots(spec.threads);
      auto bare_steps = [&bare](sync::participant& self, std::uint64_t count) { bare.run(self, count); };
      const call_result paired =
          run_call(bare_team, bare_slots, plan, static_cast<unsigned>(result->batches.batch_ns.size()),
                   result->batches.units_per_batch, harness.settings, false, bare_steps);
      if (paired.failure.empty() && !paired.batches.stalled && !paired.batches.over_budget &&
          !paired.batches.batch_ns.empty()) {
        const double off_ns = ns_per_unit(paired);
        state.counters["paired_off_ns_per_step"] = off_ns;
        state.counters["overhead_ratio"] = step_ns / off_ns;
      }
    }
  }
}

// One participant's share of a block: `count` steps of the composed step.
struct run_steps {
  template <class Step>
  void operator()(Step& step, sync::participant& self, std::uint64_t count) const {
    step.run(self, count);
  }
};

using serial_chain = kernels::staged_rk4<kernels::chain_model>;

// The serial step of a chain as one side of a pair (chain_serial_runner):
// the runners of one factory share one chain, so every comparison of a size
// divides by the same serial step.
class serial_block_runner final : public block_runner {
 public:
  explicit serial_block_runner(std::shared_ptr<serial_chain> chain) : chain_(std::move(chain)) {}

  std::optional<double> run_block(std::uint64_t units) override {
    const platform::thread_counters before = accounting_ ? platform::snapshot_current_thread() : platform::thread_counters{};
    if (accounting_ && !schedstat_) schedstat_.emplace();  // on the thread that runs the blocks
    // The run-queue wait so far, -1 where the kernel does not say (a plain
    // number: GCC 12 took an optional's difference below for uninitialised).
    const std::int64_t waited_before = accounting_ ? schedstat_->read().run_queue_wait_ns.value_or(-1) : -1;
    const std::int64_t block_start = platform::now_ns();
    chain_->run(units);  // warm-up, as a team's block has
    const std::int64_t cpu_start = thread_cpu_ns();
    const std::int64_t start = platform::now_ns();
    chain_->run(units);
    const std::int64_t elapsed = platform::now_ns() - start;
    const std::int64_t cpu_end = thread_cpu_ns();
    benchmark::DoNotOptimize(chain_->state().data());
    facts_.reset();
    if (accounting_) {
      const platform::thread_counters after = platform::snapshot_current_thread();
      const std::int64_t waited_after = schedstat_->read().run_queue_wait_ns.value_or(-1);
      block_facts facts{(after - before).involuntary_switches,
                        waited_before >= 0 && waited_after >= 0
                            ? std::optional<std::int64_t>(waited_after - waited_before)
                            : std::nullopt,
                        platform::now_ns() - block_start, std::nullopt};
      if (cpu_start >= 0 && cpu_end >= cpu_start && elapsed > 0)
        facts.cpus_busy = static_cast<double>(cpu_end - cpu_start) / static_cast<double>(elapsed);
      facts_ = facts;
    }
    if (elapsed <= 0 || units == 0) return std::nullopt;
    return static_cast<double>(elapsed) / static_cast<double>(units);
  }
  void set_accounting(bool on) override { accounting_ = on; }
  [[nodiscard]] std::optional<block_facts> last_facts() const override { return facts_; }

 private:
  std::shared_ptr<serial_chain> chain_;  // the factory's, shared by its runners
  std::optional<platform::thread_counter_reader> schedstat_;
  bool accounting_ = false;
  std::optional<block_facts> facts_;
};

// T independent serial chains stepped at once, one per participant, each of
// the masses the partition gives that participant of the S-mass chain
// (layouts::block_of in whole masses): the blocks of the parallel step with
// no exchange and no sync between them (chain_split_runner).
class split_chains {
 public:
  split_chains(std::size_t masses, unsigned threads) : slots_(threads) {
    for (unsigned participant = 0; participant < threads; ++participant)
      slots_[participant].masses =
          layouts::block_of(2 * masses, threads, participant, kernels::chain_model::block_grain()).size() / 2;
  }

  void run(unsigned participant, std::uint64_t steps) {
    slot& own = slots_[participant];
    // Built by its own participant on its first block (the warm-up batch,
    // untimed): its arrays then come from that thread's allocations (glibc
    // gives threads that allocate at once arenas of their own), not from one
    // heap where a 1-mass chain's 16-byte arrays would sit on a line beside
    // another participant's.
    if (!own.rk4)
      own.rk4.emplace(kernels::chain_model(kernels::model_choice{own.masses}.chain()), kBenchmarkStepSeconds);
    const std::int64_t start = platform::now_ns();
    own.rk4->run(steps);
    own.last_run_ns = platform::now_ns() - start;
    benchmark::DoNotOptimize(own.rk4->state().data());
  }

  // The longest of the participants' last runs (each timed on its own
  // thread, from its start to its end), after the team has joined.
  [[nodiscard]] std::int64_t slowest_last_run_ns() const noexcept {
    std::int64_t slowest = 0;
    for (const slot& own : slots_) slowest = std::max(slowest, own.last_run_ns);
    return slowest;
  }

 private:
  // A line pair of its own (platform/cache_line.hpp): the step count its
  // rk4 writes every step never shares a prefetch pair with the next
  // participant's model, read every step.
  struct alignas(platform::kPrefetchPair) slot {
    std::size_t masses = 0;
    std::optional<kernels::staged_rk4<kernels::chain_model>> rk4;
    std::int64_t last_run_ns = 0;
  };
  std::vector<slot> slots_;
};

struct run_split {
  void operator()(split_chains& chains, sync::participant& self, std::uint64_t count) const {
    chains.run(self.id, count);
  }
};

// The blocks' time is the slowest block's own stepping time, not the
// harness's batch clock: with no sync, the blocks end apart (different
// vCPU speeds, different chains), the first to end sleeps in the harness
// barrier, and its wake-up at the next batch's start line (a halted vCPU on
// a VM) would count as stepping time. The parallel step's participants end
// each batch a stage apart at most and are caught spinning.
class split_block_runner final : public block_runner {
 public:
  split_block_runner(std::unique_ptr<block_runner> team, const split_chains& blocks)
      : team_(std::move(team)), blocks_(blocks) {}

  std::optional<double> run_block(std::uint64_t units) override {
    // The timed batch is the team's last: the slots hold its runs.
    if (!team_->run_block(units) || units == 0) return std::nullopt;
    const std::int64_t slowest = blocks_.slowest_last_run_ns();
    if (slowest <= 0) return std::nullopt;
    return static_cast<double>(slowest) / static_cast<double>(units);
  }
  void set_accounting(bool on) override { team_->set_accounting(on); }
  [[nodiscard]] std::optional<block_facts> last_facts() const override { return team_->last_facts(); }

 private:
  std::unique_ptr<block_runner> team_;
  const split_chains& blocks_;  // owned by team_
};

bool selected(const std::vector<std::string>& names, std::string_view name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

template <class Sync, class Layout, class Model>
benchmark::internal::Benchmark* register_rk4_entry(const entry_spec& spec, harness_state& harness,
                                                   bool instrumented) {
  auto* entry =
      instrumented
          ? benchmark::RegisterBenchmark(spec.name().c_str(),
                                         [&harness, spec](benchmark::State& state) {
                                           // sampled: one step per sampling period
                                           // (rk4_entry sets it) reads the clock around
                                           // its syncs; the other steps read none.
                                           rk4_entry<Sync, Layout, Model, kernels::sync_timing::sampled>(
                                               state, harness, spec);
                                         })
          : benchmark::RegisterBenchmark(spec.name().c_str(), [&harness, spec](benchmark::State& state) {
              rk4_entry<Sync, Layout, Model, kernels::sync_timing::off>(state, harness, spec);
            });
  constexpr sync::primitive_info info = sync::info_of<Sync>();
  size_entry(*entry, &info, spec.threads, harness);
  return entry->UseManualTime()->Unit(benchmark::kNanosecond);
}

}  // namespace

std::vector<entry_spec> register_rk4_benchmarks(const run_selection& selection, harness_state& harness) {
  std::vector<entry_spec> registered;
  sync::for_each_primitive([&]<class Sync>() {
    if (!selected(selection.syncs, Sync::kName)) return;
    layouts::for_each_layout([&]<class Layout>() {
      if (!selected(selection.layouts, Layout::kName)) return;
      for (unsigned threads : selection.threads) {
        const kernels::model_choice model = kernels::model_for(threads, selection.masses);
        for (platform::placement pin : selection.pins) {
          const entry_spec spec =
              entry_spec::parallel_step(std::string(Sync::kName), std::string(Layout::kName), pin, threads, model);
          const std::string reason = kernels::not_applicable_reason<Sync, Layout>(model.equations(), threads);
          if (!reason.empty()) {
            harness.book->not_applicable.push_back({spec.name(), reason});
            continue;
          }
          if constexpr (kernels::applicable<Sync, Layout>().applicable) {
            with_model(model, [&]<class Model>() {
              register_rk4_entry<Sync, Layout, Model>(spec, harness, harness.settings.accounting);
              // The entry's side of a paired comparison: the bare step, as the
              // matrix builds it (paired_blocks.hpp).
              harness.block_runners[spec.name()] =
                  block_runner_of<sync::team_of_t<Sync>,
                                  kernels::parallel_rk4<Sync, Layout, Model, kernels::sync_timing::off>>(
                      harness, pin, threads, run_steps{}, model_of<Model>(spec), kBenchmarkStepSeconds, threads);
            });
            registered.push_back(spec);
          }
        }
      }
    });
  });
  return registered;
}

std::vector<entry_spec> register_overhead_pair(const run_selection& selection, harness_state& harness) {
  std::vector<entry_spec> registered;
  // The preferred combination first: the fastest and steadiest step of the
  // matrix (seqlock on private copies, pinned, two threads: one per core
  // here), where a fixed cost of the harness weighs most. futex_spin's 2-thread
  // step, the first choice before, settles into one of two rhythms (about 300
  // or 550 ns a step on the development VM) for stretches of a run, so two
  // entries measured one after the other could land in different rhythms and
  // their ratio said nothing about the harness.
  const unsigned threads =
      std::find(selection.threads.begin(), selection.threads.end(), 2u) != selection.threads.end()
          ? 2u
          : selection.threads.front();
  const platform::placement pin =
      std::find(selection.pins.begin(), selection.pins.end(), platform::placement::compact) != selection.pins.end()
          ? platform::placement::compact
          : selection.pins.front();
  const kernels::model_choice model = kernels::model_for(threads, selection.masses);
  bool done = false;
  const auto try_pair = [&]<class Sync, class Layout>() {
    if (done || !selected(selection.syncs, Sync::kName) || !selected(selection.layouts, Layout::kName)) return;
    if constexpr (kernels::applicable<Sync, Layout>().applicable) {
      if (!kernels::not_applicable_reason<Sync, Layout>(model.equations(), threads).empty()) return;
      for (bool accounting : {false, true}) {
        const entry_spec spec = entry_spec::overhead_side(accounting, std::string(Sync::kName),
                                                          std::string(Layout::kName), pin, threads, model);
        auto* entry = with_model(
            model, [&]<class Model>() { return register_rk4_entry<Sync, Layout, Model>(spec, harness, accounting); });
        if (harness.settings.overhead_repetitions > 0) entry->Repetitions(harness.settings.overhead_repetitions);
        registered.push_back(spec);
      }
      done = true;
    }
  };
  try_pair.template operator()<sync::seqlock, layouts::per_thread>();
  sync::for_each_primitive([&]<class Sync>() {
    layouts::for_each_layout([&]<class Layout>() { try_pair.template operator()<Sync, Layout>(); });
  });
  return registered;
}

std::vector<entry_spec> register_calibration_benchmarks(const run_selection& selection, harness_state& harness) {
  std::vector<entry_spec> registered;
  const entry_spec c2c_spec = entry_spec::c2c_calibration();
  const platform::placement_plan plan = platform::plan_placement(*harness.machine, platform::placement::compact, 2);
  const auto pu_a = plan.pu_at(0);
  const auto pu_b = plan.pu_at(1);
  if (pu_a && pu_b && *pu_a != *pu_b) {
    const unsigned cpu_a = *pu_a;
    const unsigned cpu_b = *pu_b;
    benchmark::RegisterBenchmark(
        c2c_spec.name().c_str(),
        [&harness, cpu_a, cpu_b](benchmark::State& state) { c2c_entry(state, harness, cpu_a, cpu_b); })
        ->Iterations(3)
        ->UseRealTime()
        ->Unit(benchmark::kMicrosecond);
    registered.push_back(c2c_spec);
  } else {
    harness.book->not_applicable.push_back(
        {c2c_spec.name(), "needs two CPUs in the affinity set; vs_c2c is omitted in this run"});
  }
  // The serial step of every model the run integrates (vs_serial divides an
  // entry's step by its own model's), the paper's system always.
  std::vector<kernels::model_choice> models{kernels::model_choice{}};
  for (const unsigned threads : selection.threads) {
    const kernels::model_choice model = kernels::model_for(threads, selection.masses);
    if (std::find(models.begin(), models.end(), model) == models.end()) models.push_back(model);
  }
  for (const kernels::model_choice& model : models) {
    const entry_spec spec = entry_spec::serial_step(model);
    with_model(model, [&]<class Model>() {
      benchmark::RegisterBenchmark(spec.name().c_str(),
                                   [&harness, spec](benchmark::State& state) {
                                     serial_entry<Model>(state, harness, spec);
                                   })
          ->Iterations(harness.settings.timed_batches)
          ->UseManualTime()
          ->Unit(benchmark::kNanosecond);
    });
    registered.push_back(spec);
  }
  return registered;
}

block_runner_factory chain_step_runner(const harness_state& harness, const std::string& sync,
                                       const std::string& layout, platform::placement pin, unsigned threads,
                                       std::size_t masses, bool accounting) {
  block_runner_factory factory;
  const kernels::model_choice model{masses};
  sync::for_each_primitive([&]<class Sync>() {
    if (Sync::kName != sync) return;
    layouts::for_each_layout([&]<class Layout>() {
      if (Layout::kName != layout) return;
      if constexpr (kernels::applicable<Sync, Layout>().applicable) {
        if (!kernels::not_applicable_reason<Sync, Layout>(model.equations(), threads).empty()) return;
        const entry_spec spec = entry_spec::parallel_step(sync, layout, pin, threads, model);
        block_runner_factory bare =
            block_runner_of<sync::team_of_t<Sync>,
                            kernels::parallel_rk4<Sync, Layout, kernels::chain_model, kernels::sync_timing::off>>(
                harness, pin, threads, run_steps{}, model_of<kernels::chain_model>(spec), kBenchmarkStepSeconds,
                threads);
        factory = [bare, accounting]() {
          std::unique_ptr<block_runner> runner = bare();
          runner->set_accounting(accounting);
          return runner;
        };
      }
    });
  });
  return factory;
}

block_runner_factory chain_split_runner(const harness_state& harness, platform::placement pin, unsigned threads,
                                        std::size_t masses, bool accounting) {
  if (threads == 0 || !layouts::cut_by_grain(2 * masses, threads, kernels::chain_model::block_grain())) return {};
  return [&harness, pin, threads, masses, accounting]() -> std::unique_ptr<block_runner> {
    auto chains = std::make_unique<split_chains>(masses, threads);
    const split_chains& blocks = *chains;
    auto team = std::make_unique<team_block_runner<sync::std_thread_team, split_chains, run_split>>(
        harness.settings, platform::plan_placement(*harness.machine, pin, threads), std::move(chains), run_split{});
    team->set_accounting(accounting);
    return std::make_unique<split_block_runner>(std::move(team), blocks);
  };
}

block_runner_factory chain_serial_runner(std::size_t masses) {
  auto chain = std::make_shared<serial_chain>(kernels::chain_model(kernels::model_choice{masses}.chain()),
                                              kBenchmarkStepSeconds);
  return [chain]() -> std::unique_ptr<block_runner> {
    auto runner = std::make_unique<serial_block_runner>(chain);
    runner->set_accounting(true);
    return runner;
  };
}

}  // namespace lockstep::bench
