// The paced RK4 step (paced.hpp): the dispatch from names to the composed step.
#include "bench/probes/paced.hpp"

#include <algorithm>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "kernels/model_choice.hpp"
#include "kernels/oscillator.hpp"
#include "kernels/parallel_step.hpp"
#include "layouts/registry.hpp"
#include "sync/registry.hpp"
#include "sync/team.hpp"

namespace lockstep::bench::probes {

void finish_record(step_record& record, std::size_t kept,
                   const std::vector<platform::thread_step_counters>& first_snapshot,
                   const platform::cpu_interrupt_totals& interrupt_start,
                   const std::vector<platform::cpu_interrupt_totals>& interrupt_reads) {
  const std::int64_t allocated = record.periods;
  const auto periods = static_cast<std::int64_t>(kept);
  const unsigned participants = record.participants;
  // Keep the first `kept` periods of each participant's run, in place.
  if (periods < allocated) {
    for (unsigned p = 0; p < participants; ++p)
      for (std::int64_t k = 0; k < periods; ++k)
        record.steps[static_cast<std::size_t>(p) * static_cast<std::size_t>(periods) + static_cast<std::size_t>(k)] =
            record.steps[static_cast<std::size_t>(p) * static_cast<std::size_t>(allocated) + static_cast<std::size_t>(k)];
    record.steps.resize(static_cast<std::size_t>(periods) * participants);
  }
  record.periods = periods;
  // Snapshots into differences, per participant, from the last to the first.
  for (unsigned p = 0; p < participants; ++p) {
    for (std::int64_t k = periods - 1; k >= 0; --k) {
      participant_period& row = record.at(k, p);
      if (!row.recorded) continue;
      if (k == 0) {
        // Its window holds the lead before the first period and the pin:
        // kept, but not compared with the others.
        row.counters = row.counters - first_snapshot[p];
      } else if (const participant_period& previous = record.at(k - 1, p); previous.recorded) {
        row.counters = row.counters - previous.resumed.value_or(previous.counters);
        row.counters_valid = true;
      }
    }
    for (std::int64_t k = 0; k < periods; ++k) record.at(k, p).resumed.reset();
  }
  // Per-CPU interrupts between consecutive reads (the columns of the first).
  record.cpus = interrupt_start.cpus;
  const std::size_t columns = record.cpus.size();
  record.interrupts.assign(static_cast<std::size_t>(periods) * columns, -1);
  record.softirqs.assign(static_cast<std::size_t>(periods) * columns, -1);
  const platform::cpu_interrupt_totals* previous = &interrupt_start;
  for (std::int64_t k = 0; k < periods && static_cast<std::size_t>(k) < interrupt_reads.size(); ++k) {
    const platform::cpu_interrupt_totals& now = interrupt_reads[static_cast<std::size_t>(k)];
    if (now.cpus.empty() || now.cpus != record.cpus) continue;
    for (std::size_t column = 0; column < columns; ++column) {
      const std::size_t at = static_cast<std::size_t>(k) * columns + column;
      if (now.interrupts.size() == columns && previous->interrupts.size() == columns)
        record.interrupts[at] = now.interrupts[column] - previous->interrupts[column];
      if (now.softirqs.size() == columns && previous->softirqs.size() == columns)
        record.softirqs[at] = now.softirqs[column] - previous->softirqs[column];
    }
    previous = &now;
  }
}

paced_run_state::paced_run_state(unsigned participants, const paced_settings& settings)
    : settings_(settings),
      participants_(participants),
      periods_(static_cast<std::size_t>(settings.periods)),
      keep_record_(settings.recording != step_recording::off && !settings.independent &&
                   settings.periods * participants <= kMaxRecordedParticipantPeriods),
      first_snapshot_(participants),
      counter_readers_(keep_record_ ? participants : 0),
      steps_ended_(settings.independent ? 0 : periods_),
      next_period_(settings.independent ? 0 : periods_),
      wake_(periods_ * participants, 0),
      end_(periods_ * participants, 0),
      period_(periods_ * participants, 0),
      own_next_(settings.independent ? periods_ * participants : 0, 0),
      steps_(participants, 0),
      cpus_(participants),
      deltas_(participants),
      errors_(participants) {
  if (settings.recording == step_recording::off || settings.independent) return;
  record_.emplace();
  step_record& record = *record_;
  record.participants = participants;
  record.period_ns = settings.period_ns;
  record.mode = settings.recording;
  record.block_periods = std::max<std::int64_t>(settings.recording_block_periods, 1);
  record.interrupt_every = std::max<std::int64_t>(settings.interrupt_every_periods, 1);
  if (!keep_record_) {
    record.not_kept = "the run has " + std::to_string(settings.periods * participants) +
                      " participant-periods, more than the record keeps (" +
                      std::to_string(kMaxRecordedParticipantPeriods) + ")";
  } else {
    record.periods = settings.periods;
    record.steps.resize(periods_ * participants);
    interrupt_reads_.resize(periods_);
  }
  record.snapshot_cost_ns = platform::snapshot_cost_ns(101);
  record.interrupt_read_cost_ns = platform::interrupt_read_cost_ns(11);
}

void paced_run_state::start() noexcept { start_ns_ = platform::now_ns() + settings_.lead_ns; }

void paced_run_state::failed(unsigned participant, std::string what) { errors_[participant] = std::move(what); }

void paced_run_state::open(paced_participant& self) {
  const unsigned id = self.id;
  if (!keep_record_) return;
  std::optional<platform::thread_counter_reader>& counters = counter_readers_[id];
  counters.emplace();
  if (counters->schedstat_available()) schedstat_seen_.store(true, std::memory_order_relaxed);
  self.interrupts.emplace();
  if (self.interrupts->available()) interrupts_seen_.store(true, std::memory_order_relaxed);
  first_snapshot_[id] = counters->read();
  if (id == 0 && self.interrupts->available()) interrupt_start_ = self.interrupts->read();
}

bool paced_run_state::runs_step(std::size_t k) const noexcept {
  // (2) relaxed: a team's sync edges order (1) before this read (paced.hpp);
  // independent participants only need to see it eventually, and compare
  // it with their next period (wake) instead.
  return k < periods_ &&
         (settings_.independent || static_cast<std::int64_t>(k) < leave_before_.load(std::memory_order_relaxed));
}

bool paced_run_state::wake(paced_participant& self, std::size_t k, stage_recorder* recorder) {
  if (!runs_step(k)) return false;
  std::int64_t period = 0;
  if (k > 0 && settings_.independent) {
    period = own_next_[(k - 1) * participants_ + self.id];
    if (period >= leave_before_.load(std::memory_order_relaxed)) return false;  // (2), a period here
  } else if (k > 0) {
    const std::optional<std::int64_t> decided = next_team_period(self, k);
    if (!decided) return false;
    period = *decided;
  }
  if (period >= static_cast<std::int64_t>(periods_)) return false;  // the schedule has ended
  if (k == 0 || period != self.period) sleep_to(self, period);
  record_wake(self, k, recorder);
  return true;
}

std::optional<std::int64_t> paced_run_state::next_team_period(paced_participant& self, std::size_t k) {
  // (5) relaxed: the period is the whole message of (4).
  const std::int64_t decided = next_period_[k - 1].load(std::memory_order_relaxed);
  if (decided != 0) return decided;
  // Not decided yet: the decision takes the latest end, so it is this
  // participant's own next period or a later one; sleep until that first.
  const std::int64_t own = next_period(self.period, self.ended_ns, settings_.period_ns);
  if (own >= static_cast<std::int64_t>(periods_)) return std::nullopt;
  sleep_to(self, own);
  return decided_period(k - 1);
}

std::int64_t paced_run_state::decided_period(std::size_t step) {
  // (5) relaxed, as above; the wait ends at the decision's notify (4).
  std::int64_t decided = next_period_[step].load(std::memory_order_relaxed);
  while (decided == 0) {
    next_period_[step].wait(0, std::memory_order_relaxed);
    decided = next_period_[step].load(std::memory_order_relaxed);
  }
  return decided;
}

void paced_run_state::sleep_to(paced_participant& self, std::int64_t period) {
  self.period = period;
  self.target_ns = start_ns_ + period * settings_.period_ns;
  sleep_until(self.target_ns);
  self.woke_ns = platform::now_ns();
}

bool paced_run_state::records_step(std::size_t k) const noexcept {
  if (!keep_record_) return false;
  if (settings_.recording == step_recording::every_period) return true;
  return (static_cast<std::int64_t>(k) / record_->block_periods) % 2 == 0;
}

void paced_run_state::record_wake(paced_participant& self, std::size_t k, stage_recorder* recorder) {
  const unsigned id = self.id;
  const std::size_t slot = k * participants_ + id;
  const std::int64_t latency = self.woke_ns - self.target_ns;
  wake_[slot] = latency;
  period_[slot] = self.period;
  if (k == 0) cpus_[id] = platform::current_cpu();
  self.row = records_step(k) ? &record_->at(static_cast<std::int64_t>(k), id) : nullptr;
  if (self.row != nullptr) {
    const auto cpu = platform::current_cpu();
    self.row->wake_cpu = cpu ? static_cast<std::int32_t>(*cpu) : -1;
  }
  if (recorder != nullptr) recorder->begin_period(id, k, self.target_ns, self.row);
  if (settings_.stop_above_ns && latency > *settings_.stop_above_ns && !self.reported_late) check_late(self, k, latency);
}

void paced_run_state::check_late(paced_participant& self, std::size_t k, std::int64_t latency) {
  self.reported_late = true;
  const std::lock_guard lock(stop_mutex_);
  if (stop_ && stop_->period <= self.period) return;
  stop_ = paced_stop{self.period,
                     static_cast<std::int64_t>(k),
                     self.id,
                     platform::current_cpu(),
                     latency,
                     self.period * settings_.period_ns + latency,
                     k == 0 ? std::nullopt : std::optional<std::int64_t>(end_[(k - 1) * participants_ + self.id])};
  if (settings_.stop_margin_periods > 0)
    leave_before((settings_.independent ? self.period : static_cast<std::int64_t>(k)) + settings_.stop_margin_periods);
}

void paced_run_state::leave_before(std::int64_t index) {
  // (1) relaxed, sequenced before this participant's next publication: see
  // (2). The minimum wins when two participants ask at once.
  fetch_min(leave_before_, index, std::memory_order_relaxed);
}

void paced_run_state::end(paced_participant& self, std::size_t k) {
  self.ended_ns = platform::now_ns() - self.target_ns;
  ++self.steps;
  const std::size_t slot = k * participants_ + self.id;
  end_[slot] = self.ended_ns;
  if (self.row != nullptr) {
    // After the end was read: outside the completion time. Nothing slower
    // than a CPU read here: a participant sharing a CPU with one still
    // stepping would delay it.
    self.row->recorded = true;
    const auto cpu = platform::current_cpu();
    self.row->end_cpu = cpu ? static_cast<std::int32_t>(*cpu) : -1;
  }
  if (settings_.independent) {
    own_next_[slot] = next_period(self.period, self.ended_ns, settings_.period_ns);
    count(self, k, own_next_[slot], self.ended_ns);
    return;
  }
  // (3) acq_rel: each participant's increment releases its end of step k
  // (and its row of the record, and its reader); the last one's acquires
  // every other's, so that its decision reads every end of the step, its
  // reads of the counters come after every end, and its writes into the
  // others' rows after theirs.
  if (steps_ended_[k].fetch_add(1, std::memory_order_acq_rel) + 1 != participants_) return;
  decide(self, k);
  // After the decision: a participant waiting for it is not kept waiting
  // behind the reads.
  if (self.row != nullptr) read_counters(self, k);
}

void paced_run_state::decide(paced_participant& self, std::size_t k) {
  std::int64_t latest = 0;
  for (unsigned other = 0; other < participants_; ++other)
    latest = std::max(latest, end_[k * participants_ + other]);
  const std::int64_t next = next_period(self.period, latest, settings_.period_ns);
  count(self, k, next, latest);
  // (4) relaxed: the period is the whole message; nothing is read on its
  // strength (the samples are read after the join, the step's data through
  // its syncs). The notify ends the waits of (5).
  next_period_[k].store(next, std::memory_order_relaxed);
  next_period_[k].notify_all();
}

void paced_run_state::count(const paced_participant& self, std::size_t k, std::int64_t next, std::int64_t completion_ns) {
  const bool overran = completion_ns > settings_.period_ns;
  const std::int64_t within = std::min(next, static_cast<std::int64_t>(periods_));
  const auto skipped = static_cast<std::uint64_t>(std::max<std::int64_t>(0, within - self.period - 1));
  if (paced_progress* progress = settings_.progress; progress != nullptr) {
    // Relaxed: see paced_progress.
    if (!settings_.independent || self.id == 0) progress->periods.store(within, std::memory_order_relaxed);
    if (overran) progress->overran.fetch_add(1, std::memory_order_relaxed);
    if (skipped > 0) progress->skipped.fetch_add(skipped, std::memory_order_relaxed);
  }
  if (settings_.independent || !settings_.stop_after_misses || settings_.stop_margin_periods <= 0) return;
  // Each period whose deadline passed without its step done is a miss: the
  // step that overran, and each period skipped after it. One decider per
  // step: each counted once. Relaxed: see counted_misses_.
  const std::uint64_t misses = (overran ? 1 : 0) + skipped;
  if (misses > 0 && counted_misses_.fetch_add(misses, std::memory_order_relaxed) + misses >= *settings_.stop_after_misses)
    leave_before(static_cast<std::int64_t>(k) + 1 + settings_.stop_margin_periods);
}

void paced_run_state::read_counters(paced_participant& self, std::size_t k) {
  // Everyone's counters, then the interrupt tables, by the last to end:
  // nobody still stepping waits behind them. Then its own again: its next
  // window starts after the reading.
  const auto step = static_cast<std::int64_t>(k);
  for (unsigned other = 0; other < participants_; ++other)
    record_->at(step, other).counters = counter_readers_[other]->read();
  if (self.interrupts->available() && step % record_->interrupt_every == 0) interrupt_reads_[k] = self.interrupts->read();
  self.row->resumed = counter_readers_[self.id]->read();
}

void paced_run_state::left(const paced_participant& self, const platform::thread_counters& delta) {
  deltas_[self.id] = delta;
  steps_[self.id] = self.steps;
}

void paced_run_state::keep_team_samples(paced_result& result) {
  // Every participant of a team ran the same steps (they leave together).
  const std::int64_t run_steps = steps_.empty() ? 0 : steps_[0];
  std::int64_t kept = run_steps;
  const std::int64_t agreed_end = leave_before_.load(std::memory_order_relaxed);  // the team has joined
  if (stop_) {
    kept = stop_->step + 1;
  } else if (agreed_end <= run_steps) {
    kept = agreed_end;
    result.stopped_after_misses = true;
  }
  const auto samples = static_cast<std::size_t>(kept) * participants_;
  result.periods = kept;
  result.steps_run.assign(participants_, kept);
  result.wakeup_ns.assign(wake_.begin(), wake_.begin() + static_cast<std::ptrdiff_t>(samples));
  result.end_ns.assign(end_.begin(), end_.begin() + static_cast<std::ptrdiff_t>(samples));
  result.period_index.assign(period_.begin(), period_.begin() + static_cast<std::ptrdiff_t>(samples));
  result.completion_ns.reserve(static_cast<std::size_t>(kept));
  for (std::size_t k = 0; k < static_cast<std::size_t>(kept); ++k) {
    const auto first = end_.begin() + static_cast<std::ptrdiff_t>(k * participants_);
    result.completion_ns.push_back(static_cast<double>(*std::max_element(first, first + participants_)));
  }
  // The span runs to the period the step after the last kept one would have
  // run in (every step run was decided: its last participant decides it).
  if (kept > 0)
    result.periods_scheduled =
        std::min(next_period_[static_cast<std::size_t>(kept - 1)].load(std::memory_order_relaxed),
                 static_cast<std::int64_t>(periods_));
  result.skipped_periods = static_cast<std::uint64_t>(std::max<std::int64_t>(0, result.periods_scheduled - kept));
  result.skipped_by_participant.assign(participants_, result.skipped_periods);
}

void paced_run_state::keep_independent_samples(paced_result& result) {
  for (unsigned p = 0; p < participants_; ++p) {
    // With a stop: each participant's steps up to the late period.
    std::int64_t kept = 0;
    while (kept < steps_[p] &&
           (!stop_ || period_[static_cast<std::size_t>(kept) * participants_ + p] <= stop_->period))
      ++kept;
    for (std::int64_t k = 0; k < kept; ++k) {
      const std::size_t slot = static_cast<std::size_t>(k) * participants_ + p;
      result.wakeup_ns.push_back(static_cast<double>(wake_[slot]));
      result.end_ns.push_back(static_cast<double>(end_[slot]));
      result.period_index.push_back(period_[slot]);
    }
    const std::int64_t span =
        kept == 0 ? 0
                  : std::min(own_next_[static_cast<std::size_t>(kept - 1) * participants_ + p],
                             static_cast<std::int64_t>(periods_));
    const auto skipped = static_cast<std::uint64_t>(std::max<std::int64_t>(0, span - kept));
    result.steps_run.push_back(kept);
    result.skipped_by_participant.push_back(skipped);
    result.periods = std::max(result.periods, kept);
    result.periods_scheduled = std::max(result.periods_scheduled, span);
    result.skipped_periods += skipped;
  }
  result.completion_ns = result.end_ns;
}

paced_result paced_run_state::result(const platform::thread_counters& main_delta) {
  paced_result result;
  result.participants = participants_;
  result.independent = settings_.independent;
  result.stop = stop_;
  result.cpus = cpus_;
  if (settings_.independent)
    keep_independent_samples(result);
  else
    keep_team_samples(result);
  for (double completion : result.completion_ns)
    if (completion > static_cast<double>(settings_.period_ns)) ++result.deadline_misses;
  result.figure5.add("main", "main", main_delta);
  for (unsigned id = 0; id < participants_; ++id)
    result.figure5.add("worker " + std::to_string(id), "worker", deltas_[id]);
  for (unsigned id = 0; id < participants_; ++id)
    if (!errors_[id].empty()) result.errors.push_back("worker " + std::to_string(id) + ": " + errors_[id]);
  if (record_) {
    if (keep_record_) finish_record(*record_, static_cast<std::size_t>(result.periods), first_snapshot_, interrupt_start_, interrupt_reads_);
    record_->schedstat_available = schedstat_seen_.load(std::memory_order_relaxed);
    record_->interrupts_available = interrupts_seen_.load(std::memory_order_relaxed);
    result.record = std::move(record_);
  }
  return result;
}

namespace {

// The primitive with its passages recorded: the same primitive, the same
// calls, and around each wait a report to the stage_recorder (two clock
// reads and two sched_getcpu per stage while a period is recorded; a null
// check otherwise). The step is composed over this type as over the
// primitive itself; its shape (barrier or channel) and traits are the
// primitive's.
template <class Barrier>
class recorded_barrier {
 public:
  static constexpr auto kName = Barrier::kName;
  explicit recorded_barrier(unsigned participants, stage_recorder* recorder = nullptr)
      : barrier_(participants), recorder_(recorder) {}
  void arrive_and_wait(sync::participant& self) {
    if (recorder_ != nullptr) recorder_->arrive(self.id);
    barrier_.arrive_and_wait(self);
    if (recorder_ != nullptr) recorder_->depart(self.id);
  }

 private:
  Barrier barrier_;
  stage_recorder* recorder_;
};

template <class Channel>
class recorded_channel {
 public:
  static constexpr auto kName = Channel::kName;
  recorded_channel(const sync::dependency_graph& graph, std::size_t width, stage_recorder* recorder = nullptr)
      : channel_(graph, width), recorder_(recorder) {}
  void publish(sync::participant& self, std::uint64_t stage, std::span<const double> values) {
    if (recorder_ != nullptr) recorder_->channel_call_begins(self.id, static_cast<unsigned>(stage % kernels::kRk4Stages));
    channel_.publish(self, stage, values);
    if (recorder_ != nullptr) recorder_->channel_call_ends(self.id);
  }
  void receive(sync::participant& self, unsigned producer, std::uint64_t stage, std::span<double> received) {
    if (recorder_ != nullptr) recorder_->channel_call_begins(self.id, static_cast<unsigned>(stage % kernels::kRk4Stages));
    channel_.receive(self, producer, stage, received);
    if (recorder_ != nullptr) recorder_->channel_call_ends(self.id);
  }

 private:
  Channel channel_;
  stage_recorder* recorder_;
};

template <class Sync>
using recorded_sync = std::conditional_t<sync::phase_barrier<Sync>, recorded_barrier<Sync>, recorded_channel<Sync>>;

// The model's time step. Fixed rather than tied to the period: the delay
// measured must not depend on the physics, and 0.1 ms keeps omega * dt about
// 0.005 for the paper's fastest mode (RK4 is stable far beyond), whatever
// period is chosen.
constexpr double kStepSeconds = 1e-4;

// How many periods after a late one a team can leave together (paced.hpp):
// max(1, ceil(d / 4)) for d the longest distance between two participants in
// the producer -> consumer graph (a barrier: 1); 0 when some participant
// cannot reach another (it could lead without bound: no early end).
template <class Step>
std::int64_t stop_margin_periods(const Step& step) {
  const unsigned threads = step.threads();
  std::size_t longest = threads > 1 ? 1 : 0;
  if constexpr (!sync::phase_barrier<typename Step::sync_type>) {
    longest = 0;
    for (unsigned source = 0; source < threads; ++source) {
      std::vector<std::size_t> distance(threads, SIZE_MAX);
      std::vector<unsigned> frontier{source};
      distance[source] = 0;
      for (std::size_t head = 0; head < frontier.size(); ++head)
        for (unsigned consumer = 0; consumer < threads; ++consumer) {
          const auto& producers = step.plan_of(consumer).producers;
          if (distance[consumer] == SIZE_MAX &&
              std::binary_search(producers.begin(), producers.end(), frontier[head])) {
            distance[consumer] = distance[frontier[head]] + 1;
            frontier.push_back(consumer);
          }
        }
      for (std::size_t d : distance) {
        if (d == SIZE_MAX) return 0;
        longest = std::max(longest, d);
      }
    }
  }
  return std::max<std::int64_t>(1, static_cast<std::int64_t>((longest + kernels::kRk4Stages - 1) / kernels::kRk4Stages));
}

template <class Sync, class Layout, kernels::oscillator_model Model>
paced_result run_combination(const Model& model, unsigned threads, const platform::placement_plan& plan,
                             paced_settings settings) {
  stage_recorder recorder(threads, settings.hook);
  const bool recording = settings.recording != step_recording::off || settings.hook;
  const auto initial = model.initial_state();
  kernels::parallel_rk4<recorded_sync<Sync>, Layout, Model> step(model, kStepSeconds, threads, std::span<const double>(initial),
                                                                 recording ? &recorder : nullptr);
  std::vector<sync::participant> participants(threads);
  for (unsigned id = 0; id < threads; ++id) participants[id].id = id;
  sync::team_of_t<Sync> team(threads);
  settings.stop_margin_periods = stop_margin_periods(step);
  settings.independent = false;
  paced_result result = run_paced(
      team, threads, settings, [&](unsigned id) { platform::pin_current_thread(plan, id); },
      [&](unsigned id, std::uint64_t period) {
        // migrate: the move happens inside the period it is due in, so its
        // cost lands in that period's completion time (the point of it).
        if (plan.moves_at(period)) {
          try {
            platform::pin_current_thread(plan, id, period);
          } catch (const std::exception&) {
            // the placement was checked at the first pin; a refusal now only
            // leaves this thread where it is for one more period
          }
        }
        step.run(participants[id], 1);
      },
      recording ? &recorder : nullptr);
  if (result.record) {
    // Whom each participant's departure waits for: a barrier releases when
    // everyone has arrived; a channel consumer when its producers have.
    result.record->waits_for.resize(threads);
    for (unsigned id = 0; id < threads; ++id) {
      if constexpr (sync::phase_barrier<Sync>) {
        for (unsigned other = 0; other < threads; ++other)
          if (other != id) result.record->waits_for[id].push_back(other);
      } else {
        result.record->waits_for[id] = step.plan_of(id).producers;
      }
    }
  }
  return result;
}

// Per CPU: participant i alone on cpus[i], with a step of its own, built on
// its own thread after the pin (its memory is first touched there). Always
// the paper's two masses: one participant owns every equation, so a bigger
// model would only lengthen the step, not add a sync to wait in.
constexpr kernels::model_choice kPerCpuModel{};

template <class Sync, class Layout>
paced_result run_per_cpu(std::span<const unsigned> cpus, paced_settings settings) {
  using step_type = kernels::parallel_rk4<Sync, Layout>;
  const kernels::two_mass_model model;
  const auto count = static_cast<unsigned>(cpus.size());
  std::vector<std::unique_ptr<step_type>> steps(count);
  std::vector<sync::participant> participants(count);  // every one is participant 0 of its own step
  sync::std_thread_team team(count);
  settings.stop_margin_periods = 1;
  settings.independent = true;
  return run_paced(
      team, count, settings,
      [&](unsigned id) {
        std::exception_ptr pin_failure;  // reported by run_paced; the step is built either way
        try {
          platform::pin_current_thread_to_pu(cpus[id]);
        } catch (...) {
          pin_failure = std::current_exception();
        }
        steps[id] = std::make_unique<step_type>(model, kStepSeconds, 1);
        if (pin_failure) std::rethrow_exception(pin_failure);
      },
      [&](unsigned id, std::uint64_t) { steps[id]->run(participants[id], 1); });
}

// Calls visit.template operator()<Sync, Layout>() for the named pair when it
// applies to `threads` participants over `model`; returns why not otherwise
// (empty: visited).
template <class Visitor>
std::string with_combination(const std::string& sync_name, const std::string& layout_name, unsigned threads,
                             const kernels::model_choice& model, Visitor&& visit) {
  if (sync::find_primitive(sync_name) == nullptr) {
    std::string names;
    for (const auto& info : sync::all_primitive_info) names += (names.empty() ? "" : ", ") + std::string(info.name);
    return "unknown primitive '" + sync_name + "' (valid: " + names + ")";
  }
  if (layouts::find_layout(layout_name) == nullptr) {
    std::string names;
    for (const auto& info : layouts::all_layout_info) names += (names.empty() ? "" : ", ") + std::string(info.name);
    return "unknown layout '" + layout_name + "' (valid: " + names + ")";
  }
  std::string problem;
  sync::for_each_primitive([&]<class Sync>() {
    if (Sync::kName != sync_name) return;
    layouts::for_each_layout([&]<class Layout>() {
      if (Layout::kName != layout_name) return;
      const std::string reason = kernels::not_applicable_reason<Sync, Layout>(model.equations(), threads);
      if (!reason.empty()) {
        problem = sync_name + " on " + layout_name + " with " + std::to_string(threads) + " threads on " +
                  model.description() + " does not run: " + reason;
        return;
      }
      if constexpr (kernels::applicable<Sync, Layout>().applicable) visit.template operator()<Sync, Layout>();
    });
  });
  return problem;
}

}  // namespace

std::string paced_step_problem(const std::string& sync, const std::string& layout, unsigned threads,
                               const kernels::model_choice& model) {
  return with_combination(sync, layout, threads, model, []<class, class>() {});
}

paced_result run_paced_step(const paced_step_settings& settings, const platform::placement_plan& plan) {
  paced_result result;
  // Both models for every pair: the chain's step is the same template over
  // another model type, so this file instantiates each pair twice (and only
  // this file: the per-CPU run stays on the two-mass step).
  const std::string problem = with_combination(
      settings.sync, settings.layout, settings.threads, settings.model, [&]<class Sync, class Layout>() {
        if (settings.model.is_chain())
          result = run_combination<Sync, Layout>(kernels::chain_model(settings.model.chain()), settings.threads, plan,
                                                 settings.pacing);
        else
          result = run_combination<Sync, Layout>(kernels::two_mass_model{}, settings.threads, plan, settings.pacing);
      });
  if (!problem.empty()) throw std::invalid_argument(problem);
  return result;
}

}  // namespace lockstep::bench::probes

namespace lockstep::bench::probes {

std::string paced_per_cpu_problem(const std::string& sync_name, const std::string& layout_name) {
  std::string problem;
  const std::string basic = with_combination(sync_name, layout_name, 1, kPerCpuModel, [&]<class Sync, class Layout>() {
    if constexpr (!std::is_same_v<sync::team_of_t<Sync>, sync::std_thread_team>)
      problem = "--per-cpu runs each CPU's step on a thread of its own; " + sync_name + " needs a team of its own (" +
                std::string(sync::team_of_t<Sync>::kName) + "): choose another --sync";
  });
  return basic.empty() ? problem : basic;
}

paced_result run_paced_per_cpu(const paced_step_settings& settings, std::span<const unsigned> cpus) {
  if (const std::string problem = paced_per_cpu_problem(settings.sync, settings.layout); !problem.empty())
    throw std::invalid_argument(problem);
  if (cpus.empty()) throw std::invalid_argument("a per-CPU run needs at least one CPU");
  paced_result result;
  (void)with_combination(settings.sync, settings.layout, 1, kPerCpuModel, [&]<class Sync, class Layout>() {
    if constexpr (std::is_same_v<sync::team_of_t<Sync>, sync::std_thread_team>)
      result = run_per_cpu<Sync, Layout>(cpus, settings.pacing);
  });
  return result;
}

}  // namespace lockstep::bench::probes
