#pragma once
// Why a step of a paced run was late: attribute_delay reads a run's per-step
// record (bench/probes/paced.hpp) and splits each late step's excess over
// the median completion into causes. Pure: it reads the run only; its text
// and JSON are attribution_output.hpp's.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "bench/probes/paced.hpp"

namespace lockstep::bench {

// The critical path. A step's completion is the latest participant's end.
// Walking back from it, stage by stage (3 to 0): the participant p that is
// on the path left stage s's sync when the last of those it waits for (and
// itself) had arrived: call that one the blocker b. The path then holds
//   a resume part   (p, s): p's departure (its end, at stage 3) minus b's
//                   arrival: release to resume, the sync's wake-up;
//   a compute part  (b, s): b's arrival minus its departure from stage s-1
//                   (its wake-up at stage 0): its own work in the stage;
// and, at the start, a timer part (b, the wake-up): how late b woke. The
// parts add up to the completion exactly. Each part's excess is its length
// minus the median of the same part (participant, stage, kind) over the run.
//
// Splitting a part's excess. A part that began on one CPU and ended on
// another is all migration. Otherwise the participant's window (from its
// previous step's end to this one's) has three kinds of time above its
// medians: run-queue wait, on-CPU time and blocked time (off the CPU, not
// runnable); the part's excess is shared among them in proportion (each
// capped by what it has left, shared by the participant's parts), and each
// is named by the guest's evidence:
//   run-queue wait   waiting on a run queue (preempted, or woken behind
//                    another task);
//   on-CPU time      page faults when it faulted more than its median;
//                    else migration when it changed CPU in the window (the
//                    move's IPIs and cold caches); else interrupts when its
//                    CPU took more interrupts and softirqs than that CPU's
//                    median; else machine stall: the guest says the thread
//                    ran, and no switch, fault or interrupt explains the time
//                    (on a VM whose host reports no steal time, the vCPU was
//                    descheduled or the hardware stalled);
//   blocked time     page faults when it had major faults; else in a
//                    compute part its own doing (compute: it slept or waited
//                    in its own stage); in a wake-up part wake-up latency
//                    when the guest shows its wake-up path at work (more
//                    switches, or more interrupts on its CPU), else machine
//                    stall (a wake-up nothing the guest did delayed);
//   what is left     in a wake-up part, wake-up latency when the guest
//                    shows its wake-up path at work, else machine stall; in
//                    a compute part, unexplained; and the step's excess the
//                    parts do not cover is unexplained.
// The wake-up path accounts for at most one typical length of the part (its
// median) per switch or interrupt above the usual, in a part's blocked time
// and what is left together; a wake-up later than that is machine stall
// beyond it (a 25 ms timer wake-up with five more switches and three more
// interrupts than usual is not the guest's doing: the timer fired while the
// vCPU did not run).
// A timer wake-up lies in the sleep before the step: of the window's time
// only its run-queue wait is shared with it; blocked time is the step's
// (from its wake-up to its end).
// (Blocked time is measured from the wake-up to the end, so that the sleep,
// whose length moves with the previous step's end, does not blur it.)
// A step whose timer part is late because the participant's own previous
// step ended after this step's target inherits that step's causes. (A
// paced run re-anchors its schedule after an overrun, so a team's step never
// starts before the previous one ended: this applies to records made
// otherwise.)
// When the parts' excesses add up to more than the step's excess (other
// parts ran faster than their median), the causes are scaled to the step's
// excess, so that a step's causes always add up to its excess.
// Nothing here knows a primitive: only the record's times, CPUs, counters
// and whom each participant waits for.
enum class delay_cause {
  compute,
  run_queue_wait,
  migration,
  page_faults,
  interrupts,
  wakeup_latency,
  machine_stall,
  unexplained,
};
inline constexpr std::size_t kDelayCauses = 8;
using cause_split = std::array<double, kDelayCauses>;  // ns per cause, indexed by delay_cause

// What each cause is called, in delay_cause's order: the one table that the
// text, the result file's keys and its list of causes (cause_kinds, which
// the report's figure reads: reports/lockstep_reports/read/delay_reader.py, read_causes) take
// their names from.
struct cause_naming {
  delay_cause cause;
  std::string_view key;     // the result file's: "run_queue_wait"
  std::string_view words;   // the text's: "run-queue wait"
  std::string_view column;  // the causes table's column, 8 characters at most: "rq wait"
};
inline constexpr std::array<cause_naming, kDelayCauses> kCauseNaming{{
    {delay_cause::compute, "compute", "compute", "compute"},
    {delay_cause::run_queue_wait, "run_queue_wait", "run-queue wait", "rq wait"},
    {delay_cause::migration, "migration", "migration", "migrate"},
    {delay_cause::page_faults, "page_faults", "page faults", "faults"},
    {delay_cause::interrupts, "interrupts", "interrupts", "irq"},
    {delay_cause::wakeup_latency, "wake_up_latency", "wake-up latency", "wake-up"},
    {delay_cause::machine_stall, "machine_stall", "machine stall", "stall"},
    {delay_cause::unexplained, "unexplained", "unexplained", "unexpl."},
}};
static_assert([] {
  for (std::size_t index = 0; index < kDelayCauses; ++index)
    if (static_cast<std::size_t>(kCauseNaming[index].cause) != index || kCauseNaming[index].column.size() > 8)
      return false;
  return true;
}(), "kCauseNaming lists every cause once, in delay_cause's order, each column in 8 characters");

// "compute", "run-queue wait", ... (text) and "compute", "run_queue_wait", ... (JSON).
std::string cause_words(delay_cause cause);
std::string cause_key(delay_cause cause);

enum class part_kind { timer_wakeup, compute, sync_resume };

// One late step, attributed.
struct late_step {
  std::int64_t period = 0;
  double completion_ns = 0;
  double excess_ns = 0;       // completion minus the run's median completion
  cause_split cause_ns{};     // adds up to excess_ns
  delay_cause top = delay_cause::unexplained;
  // The part of the path with the largest excess: who, where, what kind.
  part_kind kind = part_kind::compute;
  unsigned participant = 0;
  std::optional<unsigned> cpu;  // where that part ended
  int stage = 0;                // 0..3 (timer part: 0, the stage it was about to start)
  double part_excess_ns = 0;
  double lead_ns = 0;           // compute part: how long after the others it arrived
  // Evidence in that participant's window (above its medians; nullopt: unavailable).
  std::optional<std::int64_t> switches;  // times it was scheduled in, voluntary or not
  std::optional<std::int64_t> page_faults;
  std::optional<std::int64_t> interrupts;  // on its CPU, above that CPU's median
  std::optional<double> run_queue_wait_ns;
  std::optional<unsigned> moved_from;      // the part began on this CPU (a migration)
  // The causes are the previous step's (its overrun delayed this start); the
  // part, participant, CPU and evidence named are that step's too.
  bool inherited = false;
};

// A set of steps summed: the tail above a percentile, the maximum, the misses.
struct cause_row {
  std::string label;       // "above p99", "above p99.9", "maximum", "misses"
  double threshold_ns = 0; // completion above this (maximum: the step's own)
  std::size_t steps = 0;
  double excess_ns = 0;
  cause_split cause_ns{};
  double explained_share = 0;   // 1 - unexplained / excess (machine stalls count as explained)
  double guest_share = 0;       // share explained by a guest event (not a machine stall)
  std::optional<delay_cause> top;
};

// The cost of the record as a pair (a run with recording = alternate_blocks).
struct recording_cost {
  std::size_t pairs = 0;
  std::int64_t block_periods = 0;
  double median_ratio = 1;  // completion p50 with the record / without, per pair of adjacent blocks: the median
  double low_ratio = 1;     // the pairs' smallest and largest
  double high_ratio = 1;
  double on_p50_ns = 0;     // over all recorded / unrecorded periods
  double off_p50_ns = 0;
};

struct delay_causes {
  std::string unavailable;  // why nothing could be attributed, or empty
  double median_completion_ns = 0;
  bool schedstat = false;   // run-queue wait and on-CPU time were read
  bool interrupts = false;
  double snapshot_cost_ns = 0;  // one participant's counters
  double interrupt_read_cost_ns = 0;
  std::vector<cause_row> tail;       // above p99, above p99.9, maximum (the ones with steps)
  std::optional<cause_row> misses;   // the deadline misses, when there were any
  std::vector<late_step> worst;      // the N latest steps, latest first
  std::vector<std::pair<unsigned, cause_split>> per_cpu;  // above p99, by the CPU of each step's largest part
  std::optional<recording_cost> cost;
};

// Attributes every step of `run` whose completion is above the median;
// keeps the `worst` latest one line each. Pure: reads the run only.
delay_causes attribute_delay(const probes::paced_result& run, std::size_t worst = 10);
// One step, as attribute_delay does it (tests; `period` must be recorded).
late_step attribute_step(const probes::paced_result& run, std::int64_t period);

}  // namespace lockstep::bench
