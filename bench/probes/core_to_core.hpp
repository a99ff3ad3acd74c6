#pragma once
// Core-to-core latency: two pinned threads bounce one cache line.
//
// What it measures: the one-way latency of moving one cache line from the
// core of thread A to the core of thread B and back, i.e. the coherence cost
// a synchronisation primitive pays every time one thread publishes and
// another observes. This is the unit the harness divides stage-sync times by
// (`vs_c2c`) and what `lockstep c2c` prints per pair of cores.
//
// How: thread A (pinned to cpu_a) maps a fresh anonymous page with mmap and
// touches it first, so the line's home is A's node and no allocator metadata
// or other object shares its page. Thread B (pinned to cpu_b) then bounces the
// one 64-bit word at the start of that page with A:
//   - method::cas        A CASes the word from 2k to 2k+1, B from 2k+1 to 2k+2
//                        (each retries until it succeeds: a read-for-ownership
//                        ping-pong, what lock-free counters do);
//   - method::store_load A stores 2k+1 and spins loading until it reads
//                        2k+2; B spins loading until it reads 2k+1 and
//                        stores 2k+2 (what flags and sequence counters do);
//   - method::stage      a stage of two participants: each thread stores k+1
//                        into its own word (A's at the page's start, B's one
//                        prefetch pair further) and spins loading until the
//                        other's word reads k+1 (what every two-thread stage
//                        sync must do at least: the dataflow channels publish
//                        and poll so, the barriers arrive and wait so). The
//                        two lines cross at once, so a stage's floor is one
//                        transfer where the ping-pong pays two per round.
// A times `rounds_per_sample` round trips with the steady clock and records
// one sample = elapsed / rounds / 2 (one-way = round trip / 2); for
// method::stage a round is one stage and the sample elapsed / rounds (a
// stage's time, in the same unit: its ideal is one one-way latency). Averaging over
// rounds keeps the clock's own cost (~20 ns) out of the sample; the
// distribution over samples keeps preemptions visible (they land in the top
// percentiles, not in the minimum or the median).
//
// Contract: measure_pair blocks the caller for about
//   (warmup_rounds + samples * rounds_per_sample) * 2 * one-way latency
// (a few milliseconds with the defaults), starts and joins two threads, and
// leaves the caller's own affinity untouched. It throws std::invalid_argument
// for a bad request (cpu_a == cpu_b, negative cpu, zero counts),
// platform::placement_error when a thread cannot be pinned (the CPU is offline
// or not in the process's allowed set) and std::system_error when the page
// cannot be mapped; both derive from std::runtime_error. Link
// lockstep::platform.
//
// Memory ordering: the bounced word is the only shared datum and carries no
// payload, so each thread needs only to observe the other's write; the
// release/acquire pairs below are commented where they occur.
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <new>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include "platform/cpu_relax.hpp"
#include "platform/placement.hpp"

namespace lockstep::bench::c2c {

enum class method { cas, store_load, stage };

inline const char* to_string(method how) noexcept {
  switch (how) {
    case method::cas: return "cas";
    case method::store_load: return "store_load";
    case method::stage: return "stage";
  }
  return "?";
}

// The sample's divisor of a round's time: a round trip is two one-way
// transfers; a stage is one (both lines cross at once).
inline double transfers_per_round(method how) noexcept { return how == method::stage ? 1.0 : 2.0; }

struct pair_request {
  int cpu_a = 0;  // the initiator: maps the page, touches it first, keeps the clock
  int cpu_b = 1;  // the responder
  method how = method::cas;
  int samples = 1000;            // one-way latency samples returned
  int rounds_per_sample = 100;   // round trips averaged into one sample
  int warmup_rounds = 1000;      // round trips before the first sample (caches, frequency)
};

namespace detail {

inline void pin_this_thread(int cpu) { platform::pin_current_thread_to_pu(static_cast<unsigned>(cpu)); }

// A spin that cannot starve its partner: after many polite spins it yields,
// which only matters when both threads share one CPU (a cpuset that the pin
// could not escape) or the partner was preempted; a normal hand-over takes a
// few hundred spins at most.
class patient_spin {
 public:
  void operator()() noexcept {
    if (++spins_ < kSpinsBeforeYield) {
      platform::cpu_relax();
    } else {
      spins_ = 0;
      std::this_thread::yield();
    }
  }

 private:
  static constexpr unsigned kSpinsBeforeYield = 1u << 16;
  unsigned spins_ = 0;
};

// One mapped page; the bounced word is at its start.
class fresh_page {
 public:
  fresh_page() {
    page_size_ = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
    void* p = ::mmap(nullptr, page_size_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::system_error(errno, std::generic_category(), "mmap of the bounced page");
    memory_ = p;
    // First touch by the constructing (pinned) thread: the page's frame is
    // allocated on this thread's node, and the line starts in its cache.
    word_ = new (memory_) std::atomic<std::uint64_t>(0);
    stage_words_[0] = word_;
    for (std::size_t index = 1; index < 2 * kStageSlots; ++index)
      stage_words_[index] = new (static_cast<char*>(memory_) + index * kStageWordSpacing) std::atomic<std::uint64_t>(0);
  }
  fresh_page(const fresh_page&) = delete;  // owns a mapping
  fresh_page& operator=(const fresh_page&) = delete;
  ~fresh_page() {
    for (std::size_t index = 1; index < 2 * kStageSlots; ++index) stage_words_[index]->~atomic();
    word_->~atomic();
    ::munmap(memory_, page_size_);
  }
  std::atomic<std::uint64_t>& word() noexcept { return *word_; }
  // method::stage's words: each side's ring of kStageSlots lines (stage k
  // in slot k % kStageSlots, as a dataflow channel's ring), every word a
  // prefetch pair (128 bytes) from the next, so no adjacent-line prefetch
  // pulls another; side 0 is the initiator's, side 1 the responder's. The
  // word at the page's start (word()) is side 0's slot 0.
  static constexpr std::size_t kStageSlots = 4;
  std::atomic<std::uint64_t>& stage_word(unsigned side, std::uint64_t k) noexcept {
    return *stage_words_[side * kStageSlots + k % kStageSlots];
  }

 private:
  static constexpr std::size_t kStageWordSpacing = 128;
  void* memory_ = nullptr;
  std::size_t page_size_ = 0;
  std::atomic<std::uint64_t>* word_ = nullptr;
  std::atomic<std::uint64_t>* stage_words_[2 * kStageSlots] = {};
};

// The initiator's half of round trip k: move the word 2k -> 2k+1. With CAS
// the wait for the responder's 2k (from round k-1) is the failing CAS itself,
// so both sides are pure read-for-ownership; with store/load the initiator
// waits for 2k+2 with loads before returning.
inline void initiator_round(std::atomic<std::uint64_t>& word, method how, std::uint64_t k) {
  const std::uint64_t mine = 2 * k + 1;
  patient_spin spin;
  if (how == method::cas) {
    std::uint64_t expected = 2 * k;
    // (1) acq_rel CAS: its acquire half pairs with the release half of the
    //     responder's CAS (3) of round k-1; its release half with the acquire
    //     half of the responder's CAS (3) of round k.
    while (!word.compare_exchange_weak(expected, mine, std::memory_order_acq_rel, std::memory_order_relaxed)) {
      expected = 2 * k;
      spin();
    }
  } else {
    // (1) release store: pairs with the responder's acquire load (3).
    word.store(mine, std::memory_order_release);
    // (2) acquire load: pairs with the responder's release store (4).
    while (word.load(std::memory_order_acquire) != mine + 1) spin();
  }
}

// Stage k of method::stage, the same on both sides: publish our word, wait
// for theirs. The responder's last stage may still be polling the page when
// the initiator has seen it end, so stage_finish holds the page until the
// responder says it has left.
inline void stage_round(fresh_page& page, unsigned side, std::uint64_t k) {
  patient_spin spin;
  // (5) release store: pairs with the other side's acquire load (6) of stage k.
  page.stage_word(side, k).store(k + 1, std::memory_order_release);
  // (6) acquire load: pairs with the other side's release store (5) of stage k.
  while (page.stage_word(1 - side, k).load(std::memory_order_acquire) != k + 1) spin();
}

// The end of method::stage: the responder stores one past the last stage
// and touches the page no more; the initiator waits for that store.
inline void stage_finish_responder(fresh_page& page, std::uint64_t rounds) {
  // (7) release store: pairs with the initiator's acquire load (8).
  page.stage_word(1, rounds).store(rounds + 1, std::memory_order_release);
}
inline void stage_finish_initiator(fresh_page& page, std::uint64_t rounds) {
  patient_spin spin;
  // (8) acquire load: pairs with the responder's release store (7).
  while (page.stage_word(1, rounds).load(std::memory_order_acquire) != rounds + 1) spin();
}

// After the last CAS round the initiator waits for the responder's final
// 2k+2, so that the page outlives the responder's last write.
inline void initiator_finish(std::atomic<std::uint64_t>& word, std::uint64_t rounds) {
  patient_spin spin;
  // acquire: pairs with the release half of the responder's last CAS (3).
  while (word.load(std::memory_order_acquire) != 2 * rounds) spin();
}

// The responder's half of round trip k: wait for 2k+1, move it to 2k+2.
inline void responder_round(std::atomic<std::uint64_t>& word, method how, std::uint64_t k) {
  const std::uint64_t theirs = 2 * k + 1;
  patient_spin spin;
  if (how == method::cas) {
    std::uint64_t expected = theirs;
    // (3) acq_rel CAS: acquire pairs with the initiator's CAS (1) of round k,
    //     release with its CAS (1) of round k+1 (or initiator_finish).
    while (!word.compare_exchange_weak(expected, theirs + 1, std::memory_order_acq_rel,
                                       std::memory_order_relaxed)) {
      expected = theirs;
      spin();
    }
  } else {
    // (3) acquire load: pairs with the initiator's release store (1).
    while (word.load(std::memory_order_acquire) != theirs) spin();
    // (4) release store: pairs with the initiator's acquire load (2).
    word.store(theirs + 1, std::memory_order_release);
  }
}

inline void check_pair_request(const pair_request& request) {
  if (request.cpu_a < 0 || request.cpu_b < 0)
    throw std::invalid_argument("core_to_core: CPU numbers must be non-negative");
  if (request.cpu_a == request.cpu_b)
    throw std::invalid_argument("core_to_core: a pair needs two different CPUs");
  if (request.samples <= 0 || request.rounds_per_sample <= 0 || request.warmup_rounds < 0)
    throw std::invalid_argument("core_to_core: samples and rounds must be positive");
}

// What the two threads of one measure_pair share: the hand-over of the page
// from A to B, and of errors from either thread. `stage`: 0 = A is
// preparing, 1 = page ready, 2 = B pinned and has the page, -1 = A failed,
// -2 = B failed.
struct pair_handover {
  std::atomic<int> stage{0};
  std::atomic<std::atomic<std::uint64_t>*> shared_word{nullptr};
  std::atomic<fresh_page*> shared_page{nullptr};  // method::stage's words
  std::exception_ptr error_a;
  std::exception_ptr error_b;
};

// Thread B: pins itself, waits for A's page, answers every round.
inline void respond(const pair_request& request, pair_handover& handover, std::uint64_t total_rounds) {
  try {
    pin_this_thread(request.cpu_b);
  } catch (...) {
    handover.error_b = std::current_exception();
    // release: publishes error_b to the initiator's acquire loads of stage.
    handover.stage.exchange(-2, std::memory_order_acq_rel);
    return;
  }
  patient_spin spin;
  int seen = 0;
  // acquire: pairs with the initiator's release store of 1 or -1 (initiate)
  // (makes shared_word / error_a visible).
  while ((seen = handover.stage.load(std::memory_order_acquire)) == 0) spin();
  if (seen != 1) return;
  // relaxed: ordered after the initiator's store by the acquire load of
  // stage above (which pairs with the release half of its CAS to 1).
  std::atomic<std::uint64_t>& word = *handover.shared_word.load(std::memory_order_relaxed);
  // relaxed: as word, ordered by the acquire load of stage above.
  fresh_page& page = *handover.shared_page.load(std::memory_order_relaxed);
  handover.stage.store(2, std::memory_order_release);  // release: pairs with the initiator's acquire wait for 2
  for (std::uint64_t k = 0; k < total_rounds; ++k) {
    if (request.how == method::stage)
      stage_round(page, 1, k);
    else
      responder_round(word, request.how, k);
  }
  if (request.how == method::stage) stage_finish_responder(page, total_rounds);
}

// Thread A's rounds once B has the page: the warm-up, then each sample's
// rounds timed; one_way_ns gets one latency per sample.
inline void time_rounds(const pair_request& request, fresh_page& page, std::uint64_t total_rounds,
                        std::vector<double>& one_way_ns) {
  std::atomic<std::uint64_t>& word = page.word();
  auto round = [&](std::uint64_t k) {
    if (request.how == method::stage)
      stage_round(page, 0, k);
    else
      initiator_round(word, request.how, k);
  };
  std::uint64_t k = 0;
  for (; k < static_cast<std::uint64_t>(request.warmup_rounds); ++k) round(k);
  for (std::size_t s = 0; s < one_way_ns.size(); ++s) {
    const auto start = std::chrono::steady_clock::now();
    for (int r = 0; r < request.rounds_per_sample; ++r, ++k) round(k);
    const auto elapsed = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start);
    one_way_ns[s] = elapsed.count() / request.rounds_per_sample / transfers_per_round(request.how);
  }
  if (request.how == method::cas) initiator_finish(word, total_rounds);
  if (request.how == method::stage) stage_finish_initiator(page, total_rounds);
}

// Thread A: pins itself, prepares the page, hands it to B, times the samples.
inline void initiate(const pair_request& request, pair_handover& handover, std::uint64_t total_rounds,
                     std::vector<double>& one_way_ns) {
  try {
    pin_this_thread(request.cpu_a);
    fresh_page page;
    // relaxed, both: published by the release half of the CAS of stage to 1
    // below, which the responder's acquire load of stage pairs with.
    handover.shared_word.store(&page.word(), std::memory_order_relaxed);
    handover.shared_page.store(&page, std::memory_order_relaxed);
    int expected = 0;
    // release: publishes the page (and shared_word) to the responder's acquire load.
    if (!handover.stage.compare_exchange_strong(expected, 1, std::memory_order_acq_rel, std::memory_order_acquire))
      return;  // the responder failed to pin (-2)
    patient_spin spin;
    int seen = 1;
    // acquire: pairs with the responder's release store of 2 (or -2).
    while ((seen = handover.stage.load(std::memory_order_acquire)) == 1) spin();
    if (seen != 2) return;  // the responder failed to pin after the page was ready
    time_rounds(request, page, total_rounds, one_way_ns);
  } catch (...) {
    handover.error_a = std::current_exception();
    int expected = 0;
    // release: publishes error_a; the responder sees -1 and returns.
    handover.stage.compare_exchange_strong(expected, -1, std::memory_order_acq_rel, std::memory_order_acquire);
  }
}

}  // namespace detail

// Measures one ordered pair of CPUs; returns `samples` one-way latencies in
// nanoseconds, in the order they were taken (sort a copy for percentiles).
inline std::vector<double> measure_pair(const pair_request& request) {
  detail::check_pair_request(request);
  std::vector<double> one_way_ns(static_cast<std::size_t>(request.samples));
  const std::uint64_t total_rounds =
      static_cast<std::uint64_t>(request.warmup_rounds) +
      static_cast<std::uint64_t>(request.samples) * static_cast<std::uint64_t>(request.rounds_per_sample);
  detail::pair_handover handover;
  std::thread responder([&] { detail::respond(request, handover, total_rounds); });
  std::thread initiator([&] { detail::initiate(request, handover, total_rounds, one_way_ns); });
  initiator.join();
  responder.join();
  if (handover.error_a) std::rethrow_exception(handover.error_a);
  if (handover.error_b) std::rethrow_exception(handover.error_b);
  return one_way_ns;
}

// The c2c probe: every pair of a plan, with each method, one after another.
struct c2c_settings {
  std::vector<std::pair<int, int>> pairs;  // (initiator, responder)
  std::vector<method> methods{method::cas, method::store_load};
  int samples = 300;            // per pair and method
  int rounds_per_sample = 100;  // round trips averaged into one sample
  // Called before each pair is measured (done so far, total, cpu a, cpu b, method).
  std::function<void(std::size_t, std::size_t, int, int, method)> on_pair;
};

struct pair_latency {
  int a = 0;
  int b = 0;
  method how = method::cas;
  std::vector<double> one_way_ns;  // `samples` of them, in the order taken
};

// Measures settings.pairs x settings.methods in that order (pairs outermost).
// Throws what measure_pair throws (a CPU that cannot be pinned: a
// std::runtime_error naming it).
std::vector<pair_latency> measure_pairs(const c2c_settings& settings);

}  // namespace lockstep::bench::c2c
