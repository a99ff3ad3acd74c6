#pragma once
// Test-only primitives with one deliberate fault each, and the same primitive
// without it: the negative and positive controls of the two oracles, the
// conformance invariant (tests/sync/conformance.hpp) and the bitwise check
// (tests/matrix/matrix_cases.hpp). An oracle that passes a faulty primitive
// catches nothing; one that fails the fault-free twin fails for a reason
// other than the fault.
//
//   counting_barrier<barrier_fault::none>           a correct barrier: each
//       participant counts its arrivals on its own line (release); a leaver
//       waits until every participant's count reaches the phase (acquire).
//   counting_barrier<barrier_fault::early_release>  releases a phase once N - 1
//       participants have arrived: the wait skips the last participant's
//       count (an off-by-one in the loop bound).
//   stage_channel<channel_fault::none>              a correct stage_channel:
//       per producer a ring of two slots (values, then the stage's flag with
//       release; the consumer acquires the flag, reads, acknowledges), with
//       back-pressure on the acknowledgements.
//   stage_channel<channel_fault::flag_before_data>  publishes a stage's flag
//       before its values.
//   stage_channel<channel_fault::stage_swap>        a consumer reads the other
//       slot of the ring: the values of a neighbouring stage, not the one
//       whose flag it waited for (the stages reordered).
//
// Each fault is made certain, not left to the scheduler, so that a negative
// control fails in every run:
//  * early_release: participant N - 1 is held inside its first arrival until
//    every other participant has arrived at phase 2, so the others leave
//    phases 0 and 1 without it every time (needs at least 3 phases: the
//    conformance scenario runs 30 or more, an RK4 step is 4);
//  * flag_before_data: a stage's values are written only at the producer's
//    next publish, after every consumer has acknowledged the stage, so a
//    consumer always reads the slot before the values land (it finds the
//    values of two stages earlier, or the initial NaN);
//  * stage_swap: the other slot holds the stage before (or, once the producer
//    is ahead, after): never the one asked for, and NaN at the first stage.
//
// All of them wait with std::atomic wait/notify (futex), so oversubscribed
// runs do not stall for timeslices. The faulty ones are data races by design:
// never run them under ThreadSanitizer.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "platform/cache_line.hpp"
#include "sync/concepts.hpp"

namespace lockstep::testing::faulty {

enum class barrier_fault { none, early_release };
enum class channel_fault { none, flag_before_data, stage_swap };

template <barrier_fault Fault>
class counting_barrier {
 public:
  static constexpr std::string_view kName = Fault == barrier_fault::none ? "counting_barrier" : "early_release";
  static constexpr std::string_view kDescription =
      Fault == barrier_fault::none ? "test-only: per-participant arrival counts, correct"
                                   : "test-only: releases a phase at N - 1 arrivals";
  static constexpr sync::primitive_kind kKind = sync::primitive_kind::barrier;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = false;
  static constexpr bool kSpinsLong = false;
  static constexpr bool kVisibleToTsan = true;

  explicit counting_barrier(unsigned participants)
      : participants_(participants), arrivals_(std::make_unique<arrival_line[]>(participants)) {}
  counting_barrier(const counting_barrier&) = delete;  // participants hold its address
  counting_barrier& operator=(const counting_barrier&) = delete;

  void arrive_and_wait(sync::participant& self) noexcept {
    arrival_line& mine = arrivals_[self.id];
    const std::uint64_t arrived = mine.count.load(std::memory_order_relaxed) + 1;  // our own line
    // (1) release: everything this participant wrote before arriving
    // happens-before the leavers that acquire this count (2).
    mine.count.store(arrived, std::memory_order_release);
    mine.count.notify_all();
    const unsigned waited_for = Fault == barrier_fault::early_release ? participants_ - 1 : participants_;
    if (Fault == barrier_fault::early_release && self.id == participants_ - 1 && arrived == 1)
      wait_for_counts(waited_for, 3);  // the others at phase 2: they left phases 0 and 1 without us
    wait_for_counts(waited_for, arrived);
  }

 private:
  struct alignas(platform::kCacheLine) arrival_line {
    std::atomic<std::uint64_t> count{0};  // phases this participant has arrived at
  };

  void wait_for_counts(unsigned first_participants, std::uint64_t at_least) noexcept {
    for (unsigned other = 0; other < first_participants; ++other) {
      std::atomic<std::uint64_t>& count = arrivals_[other].count;
      // (2) acquire: pairs with (1).
      for (std::uint64_t seen = count.load(std::memory_order_acquire); seen < at_least;
           seen = count.load(std::memory_order_acquire))
        count.wait(seen, std::memory_order_acquire);
    }
  }

  unsigned participants_;
  std::unique_ptr<arrival_line[]> arrivals_;
};

template <channel_fault Fault>
class stage_channel {
 public:
  static constexpr std::string_view kName = Fault == channel_fault::none               ? "stage_channel"
                                            : Fault == channel_fault::flag_before_data ? "flag_before_data"
                                                                                       : "stage_swap";
  static constexpr std::string_view kDescription =
      Fault == channel_fault::none               ? "test-only: two-slot ring per producer, acknowledged, correct"
      : Fault == channel_fault::flag_before_data ? "test-only: publishes a stage's flag before its values"
                                                 : "test-only: a consumer reads the other slot of the ring";
  static constexpr sync::primitive_kind kKind = sync::primitive_kind::channel;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = false;
  static constexpr bool kSpinsLong = false;
  static constexpr bool kVisibleToTsan = true;

  stage_channel(const sync::dependency_graph& graph, std::size_t width)
      : width_(width), participants_(graph.participants()), consumers_of_(participants_) {
    graph.validate();
    for (unsigned consumer = 0; consumer < participants_; ++consumer)
      for (unsigned producer : graph.producers_of[consumer]) consumers_of_[producer].push_back(consumer);
    producers_ = std::make_unique<producer_state[]>(participants_);
    for (unsigned producer = 0; producer < participants_; ++producer) {
      producer_state& state = producers_[producer];
      for (slot& each : state.slots) each.values = std::make_unique<std::atomic<double>[]>(width_);
      for (slot& each : state.slots)
        for (std::size_t value = 0; value < width_; ++value)
          each.values[value].store(std::numeric_limits<double>::quiet_NaN(), std::memory_order_relaxed);
      state.received = std::make_unique<received_line[]>(participants_);
      state.held.assign(width_, 0.0);
    }
  }
  stage_channel(const stage_channel&) = delete;  // participants hold its address
  stage_channel& operator=(const stage_channel&) = delete;

  void publish(sync::participant& self, std::uint64_t stage, std::span<const double> values) noexcept {
    producer_state& mine = producers_[self.id];
    if constexpr (Fault == channel_fault::flag_before_data) {
      // The previous stage's values land only now, after every consumer has
      // acknowledged that stage: too late for all of them.
      if (stage > 0) {
        wait_for_acknowledgements(mine, self.id, stage);
        write_values(mine.slots[(stage - 1) % 2], mine.held);
      }
      std::copy(values.begin(), values.end(), mine.held.begin());
      publish_flag(mine.slots[stage % 2], stage);
    } else {
      // Slot stage % 2 held stage - 2: every consumer must have received it.
      if (stage > 1) wait_for_acknowledgements(mine, self.id, stage - 1);
      write_values(mine.slots[stage % 2], values);
      publish_flag(mine.slots[stage % 2], stage);
    }
  }

  void receive(sync::participant& self, unsigned producer, std::uint64_t stage, std::span<double> received) noexcept {
    producer_state& theirs = producers_[producer];
    std::atomic<std::uint64_t>& flag = theirs.slots[stage % 2].flag;
    // (2) acquire: pairs with the flag's release (1).
    for (std::uint64_t seen = flag.load(std::memory_order_acquire); seen < stage + 1;
         seen = flag.load(std::memory_order_acquire))
      flag.wait(seen, std::memory_order_acquire);
    const slot& source = theirs.slots[Fault == channel_fault::stage_swap ? (stage + 1) % 2 : stage % 2];
    for (std::size_t value = 0; value < received.size(); ++value)
      received[value] = source.values[value].load(std::memory_order_relaxed);  // ordered by (2)
    // (3) release: our reads of the slot happen-before the producer's reuse
    // of it, which acquires this count (4).
    std::atomic<std::uint64_t>& acknowledged = theirs.received[self.id].stages;
    acknowledged.store(stage + 1, std::memory_order_release);
    acknowledged.notify_all();
  }

 private:
  struct alignas(platform::kCacheLine) slot {
    std::atomic<std::uint64_t> flag{0};  // 1 + the stage whose values the slot holds; 0: none yet
    std::unique_ptr<std::atomic<double>[]> values;
  };
  struct alignas(platform::kCacheLine) received_line {
    std::atomic<std::uint64_t> stages{0};  // stages this consumer has received from the producer
  };
  struct producer_state {
    slot slots[2];
    std::unique_ptr<received_line[]> received;  // indexed by consumer
    std::vector<double> held;  // flag_before_data: the values not yet written
  };

  void write_values(slot& target, std::span<const double> values) noexcept {
    for (std::size_t value = 0; value < values.size(); ++value)
      target.values[value].store(values[value], std::memory_order_relaxed);  // ordered by (1)
  }
  static void publish_flag(slot& target, std::uint64_t stage) noexcept {
    // (1) release: the values written before it (and, with flag_before_data,
    // not the ones written after) are visible to a consumer that acquires it.
    target.flag.store(stage + 1, std::memory_order_release);
    target.flag.notify_all();
  }
  // Until every consumer of `producer` has received `stages` stages.
  void wait_for_acknowledgements(producer_state& mine, unsigned producer, std::uint64_t stages) noexcept {
    for (unsigned consumer : consumers_of_[producer]) {
      std::atomic<std::uint64_t>& acknowledged = mine.received[consumer].stages;
      // (4) acquire: pairs with (3).
      for (std::uint64_t seen = acknowledged.load(std::memory_order_acquire); seen < stages;
           seen = acknowledged.load(std::memory_order_acquire))
        acknowledged.wait(seen, std::memory_order_acquire);
    }
  }

  std::size_t width_;
  unsigned participants_;
  std::vector<std::vector<unsigned>> consumers_of_;
  std::unique_ptr<producer_state[]> producers_;
};

static_assert(sync::registered_primitive<counting_barrier<barrier_fault::none>>);
static_assert(sync::registered_primitive<counting_barrier<barrier_fault::early_release>>);
static_assert(sync::registered_primitive<stage_channel<channel_fault::none>>);
static_assert(sync::registered_primitive<stage_channel<channel_fault::flag_before_data>>);
static_assert(sync::registered_primitive<stage_channel<channel_fault::stage_swap>>);

}  // namespace lockstep::testing::faulty
