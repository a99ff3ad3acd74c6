#pragma once
// spsc_queue: dataflow through Boost.Lockfree's spsc_queue: stage values
// travel as messages, one queue per (producer, consumer) edge of the
// dependency graph.
//
// What it is: for every consumer c and producer p in graph.producers_of[c], a
// boost::lockfree::spsc_queue<double> with room for kDepth stages of `width`
// values. publish() pushes the stage's values into each of the producer's
// consumer queues; receive() pops one stage's values from the (p, c) queue.
// The stage number is implied by FIFO order (the queue carries values only);
// receive checks it against the consumer's own count of what it has received.
//
// Contract: construct from the dependency graph and the number of doubles per
// stage (width). Producer p (participant id p, one thread: the queue's single
// producer) publishes stages 0, 1, 2, ... in order; consumer c (one thread:
// the single consumer of each of its queues) receives each of its producers'
// stages in order. Receiving from a producer outside the graph, or a stage out
// of order, is a contract violation: reported on stderr, then abort.
// Guarantee: a producer may lead a consumer by up to kDepth stages without
// waiting; a full queue makes it wait (back-pressure), so no stage is ever
// overwritten or dropped: an overrun is impossible.
// Progress: Boost's push and pop are wait-free; waiting for room (producer) or
// for a stage (consumer) follows the regime policy of wait_policy.hpp
// (dedicated: spin about a futex round trip, then yield; oversubscribed:
// yield at once).
// Memory ordering: Boost.Lockfree's spsc_queue publishes each element with a
// release store of the write index that the consumer's pop reads with
// acquire: what the producer wrote before publish() is visible after the
// matching receive() returns.
// Counters: spins_exhausted and yields (wait_policy.hpp). futex_waits stays 0
// and that 0 is exact (kCountsFutexWaits): it never sleeps.
#include <boost/lockfree/spsc_queue.hpp>

#include <atomic>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "platform/cache_line.hpp"
#include "sync/channel_rows.hpp"
#include "sync/concepts.hpp"
#include "sync/wait_policy.hpp"

namespace lockstep::sync {

template <std::size_t Depth = 4>
class basic_spsc_queue {
 public:
  static constexpr std::string_view kName = "spsc_queue";
  static constexpr std::string_view kDescription =
      "dataflow: Boost.Lockfree spsc_queue per producer-consumer pair, stage values sent as messages";
  static constexpr primitive_kind kKind = primitive_kind::channel;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = true;
  static constexpr bool kSpinsLong = false;  // spins about a measured futex round trip, then yields (wait_policy.hpp)
  static constexpr bool kVisibleToTsan = true;  // Boost.Lockfree: C++ atomics
  static constexpr std::size_t kDepth = Depth;

  basic_spsc_queue(const dependency_graph& graph, std::size_t width)
      : width_(width),
        participants_(graph.participants()),
        received_(graph.participants()),
        census_(graph.participants()) {
    graph.validate();
    queues_.resize(static_cast<std::size_t>(participants_) * participants_);
    consumers_of_.resize(participants_);
    for (unsigned consumer = 0; consumer < participants_; ++consumer)
      for (unsigned producer : graph.producers_of[consumer]) {
        edge(producer, consumer) = std::make_unique<queue_type>(Depth * width_);
        consumers_of_[producer].push_back(consumer);
      }
    states_ = std::make_unique<participant_state[]>(participants_);
  }
  basic_spsc_queue(const basic_spsc_queue&) = delete;  // participants hold its address
  basic_spsc_queue& operator=(const basic_spsc_queue&) = delete;

  std::size_t width() const noexcept { return width_; }

  void publish(participant& self, std::uint64_t /*stage*/, std::span<const double> values) noexcept {
    assert(values.size() == width_);
    regime_view& regime = states_[self.id].regime;
    census_.enrol(regime);
    for (unsigned consumer : consumers_of_[self.id]) {
      queue_type& queue = *edge(self.id, consumer);
      std::size_t pushed = queue.push(values.data(), values.size());
      if (pushed != values.size()) {
        auto all_pushed = [&] {
          pushed += queue.push(values.data() + pushed, values.size() - pushed);
          return pushed == values.size();
        };
        wait_until(all_pushed, census_.budget(regime), self.counters,
                   [&] { yield_until(all_pushed, self.counters); });
      }
    }
  }

  void receive(participant& self, unsigned producer, std::uint64_t stage, std::span<double> out) noexcept {
    assert(out.size() == width_);
    // relaxed: only this consumer reads and writes its row.
    std::atomic<std::uint64_t>& received = received_.at(self.id, producer);
    const std::uint64_t next = received.load(std::memory_order_relaxed);
    queue_type* queue = edge(producer, self.id).get();
    if (queue == nullptr || stage != next) misuse(self.id, producer, stage, next, queue == nullptr);
    std::size_t popped = queue->pop(out.data(), out.size());
    if (popped != out.size()) {
      auto all_popped = [&] {
        popped += queue->pop(out.data() + popped, out.size() - popped);
        return popped == out.size();
      };
      wait_until(all_popped, census_.budget(states_[self.id].regime), self.counters,
                 [&] { yield_until(all_popped, self.counters); });
    }
    received.store(next + 1, std::memory_order_relaxed);
  }

 private:
  using queue_type = boost::lockfree::spsc_queue<double>;
  // Touched only by its participant's thread.
  struct alignas(platform::kCacheLine) participant_state {
    regime_view regime;  // this participant's wait regime (wait_policy.hpp)
  };

  std::unique_ptr<queue_type>& edge(unsigned producer, unsigned consumer) noexcept {
    return queues_[static_cast<std::size_t>(producer) * participants_ + consumer];
  }

  [[noreturn]] static void misuse(unsigned consumer, unsigned producer, std::uint64_t stage, std::uint64_t next,
                                  bool no_edge) noexcept {
    if (no_edge)
      std::fprintf(stderr, "lockstep::sync::spsc_queue: consumer %u receives from producer %u, which is not in its "
                           "dependency graph\n", consumer, producer);
    else
      std::fprintf(stderr, "lockstep::sync::spsc_queue: consumer %u asked producer %u for stage %llu, expected %llu "
                           "(stages are received in order)\n", consumer, producer,
                   static_cast<unsigned long long>(stage), static_cast<unsigned long long>(next));
    std::abort();
  }

  std::size_t width_;
  unsigned participants_;
  std::vector<std::unique_ptr<queue_type>> queues_;  // [producer * participants + consumer]
  std::vector<std::vector<unsigned>> consumers_of_;
  std::unique_ptr<participant_state[]> states_;
  // received_.at(c, p): the stages of p that consumer c has received (the one
  // it must be asked for next); rows on lines of their own.
  detail::received_table received_;
  regime_census census_;
};

using spsc_queue = basic_spsc_queue<>;
static_assert(graph_channel<spsc_queue>);

}  // namespace lockstep::sync
