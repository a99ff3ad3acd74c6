// The dataflow primitives: the seqlock's torn-read detector with a
// self-verifying payload, and every channel (seqlock, spsc_queue, mailbox)
// under a producer that runs far ahead (back-pressure) and under the RK4
// dependency graph (a producer up to ~3 stages ahead of a consumer it does not
// depend on). mailbox_test.cpp has the mailbox's own tests.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "platform/cpu_relax.hpp"
#include "sync/mailbox.hpp"
#include "sync/seqlock.hpp"
#include "sync/spsc_queue.hpp"
#include "sync/team.hpp"
#include "tests/support/watchdog.hpp"

namespace lockstep::sync {
namespace {

using namespace std::chrono_literals;
using lockstep::testing::kSlowdown;
using lockstep::testing::watchdog;

#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
constexpr std::uint64_t kVersions = 20'000;
constexpr std::uint64_t kStages = 2'000;
#else
constexpr std::uint64_t kVersions = 300'000;
constexpr std::uint64_t kStages = 20'000;
#endif

// Word i of version v: distinct for every (v, i), exactly representable, so a
// snapshot mixing two versions cannot pass the check.
double payload_word(std::uint64_t version, std::size_t index) {
  return static_cast<double>(version * 64 + index);
}

// 13 words: the first line's 7 and a second line, so a torn read can split
// across lines as well as within one.
TEST(SeqlockSlot, NoReaderEverAcceptsATornSnapshot) {
  watchdog guard(120s * kSlowdown, "seqlock torn-read test");
  constexpr std::size_t kWidth = 13;
  seqlock_slot slot(kWidth);
  std::atomic<std::uint64_t> accepted{0}, rejected{0}, bad{0}, backwards{0};

  auto reader = [&] {
    std::vector<double> snapshot(kWidth);
    std::uint64_t last = 0;
    std::uint64_t my_accepted = 0, my_rejected = 0;
    // Until the last version has been read: a reader that only ever
    // overlapped writes (TSan slows readers more than the writer) still ends
    // with one whole snapshot to check.
    while (last != kVersions) {
      const std::uint64_t version = slot.try_read(snapshot);
      if (version == 0) {
        ++my_rejected;
        continue;
      }
      ++my_accepted;
      if (version < last) ++backwards;
      last = version;
      for (std::size_t index = 0; index < kWidth; ++index)
        if (snapshot[index] != payload_word(version, index)) {
          ++bad;
          break;
        }
    }
    accepted += my_accepted;
    rejected += my_rejected;
  };
  {
    std::jthread first_reader(reader), second_reader(reader);
    std::vector<double> values(kWidth);
    for (std::uint64_t version = 1; version <= kVersions; ++version) {
      for (std::size_t index = 0; index < kWidth; ++index) values[index] = payload_word(version, index);
      slot.write(version, values);
      // Give readers windows between writes (and torn reads a chance: the
      // next write may still start in the middle of a copy).
      for (int spin = 0; spin < 16; ++spin) platform::cpu_relax();
    }
  }
  EXPECT_EQ(bad.load(), 0u) << "a reader accepted a snapshot mixing two versions";
  EXPECT_EQ(backwards.load(), 0u) << "a reader saw versions go backwards";
  EXPECT_GT(accepted.load(), 0u);
  std::printf("[ seqlock  ] accepted %llu snapshots, rejected %llu torn or in-progress attempts\n",
              static_cast<unsigned long long>(accepted.load()), static_cast<unsigned long long>(rejected.load()));
  std::vector<double> last(kWidth);
  EXPECT_EQ(slot.try_read(last), kVersions);
}

template <class Channel>
class Channel_ : public ::testing::Test {};
using channels = ::testing::Types<seqlock, spsc_queue, mailbox>;
struct channel_name {
  template <class Channel>
  static std::string GetName(int) {
    return std::string(Channel::kName);
  }
};
TYPED_TEST_SUITE(Channel_, channels, channel_name);

double stage_word(unsigned producer, std::uint64_t stage, std::size_t index) {
  return static_cast<double>((stage * 16 + producer) * 16 + index);
}

// Producer 0 depends on nobody and publishes as fast as it can; consumer 1 is
// slow (random delays). Without back-pressure the producer would lap the
// consumer's ring at once; with it, every stage arrives intact.
TYPED_TEST(Channel_, ProducerFarAheadIsHeldBackNotOverrun) {
  watchdog guard(120s * kSlowdown, std::string(TypeParam::kName) + ": producer/consumer stuck");
  constexpr std::size_t kWidth = 9;
  dependency_graph graph;
  graph.producers_of = {{}, {0}};
  TypeParam channel(graph, kWidth);
  participant producer{0, {}}, consumer{1, {}};
  std::uint64_t wrong = 0;
  {
    std::jthread producing([&] {
      std::vector<double> values(kWidth);
      for (std::uint64_t stage = 0; stage < kStages; ++stage) {
        for (std::size_t index = 0; index < kWidth; ++index) values[index] = stage_word(0, stage, index);
        channel.publish(producer, stage, values);
      }
    });
    std::minstd_rand random(7);
    std::vector<double> received(kWidth);
    for (std::uint64_t stage = 0; stage < kStages; ++stage) {
      for (unsigned spin = static_cast<unsigned>(random()) % 2048; spin > 0; --spin) platform::cpu_relax();
      channel.receive(consumer, 0, stage, received);
      for (std::size_t index = 0; index < kWidth; ++index)
        if (received[index] != stage_word(0, stage, index)) ++wrong;
    }
  }
  EXPECT_EQ(wrong, 0u);
  std::printf("[ %s ] producer waited: spins_exhausted=%llu yields=%llu\n", std::string(TypeParam::kName).c_str(),
              static_cast<unsigned long long>(producer.counters.spins_exhausted),
              static_cast<unsigned long long>(producer.counters.yields));
}

// The RK4 graph (kernels/oscillator.hpp): D1 <- x3, D2 <- x4, D3 <- x1, x2, D4 <- x1, x2,
// participants 0..3 owning D1..D4. At stage s each participant receives its
// producers' stage s - 1, checks them, and publishes its own stage s.
// Participant 0 may run up to ~3 stages ahead of participant 3, which it does
// not depend on.
TYPED_TEST(Channel_, Rk4GraphDeliversEveryStageIntact) {
  watchdog guard(120s * kSlowdown, std::string(TypeParam::kName) + ": RK4 graph stuck");
  dependency_graph graph;
  graph.producers_of = {{2}, {3}, {0, 1}, {0, 1}};
  TypeParam channel(graph, 1);
  std::atomic<std::uint64_t> wrong{0};
  std::vector<participant> participants(4);
  for (unsigned id = 0; id < 4; ++id) participants[id].id = id;
  std_thread_team team(4);
  team.run([&](unsigned id) {
    participant& self = participants[id];
    std::minstd_rand random(id + 1);
    for (std::uint64_t stage = 0; stage < kStages; ++stage) {
      if (stage > 0)
        for (unsigned producer : graph.producers_of[id]) {
          double received = -1;
          channel.receive(self, producer, stage - 1, std::span<double>(&received, 1));
          if (received != stage_word(producer, stage - 1, 0)) ++wrong;
        }
      if (random() % 8 == 0)
        for (unsigned spin = static_cast<unsigned>(random()) % 1024; spin > 0; --spin) platform::cpu_relax();
      const double value = stage_word(id, stage, 0);
      channel.publish(self, stage, std::span<const double>(&value, 1));
    }
    // Drain the last stage so every published stage was received once.
    for (unsigned producer : graph.producers_of[id]) {
      double received = -1;
      channel.receive(self, producer, kStages - 1, std::span<double>(&received, 1));
      if (received != stage_word(producer, kStages - 1, 0)) ++wrong;
    }
  });
  EXPECT_EQ(wrong.load(), 0u);
}

TEST(DependencyGraph, AllToAllAndValidation) {
  const auto graph = dependency_graph::all_to_all(3);
  EXPECT_EQ(graph.participants(), 3u);
  EXPECT_TRUE(graph.depends(0, 2));
  EXPECT_FALSE(graph.depends(1, 1));
  dependency_graph self_edge;
  self_edge.producers_of = {{0}};
  EXPECT_THROW(self_edge.validate(), std::invalid_argument);
  dependency_graph out_of_range;
  out_of_range.producers_of = {{5}, {}};
  EXPECT_THROW(out_of_range.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace lockstep::sync
