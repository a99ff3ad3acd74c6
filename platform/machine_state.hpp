#pragma once
// The machine's state that moves the figures, read as pyperf's `system show`
// reads it and Google Benchmark checks it before its "CPU scaling is enabled"
// warning, and the one line that says what biases a measurement here and
// what to change (as pyperf's `system tune` would, changing nothing).
//
// Why it matters: a powersave governor or turbo boost moves a step by tens of
// percent (the figures follow the frequency, which follows load and
// temperature); a busy SMT sibling takes half of a core; a CPU that is not
// isolated takes other tasks and the kernel's housekeeping, and without
// nohz_full the tick, between a paced step's periods; transparent huge pages
// change the refill after a migration.
//
// Everything is read under a root (`state_root()`: "/" on a machine, or the
// directory LOCKSTEP_STATE_ROOT names, a fixture tree of sys/ and proc/ for
// the tests: tests/fixtures/machine_state/). Paths below are relative to it:
//
//   sys/devices/system/cpu/online                   the CPUs the reading covers
//   sys/devices/system/cpu/cpuN/cpufreq/
//       scaling_driver, scaling_governor            per CPU: the driver, the governor
//       cpuinfo_min_freq, cpuinfo_max_freq          the hardware's range (kHz)
//       scaling_cur_freq                            the frequency now (kHz)
//       boost                                       per-policy boost (recent kernels)
//   sys/devices/system/cpu/intel_pstate/no_turbo, status
//   sys/devices/system/cpu/amd_pstate/status
//   sys/devices/system/cpu/cpufreq/boost            acpi-cpufreq's and amd-pstate's boost
//   sys/devices/system/cpu/smt/control, active
//   sys/devices/system/cpu/isolated, nohz_full      CPU lists
//   proc/irq/N/smp_affinity_list                    where IRQ N may land
//   proc/irq/N/effective_affinity_list              where it does land
//   sys/kernel/mm/transparent_hugepage/enabled, defrag
//   proc/stat                                       per-CPU busy time (SMT siblings' load)
//
// A value whose file cannot be read is "unavailable" (kUnavailable, or an
// empty optional): never guessed, never an error. Nothing here throws for a
// missing or odd file, so reading the state never fails a command. On a VM
// without cpufreq (this project's development VM) every frequency, the
// governor and boost read "unavailable", and the bias line is empty.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lockstep::platform {

inline constexpr const char* kUnavailable = "unavailable";

// The environment variable that moves the root; unset or empty: "/".
inline constexpr const char* kStateRootVariable = "LOCKSTEP_STATE_ROOT";
std::filesystem::path state_root();

// One CPU's cpufreq policy as it reads.
struct cpu_frequency {
  unsigned cpu = 0;
  std::string driver = kUnavailable;          // scaling_driver: "intel_pstate", "acpi-cpufreq", "amd-pstate-epp"
  std::string governor = kUnavailable;        // scaling_governor: "powersave", "performance", "schedutil"
  std::optional<std::uint64_t> min_khz;       // cpuinfo_min_freq
  std::optional<std::uint64_t> max_khz;       // cpuinfo_max_freq
  std::optional<std::uint64_t> current_khz;   // scaling_cur_freq
};

enum class boost_setting { on, off, unavailable };

// Turbo (intel_pstate's word) or boost (cpufreq's), read from the first of
// intel_pstate/no_turbo, cpufreq/boost, the per-policy cpuN/cpufreq/boost
// files that exists.
struct boost_state {
  boost_setting setting = boost_setting::unavailable;
  std::string word = "boost";  // "turbo" when intel_pstate says it
  std::string read_from;       // "intel_pstate/no_turbo = 0"
  std::string turn_off;        // the command that turns it off: "echo 1 > /sys/devices/system/cpu/intel_pstate/no_turbo"
};

// One interrupt line's affinity (proc/irq/N/).
struct irq_affinity {
  unsigned irq = 0;
  std::optional<std::vector<unsigned>> allowed;    // smp_affinity_list: where it may land
  std::optional<std::vector<unsigned>> effective;  // effective_affinity_list: where it lands (absent on older kernels)
};

struct machine_state {
  std::filesystem::path root;
  std::vector<unsigned> cpus;               // online CPUs (or every cpuN directory when online cannot be read)
  std::vector<cpu_frequency> frequencies;   // one per CPU of `cpus`, in that order
  std::string pstate_status = kUnavailable; // "intel_pstate active", "amd_pstate guided"
  boost_state boost;
  std::string smt_control = kUnavailable;   // on, off, forceoff, notsupported, notimplemented
  std::string smt_active = kUnavailable;    // "1": some core runs two threads
  std::optional<std::vector<unsigned>> isolated;   // isolcpus= (empty: none isolated)
  std::optional<std::vector<unsigned>> nohz_full;  // nohz_full= (the file exists only with CONFIG_NO_HZ_FULL)
  std::optional<std::vector<irq_affinity>> irqs;   // every numbered directory of proc/irq
  std::string transparent_hugepage = kUnavailable;         // the bracketed choice of enabled: always, madvise, never
  std::string transparent_hugepage_defrag = kUnavailable;  // of defrag: always, defer, defer+madvise, madvise, never
};

// Reads everything above under `root`. Never throws.
machine_state read_machine_state(const std::filesystem::path& root = state_root());

// The IRQs that concern a set of CPUs (the CPUs a command measures on).
struct irq_summary {
  unsigned total = 0;                              // IRQs whose smp_affinity_list could be read
  std::vector<unsigned> allowed;                   // those that may land on one of the CPUs
  std::optional<std::vector<unsigned>> effective;  // those that land there (nullopt: no effective_affinity_list)
};
// nullopt when proc/irq could not be read.
std::optional<irq_summary> irqs_on(const machine_state& state, const std::vector<unsigned>& cpus);

// --- The frequency during a command -------------------------------------
//
// scaling_cur_freq of the CPUs a command may use, sampled at its start, at
// the quiet moments the command offers (between repetitions, never inside a
// measured block: on x86 kernels before 5.18 a read sends an interrupt to the
// CPU it names, to read its APERF/MPERF counters), and at its end. Where no CPU has the file (a VM) the trace knows it from its first
// sample and every later sample costs nothing.

struct frequency_summary {
  std::vector<unsigned> cpus;  // the CPUs read
  std::size_t samples = 0;     // how many times they were read
  std::optional<std::uint64_t> lowest_khz;   // over every CPU and sample; nullopt: unavailable
  std::optional<std::uint64_t> median_khz;
  std::optional<std::uint64_t> highest_khz;
};

class frequency_trace {
 public:
  // Takes the first sample.
  frequency_trace(std::filesystem::path root, std::vector<unsigned> cpus);
  void sample();
  frequency_summary summary() const;

 private:
  std::filesystem::path root_;
  std::vector<unsigned> cpus_;
  bool available_ = false;
  std::size_t samples_ = 0;
  std::vector<std::uint64_t> readings_khz_;
};

// The process's trace, one per command: begun when the command starts
// (bench/cli/main.cpp, for the CPUs of the process's affinity set under
// state_root()), sampled by a command at its quiet moments, summarised when
// the result's context is written (bench/results/machine_state_context.cpp),
// which samples once more first. Safe from any thread. A summary asked for
// with no trace begun begins one there (one sample).
void begin_command_frequency_trace();
void sample_command_frequency();
frequency_summary command_frequency_summary();

// --- An SMT sibling busy -------------------------------------------------
//
// How it is known: from proc/stat, the busy share of each sibling of a
// measured CPU over an interval in which the team's CPUs are known (a
// repetition of a pinned entry; a whole command that pins one team). A
// sibling that is itself in the team is the placement's choice (its plan says
// `wrapped`), not the machine's state, and is not counted. Busy: user, nice,
// system, irq and softirq time over everything but guest time (steal and
// iowait count as not busy); a sibling busy for kBusySiblingShare of the
// interval or more shares its core with the measurement.

inline constexpr double kBusySiblingShare = 0.10;

struct cpu_times {
  unsigned cpu = 0;
  std::uint64_t busy = 0;   // clock ticks
  std::uint64_t total = 0;
};
// The "cpuN ..." lines of proc/stat's text (the all-CPU "cpu" line skipped).
std::vector<cpu_times> parse_proc_stat(std::string_view text);
std::vector<cpu_times> read_cpu_times(const std::filesystem::path& root = state_root());

// `cores`: each core's PUs (OS indices), as hwloc gives them
// (platform/topology.hpp, core_info::pus). The siblings of the team's CPUs,
// outside the team, busy for `share` of the interval between the two
// readings or more.
std::vector<unsigned> busy_smt_siblings(const std::vector<std::vector<unsigned>>& cores,
                                        const std::vector<unsigned>& team, const std::vector<cpu_times>& before,
                                        const std::vector<cpu_times>& after, double share = kBusySiblingShare);

// --- The bias line ---------------------------------------------------------

// What a command's figures are: times of work (run, c2c, falseshare,
// migrate: the governor, boost and busy SMT siblings move them) or wake-up
// latencies of a paced step (delay: CPUs not isolated and the tick move them).
enum class bias_focus { step_times, wake_up_latency };

// At most one line (empty: nothing known biases the figures) saying what in
// the state of the team's CPUs can bias the figures and what to change, with
// the commands, e.g. "CPUs 0-3 run the powersave governor with turbo on:
// figures move with frequency; set the performance governor and turn turbo
// off (cpupower frequency-set -g performance; echo 1 >
// /sys/devices/system/cpu/intel_pstate/no_turbo)". The line is whole: a
// terminal wraps it.
//
// step_times: a governor other than performance (userspace excepted: it
// holds the frequency the user set); boost on; `busy_siblings` (from
// busy_smt_siblings). wake_up_latency: team CPUs not isolated (when the
// isolated list could be read); team CPUs outside nohz_full (when the
// kernel has it). A value that is unavailable says nothing.
std::string bias_line(const machine_state& state, const std::vector<unsigned>& team, bias_focus focus,
                      const std::vector<unsigned>& busy_siblings = {});

}  // namespace lockstep::platform
