// lockstep run: the benchmark matrix (README.md, Commands; its entries and
// counters: docs/names-and-counters.md).
//
// The command: its options, checked and turned into a bench::matrix_request
// (bench/run/matrix_run.hpp, which measures the matrix, the pairs and the
// pace trace and writes the result file atomically), then the summary on
// stdout (bench/run/summary.hpp). Progress goes to stderr. With --runs K it
// measures nothing itself: it runs this binary K times, one fresh process
// after another (run_group), each writing run-I.json into one directory,
// the replicates lockstep compare takes as one side. Each run gets the
// group's command line unchanged and its place in the group as data, in its
// environment (group_member).
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "bench/cli/options.hpp"
#include "bench/cli/command.hpp"
#include "bench/run/matrix_run.hpp"
#include "bench/run/run_book.hpp"
#include "bench/results/result_file.hpp"
#include "bench/run/summary.hpp"
#include "bench/run/run_plan.hpp"
#include "kernels/model_choice.hpp"
#include "platform/placement.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {

namespace {

struct run_options {
  std::optional<std::string> syncs;  // not given: the defaults
  std::optional<std::string> layouts;
  std::optional<std::string> pins;
  std::optional<std::string> threads;
  std::optional<std::size_t> masses;  // --masses: not given, each thread count's own model
  bool plan = false;                  // --plan: print what would run, measure nothing
  bool scaling = false;               // --scaling: the thread sweep, one placement
  bool crossover = false;             // --crossover: the model-size sweep after the matrix
  std::string crossover_budget;       // empty: bench::kCrossoverBudgetNs
  std::size_t crossover_max_masses = bench::kCrossoverMaxMasses;
  std::size_t crossover_through = 0;  // 0: a series stops once confirmed
  unsigned crossover_pairs = bench::kCrossoverPairs;
  int repetitions = 0;   // 0: the mode's default
  std::string min_time;  // empty: the mode's default
  std::string out;
  bool quick = false;
  bool verbose = false;  // every table of the summary, not only the answer
  bool no_accounting = false;
  bool no_interleave = false;
  bool interleave = false;  // the default now; kept so that older command lines still run
  int pairs = -1;           // -1: the mode's default
  double noise_pct = 100.0 * bench::kDefaultNoise;
  std::vector<std::string> benchmark_flags;
  std::optional<int> runs;  // --runs K: the matrix in K fresh processes, one file each, in one directory
};

// A run of a group (--runs K): what the group's parent hands each run it
// starts, beside the group's own command line, which the run gets unchanged:
// its index 1..K, K, and the file it writes. The parent sets them in the
// run's environment from its own numbers (run_group); a run reads them once,
// checked, before anything else is read or measured.
struct group_member {
  int index = 0;
  int runs = 0;
  std::string out;
};
inline constexpr const char* kRunIndexVariable = "LOCKSTEP_RUN_INDEX";
inline constexpr const char* kRunsVariable = "LOCKSTEP_RUNS";
inline constexpr const char* kRunOutVariable = "LOCKSTEP_RUN_OUT";

// The thread counts (run_plan.hpp says which by default and for --scaling),
// each a count its model can split (kernels/model_choice.hpp: only a chain
// chosen with --masses can have fewer equations than threads).
std::vector<unsigned> select_threads(const run_options& options, const platform::topology& machine) {
  std::vector<unsigned> threads;
  if (options.threads) {
    for (long long count : parse_number_list(*options.threads, "--threads", 1, 1024))
      threads.push_back(static_cast<unsigned>(count));
  } else if (options.scaling) {
    threads = bench::scaling_thread_counts(static_cast<unsigned>(machine.affinity().size()));
  } else {
    threads = bench::default_thread_counts(machine.core_count());
  }
  for (const unsigned count : threads) {
    const kernels::model_choice model = kernels::model_for(count, options.masses);
    if (count > model.equations())
      throw usage_error(fmt::format("--threads: {} threads cannot split {}: at most {} threads, one equation each",
                                    count, model.description(), model.equations()));
  }
  std::sort(threads.begin(), threads.end());
  threads.erase(std::unique(threads.begin(), threads.end()), threads.end());
  return threads;
}

// The machine a run measures, or, for --plan, the one it plans for: hwloc's
// HWLOC_SYNTHETIC or HWLOC_XMLFILE describe another machine, whose every PU
// counts as the affinity set (this process's own set belongs to this machine).
platform::topology machine_for(bool plan) {
  if (plan) {
    if (const char* synthetic = std::getenv("HWLOC_SYNTHETIC"); synthetic != nullptr && *synthetic != '\0')
      return platform::topology::from_synthetic(synthetic);
    if (const char* xml = std::getenv("HWLOC_XMLFILE"); xml != nullptr && *xml != '\0')
      return platform::topology::from_xml_file(xml);
  }
  platform::topology machine = platform::topology::this_machine();
  if (!plan && !machine.is_this_system())
    throw usage_error("HWLOC_SYNTHETIC or HWLOC_XMLFILE is set, so hwloc describes another machine: only --plan "
                      "can use it (unset it to measure this one)");
  return machine;
}

// The words this process was started with, its own name apart
// (/proc/self/cmdline): a group's runs get them as they are.
std::vector<std::string> own_arguments() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::vector<std::string> words;
  for (std::string word; std::getline(in, word, '\0');) words.push_back(word);
  if (!words.empty()) words.erase(words.begin());
  return words;
}

// The number in `variable`, whole, or nothing when it is not set.
std::optional<int> number_in_environment(const char* variable) {
  const char* text = std::getenv(variable);
  if (text == nullptr) return std::nullopt;
  const std::string_view value(text);
  int number = 0;
  const auto [end, error] = std::from_chars(value.data(), value.data() + value.size(), number);
  if (error != std::errc{} || end != value.data() + value.size())
    throw usage_error(fmt::format("{}: '{}' is not a number (lockstep run --runs sets it for each run)", variable,
                                  value));
  return number;
}

// This process's place in a group, when it is a run that a group's parent
// started (--runs K on its command line, and the parent's three variables).
std::optional<group_member> group_member_of(const run_options& options) {
  const std::optional<int> index = number_in_environment(kRunIndexVariable);
  if (!options.runs || !index) return std::nullopt;
  const std::optional<int> runs = number_in_environment(kRunsVariable);
  const char* out = std::getenv(kRunOutVariable);
  if (!runs || *runs != *options.runs || *index < 1 || *index > *runs || out == nullptr || *out == '\0')
    throw usage_error(fmt::format("{}, {} and {} do not describe a run of this group of {} (lockstep run --runs "
                                  "sets them for each run)",
                                  kRunIndexVariable, kRunsVariable, kRunOutVariable, *options.runs));
  return group_member{*index, *runs, out};
}

// The environment of a group's run: this process's, with the run's place.
std::vector<std::string> member_environment(const group_member& member) {
  std::vector<std::string> variables;
  for (char** variable = environ; *variable != nullptr; ++variable) {
    const std::string_view text(*variable);
    const std::string_view name = text.substr(0, text.find('='));
    if (name != kRunIndexVariable && name != kRunsVariable && name != kRunOutVariable) variables.emplace_back(text);
  }
  variables.push_back(fmt::format("{}={}", kRunIndexVariable, member.index));
  variables.push_back(fmt::format("{}={}", kRunsVariable, member.runs));
  variables.push_back(fmt::format("{}={}", kRunOutVariable, member.out));
  return variables;
}

// The directory of a group's run files: --out, or results/<host>-<timestamp>/.
// Refused (one line, exit 2) when it names a .json file, a file, or a
// directory that already holds run files; made here, before anything runs.
std::filesystem::path group_directory(const std::string& out, bool& made) {
  namespace fs = std::filesystem;
  std::string name = out;
  if (name.empty()) {
    name = bench::default_result_path();
    name.erase(name.size() - std::string(".json").size());
  }
  const fs::path directory(name);
  if (directory.extension() == ".json")
    throw usage_error(fmt::format("--out: with --runs, a directory for run-1.json ... run-K.json, not a .json "
                                  "file ('{}')", name));
  std::error_code error;
  if (fs::exists(directory, error)) {
    if (!fs::is_directory(directory, error)) throw usage_error(fmt::format("--out: '{}' is not a directory", name));
    for (const auto& item : fs::directory_iterator(directory, error))
      if (item.path().filename().string().rfind("run-", 0) == 0)
        throw usage_error(fmt::format("--out: '{}' already holds run files ({})", name,
                                      item.path().filename().string()));
    made = false;
    return directory;
  }
  const fs::path parent = directory.has_parent_path() ? directory.parent_path() : fs::path(".");
  if (!out.empty() && !fs::is_directory(parent, error))
    throw usage_error(fmt::format("--out: the directory '{}' does not exist", parent.string()));
  fs::create_directories(directory, error);
  if (error) throw usage_error(fmt::format("--out: cannot make '{}': {}", name, error.message()));
  made = true;
  return directory;
}

// --runs K: the matrix measured in K fresh processes one after another (this
// binary again, /proc/self/exe, with this command line), each writing
// run-I.json into the group's directory. A run that fails ends the group
// with its exit status; a directory this call made and no run wrote into is
// removed again.
int run_group(const run_options& options) {
  bool made = false;
  const std::filesystem::path directory = group_directory(options.out, made);
  std::vector<std::string> words{"lockstep"};
  for (auto& word : own_arguments()) words.push_back(std::move(word));
  std::vector<char*> argv;
  for (auto& word : words) argv.push_back(word.data());
  argv.push_back(nullptr);
  const int runs = *options.runs;
  for (int index = 1; index <= runs; ++index) {
    const group_member member{index, runs, (directory / fmt::format("run-{}.json", index)).string()};
    std::vector<std::string> environment = member_environment(member);
    std::vector<char*> envp;
    for (auto& variable : environment) envp.push_back(variable.data());
    envp.push_back(nullptr);
    fmt::print(stderr, "lockstep run: run {} of {} (a fresh process) into {}\n", index, runs, member.out);
    std::fflush(stdout);
    std::fflush(stderr);
    pid_t child = 0;
    int status = 0;
    if (::posix_spawn(&child, "/proc/self/exe", nullptr, nullptr, argv.data(), envp.data()) != 0 ||
        ::waitpid(child, &status, 0) != child || !WIFEXITED(status) || WEXITSTATUS(status) != kExitOk) {
      std::error_code error;
      if (made && std::filesystem::is_empty(directory, error)) std::filesystem::remove(directory, error);
      fmt::print(stderr, "lockstep run: run {} of {} failed; the group stops\n", index, runs);
      return WIFEXITED(status) && WEXITSTATUS(status) != kExitOk ? WEXITSTATUS(status) : kExitCheckFailed;
    }
  }
  fmt::print(stderr, "lockstep run: {} runs written to {}/ (compare them as one side: lockstep compare {}/ ...)\n",
             runs, directory.string(), directory.string());
  return kExitOk;
}

int execute(const run_options& options) {
  // The topology first: it reads the affinity set before anything pins.
  platform::topology machine = [&] {
    try {
      return machine_for(options.plan);
    } catch (const platform::topology_error& error) {
      throw usage_error(std::string("--plan: ") + error.what());
    }
  }();

  bench::run_selection selection;
  selection.syncs = select_names(options.syncs, sync_names(), "--sync");
  // The scaling sweep holds the placement still (compact unless --pin says).
  std::vector<std::string> default_pins =
      options.scaling ? std::vector<std::string>{"compact"} : std::vector<std::string>{"none", "compact"};
  const std::vector<std::string> pins =
      options.pins ? select_names(options.pins, placement_names(), "--pin") : default_pins;
  for (const auto& pin : pins) selection.pins.push_back(platform::parse_placement(pin));
  selection.masses = options.masses;
  selection.threads = select_threads(options, machine);
  selection.layouts = select_names(options.layouts, layout_names(), "--layout");
  bench::matrix_request request;
  request.selection = std::move(selection);
  request.quick = options.quick;
  request.repetitions = options.repetitions;
  request.min_time_ns = parse_duration_ns(
      options.min_time.empty() ? (options.quick ? bench::kQuickMinTime : bench::kDefaultMinTime) : options.min_time,
      "--min-time", 1'000'000, 60'000'000'000);
  request.accounting = !options.no_accounting;
  request.scaling = options.scaling;
  request.interleave = !options.no_interleave;
  request.pairs = options.pairs;
  request.noise = options.noise_pct / 100.0;
  request.benchmark_flags = options.benchmark_flags;
  if (options.crossover) {
    bench::crossover_settings crossover;
    if (!options.crossover_budget.empty())
      crossover.budget_ns = parse_duration_ns(options.crossover_budget, "--crossover-budget", 1'000'000'000,
                                              3'600'000'000'000);
    crossover.max_masses = options.crossover_max_masses;
    crossover.through_masses = options.crossover_through;
    crossover.pairs = options.crossover_pairs;
    if (crossover.through_masses > crossover.max_masses)
      throw usage_error(fmt::format("--crossover-through: {} masses is above --crossover-max-masses ({})",
                                    crossover.through_masses, crossover.max_masses));
    crossover.noise = request.noise;
    request.crossover = crossover;
  }
  const std::optional<group_member> member = group_member_of(options);
  if (member) {
    request.run_index = member->index;
    request.runs = member->runs;
  }
  if (options.runs && options.plan) {
    fmt::print("{}", bench::plan_text(request, machine));
    fmt::print("runs: {} (--runs), each a fresh process measuring the plan above, one after another: {} times "
               "its estimated time\n", *options.runs, *options.runs);
    return kExitOk;
  }
  if (options.runs && !member) return run_group(options);

  // Every option is read; now the result file, before anything is measured:
  // a destination that cannot be written fails here, in a millisecond. A
  // plan writes nothing. The default destination's directory (results/) is
  // made only now, and removed again if the run ends without a file, so a
  // refused run leaves nothing behind.
  std::optional<bench::atomic_result_file> result_file;
  if (!options.plan) {
    try {
      if (member)
        result_file.emplace(member->out);
      else if (options.out.empty())
        result_file.emplace(bench::default_result_path(), bench::make_directory::when_missing);
      else
        result_file.emplace(options.out);
    } catch (const bench::result_path_error& error) {
      throw usage_error(std::string("--out: ") + error.what());
    }
  }
  try {
    if (options.plan) {
      fmt::print("{}", bench::plan_text(request, machine));
      return kExitOk;
    }
    const bench::run_result result = bench::run_matrix(request, machine, *result_file);
    fmt::print("{}", bench::render_summary(result, result_file->destination(), options.verbose));
  } catch (const bench::matrix_request_error& error) {
    throw usage_error(error.what());
  }
  std::fflush(stdout);
  fmt::print(stderr, "lockstep run: results written to {}\n", result_file->destination());
  return kExitOk;
}

}  // namespace

void add_run(CLI::App& app, int& result) {
  auto options = std::make_shared<run_options>();
  CLI::App* run = app.add_subcommand(
      "run",
      "Run the benchmark matrix (sync x layout x placement x threads) and write Google Benchmark JSON.\n"
      "Google Benchmark's own flags go after --, e.g. lockstep run --quick -- --benchmark_filter=barrier");
  run->add_option("--sync", options->syncs, "Primitives, a comma list (default: all; `lockstep list` names them)");
  run->add_option("--layout", options->layouts, "Layouts, a comma list (default: all)");
  run->add_option("--pin", options->pins, "Placements, a comma list (default: none,compact)");
  run->add_option("--threads", options->threads,
                  "Thread counts, a comma list (default: the paper's 4, this machine's core count, and up to three "
                  "counts between; beyond 4 threads the model is a chain of one equation per thread)");
  add_masses_option(*run, options->masses, "thread");
  auto* plan = run->add_flag("--plan", options->plan,
                             "Print the entries the run would measure and its estimated time, measure nothing; "
                             "HWLOC_SYNTHETIC or HWLOC_XMLFILE plan for another machine");
  run->add_flag("--scaling", options->scaling,
                "The scaling sweep: threads 2, 4, 8, ... up to the CPUs (at least 8), pin:compact unless --pin, "
                "every layout; the summary draws sync time per stage against threads, per primitive on its best layout");
  auto* crossover = run->add_flag(
      "--crossover", options->crossover,
      "After the matrix, from what model size a parallel step pays off: per thread count above 1, the run's "
      "choice and std_barrier at pin:compact step a chain of S = 2, 4, 8, ... masses, each paired with the serial "
      "step of the same chain (a speedup with its interval); the crossover S* is where the speedup crosses 1, "
      "confirmed by a point above it; a series stops once two points in a row clear 1. In the answer and the "
      "JSON (lockstep_crossover); --plan estimates it");
  run->add_option("--crossover-budget", options->crossover_budget,
                  fmt::format("The crossover sweep's time in all, with a unit (default {}s; 1s to 3600s); the "
                              "sweep stops at the first size past it",
                              bench::kCrossoverBudgetNs / 1'000'000'000))
      ->needs(crossover);
  run->add_option("--crossover-max-masses", options->crossover_max_masses,
                  fmt::format("The crossover sweep's largest chain, in masses (default {})", bench::kCrossoverMaxMasses))
      ->check(CLI::Range(std::size_t{2}, std::size_t{1} << 20))
      ->needs(crossover);
  run->add_option("--crossover-through", options->crossover_through,
                  "Sweep every series up to at least this many masses, past a confirmed crossover (default: a "
                  "series stops once two sizes in a row clear 1)")
      ->check(CLI::Range(std::size_t{2}, std::size_t{1} << 20))
      ->needs(crossover);
  run->add_option("--crossover-pairs", options->crossover_pairs,
                  fmt::format("Pairs of alternating blocks per point of the crossover sweep (default {}): fewer "
                              "give a quicker sweep and wider intervals",
                              bench::kCrossoverPairs))
      ->check(CLI::Range(2U, 1000U))
      ->needs(crossover);
  run->add_option("--repetitions", options->repetitions,
                  fmt::format("Repetitions per entry (default {}; --quick {})", bench::kDefaultRepetitions, bench::kQuickRepetitions))
      ->check(CLI::Range(1, 1000));
  run->add_option("--min-time", options->min_time,
                  fmt::format("Measured time per repetition, with a unit (default {}; --quick {}): that many "
                              "timed batches of about 2 ms (--quick 0.5 ms), at least one",
                              bench::kDefaultMinTime, bench::kQuickMinTime));
  add_out_option(*run, options->out, "the result JSON (default results/<host>-<timestamp>.json; with --runs, the directory of the run files)")->excludes(plan);
  run->add_flag("--quick", options->quick, "Shorter runs: the whole matrix in well under 30 s on 2 cores");
  run->add_flag("--verbose", options->verbose,
                "Print every table when the run is over (the full ranking, the bare primitives, every paired ratio, "
                "the harness overhead, what was left out); by default the summary is the fastest few combinations "
                "and the answer, and the tables live in the JSON and the report");
  run->add_flag("--no-interleave", options->no_interleave,
                "Run every entry's repetitions back to back. The default shuffles the repetitions of all entries "
                "over the whole run (Google Benchmark's random interleaving), so that a machine that changes pace "
                "widens every entry's spread instead of shifting the entries that ran at the wrong moment");
  run->add_flag("--interleave", options->interleave, "The default (kept for older command lines)");
  run->add_option("--pairs", options->pairs,
                  fmt::format("Pairs of alternating blocks per paired comparison (the summary's ratios with "
                              "their intervals; default {}, --quick {}; 0: none)",
                              bench::kDefaultPairs, bench::kQuickPairs))
      ->check(CLI::Range(0, 1000));
  add_noise_option(*run, options->noise_pct,
                   "a paired ratio whose interval lies inside it is \"within noise\", one whose interval straddles "
                   "its edge \"unsure\"");
  run->add_flag("--no-accounting", options->no_accounting,
                "Per-thread accounting and sync-time instrumentation off (their counters are omitted)");
  run->add_option("--runs", options->runs,
                  "Measure the matrix K times, each run a fresh process, one after another: run-1.json ... "
                  "run-K.json in the directory --out names (default results/<host>-<timestamp>/), each stating its "
                  "index; lockstep compare takes the directory as one side, its runs as replicates")
      ->check(CLI::Range(1, 100))
      ->option_text("K");
  run->add_option("benchmark_flags", options->benchmark_flags, "Google Benchmark's flags, after --");
  run->callback([options, &result] { result = execute(*options); });
}

}  // namespace lockstep::cli
