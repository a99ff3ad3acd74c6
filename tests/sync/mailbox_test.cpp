// The mailbox (sync/mailbox.hpp): what its ring depth argument promises, a
// self-verifying payload under the graphs whose edges rely on the ring alone,
// back-pressure on the edges that do not, every contract violation detected
// before it could overrun a slot, and the oversubscribed sleep path (four
// participants on one CPU) with the phase invariant.
// (The typed conformance suite runs mailbox too, through the registry, and
// dataflow_test.cpp runs it with the other channels.)
#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <random>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "platform/cpu_relax.hpp"
#include "sync/channel_barrier.hpp"
#include "sync/mailbox.hpp"
#include "sync/phase_run.hpp"
#include "sync/team.hpp"
#include "tests/support/watchdog.hpp"
#include "tests/sync/conformance.hpp"

namespace lockstep::sync {
namespace {

using namespace std::chrono_literals;
using lockstep::testing::kSlowdown;
using lockstep::testing::watchdog;

#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
constexpr std::uint64_t kStages = 2'000;
constexpr std::uint64_t kPhases = 400;
#else
constexpr std::uint64_t kStages = 20'000;
constexpr std::uint64_t kPhases = 2'000;
#endif

// The RK4 graph (kernels/oscillator.hpp): participants 0..3 own D1..D4;
// D1 <- x3, D2 <- x4, D3 <- x1, x2, D4 <- x1, x2.
dependency_graph rk4_graph() {
  dependency_graph graph;
  graph.producers_of = {{2}, {3}, {0, 1}, {0, 1}};
  return graph;
}

// A ring of `participants`: each depends on the one before it, so the path
// back from a consumer to its producer is participants - 1 long.
dependency_graph cycle_graph(unsigned participants) {
  dependency_graph graph;
  graph.producers_of.resize(participants);
  for (unsigned consumer = 0; consumer < participants; ++consumer)
    graph.producers_of[consumer] = {(consumer + participants - 1) % participants};
  return graph;
}

// Word i of producer p's stage s: distinct for every (p, s, i) and exact, so a
// payload mixing two stages (or two producers) cannot pass the check.
double stage_word(unsigned producer, std::uint64_t stage, std::size_t index) {
  return static_cast<double>((stage * 16 + producer) * 32 + index);
}

TEST(MailboxRing, DepthFourCoversTheRk4GraphAndAllToAllWithoutAcknowledgements) {
  const dependency_graph rk4 = rk4_graph();
  mailbox rk4_channel(rk4, 1);
  for (unsigned consumer = 0; consumer < 4; ++consumer)
    for (unsigned producer : rk4.producers_of[consumer])
      EXPECT_FALSE(rk4_channel.acknowledged(producer, consumer)) << producer << " -> " << consumer;
  const dependency_graph all = dependency_graph::all_to_all(8);
  mailbox all_channel(all, 1);
  for (unsigned consumer = 0; consumer < 8; ++consumer)
    for (unsigned producer : all.producers_of[consumer])
      EXPECT_FALSE(all_channel.acknowledged(producer, consumer)) << producer << " -> " << consumer;
}

TEST(MailboxRing, EdgesTheRingCannotCoverUseAcknowledgements) {
  // No path back from the consumer: the producer could lead without bound.
  dependency_graph one_way;
  one_way.producers_of = {{}, {0}};
  EXPECT_TRUE(mailbox(one_way, 1).acknowledged(0, 1));
  // A cycle of 4: path back of 3, kDepth 4 suffices. A cycle of 5: 4 > 3.
  mailbox four(cycle_graph(4), 1);
  mailbox five(cycle_graph(5), 1);
  for (unsigned producer = 0; producer < 4; ++producer) EXPECT_FALSE(four.acknowledged(producer, (producer + 1) % 4));
  for (unsigned producer = 0; producer < 5; ++producer) EXPECT_TRUE(five.acknowledged(producer, (producer + 1) % 5));
}

// Every participant: receive stage s - 1 from its producers (checking every
// word), random delays, publish stage s; drain the last stage. Returns the
// number of wrong words seen.
std::uint64_t run_self_checking_graph(const dependency_graph& graph, std::size_t width) {
  const unsigned participants = graph.participants();
  mailbox channel(graph, width);
  std::atomic<std::uint64_t> wrong{0};
  std::vector<participant> records(participants);
  for (unsigned id = 0; id < participants; ++id) records[id].id = id;
  std_thread_team team(participants);
  team.run([&](unsigned id) {
    participant& self = records[id];
    std::minstd_rand random(id + 11);
    std::vector<double> values(width), received(width);
    std::uint64_t my_wrong = 0;
    auto receive_all = [&](std::uint64_t stage) {
      for (unsigned producer : graph.producers_of[id]) {
        channel.receive(self, producer, stage, received);
        for (std::size_t index = 0; index < width; ++index)
          if (received[index] != stage_word(producer, stage, index)) ++my_wrong;
      }
    };
    for (std::uint64_t stage = 0; stage < kStages; ++stage) {
      if (stage > 0) receive_all(stage - 1);
      // Uneven pace: sometimes a long stall, so that producers run ahead by
      // as much as the graph lets them.
      const unsigned draw = static_cast<unsigned>(random());
      if (draw % 8 == 0)
        for (unsigned spin = draw % 2048; spin > 0; --spin) platform::cpu_relax();
      for (std::size_t index = 0; index < width; ++index) values[index] = stage_word(id, stage, index);
      channel.publish(self, stage, values);
    }
    receive_all(kStages - 1);
    wrong += my_wrong;
  });
  return wrong.load();
}

// 13 doubles: the first line's 7 and a second line, so a stale or mixed
// payload could hide in either line.
TEST(MailboxPayload, Rk4GraphOnTheRingAloneDeliversEveryWordOfEveryStage) {
  watchdog guard(120s * kSlowdown, "mailbox RK4 graph stuck");
  EXPECT_EQ(run_self_checking_graph(rk4_graph(), 13), 0u);
}

TEST(MailboxPayload, AllToAllDeliversEveryWordOfEveryStage) {
  watchdog guard(120s * kSlowdown, "mailbox all-to-all stuck");
  EXPECT_EQ(run_self_checking_graph(dependency_graph::all_to_all(3), 9), 0u);
}

// Every edge of a 6-cycle relies on acknowledgements: back-pressure holds
// a producer whose consumer stalls.
TEST(MailboxPayload, AcknowledgedEdgesHoldTheProducerBack) {
  watchdog guard(120s * kSlowdown, "mailbox 6-cycle stuck");
  EXPECT_EQ(run_self_checking_graph(cycle_graph(6), 3), 0u);
}

// Two consumers of one producer a lap apart: the fast one received stages
// 0..3 and sleeps for stage 4, so slot 0's word holds stage 0 with the waiter
// bit; the slow one then receives stage 0 from that word. The bit belongs to
// the fast consumer's wait, not to an overrun (seen once as a false overrun
// abort: 8 participants on an s-mass chain, 2 CPUs).
TEST(MailboxRing, AWaiterBitSetALapAheadIsNoOverrun) {
  watchdog guard(30s * kSlowdown, "mailbox lap-ahead waiter stuck");
  dependency_graph graph;
  graph.producers_of = {{}, {0}, {0}};  // 0 -> 1, 0 -> 2 (acknowledged: no path back)
  mailbox channel(graph, 1);
  participant producer{0, {}};
  participant fast{1, {}};
  participant slow{2, {}};
  std::atomic<bool> fast_received_first_lap{false};
  double fast_last = 0.0;
  std::thread fast_consumer([&] {
    double value = 0.0;
    for (std::uint64_t stage = 0; stage < mailbox::kDepth; ++stage)
      channel.receive(fast, 0, stage, std::span<double>(&value, 1));
    fast_received_first_lap.store(true);
    channel.receive(fast, 0, mailbox::kDepth, std::span<double>(&value, 1));  // sleeps on slot 0
    fast_last = value;
  });
  for (std::uint64_t stage = 0; stage < mailbox::kDepth; ++stage) {
    const double value = stage_word(0, stage, 0);
    channel.publish(producer, stage, std::span<const double>(&value, 1));
  }
  while (!fast_received_first_lap.load()) std::this_thread::yield();
  // Room for the fast consumer to spin out its budget and set the bit; the
  // test asserts what is received, never how long anything took.
  std::this_thread::sleep_for(100ms);
  double slow_first = -1.0;
  channel.receive(slow, 0, 0, std::span<double>(&slow_first, 1));
  EXPECT_EQ(slow_first, stage_word(0, 0, 0));
  for (std::uint64_t stage = 1; stage < mailbox::kDepth; ++stage) {
    double value = -1.0;
    channel.receive(slow, 0, stage, std::span<double>(&value, 1));
    EXPECT_EQ(value, stage_word(0, stage, 0));
  }
  const double fifth = stage_word(0, mailbox::kDepth, 0);
  channel.publish(producer, mailbox::kDepth, std::span<const double>(&fifth, 1));
  fast_consumer.join();
  EXPECT_EQ(fast_last, fifth);
}

// ---- contract violations: detected before any slot is overwritten ---------

// Each breaks the contract once, single-threaded; the death tests expect the
// channel to stop with its message.
void publish_before_receiving() {
  dependency_graph graph;
  graph.producers_of = {{1}, {0}};
  mailbox channel(graph, 1);
  participant zero{0, {}};
  const double value = 1.0;
  channel.publish(zero, 0, std::span<const double>(&value, 1));
  // Stage 1 before receiving stage 0 from producer 1: kept up, 0 could lap 1's ring.
  channel.publish(zero, 1, std::span<const double>(&value, 1));
}

void receive_from_outside_the_graph() {
  dependency_graph graph;
  graph.producers_of = {{1}, {0}, {0}};
  mailbox channel(graph, 1);
  participant two{2, {}};
  double value = 0.0;
  // 2 depends on 0 only; 1 never waits for 2, so it could lap 2.
  channel.receive(two, 1, 0, std::span<double>(&value, 1));
}

void receive_out_of_order() {
  dependency_graph graph;
  graph.producers_of = {{1}, {0}};
  mailbox channel(graph, 1);
  participant zero{0, {}};
  double value = 0.0;
  channel.receive(zero, 1, 2, std::span<double>(&value, 1));
}

void publish_out_of_order() {
  dependency_graph graph;
  graph.producers_of = {{}, {0}};
  mailbox channel(graph, 1);
  participant zero{0, {}};
  const double value = 1.0;
  channel.publish(zero, 5, std::span<const double>(&value, 1));
}

TEST(MailboxDeathTest, PublishingBeforeReceivingIsDetected) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(publish_before_receiving(), "publishes stage 1 before receiving stage 0 from producer 1");
}

TEST(MailboxDeathTest, ReceivingFromOutsideTheGraphIsDetected) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(receive_from_outside_the_graph(), "not in its dependency graph");
}

TEST(MailboxDeathTest, ReceivingOutOfOrderIsDetected) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(receive_out_of_order(), "receives stage 2 from producer 1, expected 0");
}

TEST(MailboxDeathTest, PublishingOutOfOrderIsDetected) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(publish_out_of_order(), "publishes stage 5, expected 0");
}

// ---- the oversubscribed sleep path ------------------------------------------

// Pins the calling thread to one CPU for the rest of its life.
void pin_to(int cpu) {
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(cpu, &one);
  ASSERT_EQ(pthread_setaffinity_np(pthread_self(), sizeof(one), &one), 0);
}

// Four participants confined to one CPU, as a barrier (every participant
// depends on all others), with the phase invariant of the conformance suite.
// Every kNapEvery phases one participant (each in turn) naps before arriving
// (not runnable: yielding to it cannot help) until a consumer has set the
// waiter bit on its words, so the others use up their yields and sleep on its
// epoch word. Two runs on one barrier: the first settles the regime (the
// census needs every participant enrolled); the second's counters are all from
// the oversubscribed regime.
TEST(MailboxOversubscribed, FourParticipantsOnOneCpuSleepAndKeepThePhaseInvariant) {
  watchdog guard(120s * kSlowdown,
                 "mailbox: four participants on one CPU stuck (a lost wake-up, or a napping participant whose "
                 "consumers never took the sleep path)");
  testing::affinity_restorer restore;
  const int cpu = testing::first_cpu(restore.saved());
  constexpr unsigned kParticipants = 4;
  // The nap lasts until a sleeper shows, not a fixed time: a waiter's 64
  // yields take 20-60 us on an idle CPU, but each yield also hands the CPU to
  // whatever else is runnable there, and under a loaded CI (ctest -j2, a
  // sanitizer) even 20 ms naps ended before the yields ran out. No time bound
  // either (a bound would turn a stalled machine into a missing sleep): every
  // other participant ends up waiting on the napper's word, so a sleeper shows
  // unless the sleep path is broken, and then the watchdog says so.
  constexpr std::uint64_t kNapEvery = 50;  // 8 naps under a sanitizer, 40 otherwise
  channel_barrier<mailbox> barrier(kParticipants);
  sync_counters second_run;
  for (int run = 0; run < 2; ++run) {
    testing::phase_invariant invariant(kParticipants);
    struct alignas(platform::kCacheLine) pinned_flag {
      bool pinned = false;
    };
    std::vector<pinned_flag> flags(kParticipants);
    const phase_run_result result =
        run_phases(barrier, kParticipants, {kPhases, std::chrono::hours(1)}, [&](participant& self, std::uint64_t phase) {
          if (!flags[self.id].pinned) {
            pin_to(cpu);
            flags[self.id].pinned = true;
          }
          invariant.before_arrival(self, phase);
          if (phase % kNapEvery == kNapEvery / 2 && self.id == (phase / kNapEvery) % kParticipants) {
            while (!barrier.channel().sleeper_on(self.id)) std::this_thread::sleep_for(200us);
          }
        });
    EXPECT_EQ(result.phases, kPhases);
    EXPECT_EQ(invariant.violations(), 0u) << invariant.first_violation();
    if (run == 1) second_run = result.total();
  }
  for (unsigned id = 0; id < kParticipants; ++id)
    EXPECT_EQ(barrier.channel().regime(id), wait_regime::oversubscribed) << "participant " << id;
  EXPECT_GT(second_run.futex_waits, 0u) << "the oversubscribed sleep path never ran";
  EXPECT_GT(second_run.futex_wakes, 0u) << "sleepers were woken by nobody";
  EXPECT_GT(second_run.yields, 0u) << "oversubscribed waits yield before they sleep";
  EXPECT_EQ(second_run.timeouts, 0u);
  std::printf("[ mailbox  ] 4 on 1 CPU, second run: futex_waits=%llu futex_wakes=%llu yields=%llu "
              "spins_exhausted=%llu\n",
              static_cast<unsigned long long>(second_run.futex_waits),
              static_cast<unsigned long long>(second_run.futex_wakes),
              static_cast<unsigned long long>(second_run.yields),
              static_cast<unsigned long long>(second_run.spins_exhausted));
}

// With a CPU for each of two participants the regime is dedicated (skipped
// where the test runs on a single CPU).
TEST(MailboxOversubscribed, TwoParticipantsWithACpuEachStayDedicated) {
  if (testing::cpus_available() < 2) GTEST_SKIP() << "needs two CPUs";
  watchdog guard(60s * kSlowdown, "mailbox: two participants stuck");
  testing::affinity_restorer restore;
  channel_barrier<mailbox> barrier(2);
  const phase_run_result result =
      run_phases(barrier, 2, {kPhases, std::chrono::hours(1)}, [](participant&, std::uint64_t) {});
  EXPECT_EQ(result.phases, kPhases);
  EXPECT_EQ(barrier.channel().regime(0), wait_regime::dedicated);
  EXPECT_EQ(barrier.channel().regime(1), wait_regime::dedicated);
}

}  // namespace
}  // namespace lockstep::sync
