// The waiting primitives' calibration (wait_calibration.hpp).
#include "platform/wait_calibration.hpp"

#include <fmt/core.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <optional>
#include <system_error>
#include <thread>
#include <vector>

#include "platform/cache_line.hpp"
#include "platform/clock.hpp"
#include "platform/futex.hpp"
#include "platform/placement.hpp"
#include "platform/statistics.hpp"

namespace lockstep::platform {

namespace {

// Round r: the pinger stores 2r + 1 and wakes the ponger; the ponger stores
// 2r + 2 and wakes the pinger. Every order here is seq_cst: the calibration
// is not a measured path, and the ball is the only value the threads share
// while they run (each writes its own records; join publishes them).
struct ping_pong {
  alignas(kCacheLine) std::atomic<std::uint32_t> ball{0};
  alignas(kCacheLine) std::atomic<bool> stop{false};
  std::int64_t deadline_ns = 0;
};

// Sleeps until `word` holds `wanted`; false when give_up() says to stop first.
// Each FUTEX_WAIT is bounded by kFutexWaitTimeoutNs, so give_up is asked at
// least that often.
template <class GiveUp>
bool sleep_until(std::atomic<std::uint32_t>& word, std::uint32_t wanted, GiveUp&& give_up) {
  for (;;) {
    const std::uint32_t seen = word.load();
    if (seen == wanted) return true;
    if (give_up()) return false;
    futex_wait(word, seen, std::chrono::nanoseconds(kFutexWaitTimeoutNs));
  }
}

// Pins the calling thread to `cpu` when there is one; false when the kernel refused.
bool pin_to(std::optional<unsigned> cpu) {
  if (!cpu) return true;
  try {
    pin_current_thread_to_pu(*cpu);
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

struct pinger_round {
  std::int64_t start_ns = 0;
  std::int64_t end_ns = 0;
  bool woke_partner = false;
  bool completed = false;
};

void run_pinger(ping_pong& game, std::vector<pinger_round>& rounds) {
  const auto give_up = [&game] { return now_ns() > game.deadline_ns; };
  for (std::uint32_t round = 0; round < rounds.size(); ++round) {
    if (give_up()) break;
    pinger_round& record = rounds[round];
    record.start_ns = now_ns();
    game.ball.store(2 * round + 1);
    record.woke_partner = futex_wake(game.ball, 1) == 1;
    if (!sleep_until(game.ball, 2 * round + 2, give_up)) break;
    record.end_ns = now_ns();
    record.completed = true;
  }
  game.stop.store(true);
  futex_wake(game.ball);
}

void run_ponger(ping_pong& game, std::vector<char>& woke_partner) {
  const auto give_up = [&game] { return game.stop.load(); };
  for (std::uint32_t round = 0; round < woke_partner.size(); ++round) {
    if (!sleep_until(game.ball, 2 * round + 1, give_up)) return;
    game.ball.store(2 * round + 2);
    woke_partner[round] = futex_wake(game.ball, 1) == 1 ? 1 : 0;
  }
}

// Where the two threads run: two CPUs of the calling thread's affinity set,
// or (one CPU, or the kernel will not say) wherever the scheduler puts them.
struct ping_pong_cpus {
  std::optional<unsigned> pinger;
  std::optional<unsigned> ponger;
  std::string where() const {
    return pinger && ponger ? fmt::format("between CPUs {} and {}", *pinger, *ponger)
                            : std::string("unpinned (fewer than two CPUs in the affinity set)");
  }
};

ping_pong_cpus choose_cpus() {
  const std::vector<unsigned> allowed = current_thread_affinity();
  if (allowed.size() < 2) return {};
  return {allowed[0], allowed[1]};
}

futex_round_trip assumed(std::string why) {
  futex_round_trip result;
  result.how = fmt::format("not measured ({}): the development VM's {:.0f} ns assumed", why, kAssumedFutexRoundTripNs);
  return result;
}

}  // namespace

futex_round_trip measure_futex_round_trip(std::int64_t budget_ns) {
  ping_pong game;
  game.deadline_ns = now_ns() + budget_ns;
  const ping_pong_cpus cpus = choose_cpus();
  std::vector<pinger_round> rounds(kFutexWarmUpRounds + kFutexRounds);
  std::vector<char> ponger_woke(rounds.size(), 0);
  std::atomic<bool> pinned{true};
  std::thread ponger;
  try {
    ponger = std::thread([&] {
      if (!pin_to(cpus.ponger)) pinned.store(false);
      run_ponger(game, ponger_woke);
    });
  } catch (const std::system_error& error) {
    return assumed(fmt::format("no thread to measure with: {}", error.what()));
  }
  std::thread pinger;
  try {
    pinger = std::thread([&] {
      if (!pin_to(cpus.pinger)) pinned.store(false);
      run_pinger(game, rounds);
    });
  } catch (const std::system_error& error) {
    game.stop.store(true);
    futex_wake(game.ball);
    ponger.join();
    return assumed(fmt::format("no thread to measure with: {}", error.what()));
  }
  pinger.join();
  ponger.join();
  std::vector<double> hand_overs;
  for (std::size_t round = kFutexWarmUpRounds; round < rounds.size(); ++round) {
    const pinger_round& record = rounds[round];
    if (record.completed && record.woke_partner && ponger_woke[round] != 0)
      hand_overs.push_back(static_cast<double>(record.end_ns - record.start_ns) / 2.0);
  }
  const std::string where = pinned.load() ? cpus.where() : cpus.where() + ", the pinning refused";
  if (hand_overs.size() < kFutexMinimumHandOvers)
    return assumed(fmt::format("{} hand-overs with both threads asleep in {:.0f} ms {}, fewer than {}",
                               hand_overs.size(), static_cast<double>(budget_ns) / 1e6, where,
                               kFutexMinimumHandOvers));
  futex_round_trip result;
  result.ns = median(hand_overs);
  result.p90_ns = quantile(hand_overs, 0.9);
  result.measured = true;
  result.hand_overs = hand_overs.size();
  result.how = fmt::format("median and 90th percentile of {} futex hand-overs {} (FUTEX_WAKE until the woken thread "
                           "ran: half a ping-pong round)",
                           hand_overs.size(), where);
  return result;
}

wait_calibration measure_wait_calibration() {
  wait_calibration calibration;
  calibration.poll_ns = measure_poll_ns(now_ns);
  calibration.futex = measure_futex_round_trip();
  return calibration;
}

const wait_calibration& machine_wait_calibration() {
  static const wait_calibration calibration = measure_wait_calibration();
  return calibration;
}

}  // namespace lockstep::platform
