// lockstep mpi: the RK4 step across MPI ranks (distributed/). Run directly,
// it checks every option and the user's files (--hostfile, --out), then
// launches mpirun for --ranks N on this host (or the hosts of --hostfile)
// with the user's own words for the ranks, and says the command it ran; run
// under mpirun, each rank checks the options again (never a file: it may run
// on a host where the user's files are not), measures, and rank 0 prints and
// writes the result (README.md says what it
// prints, docs/result-files.md what the file holds).
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cstdlib>
#include <algorithm>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <unistd.h>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "kernels/model_choice.hpp"

#if LOCKSTEP_HAVE_MPI
#include <nlohmann/json.hpp>

#include "bench/results/machine_context.hpp"
#include "bench/results/derived_figures.hpp"
#include "bench/results/result_file.hpp"
#include "bench/results/result_json.hpp"
#include "bench/run/rk4_entries.hpp"
#include "distributed/benchmark.hpp"
#include "distributed/launcher.hpp"
#include "distributed/registry.hpp"
#include "distributed/report.hpp"
#include "distributed/watchdog.hpp"
#include "distributed/world.hpp"
#include "platform/placement.hpp"
#include "platform/statistics.hpp"
#include "platform/topology.hpp"
#endif

namespace lockstep::cli {
namespace {

struct mpi_options {
  unsigned ranks = 0;  // 0: not given
  std::optional<std::string> exchanges;
  std::optional<std::string> syncs;
  std::string transport = "shm";
  std::string hostfile;
  std::string network;
  std::uint64_t steps = 5000;
  std::uint64_t warmup = 500;
  int repetitions = 5;  // compare needs 5 repetitions a side for an interval
  std::uint64_t pingpong = 10000;
  std::string pin = "compact";
  std::optional<std::size_t> masses;
  std::string watchdog = "10s";
  std::string mpirun = "mpirun";
  std::string out;
};

// The variable the launcher hands its command line down in, and the tests'
// fault injection ("stall:RANK:STEP", "die:RANK:STEP", or "slow:RANK:MS":
// rank RANK sleeps MS ms before every step of the first exchange's first round).
constexpr const char* kLaunchVariable = "LOCKSTEP_MPI_LAUNCH";
constexpr const char* kFaultVariable = "LOCKSTEP_MPI_FAULT";
// The launcher's status when the job failed otherwise (a rank died, stalled
// and was ended by its watchdog, or mpirun could not start it).
constexpr int kExitJobFailed = 3;

#if LOCKSTEP_HAVE_MPI
namespace dist = lockstep::distributed;

// What every rank and the launcher derive from the options, checked: bad
// input throws usage_error before anything is launched or measured. No file
// is read here (the launcher checks --hostfile and --out on its own).
struct checked_options {
  dist::transport how = dist::transport::shared_memory;
  std::vector<std::string> exchange_names;
  std::vector<std::string> sync_names;
  bool exchanges_named = false;
  kernels::model_choice model;
  platform::placement pin = platform::placement::compact;
  std::int64_t watchdog_ns = 0;
  dist::benchmark_settings::fault inject = dist::benchmark_settings::fault::none;
  int fault_rank = -1;
  std::uint64_t fault_step = 0;
};

checked_options check(const mpi_options& options, unsigned ranks) {
  checked_options checked;
  check_name(options.transport, {"shm", "tcp"}, "--transport: unknown value");
  if (options.transport == "tcp") checked.how = dist::transport::tcp;
  checked.exchange_names = select_names(options.exchanges, dist::exchange_names(), "--exchange");
  checked.sync_names = select_names(options.syncs, dist::exchange_syncs(), "--sync");
  checked.exchanges_named = options.exchanges.has_value() || options.syncs.has_value();
  if (ranks < 2) throw usage_error("--ranks: the step needs at least 2 ranks to exchange anything (got " +
                                   std::to_string(ranks) + ")");
  checked.model = kernels::model_for(ranks, options.masses);
  if (ranks > checked.model.equations())
    throw usage_error("--ranks " + std::to_string(ranks) + " cannot split " + checked.model.description() +
                      ": at most one rank per equation (" + std::to_string(checked.model.equations()) +
                      "); give --masses " + std::to_string((ranks + 1) / 2) + " or more");
  check_name(options.pin, placement_names(), "--pin: unknown value");
  try {
    checked.pin = platform::parse_placement(options.pin);
  } catch (const std::invalid_argument& e) {
    throw usage_error(std::string("--pin: ") + e.what());
  }
  if (checked.pin == platform::placement::migrate)
    throw usage_error("--pin: migrate moves threads of one process; ranks take none, compact, compact_smt or scatter");
  checked.watchdog_ns = parse_duration_ns(options.watchdog, "--watchdog", 100'000'000, 3'600'000'000'000);

  if (const char* fault = std::getenv(kFaultVariable); fault != nullptr && *fault != '\0') {
    char kind[16] = {};
    int rank = -1;
    unsigned long long step = 0;
    const bool parsed = std::sscanf(fault, "%15[a-z]:%d:%llu", kind, &rank, &step) == 3;
    const std::string_view named = kind;  // after sscanf filled it
    if (!parsed || (named != "stall" && named != "die" && named != "slow"))
      throw usage_error(std::string(kFaultVariable) + ": '" + fault +
                        "' is not stall:RANK:STEP, die:RANK:STEP or slow:RANK:MS");
    checked.inject = named == "stall" ? dist::benchmark_settings::fault::stall
                     : named == "die" ? dist::benchmark_settings::fault::die
                                      : dist::benchmark_settings::fault::slow;
    checked.fault_rank = rank;
    checked.fault_step = step;  // the step, or slow's milliseconds
  }
  return checked;
}

// The exchanges that can run on this job, in the order asked; an exchange the
// user named that cannot is bad input, one the default list holds is recorded
// as not applicable.
std::vector<const dist::exchange_entry*> applicable(const checked_options& checked, const dist::job_shape& job,
                                                    std::map<std::string, std::string>& not_applicable) {
  std::vector<const dist::exchange_entry*> result;
  const auto chosen = [](const std::vector<std::string>& names, std::string_view value) {
    return value.empty() || std::find(names.begin(), names.end(), value) != names.end();
  };
  for (const std::string& name : checked.exchange_names) {
    for (const dist::exchange_entry& entry : dist::exchanges()) {
      if (entry.name != name || !chosen(checked.sync_names, entry.sync)) continue;
      const std::string reason = entry.not_applicable(job);
      if (reason.empty()) {
        result.push_back(&entry);
      } else if (checked.exchanges_named) {
        throw usage_error("--exchange " + std::string(entry.label) + ": " + reason);
      } else {
        not_applicable[std::string(entry.label)] = reason;
      }
    }
  }
  if (result.empty()) throw usage_error("--exchange: none of the exchanges can run on this job");
  return result;
}

void launch(const mpi_options& options, int& result) {
  if (options.ranks == 0) throw usage_error("--ranks N is required when lockstep mpi is not run under mpirun");
  const checked_options checked = check(options, options.ranks);
  // The user's files, here only: a rank may run where they are not.
  std::vector<std::string> hosts;  // from --hostfile; empty: this host
  if (!options.hostfile.empty()) {
    try {
      hosts = dist::read_hostfile(options.hostfile);
    } catch (const std::invalid_argument& e) {
      throw usage_error(e.what());
    }
  }
  check_out(options.out);
  // The hosts the ranks span: dealt out host by host (--map-by node), the
  // hostfile's distinct hosts or the ranks, whichever is fewer.
  std::sort(hosts.begin(), hosts.end());
  hosts.erase(std::unique(hosts.begin(), hosts.end()), hosts.end());
  const int spanned = hosts.empty() ? 1 : static_cast<int>(std::min<std::size_t>(hosts.size(), options.ranks));
  const dist::job_shape shape{static_cast<int>(options.ranks), spanned,
                              checked.how};
  std::map<std::string, std::string> not_applicable;
  (void)applicable(checked, shape, not_applicable);

  const std::optional<std::string> mpirun = dist::find_program(options.mpirun);
  if (!mpirun)
    throw usage_error("cannot find " + options.mpirun +
                      " (install Open MPI: scripts/setup.sh installs openmpi-bin; or name one with --mpirun)");
  dist::launch_request request;
  request.mpirun = *mpirun;
  request.open_mpi = dist::is_open_mpi(*mpirun);
  request.ranks = options.ranks;
  request.how = checked.how;
  request.hostfile = options.hostfile;
  request.network = options.network;
  request.watchdog_ns = checked.watchdog_ns;
  request.host_cpus = platform::affinity_cpu_count();
  request.as_root = geteuid() == 0;
  request.executable = dist::this_executable();
  // The user's own words, every option as typed (the ranks know they are
  // ranks from the variables mpirun sets: distributed::launched_by_mpi).
  request.arguments = dist::own_arguments();
  request.forwarded = {kLaunchVariable};
  if (std::getenv(kFaultVariable) != nullptr) request.forwarded.emplace_back(kFaultVariable);
  dist::launch_plan plan;
  try {
    plan = dist::plan_launch(request);
  } catch (const std::invalid_argument& e) {
    throw usage_error(e.what());
  }
  const std::string shown = plan.shown();
  fmt::print(stderr, "lockstep mpi: running: {}\n", shown);
  plan.environment.emplace_back(kLaunchVariable, shown);
  const int status = dist::run_plan(plan);
  if (status != 0) {
    fmt::print(stderr, "lockstep mpi: the MPI job failed (mpirun exited with status {}); the lines above say which rank and why\n",
               status);
    result = status == kExitUsage || status == kExitCheckFailed ? status : kExitJobFailed;
    return;
  }
  result = kExitOk;
}

// Rank 0's readings: the text, and the result file (the measurement's own
// keys from distributed/report.hpp, the machine context beside them).
void report(const mpi_options& options, const checked_options& checked, const dist::world& job,
            const dist::benchmark_settings& settings, const dist::benchmark_result& measured,
            const std::map<std::string, std::string>& not_applicable, const std::string& launch_text, int& result) {
  dist::report_input input;
  input.job = &job;
  input.settings = &settings;
  input.measured = &measured;
  input.how = checked.how;
  input.pin = options.pin;
  input.watchdog_ns = checked.watchdog_ns;
  input.not_applicable = not_applicable;
  input.launch_text = launch_text;
  const dist::mpi_analysis analysis = dist::analyse(input);
  fmt::print("{}", dist::mpi_text(analysis));
  if (!options.out.empty()) {
    nlohmann::json document = bench::result_document("mpi", platform::topology::this_machine());
    bench::merge_into_result(document, dist::mpi_context(analysis));
    document.update(dist::mpi_json(analysis));
    bench::write_result_file(options.out, document.dump(2) + "\n");
    fmt::print("wrote {}\n", options.out);
  }
  if (!analysis.all_bitwise) {
    fmt::print(stderr, "lockstep mpi: a rank's block differs from the serial RK4 (bitwise column): the exchange is wrong\n");
    result = kExitCheckFailed;
    return;
  }
  result = kExitOk;
}

void run_as_rank(const mpi_options& options, int& result) {
  // Declared before the session, so that it goes after it: MPI_Finalize runs
  // watched (a rank that hangs there is ended like any other stall).
  std::optional<dist::watchdog> dog;
  dist::mpi_session session;
  const dist::world job = dist::describe_world();
  // Every rank checks the same options the same way. A rank that refuses says
  // so in one line with its rank and host, and then no rank goes on.
  checked_options checked;
  std::map<std::string, std::string> not_applicable;
  std::vector<const dist::exchange_entry*> exchanges;
  int refused = 0;
  try {
    if (options.ranks != 0 && options.ranks != static_cast<unsigned>(job.size))
      throw usage_error("--ranks " + std::to_string(options.ranks) + " but mpirun started " +
                        std::to_string(job.size) + " ranks");
    checked = check(options, static_cast<unsigned>(job.size));
    exchanges = applicable(checked, dist::job_shape{job.size, job.hosts, checked.how}, not_applicable);
  } catch (const usage_error& e) {
    fmt::print(stderr, "lockstep mpi: rank {} on {}: {}\n", job.rank, job.host, e.what());
    refused = 1;
  }
  int any_refused = 0;
  MPI_Allreduce(&refused, &any_refused, 1, MPI_INT, MPI_MAX, job.comm);
  if (any_refused != 0) {
    result = kExitUsage;
    return;
  }
  const char* launch_text = std::getenv(kLaunchVariable);

  dist::benchmark_settings settings;
  settings.exchanges = exchanges;
  settings.model = checked.model;
  settings.dt = bench::kBenchmarkStepSeconds;
  settings.steps = options.steps;
  settings.warmup_steps = options.warmup;
  settings.rounds = static_cast<unsigned>(options.repetitions);
  settings.pingpong_round_trips = options.pingpong;
  settings.pingpong_warmup = options.pingpong / 10;  // osu_latency's ratio: 1,000 skipped before 10,000 timed
  settings.pin = checked.pin;
  settings.inject = checked.inject;
  settings.fault_rank = checked.fault_rank;
  settings.fault_step = checked.fault_step;
  settings.fault_sleep_ms = checked.fault_step;

  dog.emplace(std::chrono::nanoseconds(checked.watchdog_ns), fmt::format("rank {} on {}", job.rank, job.host));
  const dist::benchmark_result measured = dist::run_benchmark(
      job, settings, *dog, [](const std::string& line) { fmt::print(stderr, "lockstep mpi: {}\n", line); });
  dog->phase("reporting");
  int status = kExitOk;
  if (job.rank == 0) {
    try {
      report(options, checked, job, settings, measured, not_applicable,
             launch_text != nullptr ? launch_text : "external (started by the user's mpirun)", status);
    } catch (const bench::result_path_error& e) {
      // --out was checked on the launcher's host; this one may differ.
      fmt::print(stderr, "lockstep mpi: rank {} on {}: --out: {}\n", job.rank, job.host, e.what());
      status = kExitUsage;
    }
  }
  MPI_Bcast(&status, 1, MPI_INT, 0, job.comm);
  dog->phase("finalising MPI");
  result = status;
}
#endif  // LOCKSTEP_HAVE_MPI

void run_mpi(const mpi_options& options, int& result) {
#if LOCKSTEP_HAVE_MPI
  if (distributed::launched_by_mpi())
    run_as_rank(options, result);
  else
    launch(options, result);
#else
  (void)options;
  (void)result;
#if LOCKSTEP_STATIC_BUILD
  // The static build (the bundle) carries no MPI: Open MPI has no static
  // library, and an MPI program must use the cluster's own MPI and launcher.
  throw usage_error(
      "this lockstep is the static bundle, built without MPI: build lockstep on the cluster, against its own MPI "
      "(README.md, \"Taking lockstep to another machine\")");
#else
  throw usage_error("this lockstep was built without MPI (install libopenmpi-dev: scripts/setup.sh, then rebuild)");
#endif
#endif
}

}  // namespace

void add_mpi(CLI::App& app, int& result) {
  auto options = std::make_shared<mpi_options>();
  auto* command = app.add_subcommand(
      "mpi",
      "The RK4 step across MPI ranks: per-stage exchange latency (p50..max), per-rank skew, step time and an OSU-style "
      "ping-pong, for each exchange (p2p, allgather, rma_put, shm_window). Exit status: 0 measured, 1 a rank's "
      "trajectory differs from the serial RK4, 2 bad input, 3 the job failed (a rank died or stalled)");
  command->add_option("--ranks", options->ranks,
                      "MPI ranks (one equation block each); lockstep launches mpirun for them, or checks the count it "
                      "runs under")
      ->check(CLI::Range(1U, 4096U));
  command->add_option("--exchange", options->exchanges,
                      "Comma list of exchanges: p2p, allgather, rma_put, shm_window (default: every one that applies)");
  command->add_option("--sync", options->syncs,
                      "Comma list of lockstep's primitives inside shm_window: futex_spin, mailbox (default: both)");
  command->add_option("--transport", options->transport,
                      "shm (shared memory between ranks on one host) or tcp (the TCP path, on loopback for one host)")
      ->capture_default_str();
  command->add_option("--hostfile", options->hostfile,
                      "Open MPI hostfile: run the ranks on these hosts, dealt out host by host (mpirun reaches them "
                      "with ssh, or the agent OMPI_MCA_plm_rsh_agent names)");
  command->add_option("--network", options->network,
                      "With --hostfile: the interface or CIDR the ranks and mpirun's daemons use between hosts "
                      "(Open MPI's btl_tcp_if_include and oob_tcp_if_include), e.g. eth1 or 10.0.0.0/24");
  command->add_option("--steps", options->steps, "Steps per measurement (untimed for the step time, then timed)")
      ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{10'000'000}))
      ->capture_default_str();
  command->add_option("--warmup", options->warmup, "Steps before each measurement")
      ->check(CLI::Range(std::uint64_t{0}, std::uint64_t{10'000'000}))
      ->capture_default_str();
  add_repetitions_option(*command, options->repetitions, 1000,
                         "a round, the ping-pong and every exchange measured in turn (compare needs 5 a side)",
                         "--rounds");
  command->add_option("--pingpong", options->pingpong, "Ping-pong round trips per round (after a tenth as many untimed, as osu_latency skips 1,000 of 10,000)")
      ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{100'000'000}))
      ->capture_default_str();
  command->add_option("--pin", options->pin, "Placement of a host's ranks: none, compact, compact_smt, scatter")
      ->capture_default_str();
  add_masses_option(*command, options->masses, "rank");
  command->add_option("--watchdog", options->watchdog,
                      "A rank that makes no progress for this long ends the job with a message")
      ->capture_default_str();
  command->add_option("--mpirun", options->mpirun, "The mpirun to launch (a name in PATH or a path)")
      ->capture_default_str();
  add_out_option(*command, options->out);
  command->callback([options, &result] { run_mpi(*options, result); });
}

}  // namespace lockstep::cli
