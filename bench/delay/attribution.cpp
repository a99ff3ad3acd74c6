// The late steps' causes (attribution.hpp): the critical path of each step
// above the median completion, and its excess split into causes.
#include "bench/delay/attribution.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "kernels/rk4.hpp"
#include "platform/stats.hpp"

namespace lockstep::bench {

namespace {

using probes::participant_period;
using probes::step_record;

constexpr int kStages = static_cast<int>(kernels::kRk4Stages);

double median_or(std::vector<double> samples, double otherwise) {
  if (samples.empty()) return otherwise;
  return platform::summarize(std::move(samples)).p50;
}

// Minor and major faults together, when the window has both.
std::optional<std::int64_t> faults_of(const platform::thread_step_counters& counters) {
  if (!counters.minor_faults || !counters.major_faults) return std::nullopt;
  return *counters.minor_faults + *counters.major_faults;
}

// A window's count above the participant's median of it (never below 0),
// when the window has the count.
std::optional<std::int64_t> above_median(std::optional<std::int64_t> count, double median) {
  if (!count) return std::nullopt;
  return std::max<std::int64_t>(0, *count - static_cast<std::int64_t>(std::llround(median)));
}

struct part {
  part_kind kind = part_kind::compute;
  unsigned participant = 0;
  int stage = 0;
  double ns = 0;
  double typical = 0;
  std::int32_t cpu_start = -1;
  std::int32_t cpu_end = -1;
  double lead_ns = 0;
};

// What the record says, period by period, and the run's medians of it.
class step_reader {
 public:
  explicit step_reader(const probes::paced_result& run) : run_(run), record_(*run.record) {
    participants_ = record_.participants;
    periods_ = record_.periods;
    period_ns_ = static_cast<double>(record_.period_ns);
    columns_ = record_.cpus.size();
    median_completion_ = run.completion_ns.empty() ? 0 : platform::summarize(run.completion_ns).p50;
    // Typical part lengths, and the counters' medians, over recorded periods.
    std::vector<std::vector<double>> compute(participants_ * kStages), resume(participants_ * kStages),
        timer(participants_);
    std::vector<std::vector<double>> on_cpu(participants_), run_queue(participants_), blocked_time(participants_),
        switches(participants_), faults(participants_);
    for (std::int64_t k = 0; k < periods_; ++k) {
      for (unsigned p = 0; p < participants_; ++p) {
        const participant_period& row = record_.at(k, p);
        if (!row.recorded) continue;
        timer[p].push_back(wake(k, p));
        for (int s = 0; s < kStages; ++s) {
          if (const auto length = compute_length(k, p, s)) compute[p * kStages + s].push_back(*length);
          if (const auto blocker = blocker_of(k, p, s))
            resume[p * kStages + s].push_back(departure(k, p, s) - arrival(k, *blocker, s));
        }
        if (!row.counters_valid) continue;
        if (row.counters.on_cpu_ns) on_cpu[p].push_back(static_cast<double>(*row.counters.on_cpu_ns));
        if (row.counters.run_queue_wait_ns) run_queue[p].push_back(static_cast<double>(*row.counters.run_queue_wait_ns));
        if (const auto b = blocked(k, p)) blocked_time[p].push_back(*b);
        if (row.counters.switches) switches[p].push_back(static_cast<double>(*row.counters.switches));
        if (const auto f = faults_of(row.counters)) faults[p].push_back(static_cast<double>(*f));
      }
    }
    typical_compute_.resize(compute.size());
    typical_resume_.resize(resume.size());
    for (std::size_t i = 0; i < compute.size(); ++i) typical_compute_[i] = median_or(compute[i], 0);
    for (std::size_t i = 0; i < resume.size(); ++i) typical_resume_[i] = median_or(resume[i], 0);
    for (unsigned p = 0; p < participants_; ++p) {
      typical_timer_.push_back(median_or(timer[p], 0));
      medians_.push_back({median_or(on_cpu[p], 0), median_or(run_queue[p], 0), median_or(blocked_time[p], 0),
                          median_or(switches[p], 0), median_or(faults[p], 0)});
    }
    for (std::size_t column = 0; column < columns_; ++column) {
      std::vector<double> counts;
      for (std::int64_t k = 0; k < periods_; ++k)
        if (const auto count = interrupts_of(k, column)) counts.push_back(static_cast<double>(*count));
      interrupt_median_.push_back(median_or(counts, 0));
    }
  }

  std::int64_t periods() const noexcept { return periods_; }
  double median_completion() const noexcept { return median_completion_; }
  double completion(std::int64_t k) const { return run_.completion_ns[static_cast<std::size_t>(k)]; }
  bool recorded(std::int64_t k) const {
    for (unsigned p = 0; p < participants_; ++p)
      if (!record_.at(k, p).recorded) return false;
    return true;
  }
  // How long after step k - 1's target step k's target was: one period, or
  // more when an overrun made the schedule skip periods (paced.hpp).
  double gap_ns(std::int64_t k) const {
    if (k <= 0 || run_.period_index.empty()) return period_ns_;
    return static_cast<double>(run_.period_index[index(k, 0)] - run_.period_index[index(k - 1, 0)]) * period_ns_;
  }

  double wake(std::int64_t k, unsigned p) const { return run_.wakeup_ns[index(k, p)]; }
  double end(std::int64_t k, unsigned p) const { return run_.end_ns[index(k, p)]; }
  double arrival(std::int64_t k, unsigned p, int s) const {
    return static_cast<double>(record_.at(k, p).stages[static_cast<std::size_t>(s)].arrival_ns);
  }
  // Stage 3's departure is the step's end: what follows the last sync
  // (its copy-in) belongs to the release too.
  double departure(std::int64_t k, unsigned p, int s) const {
    if (s == kStages - 1) return end(k, p);
    return static_cast<double>(record_.at(k, p).stages[static_cast<std::size_t>(s)].departure_ns);
  }
  std::int32_t arrival_cpu(std::int64_t k, unsigned p, int s) const {
    return record_.at(k, p).stages[static_cast<std::size_t>(s)].arrival_cpu;
  }
  std::int32_t departure_cpu(std::int64_t k, unsigned p, int s) const {
    if (s == kStages - 1) return record_.at(k, p).end_cpu;
    return record_.at(k, p).stages[static_cast<std::size_t>(s)].departure_cpu;
  }
  bool stage_recorded(std::int64_t k, unsigned p, int s) const {
    const auto& passage = record_.at(k, p).stages[static_cast<std::size_t>(s)];
    return passage.arrival_ns >= 0 && (s == kStages - 1 || passage.departure_ns >= 0);
  }

  // The last to arrive at stage s among p and those p waits for.
  std::optional<unsigned> blocker_of(std::int64_t k, unsigned p, int s) const {
    if (!stage_recorded(k, p, s)) return std::nullopt;
    unsigned latest = p;
    for (unsigned other : record_.waits_for[p]) {
      if (!stage_recorded(k, other, s)) return std::nullopt;
      if (arrival(k, other, s) > arrival(k, latest, s)) latest = other;
    }
    return latest;
  }
  // How long after the second latest of that set the blocker arrived.
  double lead(std::int64_t k, unsigned p, int s, unsigned blocker) const {
    double second = -1;
    const auto consider = [&](unsigned q) {
      if (q != blocker) second = std::max(second, arrival(k, q, s));
    };
    consider(p);
    for (unsigned other : record_.waits_for[p]) consider(other);
    return second < 0 ? 0 : arrival(k, blocker, s) - second;
  }
  std::optional<double> compute_length(std::int64_t k, unsigned p, int s) const {
    if (!stage_recorded(k, p, s) || (s > 0 && !stage_recorded(k, p, s - 1))) return std::nullopt;
    return arrival(k, p, s) - (s > 0 ? departure(k, p, s - 1) : wake(k, p));
  }

  // Time off the CPU and not runnable in p's step: from its wake-up to its
  // end, less the window's on-CPU time and run-queue wait (the window also
  // holds the sleep before the wake-up, whose length moves with the previous
  // step's end; that sleep is off the CPU, so it is left out here, and the
  // little CPU and run-queue time around the wake-up only shifts the median).
  std::optional<double> blocked(std::int64_t k, unsigned p) const {
    const participant_period& row = record_.at(k, p);
    if (!row.counters_valid || !row.counters.on_cpu_ns || !row.counters.run_queue_wait_ns) return std::nullopt;
    return end(k, p) - wake(k, p) - static_cast<double>(*row.counters.on_cpu_ns) -
           static_cast<double>(*row.counters.run_queue_wait_ns);
  }
  std::optional<std::int64_t> interrupts_of(std::int64_t k, std::size_t column) const {
    const std::size_t at = static_cast<std::size_t>(k) * columns_ + column;
    if (at >= record_.interrupts.size() || record_.interrupts[at] < 0) return std::nullopt;
    return record_.interrupts[at] + std::max<std::int64_t>(record_.softirqs[at], 0);
  }
  // p's CPU's interrupts and softirqs above that CPU's median in window k.
  std::optional<std::int64_t> interrupt_excess(std::int64_t k, std::int32_t cpu) const {
    if (cpu < 0) return std::nullopt;
    const auto column = record_.cpu_column(static_cast<unsigned>(cpu));
    if (!column) return std::nullopt;
    const auto count = interrupts_of(k, *column);
    if (!count) return std::nullopt;
    return *count - static_cast<std::int64_t>(std::llround(interrupt_median_[*column]));
  }

  struct counter_medians {
    double on_cpu = 0, run_queue = 0, blocked = 0, switches = 0, faults = 0;
  };
  const counter_medians& medians(unsigned p) const { return medians_[p]; }
  const participant_period& row(std::int64_t k, unsigned p) const { return record_.at(k, p); }

  // The critical path of step k (see delay_report.hpp); empty when a stage
  // of it was not recorded.
  std::vector<part> path(std::int64_t k) const {
    std::vector<part> parts;
    unsigned p = 0;
    for (unsigned q = 1; q < participants_; ++q)
      if (end(k, q) > end(k, p)) p = q;
    for (int s = kStages - 1; s >= 0; --s) {
      const auto blocker = blocker_of(k, p, s);
      if (!blocker) return {};
      const unsigned b = *blocker;
      part resume{part_kind::sync_resume, p, s, departure(k, p, s) - arrival(k, b, s),
                  typical_resume_[p * kStages + s], arrival_cpu(k, p, s), departure_cpu(k, p, s), 0};
      parts.push_back(resume);
      const auto length = compute_length(k, b, s);
      if (!length) return {};
      part work{part_kind::compute, b, s, *length, typical_compute_[b * kStages + s],
                s > 0 ? departure_cpu(k, b, s - 1) : row(k, b).wake_cpu, arrival_cpu(k, b, s), lead(k, p, s, b)};
      parts.push_back(work);
      p = b;
    }
    const std::int32_t slept_on = k > 0 && row(k - 1, p).recorded ? row(k - 1, p).end_cpu : -1;
    parts.push_back({part_kind::timer_wakeup, p, 0, wake(k, p), typical_timer_[p], slept_on, row(k, p).wake_cpu, 0});
    return parts;
  }

 private:
  std::size_t index(std::int64_t k, unsigned p) const {
    return static_cast<std::size_t>(k) * participants_ + p;
  }

  const probes::paced_result& run_;
  const step_record& record_;
  unsigned participants_ = 0;
  std::int64_t periods_ = 0;
  double period_ns_ = 0;
  std::size_t columns_ = 0;
  double median_completion_ = 0;
  std::vector<double> typical_compute_, typical_resume_, typical_timer_;
  std::vector<counter_medians> medians_;
  std::vector<double> interrupt_median_;
};

std::size_t cause_index(delay_cause cause) { return static_cast<std::size_t>(cause); }

// What is left to explain in one participant's window, shared by its parts.
struct window_budget {
  double run_queue = 0;
  double on_cpu = 0;
  double blocked = 0;
  std::int64_t fault_excess = 0;  // faults above the median
  std::int64_t major_faults = 0;
  // Switches (voluntary or not) above their median: more than none, the
  // guest scheduled it differently.
  std::int64_t extra_switches = 0;
  bool migrated = false;  // it changed CPU somewhere in its window: the move's IPIs and cold caches are the move's
};

window_budget budget_of(const step_reader& reader, std::int64_t k, unsigned p) {
  window_budget budget;
  const participant_period& row = reader.row(k, p);
  if (!row.counters_valid) return budget;
  const auto& median = reader.medians(p);
  if (row.counters.run_queue_wait_ns)
    budget.run_queue = std::max(0.0, static_cast<double>(*row.counters.run_queue_wait_ns) - median.run_queue);
  if (row.counters.on_cpu_ns) budget.on_cpu = std::max(0.0, static_cast<double>(*row.counters.on_cpu_ns) - median.on_cpu);
  if (const auto blocked = reader.blocked(k, p)) budget.blocked = std::max(0.0, *blocked - median.blocked);
  budget.fault_excess = above_median(faults_of(row.counters), median.faults).value_or(0);
  budget.major_faults = row.counters.major_faults.value_or(0);
  budget.extra_switches = above_median(row.counters.switches, median.switches).value_or(0);
  const std::int32_t woke_on = row.wake_cpu;
  const auto moved = [&](std::int32_t cpu) { return cpu >= 0 && woke_on >= 0 && cpu != woke_on; };
  if (k > 0 && reader.row(k - 1, p).recorded) budget.migrated = moved(reader.row(k - 1, p).end_cpu);
  for (const auto& passage : row.stages)
    budget.migrated = budget.migrated || moved(passage.arrival_cpu) || moved(passage.departure_cpu);
  budget.migrated = budget.migrated || moved(row.end_cpu);
  return budget;
}

// Splits one part's excess `excess` (see delay_report.hpp).
void split_part(const step_reader& reader, std::int64_t k, const part& piece, double excess, window_budget& budget,
                cause_split& split) {
  double left = excess;
  if (piece.cpu_start >= 0 && piece.cpu_end >= 0 && piece.cpu_start != piece.cpu_end) {
    // The part itself crossed CPUs: all of it is the move's.
    split[cause_index(delay_cause::migration)] += left;
    budget.run_queue -= std::min(budget.run_queue, left);
    return;
  }
  const auto interrupts = reader.interrupt_excess(k, piece.cpu_end);
  const bool more_interrupts = interrupts && *interrupts > 0;
  // Where the on-CPU time above the median went: faults, else the move's
  // IPIs and cold caches, else interrupts, else no guest event (a stall).
  const delay_cause on_cpu = budget.fault_excess > 0 ? delay_cause::page_faults
                             : budget.migrated       ? delay_cause::migration
                             : more_interrupts       ? delay_cause::interrupts
                                                     : delay_cause::machine_stall;
  // Blocked longer than usual: in its own stage, its own doing (compute);
  // in a wake-up, the kernel's wake-up path when the guest shows it at work
  // (more switches or interrupts than usual), otherwise a wake-up no guest
  // event delayed (the timer or the waker's signal was not delivered while
  // the vCPU did not run: a stall). Major faults block too.
  const bool guest_event = budget.extra_switches > 0 || more_interrupts;
  // What the guest's wake-up path can account for: each switch or interrupt
  // above the usual at most one more typical length of this part (the
  // wake-up run again: preempted once more, an interrupt served first). A
  // wake-up later than that is a wake-up nothing the guest did delayed: a
  // timer or a waker's signal that arrived while the vCPU did not run.
  const double events = static_cast<double>(budget.extra_switches + (more_interrupts ? *interrupts : 0));
  double wakeup_allowance = events * std::max(0.0, piece.typical);
  const auto credit_wakeup = [&](double ns) {
    const double wakeup = std::min(ns, wakeup_allowance);
    wakeup_allowance -= wakeup;
    split[cause_index(delay_cause::wakeup_latency)] += wakeup;
    split[cause_index(delay_cause::machine_stall)] += ns - wakeup;
  };
  const delay_cause blocked = budget.major_faults > 0           ? delay_cause::page_faults
                              : piece.kind == part_kind::compute ? delay_cause::compute
                              : guest_event                      ? delay_cause::wakeup_latency
                                                                 : delay_cause::machine_stall;
  // The part's excess is shared among the window's three kinds of time in
  // proportion to what each has above its median (each capped by it).
  // A timer wake-up lies before the step (in the sleep): of the window's
  // time only its run-queue wait can be the wake-up's.
  const bool timer = piece.kind == part_kind::timer_wakeup;
  const double available = budget.run_queue + (timer ? 0.0 : budget.on_cpu + budget.blocked);
  if (available > 0) {
    const double share = std::min(1.0, left / available);
    const double run_queue = budget.run_queue * share;
    const double cpu = timer ? 0.0 : budget.on_cpu * share;
    const double off = timer ? 0.0 : budget.blocked * share;
    split[cause_index(delay_cause::run_queue_wait)] += run_queue;
    split[cause_index(on_cpu)] += cpu;
    if (blocked == delay_cause::wakeup_latency)
      credit_wakeup(off);
    else
      split[cause_index(blocked)] += off;
    budget.run_queue -= run_queue;
    budget.on_cpu -= cpu;
    budget.blocked -= off;
    left -= run_queue + cpu + off;
  }
  if (left > 0) {
    if (piece.kind == part_kind::compute)
      split[cause_index(delay_cause::unexplained)] += left;
    else if (guest_event)
      credit_wakeup(left);
    else
      split[cause_index(delay_cause::machine_stall)] += left;
  }
}

delay_cause top_of(const cause_split& split) {
  std::size_t top = 0;
  for (std::size_t cause = 1; cause < kDelayCauses; ++cause)
    if (split[cause] > split[top]) top = cause;
  return static_cast<delay_cause>(top);
}

// `previous`: the attribution of step k - 1 when it was late (for a start
// its overrun delayed).
late_step attribute_with(const step_reader& reader, std::int64_t k, const late_step* previous) {
  late_step step;
  step.period = k;
  step.completion_ns = reader.completion(k);
  step.excess_ns = step.completion_ns - reader.median_completion();
  if (step.excess_ns <= 0) {
    step.excess_ns = 0;
    return step;
  }
  const std::vector<part> parts = reader.path(k);
  if (parts.empty()) {
    step.cause_ns[cause_index(delay_cause::unexplained)] = step.excess_ns;
    return step;
  }
  std::vector<window_budget> budgets;
  std::vector<bool> budget_made;
  cause_split split{};
  double covered = 0;
  const part* dominant = nullptr;
  double dominant_excess = 0;
  for (const part& piece : parts) {
    const double excess = piece.ns - piece.typical;
    if (excess <= 0) continue;
    covered += excess;
    if (excess > dominant_excess) {
      dominant_excess = excess;
      dominant = &piece;
    }
    if (budgets.size() <= piece.participant) {
      budgets.resize(piece.participant + 1);
      budget_made.resize(piece.participant + 1, false);
    }
    if (!budget_made[piece.participant]) {
      budgets[piece.participant] = budget_of(reader, k, piece.participant);
      budget_made[piece.participant] = true;
    }
    // A start its own previous step delayed: that step's causes, in its proportions.
    if (piece.kind == part_kind::timer_wakeup && previous != nullptr && previous->excess_ns > 0 && k > 0 &&
        reader.end(k - 1, piece.participant) > reader.gap_ns(k)) {
      for (std::size_t cause = 0; cause < kDelayCauses; ++cause)
        split[cause] += excess * previous->cause_ns[cause] / previous->excess_ns;
      if (dominant == &piece) step.inherited = true;
      continue;
    }
    split_part(reader, k, piece, excess, budgets[piece.participant], split);
  }
  if (covered > step.excess_ns) {
    for (double& ns : split) ns *= step.excess_ns / covered;
  } else {
    split[cause_index(delay_cause::unexplained)] += step.excess_ns - covered;
  }
  step.cause_ns = split;
  step.top = top_of(split);
  if (step.inherited) {
    // Named as the step whose overrun delayed this one.
    const cause_split own = step.cause_ns;
    const double excess = step.excess_ns;
    const std::int64_t period = step.period;
    const double completion = step.completion_ns;
    step = *previous;
    step.period = period;
    step.completion_ns = completion;
    step.excess_ns = excess;
    step.cause_ns = own;
    step.top = top_of(own);
    step.inherited = true;
    return step;
  }
  if (dominant != nullptr) {
    step.kind = dominant->kind;
    step.participant = dominant->participant;
    if (dominant->cpu_end >= 0) step.cpu = static_cast<unsigned>(dominant->cpu_end);
    step.stage = dominant->stage;
    step.part_excess_ns = dominant_excess;
    step.lead_ns = dominant->lead_ns;
    if (dominant->cpu_start >= 0 && dominant->cpu_end >= 0 && dominant->cpu_start != dominant->cpu_end)
      step.moved_from = static_cast<unsigned>(dominant->cpu_start);
    const participant_period& row = reader.row(k, dominant->participant);
    if (row.counters_valid) {
      const auto& median = reader.medians(dominant->participant);
      step.switches = above_median(row.counters.switches, median.switches);
      step.page_faults = above_median(faults_of(row.counters), median.faults);
      if (row.counters.run_queue_wait_ns)
        step.run_queue_wait_ns = std::max(0.0, static_cast<double>(*row.counters.run_queue_wait_ns) - median.run_queue);
    }
    if (const auto interrupts = reader.interrupt_excess(k, dominant->cpu_end))
      step.interrupts = std::max<std::int64_t>(0, *interrupts);
  }
  return step;
}

cause_row sum_row(std::string label, double threshold, const std::vector<const late_step*>& steps) {
  cause_row row;
  row.label = std::move(label);
  row.threshold_ns = threshold;
  row.steps = steps.size();
  for (const late_step* step : steps) {
    row.excess_ns += step->excess_ns;
    for (std::size_t cause = 0; cause < kDelayCauses; ++cause) row.cause_ns[cause] += step->cause_ns[cause];
  }
  if (row.excess_ns > 0) {
    const double unexplained = row.cause_ns[cause_index(delay_cause::unexplained)];
    const double stall = row.cause_ns[cause_index(delay_cause::machine_stall)];
    row.explained_share = std::clamp(1.0 - unexplained / row.excess_ns, 0.0, 1.0);
    row.guest_share = std::clamp(1.0 - (unexplained + stall) / row.excess_ns, 0.0, 1.0);
    row.top = top_of(row.cause_ns);
  }
  return row;
}

std::optional<recording_cost> cost_of(const probes::paced_result& run) {
  const step_record& record = *run.record;
  if (record.mode != probes::step_recording::alternate_blocks || record.periods == 0) return std::nullopt;
  recording_cost cost;
  cost.block_periods = record.block_periods;
  std::vector<double> on_all, off_all, ratios;
  const std::int64_t blocks = record.periods / record.block_periods;
  for (std::int64_t pair = 0; 2 * pair + 1 < blocks; ++pair) {
    std::vector<double> on, off;
    for (std::int64_t k = 2 * pair * record.block_periods; k < (2 * pair + 1) * record.block_periods; ++k)
      on.push_back(run.completion_ns[static_cast<std::size_t>(k)]);
    for (std::int64_t k = (2 * pair + 1) * record.block_periods; k < (2 * pair + 2) * record.block_periods; ++k)
      off.push_back(run.completion_ns[static_cast<std::size_t>(k)]);
    on_all.insert(on_all.end(), on.begin(), on.end());
    off_all.insert(off_all.end(), off.begin(), off.end());
    const double off_p50 = platform::summarize(off).p50;
    if (off_p50 > 0) ratios.push_back(platform::summarize(on).p50 / off_p50);
  }
  if (ratios.empty()) return std::nullopt;
  cost.pairs = ratios.size();
  cost.median_ratio = platform::summarize(ratios).p50;
  cost.low_ratio = *std::min_element(ratios.begin(), ratios.end());
  cost.high_ratio = *std::max_element(ratios.begin(), ratios.end());
  cost.on_p50_ns = platform::summarize(on_all).p50;
  cost.off_p50_ns = platform::summarize(off_all).p50;
  return cost;
}

}  // namespace

std::string cause_words(delay_cause cause) { return std::string(kCauseNaming[cause_index(cause)].words); }

std::string cause_key(delay_cause cause) { return std::string(kCauseNaming[cause_index(cause)].key); }

late_step attribute_step(const probes::paced_result& run, std::int64_t period) {
  const step_reader reader(run);
  std::optional<late_step> previous;
  // The chain of overrunning steps before it, oldest first (each may inherit).
  std::int64_t first = period;
  while (first > 0 && reader.completion(first - 1) > reader.gap_ns(first) && reader.recorded(first - 1)) --first;
  for (std::int64_t k = first; k < period; ++k) previous = attribute_with(reader, k, previous ? &*previous : nullptr);
  return attribute_with(reader, period, previous ? &*previous : nullptr);
}

delay_causes attribute_delay(const probes::paced_result& run, std::size_t worst) {
  delay_causes causes;
  if (!run.record) {
    causes.unavailable = "the run kept no per-step record";
    return causes;
  }
  const step_record& record = *run.record;
  causes.schedstat = record.schedstat_available;
  causes.interrupts = record.interrupts_available;
  causes.snapshot_cost_ns = record.snapshot_cost_ns;
  causes.interrupt_read_cost_ns = record.interrupt_read_cost_ns;
  if (!record.not_kept.empty()) {
    causes.unavailable = record.not_kept;
    return causes;
  }
  if (record.periods == 0 || run.completion_ns.empty()) {
    causes.unavailable = "no period was recorded";
    return causes;
  }
  causes.cost = cost_of(run);
  const step_reader reader(run);
  causes.median_completion_ns = reader.median_completion();
  std::vector<late_step> late;
  std::optional<late_step> previous;
  for (std::int64_t k = 0; k < reader.periods(); ++k) {
    if (!reader.recorded(k)) {
      previous.reset();
      continue;
    }
    late_step step = attribute_with(reader, k, previous ? &*previous : nullptr);
    if (step.excess_ns > 0) {
      late.push_back(step);
      previous = std::move(step);
    } else {
      previous.reset();
    }
  }
  const platform::distribution completion = platform::summarize(run.completion_ns);
  const auto above = [&](double threshold) {
    std::vector<const late_step*> chosen;
    for (const late_step& step : late)
      if (step.completion_ns > threshold) chosen.push_back(&step);
    return chosen;
  };
  for (const auto& [label, threshold] : {std::pair<std::string, double>{"above p99", completion.p99},
                                         std::pair<std::string, double>{"above p99.9", completion.p999}}) {
    const auto chosen = above(threshold);
    if (!chosen.empty()) causes.tail.push_back(sum_row(label, threshold, chosen));
  }
  if (!late.empty()) {
    const late_step* latest = &late.front();
    for (const late_step& step : late)
      if (step.excess_ns > latest->excess_ns) latest = &step;
    causes.tail.push_back(sum_row("maximum", latest->completion_ns, {latest}));
  }
  const auto missed = above(static_cast<double>(record.period_ns));
  if (!missed.empty()) causes.misses = sum_row("misses", static_cast<double>(record.period_ns), missed);
  // Per CPU, above p99: each step's causes under the CPU of its largest part.
  for (const late_step* step : above(completion.p99)) {
    if (!step->cpu) continue;
    auto slot = std::find_if(causes.per_cpu.begin(), causes.per_cpu.end(),
                             [&](const auto& entry) { return entry.first == *step->cpu; });
    if (slot == causes.per_cpu.end()) {
      causes.per_cpu.push_back({*step->cpu, cause_split{}});
      slot = causes.per_cpu.end() - 1;
    }
    for (std::size_t cause = 0; cause < kDelayCauses; ++cause) slot->second[cause] += step->cause_ns[cause];
  }
  std::sort(causes.per_cpu.begin(), causes.per_cpu.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::sort(late.begin(), late.end(), [](const late_step& a, const late_step& b) {
    return a.excess_ns != b.excess_ns ? a.excess_ns > b.excess_ns : a.period < b.period;
  });
  if (late.size() > worst) late.resize(worst);
  causes.worst = std::move(late);
  return causes;
}

}  // namespace lockstep::bench
