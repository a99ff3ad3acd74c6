#pragma once
// Bookkeeping shared by the dataflow channels (seqlock, mailbox): the table of
// what each consumer has received from each producer, and the one way a
// channel reports a broken contract.
//
// received_table: at(consumer, producer) counts the stages of `producer` that
// `consumer` has received. Each consumer's row sits on prefetch pairs of its
// own (only that consumer writes it, and a neighbour's adjacent-line prefetch
// never pulls it); producers read it when they must not overwrite a stage a
// consumer has not received yet (back-pressure).
// Memory ordering: none of its own; the channels say what they pair.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string_view>

#include "platform/cache_line.hpp"

namespace lockstep::sync::detail {

class received_table {
 public:
  explicit received_table(unsigned participants)
      : participants_(participants),
        lines_per_row_((participants + kPerLine - 1) / kPerLine),
        owned_(std::make_unique<row_line[]>(static_cast<std::size_t>(participants) * lines_per_row_)),
        lines_(owned_.get()) {}
  // The rows in a primitive's storage (sync/storage.hpp): the heap, or a
  // block that several processes share.
  template <class Storage>
  received_table(unsigned participants, Storage& storage)
      : participants_(participants),
        lines_per_row_((participants + kPerLine - 1) / kPerLine),
        lines_(storage.template make_array<row_line>(static_cast<std::size_t>(participants) * lines_per_row_)) {}

  std::atomic<std::uint64_t>& at(unsigned consumer, unsigned producer) const noexcept {
    return lines_[static_cast<std::size_t>(consumer) * lines_per_row_ + producer / kPerLine]
        .received[producer % kPerLine];
  }
  unsigned participants() const noexcept { return participants_; }

 private:
  static constexpr unsigned kPerLine = platform::kPrefetchPair / sizeof(std::uint64_t);
  struct alignas(platform::kPrefetchPair) row_line {
    std::atomic<std::uint64_t> received[kPerLine]{};
  };
  static_assert(sizeof(row_line) == platform::kPrefetchPair,
                "one consumer's row never shares a line, or a prefetch pair, with another's");
  unsigned participants_;
  unsigned lines_per_row_;
  std::unique_ptr<row_line[]> owned_;  // empty when the rows live in a primitive's storage
  row_line* lines_;
};

// A stage was (or was about to be) overwritten before a consumer received it:
// say so and stop (never a silent wrong value).
[[noreturn]] inline void channel_overrun(std::string_view channel, unsigned producer, std::uint64_t stage,
                                         std::uint64_t found) noexcept {
  std::fprintf(stderr,
               "lockstep::sync::%.*s: overrun: stage %llu of producer %u was overwritten (slot holds stage %llu) "
               "before this consumer received it; receive only from producers in the dependency graph\n",
               static_cast<int>(channel.size()), channel.data(), static_cast<unsigned long long>(stage), producer,
               static_cast<unsigned long long>(found));
  std::abort();
}

}  // namespace lockstep::sync::detail
