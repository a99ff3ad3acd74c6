#pragma once
// `lockstep mpi`'s measurement, on every rank of the job (collective over
// MPI_COMM_WORLD); the command (bench/cli/mpi.cpp) parses, prints and writes.
//
// First the ranks are placed (rank_placement.hpp): every rank reports its
// kernel and the CPUs it was given, the ranks of each kernel are placed
// together, every rank reports the CPUs it is bound to, and ranks that must
// share a CPU yield when idle; rank 0 says so in one line (`progress`).
// Then, per round, side by side (rounds interleave the exchanges, so a machine that
// changes pace moves them all):
//   1. the ping-pong calibration between ranks 0 and 1, timed as the OSU
//      Micro-Benchmarks time osu_latency: 0-byte MPI_Send / MPI_Recv, a
//      warm-up, then the mean of `pingpong_round_trips` round trips / 2 with
//      one clock reading before and one after; then the same number again,
//      each round trip timed, for the distribution (min, p50, p99);
//   2. each exchange in turn: reset to x_0, `warmup_steps` steps, then
//      `steps` steps untimed (the step time: the slowest rank's wall time /
//      steps, from an MPI_Barrier), then `steps` steps with every share()
//      timed (per-stage latency, arrivals for the skew), then the bitwise
//      check of every rank's block against the serial RK4 after the same
//      number of steps.
// Skew of a stage: the latest rank's arrival at share() minus the earliest's.
// Transfer of a stage: the latest rank's departure from share() minus the
// latest arrival: what the exchange itself took once every rank was there
// (the counterpart of a ping-pong's one-way time; a stage's latency at a rank
// is its wait for the others, up to the skew, plus this).
// Ranks on one host read one CLOCK_MONOTONIC; across hosts each rank's clock
// offset to rank 0 is estimated first (the ping-pong with the smallest round
// trip of 64 wins; offset = its reading minus the midpoint of rank 0's) and
// arrivals are corrected by it.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "distributed/rank_placement.hpp"
#include "distributed/registry.hpp"
#include "distributed/watchdog.hpp"
#include "distributed/world.hpp"
#include "kernels/model_choice.hpp"
#include "platform/placement.hpp"
#include "platform/stats.hpp"
#include "sync/concepts.hpp"

namespace lockstep::distributed {

struct benchmark_settings {
  std::vector<const exchange_entry*> exchanges;  // applicable ones, in order
  kernels::model_choice model;
  double dt = 1e-4;
  std::uint64_t steps = 5000;
  std::uint64_t warmup_steps = 500;
  unsigned rounds = 5;
  std::uint64_t pingpong_round_trips = 10000;
  std::uint64_t pingpong_warmup = 1000;
  platform::placement pin = platform::placement::compact;
  // Fault injection for the tests: rank `fault_rank` stalls (sleeps for ever)
  // or dies (SIGKILL) before step `fault_step` of the first exchange, or is
  // slow but progressing: sleeps `fault_sleep_ms` before every step of the
  // first exchange's first round (each sleep shorter than the watchdog's
  // limit, all of them together longer).
  enum class fault { none, stall, die, slow };
  fault inject = fault::none;
  int fault_rank = -1;
  std::uint64_t fault_step = 0;
  std::uint64_t fault_sleep_ms = 0;
};

struct rank_figures {
  int rank = 0;
  std::string host;
  std::optional<unsigned> cpu;  // the one CPU it was bound to (none: several, unpinned)
  double stage_p50_ns = 0;
  double stage_p99_ns = 0;
  std::int64_t context_switches = 0;
  std::optional<std::int64_t> migrations;
  std::uint64_t futex_waits = 0;  // shm_window's futex_spin; 0 for the MPI exchanges
};

struct exchange_figures {
  const exchange_entry* entry = nullptr;
  unsigned round = 0;
  double step_ns = 0;                       // slowest rank's untimed wall time / steps
  platform::distribution stage_latency;     // every rank's every timed share(), pooled
  platform::distribution skew;              // per stage: latest arrival - earliest
  platform::distribution transfer;          // per stage: latest departure - latest arrival
  std::vector<std::uint64_t> slowest_counts;  // per rank: stages where it arrived last
  bool bitwise = false;                     // every rank's block equals the serial RK4
  std::vector<rank_figures> ranks;
};

struct pingpong_figures {
  unsigned round = 0;
  std::uint64_t round_trips = 0;
  double one_way_mean_ns = 0;           // OSU style
  platform::distribution one_way;       // per round trip / 2
};

struct benchmark_result {
  std::vector<pingpong_figures> pingpongs;
  std::vector<exchange_figures> exchanges;
  bool one_clock = true;                 // arrivals read on one host's clock (else offset-corrected)
  rank_placement placement;              // where every rank ran, and whether two shared a CPU
};

// Collective. `progress` is called on rank 0 only. The result is complete on
// rank 0 (the others return what they measured themselves).
benchmark_result run_benchmark(const world& job, const benchmark_settings& settings, watchdog& dog,
                               const std::function<void(const std::string&)>& progress);

}  // namespace lockstep::distributed
