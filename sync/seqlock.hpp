#pragma once
// seqlock: dataflow through sequence locks. Each producer publishes its stage
// values into a slot guarded by a sequence counter (Boehm's recipe,
// "Can seqlocks get along with programming language memory models?", 2012);
// a consumer waits only for the producers it depends on.
//
// Two types:
//  * seqlock_slot: one single-writer sequence lock over `width` doubles. The
//    writer never waits; a reader retries until it has read one version whole.
//  * seqlock (the stage_channel): per producer a ring of kDepth slots, stage s
//    in slot s % kDepth, plus back-pressure so that a slot is never rewritten
//    before every consumer of that producer has received the stage it holds.
//
// seqlock_slot contract: one writer thread calls write() with strictly
// increasing versions >= 1 (0 means "never written"); any number of reader
// threads call try_read() / version(). Progress: write is wait-free; a read
// is obstruction-free (it retries while a write overlaps it).
// Memory ordering (numbered edges in the bodies):
//  * (W4) release / (R1) acquire: a reader that sees version v completed reads
//    v's payload, and everything the writer did before write(v).
//  * (W2) release fence / (R3) acquire fence: if a reader's payload loads (R2)
//    saw any value of a later write, its second sequence load (R4) sees at
//    least that write's odd sequence (W1), so the torn read is detected.
//  Payload words are relaxed atomics: a concurrent read of a word being
//  written is not a data race, and nothing is copied with memcpy (which would
//  be one: rigtorp's Seqlock copies its payload that way, a data race outside
//  x86 that ThreadSanitizer flags).
//  ThreadSanitizer does not model standalone fences; under __SANITIZE_THREAD__
//  the payload stores become release and the payload loads acquire, which
//  give TSan the same edges as (W2)/(R3) (stronger and slower, TSan builds
//  only).
//
// seqlock (channel) contract: construct from the dependency graph and the
// number of doubles per stage (width). Producer p (participant id p, one
// thread) calls publish(self, stage, values) for stages 0, 1, 2, ... in order;
// consumer c calls receive(self, p, stage, out) for each producer p it
// depends on (graph.producers_of[c]), stages in order. Receiving from a
// producer not in the graph is a contract violation: the producer does not
// wait for that consumer, and an overrun is then detected and aborts.
// Guarantee: a producer may lead any of its consumers by up to kDepth - 1
// stages without waiting (the RK4 graph needs about 3: kDepth = 4); before it
// would overwrite the stage a consumer has not yet received, it waits
// (back-pressure). An overrun is therefore impossible for callers that keep
// the contract, and detected (a message on stderr, then abort) for those who
// do not: never silent.
// Progress: blocking by waiting: a consumer waits for its producer's stage, a
// producer (rarely) for its slowest consumer; both wait by the regime policy
// of wait_policy.hpp (dedicated: spin about a futex round trip, then yield;
// oversubscribed: yield at once), so oversubscription does not stall them.
// Counters: spins_exhausted and yields (wait_policy.hpp), for both waits.
// futex_waits stays 0 and that 0 is exact (kCountsFutexWaits): it never sleeps.
// Memory ordering: receive() of (p, s) happens-after p's publish(s) ((W4) -> (R1)),
// so what p wrote before publishing is visible after receiving. Consumer
// acknowledgements: (B1) release store of "received up to s" pairs with the
// producer's (B2) acquire load before it rewrites that slot, so the consumer's
// reads of the old stage happen-before the new stage is written.
#include <algorithm>
#include <atomic>
#include <cassert>
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
#include "sync/wait_policy.hpp"

namespace lockstep::sync {

namespace detail {
#if defined(__SANITIZE_THREAD__)
// TSan: see the header. Fences are not modelled (GCC warns -Wtsan), so the
// payload carries their edges: a release payload store orders (W1) before it,
// an acquire payload load orders (R4) after it, exactly what (W2)/(R3) give.
inline constexpr std::memory_order kPayloadStore = std::memory_order_release;
inline constexpr std::memory_order kPayloadLoad = std::memory_order_acquire;
inline void seqlock_fence(std::memory_order) noexcept {}
#else
inline constexpr std::memory_order kPayloadStore = std::memory_order_relaxed;
inline constexpr std::memory_order kPayloadLoad = std::memory_order_relaxed;
inline void seqlock_fence(std::memory_order order) noexcept { std::atomic_thread_fence(order); }
#endif
}  // namespace detail

class seqlock_slot {
 public:
  // The sequence word and the first payload words share the slot's first line
  // (one line transfer per read for small widths); more words take more lines.
  static constexpr std::size_t kValuesInFirstLine = 7;
  static constexpr std::size_t kValuesPerLine = 8;

  explicit seqlock_slot(std::size_t width)
      : width_(width),
        first_(std::make_unique<first_line>()),
        extra_(std::make_unique<extra_line[]>(extra_lines(width))) {}
  seqlock_slot(const seqlock_slot&) = delete;  // readers hold its address
  seqlock_slot& operator=(const seqlock_slot&) = delete;

  std::size_t width() const noexcept { return width_; }

  // Single writer. version >= 1, strictly increasing.
  void write(std::uint64_t version, std::span<const double> values) noexcept {
    assert(values.size() == width_ && version >= 1);
    // (W1) relaxed: odd = write in progress. Ordered before the payload by (W2).
    first().sequence.store(2 * version - 1, std::memory_order_relaxed);
    // (W2) release fence: pairs with the reader's acquire fence (R3): a reader
    // whose payload load saw a value stored below also sees (W1) or later at (R4).
    // (Under TSan the payload stores are release instead: same edge, one TSan sees.)
    detail::seqlock_fence(std::memory_order_release);
    for (std::size_t index = 0; index < width_; ++index)
      // relaxed (release under TSan): ordered by (W2) and (W4).
      word(index).store(values[index], detail::kPayloadStore);
    // (W4) release: pairs with (R1): a reader that sees 2v reads v's payload.
    first().sequence.store(2 * version, std::memory_order_release);
  }

  // The last completed version (0 if none). (R1) acquire, pairs with (W4).
  std::uint64_t version() const noexcept { return first().sequence.load(std::memory_order_acquire) / 2; }

  // One attempt: copies the payload into `out` and returns the version it
  // belongs to, or 0 if a write was in progress or overlapped the copy
  // (torn: `out` is garbage then; try again).
  std::uint64_t try_read(std::span<double> out) const noexcept {
    assert(out.size() == width_);
    // (R1) acquire: pairs with (W4).
    const std::uint64_t before = first().sequence.load(std::memory_order_acquire);
    if (before % 2 != 0 || before == 0) return 0;
    for (std::size_t index = 0; index < width_; ++index)
      // (R2) relaxed (acquire under TSan): validated by (R3)/(R4).
      out[index] = word(index).load(detail::kPayloadLoad);
    // (R3) acquire fence: pairs with (W2), see there. (Under TSan the payload
    // loads are acquire instead.)
    detail::seqlock_fence(std::memory_order_acquire);
    // (R4) relaxed: ordered after (R2) by (R3).
    const std::uint64_t after = first().sequence.load(std::memory_order_relaxed);
    return after == before ? before / 2 : 0;
  }

 private:
  struct alignas(platform::kCacheLine) first_line {
    std::atomic<std::uint64_t> sequence{0};
    std::atomic<double> values[kValuesInFirstLine]{};
  };
  struct alignas(platform::kCacheLine) extra_line {
    std::atomic<double> values[kValuesPerLine]{};
  };
  static_assert(sizeof(first_line) == platform::kCacheLine, "the sequence and the first values fill one line");
  static_assert(sizeof(extra_line) == platform::kCacheLine, "an extra payload line is exactly one cache line");
  static_assert(std::atomic<double>::is_always_lock_free, "payload words must be lock-free atomics");

  static std::size_t extra_lines(std::size_t width) noexcept {
    return width <= kValuesInFirstLine ? 0 : (width - kValuesInFirstLine + kValuesPerLine - 1) / kValuesPerLine;
  }
  std::atomic<double>& word(std::size_t index) const noexcept {
    if (index < kValuesInFirstLine) return first_->values[index];
    const std::size_t rest = index - kValuesInFirstLine;
    return extra_[rest / kValuesPerLine].values[rest % kValuesPerLine];
  }
  first_line& first() const noexcept { return *first_; }

  std::size_t width_;
  std::unique_ptr<first_line> first_;
  std::unique_ptr<extra_line[]> extra_;
};


template <std::size_t Depth = 4>
class basic_seqlock {
 public:
  static constexpr std::string_view kName = "seqlock";
  static constexpr std::string_view kDescription =
      "dataflow: each producer publishes stage values behind a sequence counter (Boehm's recipe); "
      "consumers wait only for their producers";
  static constexpr primitive_kind kKind = primitive_kind::channel;
  static constexpr bool kPureSpin = false;
  static constexpr bool kMayLoseWakeups = false;
  static constexpr bool kCountsFutexWaits = true;
  static constexpr bool kSpinsLong = false;  // spins about a measured futex round trip, then yields (wait_policy.hpp)
  static constexpr bool kVisibleToTsan = true;  // C++ atomics (payload orders strengthened under TSan)
  static constexpr std::size_t kDepth = Depth;
  static_assert(Depth >= 2, "back-pressure needs at least two slots per producer");

  basic_seqlock(const dependency_graph& graph, std::size_t width)
      : width_(width),
        participants_(graph.participants()),
        acknowledged_(graph.participants()),
        census_(graph.participants()) {
    graph.validate();
    consumers_of_.resize(participants_);
    for (unsigned consumer = 0; consumer < participants_; ++consumer)
      for (unsigned producer : graph.producers_of[consumer]) consumers_of_[producer].push_back(consumer);
    producers_ = std::make_unique<producer_state[]>(participants_);
    slots_.reserve(static_cast<std::size_t>(participants_) * Depth);
    for (std::size_t index = 0; index < static_cast<std::size_t>(participants_) * Depth; ++index)
      slots_.push_back(std::make_unique<seqlock_slot>(width));
  }
  basic_seqlock(const basic_seqlock&) = delete;  // participants hold its address
  basic_seqlock& operator=(const basic_seqlock&) = delete;

  std::size_t width() const noexcept { return width_; }

  void publish(participant& self, std::uint64_t stage, std::span<const double> values) noexcept {
    producer_state& mine = producers_[self.id];
    assert(stage == mine.next_stage && "a producer publishes its stages in order");
    if (stage >= Depth) {
      // Slot stage % Depth still holds stage - Depth: every consumer must have
      // received it (acknowledged > stage - Depth) before we overwrite it.
      const std::uint64_t needed = stage - Depth + 1;
      if (mine.all_received < needed) {
        auto all_received = [&] { return (mine.all_received = slowest_consumer(self.id)) >= needed; };
        wait_until(all_received, census_.budget(mine.regime), self.counters,
                   [&] { yield_until(all_received, self.counters); });
      }
    }
    census_.enrol(mine.regime);
    slot(self.id, stage).write(stage + 1, values);
    mine.next_stage = stage + 1;
  }

  void receive(participant& self, unsigned producer, std::uint64_t stage, std::span<double> out) noexcept {
    seqlock_slot& source = slot(producer, stage);
    const std::uint64_t wanted = stage + 1;  // the version stage s is written as
    for (;;) {
      auto published = [&] { return source.version() >= wanted; };
      if (!published()) {
        producer_state& mine = producers_[self.id];
        wait_until(published, census_.budget(mine.regime), self.counters,
                   [&] { yield_until(published, self.counters); });
      }
      const std::uint64_t version = source.try_read(out);
      if (version == wanted) break;
      if (version > wanted) detail::channel_overrun(kName, producer, stage, version - 1);
      // version 0: a write overlapped the copy. With back-pressure only a
      // write of this very stage can (we saw it complete above, so this is
      // unreachable for contract-keeping callers); retry rather than trust it.
      if (source.version() > wanted) detail::channel_overrun(kName, producer, stage, source.version() - 1);
    }
    // (B1) release: pairs with the producer's acquire (B2): our reads of this
    // slot happen-before the producer rewrites it.
    acknowledged_.at(self.id, producer).store(wanted, std::memory_order_release);
  }

 private:
  struct alignas(platform::kCacheLine) producer_state {
    std::uint64_t next_stage = 0;    // debug check of the in-order contract
    std::uint64_t all_received = 0;  // cached minimum of the consumers' acknowledgements
    regime_view regime;              // this participant's wait regime (wait_policy.hpp)
  };

  std::uint64_t slowest_consumer(unsigned producer) const noexcept {
    std::uint64_t slowest = std::numeric_limits<std::uint64_t>::max();
    for (unsigned consumer : consumers_of_[producer])
      // (B2) acquire: pairs with the consumer's (B1).
      slowest = std::min(slowest, acknowledged_.at(consumer, producer).load(std::memory_order_acquire));
    return slowest;
  }

  seqlock_slot& slot(unsigned producer, std::uint64_t stage) const noexcept {
    return *slots_[static_cast<std::size_t>(producer) * Depth + static_cast<std::size_t>(stage % Depth)];
  }

  std::size_t width_;
  unsigned participants_;
  std::vector<std::vector<unsigned>> consumers_of_;
  std::unique_ptr<producer_state[]> producers_;
  std::vector<std::unique_ptr<seqlock_slot>> slots_;
  detail::received_table acknowledged_;
  regime_census census_;
};

using seqlock = basic_seqlock<>;
static_assert(graph_channel<seqlock>);

}  // namespace lockstep::sync
