// The per-step counters (platform/step_counters.hpp): the parsers on
// constructed texts, and the readers on this machine (a source the machine
// lacks is skipped, saying so).
#include "platform/step_counters.hpp"

#include <sys/mman.h>

#include <chrono>
#include <cstddef>
#include <cstdio>
#include <latch>
#include <optional>
#include <thread>
#include <utility>

#include <gtest/gtest.h>

#include "tests/support/watchdog.hpp"

namespace {

using lockstep::platform::cpu_interrupt_totals;
using lockstep::platform::interrupt_reader;
using lockstep::platform::parse_per_cpu_table;
using lockstep::platform::parse_schedstat;
using lockstep::platform::parse_stat_faults;
using lockstep::platform::thread_counter_reader;
using lockstep::platform::thread_step_counters;

TEST(StepCounters, ParsesSchedstat) {
  const auto fields = parse_schedstat("12345 678 9\n");
  ASSERT_TRUE(fields.has_value());
  EXPECT_EQ(fields->on_cpu_ns, 12345);
  EXPECT_EQ(fields->run_queue_wait_ns, 678);
  EXPECT_EQ(fields->timeslices, 9);
  EXPECT_FALSE(parse_schedstat("12345 678\n").has_value()) << "two numbers are not a schedstat line";
  EXPECT_FALSE(parse_schedstat("").has_value());
}

TEST(StepCounters, SumsEveryLineOfAPerCpuTable) {
  // The shape of /proc/interrupts: a header naming the CPUs (here not 0..n-1),
  // numbered lines, named lines, and a short line (ERR) with one number.
  const char* text =
      "           CPU0       CPU2       \n"
      " 24:          1          0  IO-APIC   5-edge      ACPI:Ged\n"
      "LOC:        100        200   Local timer interrupts\n"
      "ERR:          7\n";
  const auto table = parse_per_cpu_table(text);
  ASSERT_EQ(table.cpus, (std::vector<unsigned>{0, 2}));
  EXPECT_EQ(table.sums, (std::vector<std::int64_t>{108, 200})) << "ERR's lone number counts on the first column only";
  EXPECT_TRUE(parse_per_cpu_table("no header here\n").cpus.empty());
}

TEST(StepCounters, DifferenceKeepsUnavailableFieldsUnavailable) {
  thread_step_counters before;
  thread_step_counters after;
  after.on_cpu_ns = 500;
  after.minor_faults = 3;
  before.minor_faults = 1;
  const thread_step_counters delta = after - before;
  EXPECT_FALSE(delta.on_cpu_ns.has_value()) << "before had no on-CPU time: no difference";
  EXPECT_EQ(delta.minor_faults, 2);
  EXPECT_FALSE(delta.major_faults.has_value());
}

TEST(StepCounters, ASleepAndFreshPagesShowInTheSnapshot) {
  lockstep::testing::watchdog guard(std::chrono::seconds(10 * lockstep::testing::kSlowdown), "snapshot thread");
  bool schedstat = false;
  thread_step_counters delta;
  constexpr std::size_t kPages = 64;
  std::thread reader_thread([&] {
    thread_counter_reader reader;
    schedstat = reader.schedstat_available();
    const thread_step_counters before = reader.read();
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    void* memory = ::mmap(nullptr, kPages * 4096, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    ASSERT_NE(memory, MAP_FAILED);
    auto* bytes = static_cast<volatile char*>(memory);
    for (std::size_t page = 0; page < kPages; ++page) bytes[page * 4096] = 1;
    delta = reader.read() - before;
    ::munmap(memory, kPages * 4096);
  });
  reader_thread.join();
  ASSERT_TRUE(delta.minor_faults.has_value()) << "/proc/thread-self/stat names the faults";
  EXPECT_GE(*delta.minor_faults, static_cast<std::int64_t>(kPages) / 2)
      << "touching fresh anonymous pages faults them in (transparent huge pages may merge some)";
  if (!schedstat) GTEST_SKIP() << "/proc/thread-self/schedstat is not readable here: on-CPU and run-queue time unavailable";
  ASSERT_TRUE(delta.on_cpu_ns.has_value());
  EXPECT_GT(*delta.on_cpu_ns, 0) << "touching pages ran on the CPU";
  EXPECT_GE(*delta.switches, 1) << "the sleep switched the thread out and back in";
}

TEST(StepCounters, ParsesTheFaultsOfAStatLine) {
  // A command name with a space and a ')' of its own: the fields resume
  // after the last ')'.
  const auto faults =
      parse_stat_faults("4242 (a b) c) S 1 4242 4242 0 -1 4194560 17 3 5 0 12 4 0 0 20 0 1 0 99 1000 50\n");
  ASSERT_TRUE(faults.has_value());
  EXPECT_EQ(faults->minor, 17) << "field 10";
  EXPECT_EQ(faults->major, 5) << "field 12 (11 is the children's minor faults)";
  EXPECT_FALSE(parse_stat_faults("4242 (lockstep) S 1 4242\n").has_value()) << "too few fields";
  EXPECT_FALSE(parse_stat_faults("no parenthesis 1 2 3 4 5 6 7 8 9 10\n").has_value());
}

TEST(StepCounters, AnotherThreadReadsTheOwnersCounters) {
  // The per-step record's reads: the last participant to end reads
  // everyone's counters. The owner touches fresh pages; the reader (this
  // thread) touches none, so the faults it reads are the owner's. The owner
  // waits until it has been read (a thread that has exited cannot be).
  lockstep::testing::watchdog guard(std::chrono::seconds(10 * lockstep::testing::kSlowdown), "owner thread");
  constexpr std::size_t kPages = 64;
  std::optional<thread_counter_reader> reader;
  thread_step_counters before;
  std::latch touched(1);
  std::latch read(1);
  std::thread owner([&] {
    reader.emplace();
    before = std::as_const(*reader).read();
    void* memory = ::mmap(nullptr, kPages * 4096, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (memory != MAP_FAILED) {
      auto* bytes = static_cast<volatile char*>(memory);
      for (std::size_t page = 0; page < kPages; ++page) bytes[page * 4096] = 1;
      ::munmap(memory, kPages * 4096);
    }
    touched.count_down();
    read.wait();
  });
  touched.wait();
  const thread_step_counters after = reader->read();
  read.count_down();
  owner.join();
  const thread_step_counters delta = after - before;
  ASSERT_TRUE(delta.minor_faults.has_value());
  EXPECT_GE(*delta.minor_faults, static_cast<std::int64_t>(kPages) / 2) << "the owner's faults, read from here";
}

TEST(StepCounters, InterruptTotalsNameEveryColumn) {
  interrupt_reader reader;
  if (!reader.available()) GTEST_SKIP() << "/proc/interrupts and /proc/softirqs are not readable here";
  const cpu_interrupt_totals first = reader.read();
  ASSERT_FALSE(first.cpus.empty());
  if (!first.interrupts.empty()) {
    EXPECT_EQ(first.interrupts.size(), first.cpus.size());
  }
  if (!first.softirqs.empty()) {
    EXPECT_EQ(first.softirqs.size(), first.cpus.size());
  }
  const cpu_interrupt_totals second = reader.read();
  ASSERT_EQ(second.cpus, first.cpus) << "a reread gives the same columns";
  for (std::size_t column = 0; column < first.interrupts.size() && column < second.interrupts.size(); ++column)
    EXPECT_GE(second.interrupts[column], first.interrupts[column]) << "interrupt counts only grow";
}

TEST(StepCounters, SnapshotCostIsMeasured) {
  // The figure lockstep delay prints beside its record; reported, not asserted.
  const double thread_ns = lockstep::platform::snapshot_cost_ns(101);
  const double interrupts_ns = lockstep::platform::interrupt_read_cost_ns(21);
  std::printf("one thread snapshot: %.0f ns; per-CPU interrupt totals: %.0f ns (medians)\n", thread_ns,
              interrupts_ns);
  EXPECT_GT(thread_ns, 0.0);
}

}  // namespace
