#include "distributed/benchmark.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstring>
#include <limits>
#include <memory>
#include <thread>

#include "distributed/rank_step.hpp"
#include "kernels/parallel_exchange.hpp"
#include "platform/clock.hpp"
#include "platform/thread_accounting.hpp"
#include "platform/topology.hpp"

namespace lockstep::distributed {
namespace {

constexpr int kPingTag = 17;

// The rank waits for other ranks while one lives (the watchdog's waiting
// flag: a rank that stops here is waiting for another, not the one that stopped).
class waiting_for_others {
 public:
  explicit waiting_for_others(watchdog& dog) noexcept : flag_(dog.waiting()) {
    flag_.store(true, std::memory_order_relaxed);
  }
  ~waiting_for_others() { flag_.store(false, std::memory_order_relaxed); }
  waiting_for_others(const waiting_for_others&) = delete;
  waiting_for_others& operator=(const waiting_for_others&) = delete;

 private:
  std::atomic<bool>& flag_;
};
constexpr int kClockTag = 18;
constexpr int kClockSamples = 64;

// Each rank's clock minus rank 0's (0 on rank 0, and everywhere on one host).
std::int64_t clock_offset(const world& job, watchdog& dog) {
  if (job.one_host()) return 0;
  const waiting_for_others waiting(dog);
  std::int64_t offset = 0;
  for (int peer = 1; peer < job.size; ++peer) {
    if (job.rank == 0) {
      std::int64_t best_round_trip = std::numeric_limits<std::int64_t>::max();
      std::int64_t best_offset = 0;
      for (int sample = 0; sample < kClockSamples; ++sample) {
        const std::int64_t sent = platform::now_ns();
        MPI_Send(&sent, 1, MPI_INT64_T, peer, kClockTag, job.comm);
        std::int64_t theirs = 0;
        MPI_Recv(&theirs, 1, MPI_INT64_T, peer, kClockTag, job.comm, MPI_STATUS_IGNORE);
        const std::int64_t back = platform::now_ns();
        if (back - sent < best_round_trip) {
          best_round_trip = back - sent;
          best_offset = theirs - (sent + (back - sent) / 2);
        }
      }
      MPI_Send(&best_offset, 1, MPI_INT64_T, peer, kClockTag, job.comm);
    } else if (job.rank == peer) {
      for (int sample = 0; sample < kClockSamples; ++sample) {
        std::int64_t sent = 0;
        MPI_Recv(&sent, 1, MPI_INT64_T, 0, kClockTag, job.comm, MPI_STATUS_IGNORE);
        const std::int64_t mine = platform::now_ns();
        MPI_Send(&mine, 1, MPI_INT64_T, 0, kClockTag, job.comm);
      }
      MPI_Recv(&offset, 1, MPI_INT64_T, 0, kClockTag, job.comm, MPI_STATUS_IGNORE);
    }
  }
  return offset;
}

// Every rank waits here until every rank has arrived, beating while it
// waits. Not MPI_Barrier: a blocking wait beats no more, and the ranks that
// wait for the ping-pong of ranks 0 and 1 can wait longer than the watchdog's
// limit when the machine is busy (9 ranks on 2 CPUs under a build: over 10 s,
// and the watchdogs ended a healthy job). A stall is still caught: a ping-pong
// rank whose peer stalls waits in a blocking receive, beats no more and ends
// the job; a rank that dies, mpirun ends it.
void barrier_beating(const world& job, watchdog& dog) {
  MPI_Request request = MPI_REQUEST_NULL;
  MPI_Ibarrier(job.comm, &request);
  int done = 0;
  for (std::uint64_t polls = 0; MPI_Test(&request, &done, MPI_STATUS_IGNORE) == MPI_SUCCESS && done == 0; ++polls)
    dog.beat(polls);
}

// Ranks 0 and 1; the others wait for them (barrier_beating).
pingpong_figures pingpong(const world& job, const benchmark_settings& settings, unsigned round, watchdog& dog) {
  dog.phase("the ping-pong");
  pingpong_figures figures;
  figures.round = round;
  figures.round_trips = settings.pingpong_round_trips;
  const auto trip = [&](int me) {
    if (me == 0) {
      MPI_Send(nullptr, 0, MPI_BYTE, 1, kPingTag, job.comm);
      MPI_Recv(nullptr, 0, MPI_BYTE, 1, kPingTag, job.comm, MPI_STATUS_IGNORE);
    } else {
      MPI_Recv(nullptr, 0, MPI_BYTE, 0, kPingTag, job.comm, MPI_STATUS_IGNORE);
      MPI_Send(nullptr, 0, MPI_BYTE, 0, kPingTag, job.comm);
    }
  };
  if (job.rank < 2) {
    const waiting_for_others waiting(dog);
    for (std::uint64_t done = 0; done < settings.pingpong_warmup; ++done) {
      trip(job.rank);
      if ((done & 1023U) == 0) dog.beat(done);
    }
    dog.phase("the ping-pong (timed)");
    const std::int64_t start = platform::now_ns();
    for (std::uint64_t done = 0; done < settings.pingpong_round_trips; ++done) {
      trip(job.rank);
      if ((done & 1023U) == 0) dog.beat(done);
    }
    const std::int64_t elapsed = platform::now_ns() - start;
    figures.one_way_mean_ns =
        static_cast<double>(elapsed) / static_cast<double>(settings.pingpong_round_trips) / 2.0;
    dog.phase("the ping-pong (distribution)");
    std::vector<double> one_way(settings.pingpong_round_trips);
    for (std::uint64_t done = 0; done < settings.pingpong_round_trips; ++done) {
      const std::int64_t before = platform::now_ns();
      trip(job.rank);
      one_way[done] = static_cast<double>(platform::now_ns() - before) / 2.0;
      if ((done & 1023U) == 0) dog.beat(done);
    }
    figures.one_way = platform::summarize(std::move(one_way));
  }
  barrier_beating(job, dog);
  return figures;
}

template <kernels::oscillator_model Model>
class exchange_runner {
 public:
  exchange_runner(const world& job, const benchmark_settings& settings, const Model& model, std::int64_t offset,
                  const rank_placement& placement)
      : job_(job), settings_(settings), model_(model), offset_(offset), placement_(placement),
        setup_{job.comm, job.host_comm, job.rank, job.size,
               kernels::partition_of(model, static_cast<unsigned>(job.size)),
               kernels::plan_participants(model, kernels::partition_of(model, static_cast<unsigned>(job.size))),
               placement.crowded_here()} {
    // The serial reference for the whole trajectory one measurement runs.
    kernels::staged_rk4<Model> serial(model_, settings.dt);
    serial.run(settings.warmup_steps + 2 * settings.steps);
    const layouts::equation_block block = setup_.mine().block;
    reference_.assign(serial.state().begin() + static_cast<std::ptrdiff_t>(block.first),
                      serial.state().begin() + static_cast<std::ptrdiff_t>(block.last));
    record_.resize(settings.steps);
  }

  exchange_figures measure(const exchange_entry& entry, exchange& values, unsigned round, watchdog& dog) {
    const bool first = round == 0 && &entry == settings_.exchanges.front();
    rank_step<Model> step(model_, settings_.dt, setup_.mine().block, values);
    step_hooks hooks;
    hooks.heartbeat = &dog.heartbeat();
    hooks.waiting = &dog.waiting();
    if (first && settings_.inject == benchmark_settings::fault::slow && settings_.fault_rank == job_.rank) {
      hooks.at_step = [this](std::uint64_t) {
        std::this_thread::sleep_for(std::chrono::milliseconds(settings_.fault_sleep_ms));
      };
    } else if (first && settings_.inject != benchmark_settings::fault::none && settings_.fault_rank == job_.rank) {
      hooks.at_step = [this](std::uint64_t at) {
        if (at != settings_.fault_step) return;
        if (settings_.inject == benchmark_settings::fault::die) std::raise(SIGKILL);
        for (;;) std::this_thread::sleep_for(std::chrono::hours(1));
      };
    }
    dog.phase(entry.label.data());
    step.reset();
    step.run(settings_.warmup_steps, hooks);

    {
      const waiting_for_others waiting(dog);
      MPI_Barrier(job_.comm);
    }
    const std::int64_t start = platform::now_ns();
    step.run(settings_.steps, hooks);
    const std::int64_t elapsed = platform::now_ns() - start;
    std::int64_t slowest = 0;
    {
      const waiting_for_others waiting(dog);
      MPI_Reduce(&elapsed, &slowest, 1, MPI_INT64_T, MPI_MAX, 0, job_.comm);
    }

    const sync::sync_counters counters_before = values.counters();
    const platform::thread_counters switches_before = platform::snapshot_current_thread();
    step.run_timed(settings_.steps, record_, hooks);
    const platform::thread_counters switches = platform::snapshot_current_thread() - switches_before;
    const std::uint64_t futex_waits = values.counters().futex_waits - counters_before.futex_waits;

    const std::vector<double> block = step.own_block();
    int identical = block.size() == reference_.size() &&
                    std::memcmp(block.data(), reference_.data(), block.size() * sizeof(double)) == 0;
    int all_identical = 0;
    const waiting_for_others waiting(dog);
    MPI_Reduce(&identical, &all_identical, 1, MPI_INT, MPI_LAND, 0, job_.comm);

    exchange_figures figures;
    figures.entry = &entry;
    figures.round = round;
    figures.step_ns = static_cast<double>(slowest) / static_cast<double>(settings_.steps);
    figures.bitwise = all_identical != 0;
    gather(figures, switches, futex_waits);
    return figures;
  }

  [[nodiscard]] const exchange_setup& setup() const noexcept { return setup_; }

 private:
  void gather(exchange_figures& figures, const platform::thread_counters& switches, std::uint64_t futex_waits) {
    const std::size_t stages = record_.arrival_ns.size();
    const bool root = job_.rank == 0;
    for (auto& arrival : record_.arrival_ns) arrival -= offset_;
    std::vector<std::int64_t> arrivals(root ? stages * static_cast<std::size_t>(job_.size) : 0);
    std::vector<std::int64_t> latencies(root ? stages * static_cast<std::size_t>(job_.size) : 0);
    MPI_Gather(record_.arrival_ns.data(), static_cast<int>(stages), MPI_INT64_T, arrivals.data(),
               static_cast<int>(stages), MPI_INT64_T, 0, job_.comm);
    MPI_Gather(record_.latency_ns.data(), static_cast<int>(stages), MPI_INT64_T, latencies.data(),
               static_cast<int>(stages), MPI_INT64_T, 0, job_.comm);
    // Per rank: cpu, switches, migrations (-1: unavailable), futex waits.
    const std::int64_t mine[5] = {
        placement_.bound_cpu(job_.rank) ? static_cast<std::int64_t>(*placement_.bound_cpu(job_.rank)) : -1,
        switches.total_switches(), switches.migrations.value_or(-1), static_cast<std::int64_t>(futex_waits), 0};
    std::vector<std::int64_t> per_rank(root ? 5 * static_cast<std::size_t>(job_.size) : 0);
    MPI_Gather(mine, 5, MPI_INT64_T, per_rank.data(), 5, MPI_INT64_T, 0, job_.comm);
    if (!root) return;

    const auto size = static_cast<std::size_t>(job_.size);
    std::vector<double> pooled(latencies.begin(), latencies.end());
    figures.stage_latency = platform::summarize(std::move(pooled));
    std::vector<double> skews(stages);
    std::vector<double> transfers(stages);
    figures.slowest_counts.assign(size, 0);
    for (std::size_t stage = 0; stage < stages; ++stage) {
      std::int64_t earliest = std::numeric_limits<std::int64_t>::max();
      std::int64_t latest = std::numeric_limits<std::int64_t>::min();
      std::int64_t last_departure = std::numeric_limits<std::int64_t>::min();
      std::size_t latest_rank = 0;
      for (std::size_t rank = 0; rank < size; ++rank) {
        const std::int64_t arrival = arrivals[rank * stages + stage];
        earliest = std::min(earliest, arrival);
        last_departure = std::max(last_departure, arrival + latencies[rank * stages + stage]);
        if (arrival > latest) {
          latest = arrival;
          latest_rank = rank;
        }
      }
      skews[stage] = static_cast<double>(latest - earliest);
      transfers[stage] = static_cast<double>(last_departure - latest);
      ++figures.slowest_counts[latest_rank];
    }
    figures.skew = platform::summarize(std::move(skews));
    figures.transfer = platform::summarize(std::move(transfers));
    for (std::size_t rank = 0; rank < size; ++rank) {
      rank_figures entry;
      entry.rank = static_cast<int>(rank);
      entry.host = job_.host_of_rank[rank];
      const std::int64_t* values = per_rank.data() + 5 * rank;
      if (values[0] >= 0) entry.cpu = static_cast<unsigned>(values[0]);
      entry.context_switches = values[1];
      if (values[2] >= 0) entry.migrations = values[2];
      entry.futex_waits = static_cast<std::uint64_t>(values[3]);
      std::vector<double> own(latencies.begin() + static_cast<std::ptrdiff_t>(rank * stages),
                              latencies.begin() + static_cast<std::ptrdiff_t>((rank + 1) * stages));
      const platform::distribution summary = platform::summarize(std::move(own));
      entry.stage_p50_ns = summary.p50;
      entry.stage_p99_ns = summary.p99;
      figures.ranks.push_back(std::move(entry));
    }
  }

  const world& job_;
  const benchmark_settings& settings_;
  Model model_;
  std::int64_t offset_;
  const rank_placement& placement_;
  exchange_setup setup_;
  std::vector<double> reference_;
  stage_record record_;
};

template <kernels::oscillator_model Model>
void run_exchanges(const world& job, const benchmark_settings& settings, const Model& model, std::int64_t offset,
                   watchdog& dog, const std::function<void(const std::string&)>& progress, benchmark_result& result) {
  exchange_runner<Model> runner(job, settings, model, offset, result.placement);
  dog.phase("building the exchanges");
  std::vector<std::unique_ptr<exchange>> built;
  for (const exchange_entry* entry : settings.exchanges) built.push_back(entry->make(runner.setup()));
  for (unsigned round = 0; round < settings.rounds; ++round) {
    result.pingpongs.push_back(pingpong(job, settings, round, dog));
    if (job.rank == 0)
      progress("round " + std::to_string(round + 1) + "/" + std::to_string(settings.rounds) + ": ping-pong " +
               std::to_string(static_cast<long long>(result.pingpongs.back().one_way_mean_ns)) + " ns one-way");
    for (std::size_t index = 0; index < built.size(); ++index) {
      result.exchanges.push_back(runner.measure(*settings.exchanges[index], *built[index], round, dog));
      if (job.rank == 0)
        progress("round " + std::to_string(round + 1) + "/" + std::to_string(settings.rounds) + ": " +
                 std::string(settings.exchanges[index]->label) + " " +
                 std::to_string(static_cast<long long>(result.exchanges.back().step_ns)) + " ns/step");
    }
  }
  dog.phase("freeing the exchanges");
  built.clear();  // collective: every rank frees its windows in the same order
}

}  // namespace

benchmark_result run_benchmark(const world& job, const benchmark_settings& settings, watchdog& dog,
                               const std::function<void(const std::string&)>& progress) {
  benchmark_result result;
  dog.phase("placing the ranks");
  // Loaded before anything pins this thread: its affinity set is what the rank was given.
  const platform::topology machine = platform::topology::this_machine();
  {
    const waiting_for_others waiting(dog);
    result.placement = place_ranks(job, settings.pin, machine);
  }
  if (job.rank == 0 && !result.placement.line.empty()) progress(result.placement.line);
  dog.phase("estimating clock offsets");
  result.one_clock = job.one_host();
  const std::int64_t offset = clock_offset(job, dog);
  if (settings.model.is_chain()) {
    run_exchanges(job, settings, kernels::chain_model(settings.model.chain()), offset, dog, progress, result);
  } else {
    run_exchanges(job, settings, kernels::two_mass_model(), offset, dog, progress, result);
  }
  return result;
}

}  // namespace lockstep::distributed
