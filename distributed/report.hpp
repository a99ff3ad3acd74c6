#pragma once
// What a `lockstep mpi` measurement (benchmark.hpp) means, and its two
// readings: the text rank 0 prints and the result file's entries
// (docs/result-files.md, kind "mpi"). analyse() derives every figure once
// (medians over rounds, platform/statistics.hpp; each round's ratio to the
// ping-pong measured beside it; the slowest rank); mpi_text and mpi_json
// only arrange them. The machine context is the command's to add
// (bench/results/machine_context.hpp).
#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "distributed/benchmark.hpp"
#include "distributed/registry.hpp"
#include "distributed/world.hpp"

namespace lockstep::distributed {

// What the command knows beside the measurement.
struct report_input {
  const world* job = nullptr;
  const benchmark_settings* settings = nullptr;
  const benchmark_result* measured = nullptr;
  transport how = transport::shared_memory;
  std::string pin;                                   // as the user named it
  std::int64_t watchdog_ns = 0;
  std::map<std::string, std::string> not_applicable;  // entry name -> reason
  std::string launch_text;                           // the command that started the job
};

// One exchange over its rounds.
struct exchange_reading {
  const exchange_entry* entry = nullptr;
  std::string name;  // mpi/<segment>/ranks:N/hosts:H
  double step_median_ns = 0, step_min_ns = 0, step_max_ns = 0;
  double stage_p50_ns = 0, stage_p99_ns = 0, stage_p999_ns = 0, stage_max_ns = 0;  // medians over rounds
  double skew_p50_ns = 0, skew_p99_ns = 0;
  double transfer_p50_ns = 0;
  double over_pingpong_median = 0, over_pingpong_min = 0, over_pingpong_max = 0;
  int slowest_rank = 0;              // arrived last most often, over every round
  std::string slowest_rank_host;     // where it runs
  double slowest_rank_percent = 0;   // of the stages counted
  bool bitwise = true;               // every round
};

struct mpi_analysis {
  report_input input;
  std::string library_short;  // "Open MPI v4.1.4"
  double pingpong_median_ns = 0, pingpong_min_ns = 0, pingpong_max_ns = 0;  // one-way means over rounds
  std::map<unsigned, double> pingpong_of_round;  // each round's one-way mean
  std::vector<exchange_reading> exchanges;
  bool all_bitwise = true;
};

mpi_analysis analyse(const report_input& input);

// The whole text rank 0 prints.
std::string mpi_text(const mpi_analysis& analysis);

// The context keys of an MPI result file.
std::map<std::string, std::string> mpi_context(const mpi_analysis& analysis);

// The result file's own keys: settings, benchmarks (one entry per round and
// exchange, and per round for the ping-pong, in Google Benchmark's shape:
// real_time is a step's time, or the ping-pong's one-way time), exchanges
// (the last round's details), not_applicable and placement (every rank's
// kernel and CPUs, each kernel's ranks, whether two shared a CPU and what was
// done: rank_placement.hpp).
nlohmann::json mpi_json(const mpi_analysis& analysis);

}  // namespace lockstep::distributed
