// The machine's state read under a root (platform/machine_state.hpp), on the
// fixture trees of tests/fixtures/machine_state/: an Intel machine on
// powersave with turbo on and CPUs 2-3 isolated, an AMD machine on
// performance with boost off, a VM with no cpufreq; and the bias line each
// gives a run and a paced run.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "platform/cpu_list.hpp"
#include "platform/machine_state.hpp"
#include "tests/support/scratch_directory.hpp"

namespace {

namespace fs = std::filesystem;
using lockstep::platform::bias_focus;
using lockstep::platform::bias_line;
using lockstep::platform::boost_setting;
using lockstep::platform::format_cpu_list;
using lockstep::platform::parse_cpu_list;
using lockstep::platform::read_machine_state;

fs::path fixture(const std::string& tree) {
  return fs::path(LOCKSTEP_SOURCE_DIR) / "tests" / "fixtures" / "machine_state" / tree;
}

const std::vector<unsigned> kIntelCpus{0, 1, 2, 3};
const std::vector<unsigned> kAmdCpus{0, 1, 2, 3, 4, 5, 6, 7};

TEST(CpuList, ReadsAndWritesTheKernelsFormat) {
  EXPECT_EQ(parse_cpu_list("0-3,8,10-11\n"), (std::vector<unsigned>{0, 1, 2, 3, 8, 10, 11}));
  EXPECT_EQ(parse_cpu_list(""), std::vector<unsigned>{});
  EXPECT_EQ(parse_cpu_list("\n"), std::vector<unsigned>{});
  EXPECT_EQ(parse_cpu_list("(null)\n"), std::vector<unsigned>{}) << "an unset nohz_full mask on older kernels";
  EXPECT_EQ(parse_cpu_list("3,1,1-2"), (std::vector<unsigned>{1, 2, 3}));
  for (const char* bad : {"3-1", "a", "1,", "1-", "0-4000000000", "-2"}) EXPECT_FALSE(parse_cpu_list(bad)) << bad;
  EXPECT_EQ(format_cpu_list({0, 1, 2, 3, 8, 10, 11}), "0-3,8,10-11");
  EXPECT_EQ(format_cpu_list({5, 3, 4, 4}), "3-5");
  EXPECT_EQ(format_cpu_list({}), "");
}

TEST(MachineState, IntelOnPowersaveWithTurboAndTwoIsolatedCpus) {
  const auto state = read_machine_state(fixture("intel_powersave_turbo"));
  EXPECT_EQ(state.cpus, kIntelCpus);
  ASSERT_EQ(state.frequencies.size(), 4U);
  for (const auto& cpu : state.frequencies) {
    EXPECT_EQ(cpu.driver, "intel_pstate");
    EXPECT_EQ(cpu.governor, "powersave");
    EXPECT_EQ(cpu.min_khz, 800000U);
    EXPECT_EQ(cpu.max_khz, 4700000U);
  }
  EXPECT_EQ(state.frequencies[2].current_khz, 800000U);
  EXPECT_EQ(state.pstate_status, "intel_pstate active");
  EXPECT_EQ(state.boost.setting, boost_setting::on);
  EXPECT_EQ(state.boost.word, "turbo");
  EXPECT_EQ(state.boost.read_from, "intel_pstate/no_turbo = 0");
  EXPECT_EQ(state.smt_control, "on");
  EXPECT_EQ(state.smt_active, "1");
  EXPECT_EQ(state.isolated, (std::vector<unsigned>{2, 3}));
  EXPECT_EQ(state.nohz_full, std::vector<unsigned>{}) << "(null): the kernel has nohz_full, no CPU is in it";
  EXPECT_EQ(state.transparent_hugepage, "always");
  EXPECT_EQ(state.transparent_hugepage_defrag, "madvise");
  ASSERT_TRUE(state.irqs);
  EXPECT_EQ(state.irqs->size(), 9U);

  const auto on_isolated = lockstep::platform::irqs_on(state, {2, 3});
  ASSERT_TRUE(on_isolated);
  EXPECT_EQ(on_isolated->total, 9U);
  EXPECT_EQ(on_isolated->allowed, (std::vector<unsigned>{0, 1, 16, 122, 123}));
  ASSERT_TRUE(on_isolated->effective);
  EXPECT_EQ(*on_isolated->effective, (std::vector<unsigned>{16, 122, 123}));
}

TEST(MachineState, AmdOnPerformanceWithBoostOff) {
  const auto state = read_machine_state(fixture("amd_performance_noboost"));
  EXPECT_EQ(state.cpus, kAmdCpus);
  ASSERT_EQ(state.frequencies.size(), 8U);
  EXPECT_EQ(state.frequencies[0].driver, "amd-pstate-epp");
  EXPECT_EQ(state.frequencies[7].governor, "performance");
  EXPECT_EQ(state.frequencies[0].max_khz, 5881000U);
  EXPECT_EQ(state.frequencies[7].max_khz, 5452000U) << "preferred cores: each core its own highest frequency";
  EXPECT_EQ(state.pstate_status, "amd_pstate active");
  EXPECT_EQ(state.boost.setting, boost_setting::off);
  EXPECT_EQ(state.boost.word, "boost");
  EXPECT_EQ(state.boost.read_from, "cpufreq/boost = 0");
  EXPECT_EQ(state.isolated, std::vector<unsigned>{}) << "an empty line: none isolated";
  EXPECT_EQ(state.nohz_full, std::vector<unsigned>{});
  EXPECT_EQ(state.transparent_hugepage, "madvise");
}

TEST(MachineState, VmWithoutCpufreqReadsUnavailable) {
  const auto state = read_machine_state(fixture("vm_no_cpufreq"));
  EXPECT_EQ(state.cpus, (std::vector<unsigned>{0, 1}));
  ASSERT_EQ(state.frequencies.size(), 2U);
  for (const auto& cpu : state.frequencies) {
    EXPECT_EQ(cpu.driver, "unavailable");
    EXPECT_EQ(cpu.governor, "unavailable");
    EXPECT_FALSE(cpu.min_khz);
    EXPECT_FALSE(cpu.max_khz);
    EXPECT_FALSE(cpu.current_khz);
  }
  EXPECT_EQ(state.pstate_status, "unavailable");
  EXPECT_EQ(state.boost.setting, boost_setting::unavailable);
  EXPECT_EQ(state.smt_control, "notsupported");
  EXPECT_EQ(state.isolated, std::vector<unsigned>{});
  EXPECT_FALSE(state.nohz_full) << "no nohz_full file: a kernel without CONFIG_NO_HZ_FULL";
}

TEST(MachineState, NoTreeAtAllIsUnavailableAndNoError) {
  const auto state = read_machine_state("/nonexistent/lockstep-state-root");
  EXPECT_TRUE(state.cpus.empty());
  EXPECT_EQ(state.boost.setting, boost_setting::unavailable);
  EXPECT_EQ(state.smt_control, "unavailable");
  EXPECT_FALSE(state.isolated);
  EXPECT_FALSE(state.nohz_full);
  EXPECT_FALSE(state.irqs);
  EXPECT_EQ(state.transparent_hugepage, "unavailable");
  EXPECT_FALSE(lockstep::platform::irqs_on(state, {0}));
  EXPECT_EQ(bias_line(state, {0, 1}, bias_focus::step_times), "");
  EXPECT_EQ(bias_line(state, {0, 1}, bias_focus::wake_up_latency), "");
}

// Odd files: a value that is not what the kernel writes reads "unavailable"
// (never guessed); IRQs without effective_affinity_list (kernels before 4.13).
TEST(MachineState, OddValuesAreUnavailable) {
  lockstep::testing::scratch_directory root("lockstep-machine-state");
  const auto put = [&](const std::string& path, const std::string& text) {
    fs::create_directories((root.path() / path).parent_path());
    std::ofstream(root.path() / path) << text;
  };
  put("sys/devices/system/cpu/online", "0-1\n");
  put("sys/devices/system/cpu/cpu0/cpufreq/cpuinfo_max_freq", "fast\n");
  put("sys/devices/system/cpu/intel_pstate/no_turbo", "maybe\n");
  put("sys/devices/system/cpu/isolated", "1-0\n");
  put("sys/kernel/mm/transparent_hugepage/enabled", "always madvise never\n");
  put("proc/irq/3/smp_affinity_list", "0-1\n");
  put("proc/irq/default_smp_affinity", "3\n");
  const auto state = read_machine_state(root.path());
  EXPECT_FALSE(state.frequencies.at(0).max_khz);
  EXPECT_EQ(state.boost.setting, boost_setting::unavailable);
  EXPECT_FALSE(state.isolated);
  EXPECT_EQ(state.transparent_hugepage, "unavailable");
  const auto irqs = lockstep::platform::irqs_on(state, {1});
  ASSERT_TRUE(irqs);
  EXPECT_EQ(irqs->total, 1U) << "default_smp_affinity is not an IRQ";
  EXPECT_EQ(irqs->allowed, std::vector<unsigned>{3});
  EXPECT_FALSE(irqs->effective);
}

// Per-policy boost files (amd-pstate on recent kernels) when no global one exists.
TEST(MachineState, PerPolicyBoost) {
  lockstep::testing::scratch_directory root("lockstep-machine-state");
  const auto put = [&](const std::string& path, const std::string& text) {
    fs::create_directories((root.path() / path).parent_path());
    std::ofstream(root.path() / path) << text;
  };
  put("sys/devices/system/cpu/online", "0-1\n");
  put("sys/devices/system/cpu/cpu0/cpufreq/boost", "0\n");
  put("sys/devices/system/cpu/cpu1/cpufreq/boost", "1\n");
  const auto state = read_machine_state(root.path());
  EXPECT_EQ(state.boost.setting, boost_setting::on);
  EXPECT_EQ(state.boost.read_from, "cpuN/cpufreq/boost = 1 on some CPU");
  EXPECT_EQ(bias_line(state, {0, 1}, bias_focus::step_times),
            "CPUs 0-1 run with boost on: figures move with frequency; turn boost off "
            "(echo 0 | tee /sys/devices/system/cpu/cpu*/cpufreq/boost)");
}

// The one line the answer prints, per tree and focus.
TEST(BiasLine, IntelRunNamesTheGovernorAndTurboAndWhatToChange) {
  const auto state = read_machine_state(fixture("intel_powersave_turbo"));
  EXPECT_EQ(bias_line(state, kIntelCpus, bias_focus::step_times),
            "CPUs 0-3 run the powersave governor with turbo on: figures move with frequency; set the performance "
            "governor and turn turbo off (cpupower frequency-set -g performance; echo 1 > "
            "/sys/devices/system/cpu/intel_pstate/no_turbo)");
  EXPECT_EQ(bias_line(state, {}, bias_focus::step_times), "") << "no team, nothing to say";
}

TEST(BiasLine, IntelDelayOnIsolatedCpusNamesTheTickOnly) {
  const auto state = read_machine_state(fixture("intel_powersave_turbo"));
  EXPECT_EQ(bias_line(state, {2, 3}, bias_focus::wake_up_latency),
            "the tick runs on CPUs 2-3: the tick interrupts the step; stop the tick there "
            "(nohz_full=2-3 on the kernel command line)");
  EXPECT_EQ(bias_line(state, {1, 2}, bias_focus::wake_up_latency),
            "CPU 1 is not isolated and the tick runs on CPUs 1-2: other tasks share them and the tick interrupts "
            "the step; isolate them and stop the tick there (isolcpus=1 nohz_full=1-2 on the kernel command line)");
}

TEST(BiasLine, AmdOnPerformanceWithBoostOffSaysNothingForARun) {
  const auto state = read_machine_state(fixture("amd_performance_noboost"));
  EXPECT_EQ(bias_line(state, kAmdCpus, bias_focus::step_times), "");
  EXPECT_EQ(bias_line(state, {0, 1}, bias_focus::wake_up_latency),
            "CPUs 0-1 are not isolated and the tick runs on them: other tasks share them and the tick interrupts "
            "the step; isolate them and stop the tick there (isolcpus=0-1 nohz_full=0-1 on the kernel command line)");
}

TEST(BiasLine, AmdWithABusySmtSibling) {
  const auto state = read_machine_state(fixture("amd_performance_noboost"));
  EXPECT_EQ(bias_line(state, {0, 1}, bias_focus::step_times, {4}),
            "the SMT sibling 4 of the measured CPUs was busy: a busy sibling takes part of its core; leave the "
            "siblings idle or turn SMT off (echo off > /sys/devices/system/cpu/smt/control)");
}

TEST(BiasLine, VmWithoutCpufreqSaysNothingForARun) {
  const auto state = read_machine_state(fixture("vm_no_cpufreq"));
  EXPECT_EQ(bias_line(state, {0, 1}, bias_focus::step_times), "");
  EXPECT_EQ(bias_line(state, {0, 1}, bias_focus::wake_up_latency),
            "CPUs 0-1 are not isolated: other tasks share them; isolate them (isolcpus=0-1 on the kernel command "
            "line)")
      << "nohz_full unavailable: nothing said of the tick";
}

TEST(BiasLine, UserspaceAndPerformanceGovernorsAreNotABias) {
  auto state = read_machine_state(fixture("intel_powersave_turbo"));
  state.boost.setting = boost_setting::off;
  state.frequencies[0].governor = "performance";
  state.frequencies[1].governor = "userspace";
  state.frequencies[2].governor = "schedutil";
  EXPECT_EQ(bias_line(state, {0, 1}, bias_focus::step_times), "");
  EXPECT_EQ(bias_line(state, kIntelCpus, bias_focus::step_times),
            "CPUs 2-3 run the schedutil and powersave governors: figures move with frequency; set the performance "
            "governor (cpupower frequency-set -g performance)");
  state.frequencies[0].governor = "ondemand";
  EXPECT_EQ(bias_line(state, kIntelCpus, bias_focus::step_times),
            "CPUs 0,2-3 run the ondemand, schedutil and powersave governors: figures move with frequency; set the "
            "performance governor (cpupower frequency-set -g performance)");
}

// proc/stat between two readings: a sibling outside the team busy for at
// least a tenth of the interval is named; one inside the team, or idle, is not.
TEST(BusySiblings, FromProcStatOverAnInterval) {
  const auto before = lockstep::platform::parse_proc_stat(
      "cpu  100 0 100 1000 0 0 0 0 0 0\n"
      "cpu0 10 0 10 100 0 0 0 0 0 0\n"
      "cpu1 10 0 10 100 0 0 0 0 0 0\n"
      "cpu2 10 0 10 100 0 0 0 0 0 0\n"
      "cpu3 10 0 10 100 0 0 0 0 0 0\n"
      "intr 5 0\n");
  // Over 100 ticks: CPU 2 busy 50 (irq and softirq counted), CPU 3 busy 5, CPU 1 busy 100.
  const auto after = lockstep::platform::parse_proc_stat(
      "cpu  100 0 100 1000 0 0 0 0 0 0\n"
      "cpu0 110 0 10 100 0 0 0 0 0 0\n"
      "cpu1 110 0 10 100 0 0 0 0 0 0\n"
      "cpu2 40 0 10 150 0 10 10 0 0 0\n"
      "cpu3 15 0 10 195 0 0 0 0 0 0\n");
  ASSERT_EQ(before.size(), 4U);
  EXPECT_EQ(after[2].busy - before[2].busy, 50U);
  EXPECT_EQ(after[2].total - before[2].total, 100U);
  // Cores {0, 2} and {1, 3}: the team on 0 and 1.
  const std::vector<std::vector<unsigned>> cores{{0, 2}, {1, 3}};
  EXPECT_EQ(lockstep::platform::busy_smt_siblings(cores, {0, 1}, before, after), std::vector<unsigned>{2});
  EXPECT_EQ(lockstep::platform::busy_smt_siblings(cores, {0, 1}, before, after, 0.04),
            (std::vector<unsigned>{2, 3}));
  EXPECT_TRUE(lockstep::platform::busy_smt_siblings(cores, {0, 2}, before, after).empty())
      << "a sibling in the team is the placement's choice, not the machine's state";
  EXPECT_TRUE(lockstep::platform::busy_smt_siblings({{0}, {1}, {2}, {3}}, {0, 1}, before, after).empty())
      << "no SMT: no sibling";
}

TEST(FrequencyTrace, SamplesTheCpusThatHaveAFrequency) {
  lockstep::platform::frequency_trace intel(fixture("intel_powersave_turbo"), {0, 1, 2, 3, 9});
  intel.sample();
  const auto summary = intel.summary();
  EXPECT_EQ(summary.cpus, kIntelCpus) << "CPU 9 has no cpufreq";
  EXPECT_EQ(summary.samples, 2U);
  EXPECT_EQ(summary.lowest_khz, 800000U);
  EXPECT_EQ(summary.highest_khz, 4600000U);
  EXPECT_EQ(summary.median_khz, 3900000U);

  lockstep::platform::frequency_trace vm(fixture("vm_no_cpufreq"), {0, 1});
  vm.sample();
  EXPECT_TRUE(vm.summary().cpus.empty());
  EXPECT_FALSE(vm.summary().lowest_khz);
}

}  // namespace
