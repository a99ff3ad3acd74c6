#pragma once
// channel_barrier: a stage_channel used as a phase_barrier. Every participant
// depends on every other one (dependency_graph::all_to_all); arriving at phase
// p publishes the participant's token for stage p, waiting receives stage p
// from every other participant. So the conformance suite and the bare barrier
// benchmarks run the dataflow primitives too (barrier/sync:seqlock/...).
//
// Contract: construct with the number of participants; each calls
// arrive_and_wait(self) once per phase (one thread per participant);
// destroy after every participant has returned from its last call.
// Progress and counters: the channel's.
// Memory ordering: returning from phase p means every other participant's
// publish of stage p has been received, so (by the channel's guarantee)
// everything each participant wrote before arriving is visible.
// Self-check: the token a participant publishes is its phase number; a
// received token that is not the phase being completed means the channel
// delivered a wrong stage: reported on stderr, then abort (one compare per
// received value: negligible next to the wait).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <span>
#include <string_view>

#include "platform/cache_line.hpp"
#include "sync/concepts.hpp"

namespace lockstep::sync {

template <graph_channel Channel>
class channel_barrier {
 public:
  static constexpr std::string_view kName = Channel::kName;
  static constexpr std::string_view kDescription = Channel::kDescription;
  static constexpr primitive_kind kKind = primitive_kind::barrier;
  static constexpr bool kPureSpin = Channel::kPureSpin;
  static constexpr bool kMayLoseWakeups = Channel::kMayLoseWakeups;
  static constexpr bool kCountsFutexWaits = Channel::kCountsFutexWaits;
  static constexpr bool kSpinsLong = Channel::kSpinsLong;
  static constexpr bool kVisibleToTsan = Channel::kVisibleToTsan;

  explicit channel_barrier(unsigned participants)
      : participants_(participants),
        channel_(dependency_graph::all_to_all(participants), 1),
        phases_(std::make_unique<phase_slot[]>(participants)) {}
  channel_barrier(const channel_barrier&) = delete;  // participants hold its address
  channel_barrier& operator=(const channel_barrier&) = delete;

  void arrive_and_wait(participant& self) noexcept {
    const std::uint64_t phase = phases_[self.id].phase++;
    const double token = static_cast<double>(phase);
    channel_.publish(self, phase, std::span<const double>(&token, 1));
    for (unsigned producer = 0; producer < participants_; ++producer) {
      if (producer == self.id) continue;
      double received = -1.0;
      channel_.receive(self, producer, phase, std::span<double>(&received, 1));
      if (received != token) wrong_stage(producer, phase, received);
    }
  }

  Channel& channel() noexcept { return channel_; }

 private:
  struct alignas(platform::kCacheLine) phase_slot {
    std::uint64_t phase = 0;  // touched only by its participant
  };

  [[noreturn]] static void wrong_stage(unsigned producer, std::uint64_t phase, double received) noexcept {
    std::fprintf(stderr, "lockstep::sync::channel_barrier<%.*s>: phase %llu received %.17g from producer %u\n",
                 static_cast<int>(kName.size()), kName.data(), static_cast<unsigned long long>(phase), received,
                 producer);
    std::abort();
  }

  unsigned participants_;
  Channel channel_;
  std::unique_ptr<phase_slot[]> phases_;
};

}  // namespace lockstep::sync
