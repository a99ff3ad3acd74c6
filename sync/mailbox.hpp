#pragma once
// mailbox: dataflow in which one cache line carries both the flag and the
// data. Each producer owns, per stage slot, a single-writer line holding an
// epoch word (the futex word) and the first payload values; a consumer polls
// that word and, once it shows the stage, reads the values from the same line
// it has just fetched: one line transfer per stage and edge. A consumer waits
// only for the producers it depends on (like seqlock).
//
// Contract: construct from the dependency graph and the number of doubles per
// stage (width). Producer p (participant id p, one thread) publishes stages
// 0, 1, 2, ... in order; consumer c receives each of its producers'
// (graph.producers_of[c]) stages in order, and receives stage s from every one
// of its producers before it publishes stage s + 1 (the RK4 step and
// channel_barrier do: publish s, receive s, publish s + 1, ...). Each
// violation is detected before it could overwrite anything: receiving from a
// producer outside the graph or out of order, or publishing before receiving,
// prints one line on stderr and aborts.
// Guarantee (ring depth): stage s goes to slot s % kDepth, over stage
// s - kDepth. For an edge p -> c, let d be the length of the shortest path
// c -> ... -> p along producer -> consumer edges. When p publishes s, the
// contract gives a chain: p received s - 1 from its predecessor on the path,
// which published s - 1 after receiving s - 2, ..., so c published s - d,
// after receiving s - d - 1 from p. So p's unreceived stages at c are at most
// s - d .. s, d + 1 of them, and the slot p overwrites is free whenever
// kDepth >= d + 1. The channel computes d for every edge at construction;
// edges with kDepth < d + 1, or with no path back at all (a consumer that
// publishes nothing to p's side), get back-pressure instead: p waits for c's
// acknowledgement before it reuses the slot (as seqlock does). So an overrun
// is impossible for contract-keeping callers, and a slot holding any stage
// but the expected one or its predecessor is reported (stderr, abort): never
// a torn read. (Prevention, not a re-check after the payload reads: the word
// changes only after the payload stores (P2 after P1), so a re-check could
// not see an overwrite still in progress; a seqlock's odd store would, at the
// price of a second write to the line per stage.)
//   RK4, two masses on four participants (D1 <- x3, D2 <- x4, D3 and D4 <- x1,
//   x2): the longest such path is 3 (3 -> 1 -> 2 -> 0 for the edge 0 -> 3),
//   so kDepth = 4 needs no acknowledgement; two participants, and
//   channel_barrier's all-to-all graph, have d = 1 for every edge (kDepth 2
//   would do). The s-mass chain's step graphs need no acknowledgement either
//   (checked for 2..24 masses on 2..min(2s, 48) participants: 575 graphs,
//   d <= 3 everywhere); any graph that does is still correct, through them.
// Progress: blocking. A consumer polls its producer's epoch word by the
// regime policy of wait_policy.hpp (dedicated: spin about one futex round
// trip, measured at start-up; oversubscribed: no spin, kOversubscribedYields
// yields), then sleeps on that word (FUTEX_WAIT): the word of the first
// producer it still misses, since it receives its producers one by one. The
// producer wakes it. A producer held back by an acknowledgement waits by
// the same policy, then yields (it has no word to sleep on; the RK4 and
// barrier graphs never make it wait).
// Memory ordering (numbered edges in the bodies): receive() of (p, s)
// happens-after p's publish(s): (P2) release exchange -> (C1)/(C3) acquire
// load. So the payload (relaxed stores (P1), relaxed loads (C2)) is the one
// published, and everything p wrote before publish() is visible after
// receive(). The ring's reuse is ordered by the chain of those same edges
// (the guarantee above), or by (A1) release -> (A2) acquire on acknowledged
// edges. Payload words are atomics: TSan sees no race, and no value is copied
// with memcpy.
// No lost wake-up: the producer's exchange (P2) and the consumer's
// compare-exchange that sets the waiter bit (C4) are read-modify-writes of
// the same word, so one of them comes first in its modification order:
//  * (C4) first: (P2) reads the waiter bit and the producer calls FUTEX_WAKE
//    (P3) after its store. The consumer's FUTEX_WAIT (C5) expects the word
//    with the bit: the kernel compares it atomically with the wake, so either
//    the consumer is already queued (and woken) or it finds the new word and
//    returns at once.
//  * (P2) first: (C4) finds the new word instead of the expected old one and
//    fails; the consumer re-checks (C3) and sees the stage published.
// Across processes (template parameter Storage, sync/storage.hpp): with
// process_shared_storage the rings, the received rows and the regime census
// live in a block several processes map, every process constructs its own
// mailbox over it (its graph, its participant's state), and the futexes are
// the shared kind; distributed/shm_window.hpp runs the RK4 ranks on it. The
// protocol is the same; the registry's `mailbox` is the heap one.
// Counters (self.counters): futex_waits per FUTEX_WAIT (slept or returned at
// once), futex_wakes per FUTEX_WAKE issued, yields and spins_exhausted
// (wait_policy.hpp). timeouts stay 0. Every futex wait is counted.
#include <climits>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "platform/cache_line.hpp"
#include "sync/channel_rows.hpp"
#include "sync/concepts.hpp"
#include "platform/futex.hpp"
#include "sync/storage.hpp"
#include "sync/wait_policy.hpp"

namespace lockstep::sync {

template <std::size_t Depth = 4, class Storage = heap_storage>
class basic_mailbox {
 public:
  static constexpr std::string_view kName = "mailbox";
  static constexpr std::string_view kDescription =
      "dataflow: per producer and stage one line holding an epoch word and the values; release exchange to "
      "publish, acquire poll, futex sleep with a waiter bit; spins or yields by regime";
  static constexpr primitive_kind kKind = primitive_kind::channel;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = true;
  static constexpr bool kSpinsLong = false;  // spins about a measured futex round trip, then sleeps
  static constexpr bool kVisibleToTsan = true;  // C++ atomics and futexes
  static constexpr std::size_t kDepth = Depth;
  static_assert(Depth >= 2, "a producer and a consumer that depend on each other need two slots (see the header)");
  static_assert(Depth % 2 == 0,
                "an even number of slots per producer keeps every 128-byte prefetch pair inside one producer's ring");

  // Payload values in a slot's first line (after the epoch word), and in each
  // further line when the width needs more.
  static constexpr std::size_t kValuesInFirstLine = 7;
  static constexpr std::size_t kValuesPerLine = 8;

  // `storage`: where the shared words go (sync/storage.hpp; the heap unless
  // the caller hands a shared block).
  basic_mailbox(const dependency_graph& graph, std::size_t width, Storage storage = Storage{})
      : storage_(std::move(storage)),
        width_(width),
        participants_(graph.participants()),
        extra_lines_per_slot_(extra_lines(width)),
        rings_(storage_.template make_array<ring>(participants_)),
        extra_lines_(storage_.template make_array<extra_line>(static_cast<std::size_t>(participants_) * Depth *
                                                             extra_lines_per_slot_)),
        states_(std::make_unique<participant_state[]>(participants_)),
        received_(participants_, storage_),
        census_(*storage_.template make<regime_census>(participants_)) {
    graph.validate();
    producers_of_ = graph.producers_of;
    consumers_of_.resize(participants_);
    acknowledging_consumers_.resize(participants_);
    for (unsigned consumer = 0; consumer < participants_; ++consumer)
      for (unsigned producer : graph.producers_of[consumer]) consumers_of_[producer].push_back(consumer);
    for (unsigned producer = 0; producer < participants_; ++producer) {
      for (unsigned consumer : consumers_of_[producer]) {
        const std::size_t back = path_back(producer, consumer);
        if (back == SIZE_MAX || back + 1 > Depth) acknowledging_consumers_[producer].push_back(consumer);
      }
      states_[producer].acknowledged = !acknowledging_consumers_[producer].empty();
    }
    if (!storage_.initialises()) return;  // another process wrote the first values
    // Slot j's word starts as if it held stage j - Depth (its predecessor in
    // the ring): the first stage to land there then looks like any other.
    for (unsigned producer = 0; producer < participants_; ++producer)
      for (std::size_t slot = 0; slot < Depth; ++slot)
        first(producer, slot).epoch.store(word_of(static_cast<std::uint64_t>(slot) - Depth),
                                          std::memory_order_relaxed);  // published by the threads' start
    // A consumer's row: the next stage it expects from each producer; a
    // producer it does not depend on gets a value no stage ever equals.
    for (unsigned consumer = 0; consumer < participants_; ++consumer)
      for (unsigned producer = 0; producer < participants_; ++producer)
        if (!graph.depends(consumer, producer))
          received_.at(consumer, producer).store(kNotAProducer, std::memory_order_relaxed);
  }
  basic_mailbox(const basic_mailbox&) = delete;  // participants hold its address
  basic_mailbox& operator=(const basic_mailbox&) = delete;

  std::size_t width() const noexcept { return width_; }
  // The shared words' bytes (for a shared block the same arguments need).
  std::size_t storage_bytes() const noexcept { return storage_.bytes(); }

  // Whether the edge producer -> consumer relies on acknowledgements (false:
  // the ring alone keeps it safe; see the header). For tests and curiosity.
  bool acknowledged(unsigned producer, unsigned consumer) const noexcept {
    for (unsigned candidate : acknowledging_consumers_[producer])
      if (candidate == consumer) return true;
    return false;
  }

  // Whether a consumer has set the waiter bit on one of `producer`'s slots
  // (it is asleep on that word, or about to be). For tests: a producer that
  // stalls on purpose can wait until its consumers took the sleep path.
  bool sleeper_on(unsigned producer) const noexcept {
    for (std::size_t slot = 0; slot < Depth; ++slot)
      // relaxed: a snapshot for a test's pacing; nothing is read through it.
      if ((first(producer, slot).epoch.load(std::memory_order_relaxed) & kWaiterBit) != 0) return true;
    return false;
  }

  // The regime participant `id` waits in (wait_policy.hpp): dedicated until
  // every participant has enrolled. Read it only while that participant is
  // not running (after the team joined): for tests.
  wait_regime regime(unsigned id) const noexcept { return states_[id].regime.regime; }

  void publish(participant& self, std::uint64_t stage, std::span<const double> values) noexcept {
    participant_state& mine = states_[self.id];
    census_.enrol(mine.regime);
    if (stage != mine.next_publish) [[unlikely]]
      misuse(violation::out_of_order_publish, self.id, self.id, stage, mine.next_publish);
    // The ring's guarantee needs every stage before this one received from
    // every producer of ours (the header's chain). relaxed: our own row.
    for (unsigned producer : producers_of_[self.id]) {
      const std::uint64_t received = received_.at(self.id, producer).load(std::memory_order_relaxed);
      if (received < stage) [[unlikely]]
        misuse(violation::publish_before_receive, self.id, producer, stage, received);
    }
    if (mine.acknowledged && stage >= Depth) [[unlikely]]
      wait_for_acknowledgements(self, mine, stage - Depth + 1);

    first_line& line = first(self.id, stage % Depth);
    write_payload(self.id, stage % Depth, values);
    // (P2) release: pairs with the consumers' acquire loads (C1) and (C3): a
    // consumer that sees this stage's word reads this stage's payload (P1).
    // An exchange, not a store: it must read the waiter bit that a consumer's
    // (C4) may have set, atomically with replacing the word (the no-lost-
    // wake-up argument in the header).
    const std::uint32_t old = line.epoch.exchange(word_of(stage), std::memory_order_release);
    if ((old & ~kWaiterBit) != word_of(stage - Depth)) [[unlikely]]
      detail::channel_overrun(kName, self.id, stage - Depth, version_of(old));
    if ((old & kWaiterBit) != 0) {
      // (P3) after (P2): see the header.
      platform::futex_wake<Storage::kScope>(line.epoch, INT_MAX);
      ++self.counters.futex_wakes;
    }
    mine.next_publish = stage + 1;
  }

  void receive(participant& self, unsigned producer, std::uint64_t stage, std::span<double> out) noexcept {
    // relaxed: only this consumer writes its row (the release below is for
    // producers that read it).
    std::atomic<std::uint64_t>& received = received_.at(self.id, producer);
    const std::uint64_t expected = received.load(std::memory_order_relaxed);
    if (stage != expected) [[unlikely]] {
      misuse(expected == kNotAProducer ? violation::not_a_producer : violation::out_of_order_receive, self.id,
             producer, stage, expected);
    }
    first_line& line = first(producer, stage % Depth);
    // (C1) acquire: pairs with (P2).
    if (line.epoch.load(std::memory_order_acquire) != word_of(stage)) [[unlikely]]
      wait_for_stage(self, line, producer, stage);
    read_payload(producer, stage % Depth, out);
    // (A1) release: "received up to stage". Pairs with (A2) on acknowledged
    // edges: our payload reads (C2) happen-before the producer reuses the slot.
    received.store(stage + 1, std::memory_order_release);
  }

 private:
  // The epoch word: bits 31..1 hold the stage's version (stage + 1, modulo
  // 2^31; only equality is ever tested, between a stage and its predecessor in
  // the slot, kDepth apart), bit 0 says a consumer sleeps on the word.
  static constexpr std::uint32_t kWaiterBit = 1;
  static constexpr std::uint32_t word_of(std::uint64_t stage) noexcept {
    return static_cast<std::uint32_t>((stage + 1) << 1);
  }
  static constexpr std::uint64_t version_of(std::uint32_t word) noexcept { return word >> 1; }
  static constexpr std::uint64_t kNotAProducer = std::numeric_limits<std::uint64_t>::max();

  struct alignas(platform::kCacheLine) first_line {
    std::atomic<std::uint32_t> epoch{0};
    std::atomic<double> values[kValuesInFirstLine]{};
  };
  struct alignas(platform::kCacheLine) extra_line {
    std::atomic<double> values[kValuesPerLine]{};
  };
  // One producer's ring of first lines, starting on a prefetch pair: with an
  // even kDepth no 128-byte pair holds two producers' lines.
  struct alignas(platform::kPrefetchPair) ring {
    first_line slots[Depth];
  };
  static_assert(sizeof(ring) == Depth * platform::kCacheLine, "a ring is its slots' lines, nothing more");
  static_assert(sizeof(first_line) == platform::kCacheLine,
                "the epoch word and the first values fill exactly one line: one transfer carries flag and data");
  static_assert(offsetof(first_line, values) == sizeof(double),
                "the first value sits right after the epoch word (its padding), on the same line");
  static_assert(sizeof(extra_line) == platform::kCacheLine, "a further payload line is exactly one cache line");
  static_assert(std::atomic<double>::is_always_lock_free && std::atomic<std::uint32_t>::is_always_lock_free,
                "payload and epoch words must be lock-free atomics");

  // Per participant, touched only by its own thread (its producer side and
  // its consumer side).
  struct alignas(platform::kPrefetchPair) participant_state {
    std::uint64_t next_publish = 0;      // the stage publish() must be called with next
    std::uint64_t all_acknowledged = 0;  // cached minimum over acknowledging consumers
    bool acknowledged = false;           // some consumer of ours is on an acknowledged edge
    regime_view regime;                  // wait_policy.hpp
  };
  static_assert(sizeof(participant_state) == platform::kPrefetchPair,
                "one prefetch pair per participant: a neighbour's prefetch never pulls our line");

  static std::size_t extra_lines(std::size_t width) noexcept {
    return width <= kValuesInFirstLine ? 0 : (width - kValuesInFirstLine + kValuesPerLine - 1) / kValuesPerLine;
  }
  first_line& first(unsigned producer, std::size_t slot) const noexcept {
    return rings_[producer].slots[slot];
  }
  extra_line* extras(unsigned producer, std::size_t slot) const noexcept {
    return extra_lines_ + (static_cast<std::size_t>(producer) * Depth + slot) * extra_lines_per_slot_;
  }

  void write_payload(unsigned producer, std::size_t slot, std::span<const double> values) noexcept {
    first_line& line = first(producer, slot);
    const std::size_t in_first = width_ < kValuesInFirstLine ? width_ : kValuesInFirstLine;
    // (P1) relaxed: ordered before the word by (P2).
    for (std::size_t index = 0; index < in_first; ++index)
      line.values[index].store(values[index], std::memory_order_relaxed);
    extra_line* rest = extras(producer, slot);
    for (std::size_t index = in_first; index < width_; ++index) {
      const std::size_t offset = index - kValuesInFirstLine;
      // (P1) relaxed, as above.
      rest[offset / kValuesPerLine].values[offset % kValuesPerLine].store(values[index], std::memory_order_relaxed);
    }
  }

  void read_payload(unsigned producer, std::size_t slot, std::span<double> out) const noexcept {
    const first_line& line = first(producer, slot);
    const std::size_t in_first = width_ < kValuesInFirstLine ? width_ : kValuesInFirstLine;
    // (C2) relaxed: ordered after the word by (C1)/(C3).
    for (std::size_t index = 0; index < in_first; ++index)
      out[index] = line.values[index].load(std::memory_order_relaxed);
    const extra_line* rest = extras(producer, slot);
    for (std::size_t index = in_first; index < width_; ++index) {
      const std::size_t offset = index - kValuesInFirstLine;
      // (C2) relaxed, as above.
      out[index] = rest[offset / kValuesPerLine].values[offset % kValuesPerLine].load(std::memory_order_relaxed);
    }
  }

  // The slow path of receive: poll by the regime's budget, then sleep.
  void wait_for_stage(participant& self, first_line& line, unsigned producer, std::uint64_t stage) noexcept {
    const std::uint32_t wanted = word_of(stage);
    const std::uint32_t previous = word_of(stage - Depth);
    // (C3) acquire: pairs with (P2). Anything but the stage or its
    // predecessor in the slot is an overrun (see the header). The waiter bit
    // is ignored: it may sit on our stage's word too, set by another consumer
    // of this producer that is a lap ahead of us (it received this stage and
    // now waits for stage + kDepth in the same slot; the ring's guarantee
    // allows the skew). Read with the bit, such a word once looked like an
    // overrun to the slower consumer (8 participants on an s-mass chain, 2 CPUs).
    auto published = [&] {
      const std::uint32_t word = line.epoch.load(std::memory_order_acquire) & ~kWaiterBit;
      if (word == wanted) return true;
      if (word != previous) [[unlikely]]
        detail::channel_overrun(kName, producer, stage, version_of(word) - 1);
      return false;
    };
    auto sleep = [&] {
      while (!published()) {
        // (C4) relaxed: the bit only steers the producer's (P3); what we read
        // after waking is ordered by (C3). Fails if the word changed (the
        // stage was published, or another consumer set the bit first): re-check.
        std::uint32_t expected = previous;
        if (!line.epoch.compare_exchange_strong(expected, previous | kWaiterBit, std::memory_order_relaxed,
                                                std::memory_order_relaxed) &&
            expected != (previous | kWaiterBit))
          continue;
        // (C5) sleeps only while the word still holds previous | kWaiterBit.
        platform::futex_wait<Storage::kScope>(line.epoch, previous | kWaiterBit);
        ++self.counters.futex_waits;
      }
    };
    wait_until(published, census_.budget(states_[self.id].regime), self.counters, sleep);
  }

  // The slow path of publish on an acknowledged edge: every acknowledging
  // consumer must have received stage `needed` - 1 (the slot's occupant).
  void wait_for_acknowledgements(participant& self, participant_state& mine, std::uint64_t needed) noexcept {
    if (mine.all_acknowledged >= needed) return;
    auto acknowledged = [&] {
      std::uint64_t slowest = std::numeric_limits<std::uint64_t>::max();
      for (unsigned consumer : acknowledging_consumers_[self.id]) {
        // (A2) acquire: pairs with the consumer's (A1).
        const std::uint64_t received = received_.at(consumer, self.id).load(std::memory_order_acquire);
        slowest = received < slowest ? received : slowest;
      }
      mine.all_acknowledged = slowest;
      return slowest >= needed;
    };
    wait_until(acknowledged, census_.budget(mine.regime), self.counters,
               [&] { yield_until(acknowledged, self.counters); });
  }

  // The length d of the shortest path consumer -> ... -> producer along
  // producer -> consumer edges (SIZE_MAX if there is none): the producer's
  // lead over that consumer is at most d + 1 stages (see the header).
  std::size_t path_back(unsigned producer, unsigned consumer) const {
    std::vector<std::size_t> distance(participants_, SIZE_MAX);
    std::vector<unsigned> frontier{consumer};
    distance[consumer] = 0;
    for (std::size_t head = 0; head < frontier.size(); ++head) {
      const unsigned from = frontier[head];
      for (unsigned next : consumers_of_[from])
        if (distance[next] == SIZE_MAX) {
          distance[next] = distance[from] + 1;
          frontier.push_back(next);
        }
    }
    return distance[producer];
  }

  enum class violation { out_of_order_publish, publish_before_receive, not_a_producer, out_of_order_receive };
  [[noreturn]] static void misuse(violation what, unsigned participant_id, unsigned producer, std::uint64_t stage,
                                  std::uint64_t found) noexcept {
    const auto stage_number = static_cast<unsigned long long>(stage);
    const auto found_number = static_cast<unsigned long long>(found);
    std::fprintf(stderr, "lockstep::sync::mailbox: participant %u ", participant_id);
    switch (what) {
      case violation::out_of_order_publish:
        std::fprintf(stderr, "publishes stage %llu, expected %llu (stages are published in order)", stage_number,
                     found_number);
        break;
      case violation::publish_before_receive:
        std::fprintf(stderr, "publishes stage %llu before receiving stage %llu from producer %u (received %llu)",
                     stage_number, stage_number - 1, producer, found_number);
        break;
      case violation::not_a_producer:
        std::fprintf(stderr, "receives stage %llu from producer %u, which is not in its dependency graph",
                     stage_number, producer);
        break;
      case violation::out_of_order_receive:
        std::fprintf(stderr, "receives stage %llu from producer %u, expected %llu (stages are received in order)",
                     stage_number, producer, found_number);
        break;
    }
    std::fprintf(stderr, "; that could overrun a slot, so the channel stops (sync/mailbox.hpp, contract)\n");
    std::abort();
  }

  Storage storage_;  // first: the members below take their shared words from it
  std::size_t width_;
  unsigned participants_;
  std::size_t extra_lines_per_slot_;
  ring* rings_;              // [producer], in storage_
  extra_line* extra_lines_;  // [(producer * Depth + slot) * extra_lines_per_slot_ + line], in storage_
  std::unique_ptr<participant_state[]> states_;  // this process's own: each touched by its participant only
  std::vector<std::vector<unsigned>> producers_of_;
  std::vector<std::vector<unsigned>> consumers_of_;
  std::vector<std::vector<unsigned>> acknowledging_consumers_;  // per producer: edges the ring alone does not cover
  detail::received_table received_;  // rows in storage_
  regime_census& census_;            // in storage_
};

using mailbox = basic_mailbox<>;
static_assert(graph_channel<mailbox>);

// The mailbox for processes that map one block (distributed/shm_window.hpp).
using process_shared_mailbox = basic_mailbox<4, process_shared_storage>;

}  // namespace lockstep::sync
