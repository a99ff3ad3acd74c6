// `lockstep run` and `lockstep list` as a user runs them: bad input is one
// line and exit 2; a tiny run writes a JSON file that parses and carries the
// agreed names, counters and context keys; Ctrl-C leaves no result file.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <sstream>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "platform/placement.hpp"
#include "layouts/registry.hpp"
#include "sync/registry.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/scratch_directory.hpp"
#include "tests/support/watchdog.hpp"

namespace {

using lockstep::testing::count_lines;
using lockstep::testing::run_command;
using lockstep::testing::scratch_directory;
using lockstep::testing::watchdog;
namespace fs = std::filesystem;


// The primitive of a "kind/sync:S/..." entry, from the registry.
const lockstep::sync::primitive_info& primitive_of(const std::string& entry_name) {
  const std::size_t start = entry_name.find("/sync:") + 6;
  const std::string name = entry_name.substr(start, entry_name.find('/', start) - start);
  const lockstep::sync::primitive_info* info = lockstep::sync::find_primitive(name);
  if (info == nullptr) throw std::runtime_error("no primitive in " + entry_name);
  return *info;
}

std::vector<std::string> run_args(std::initializer_list<std::string> extra) {
  std::vector<std::string> args{LOCKSTEP_BINARY, "run"};
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

TEST(RunCli, BadInputIsOneLineAndExitTwo) {
  watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown), "lockstep run with bad input hung");
  const std::vector<std::vector<std::string>> bad_inputs{
      run_args({"--sync", "no_such_barrier"}),
      run_args({"--sync", "std_barrier,nope"}),
      run_args({"--pin", "everywhere"}),
      run_args({"--layout", "diagonal"}),
      run_args({"--threads", "0"}),
      run_args({"--threads", "two"}),
      run_args({"--threads", "2,5000"}),
      run_args({"--threads", "8", "--masses", "3"}),
      run_args({"--repetitions", "-3"}),
      run_args({"--repetitions", "many"}),
      run_args({"--", "--benchmark_out=/tmp/x.json"}),
      run_args({"--", "--benchmark_no_such_flag=1"}),
      run_args({"stray"}),
  };
  for (const auto& args : bad_inputs) {
    const auto result = run_command(args);
    std::string shown;
    for (const auto& arg : args) shown += arg + " ";
    EXPECT_EQ(result.exit_status, 2) << shown << "\nstderr: " << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << shown << "\nstderr: " << result.err;
    EXPECT_TRUE(result.out.empty()) << shown << "\nstdout: " << result.out;
  }
}

// --plan measures nothing and writes nothing: the entries, with chains past
// four threads, and the estimated time.
TEST(RunCli, PlanListsTheEntriesAndTheEstimateWithoutMeasuring) {
  watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown));
  const auto result = run_command(run_args({"--plan", "--sync", "mailbox,std_barrier", "--threads", "2,8"}));
  EXPECT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("estimated time: "), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("rk4/model:chain4/sync:mailbox/layout:per_thread/pin:compact/threads:8"),
            std::string::npos)
      << result.out;
  EXPECT_NE(result.out.find("rk4/model:chain4/serial"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("rk4/sync:std_barrier/layout:packed/pin:none/threads:2"), std::string::npos)
      << result.out;
  EXPECT_EQ(result.out.find("lockstep run: results written"), std::string::npos);
}

// --plan --crossover states the sweep and its estimate, here and for a
// many-core machine hwloc describes (HWLOC_SYNTHETIC).
TEST(RunCli, PlanStatesTheCrossoverSweepAndItsEstimate) {
  watchdog guard(std::chrono::seconds(60 * lockstep::testing::kSlowdown));
  const auto here = run_command(run_args({"--plan", "--threads", "2", "--crossover", "--crossover-budget", "90s"}));
  EXPECT_EQ(here.exit_status, 0) << here.err;
  EXPECT_NE(here.out.find("crossover sweep (--crossover): up to 3 series"), std::string::npos) << here.out;
  EXPECT_NE(here.out.find("budget 1 min 30 s"), std::string::npos) << here.out;
  EXPECT_NE(here.out.find("up to 2 more batches where its interval is wider than 10 % of its median"),
            std::string::npos)
      << here.out;
  const auto many = run_command({"/usr/bin/env", "HWLOC_SYNTHETIC=package:2 core:32 pu:1", LOCKSTEP_BINARY, "run", "--plan",
                                 "--crossover"});
  EXPECT_EQ(many.exit_status, 0) << many.err;
  EXPECT_NE(many.out.find("crossover sweep (--crossover): up to 15 series"), std::string::npos) << many.out;
  const auto without = run_command(run_args({"--plan", "--threads", "2"}));
  EXPECT_EQ(without.out.find("crossover sweep"), std::string::npos) << without.out;
  const auto more_pairs = run_command(run_args({"--plan", "--threads", "2", "--crossover", "--crossover-pairs", "40"}));
  EXPECT_EQ(more_pairs.exit_status, 0) << more_pairs.err;
  EXPECT_NE(more_pairs.out.find("40 pairs of 4.00 ms blocks a point"), std::string::npos) << more_pairs.out;
}

// --scaling: 2, 4 and 8 threads at pin:compact, the curve in the summary and
// in the JSON's lockstep_scaling (its values: tests/run/scaling_curve_test.cpp).
TEST(RunCli, ScalingWritesTheCurve) {
  watchdog guard(std::chrono::seconds(150 * lockstep::testing::kSlowdown), "lockstep run --scaling did not finish");
  scratch_directory scratch("lockstep-scaling-test");
  const fs::path out = scratch.path() / "scaling.json";
  const auto result = run_command(run_args({"--scaling", "--quick", "--sync", "mailbox,futex_spin", "--repetitions",
                                            "2", "--pairs", "0", "--out", out.string(), "--",
                                            "--benchmark_min_time=0.001"}));
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("Scaling (pin:compact;"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("Scales best: "), std::string::npos) << result.out;
  std::ifstream file(out);
  const nlohmann::json document = nlohmann::json::parse(file);
  ASSERT_TRUE(document.contains("lockstep_scaling"));
  const auto& curve = document["lockstep_scaling"];
  EXPECT_EQ(curve["pin"], "compact");
  EXPECT_EQ(curve["threads"], nlohmann::json::array({2, 4, 8}));
  std::set<std::pair<std::string, unsigned>> points;
  for (const auto& point : curve["points"]) {
    points.insert({point["sync"].get<std::string>(), point["threads"].get<unsigned>()});
    EXPECT_EQ(point["model"], point["threads"].get<unsigned>() > 4 ? "chain4" : "two_mass");
    EXPECT_LE(point["repetitions_min"].get<double>(), point["repetitions_max"].get<double>());
  }
  for (const char* sync : {"mailbox", "futex_spin"})
    for (const unsigned threads : {2U, 4U, 8U}) EXPECT_EQ(points.count({sync, threads}), 1U) << sync << " " << threads;
  ASSERT_TRUE(curve["best"].is_string());
  EXPECT_EQ(document["context"]["lockstep_scaling"], "on") << document["context"].dump();
}

TEST(RunCli, UnknownSyncListsTheValidOnes) {
  watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown));
  const auto result = run_command(run_args({"--sync", "nope"}));
  EXPECT_EQ(result.exit_status, 2);
  for (const auto& info : lockstep::sync::all_primitive_info)
    EXPECT_NE(result.err.find(std::string(info.name)), std::string::npos) << info.name << " missing in: " << result.err;
}

void expect_typed_entries(const nlohmann::json& document);

TEST(RunCli, TinyRunWritesAgreedJson) {
  watchdog guard(std::chrono::seconds(150 * lockstep::testing::kSlowdown), "a tiny lockstep run did not finish");
  scratch_directory scratch("lockstep-run-test");
  const fs::path out = scratch.path() / "tiny.json";
  const auto result = run_command(run_args({"--quick", "--sync", "std_barrier,futex_spin,seqlock", "--layout",
                                            "padded64,per_thread", "--threads", "2", "--pin", "compact",
                                            "--repetitions", "2", "--out", out.string(), "--",
                                            "--benchmark_min_time=0.001"}));
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find(out.string()), std::string::npos) << "the summary names the result file:\n" << result.out;
  EXPECT_NE(result.err.find("entries complete"), std::string::npos) << "progress on stderr:\n" << result.err;
  // The short summary ends with the answer, and says where the tables are.
  EXPECT_NE(result.out.find("The answer on this machine"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("lockstep run --verbose"), std::string::npos) << result.out;
  EXPECT_EQ(result.out.find("Paired ratios:"), std::string::npos) << "a table outside --verbose:\n" << result.out;

  // Only the result file: no temporary left behind.
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(out.parent_path())) files.push_back(entry.path().filename());
  EXPECT_EQ(files, std::vector<std::string>{"tiny.json"});

  std::ifstream file(out);
  const nlohmann::json document = nlohmann::json::parse(file);  // throws (fails) if it does not parse
  ASSERT_TRUE(document.contains("context"));
  ASSERT_TRUE(document.contains("benchmarks"));
  for (const char* key : {"lockstep_version", "lockstep_schema", "git_revision", "compiler", "cxx_flags", "build_type",
                          "cpu_model", "hypervisor", "kernel", "topology", "topology_packages", "topology_l3",
                          "topology_cores", "topology_pus", "hwloc_version", "benchmark_version", "boost_version",
                          "c2c_one_way_ns", "serial_step_ns", "oversubscribed_note"}) {
    ASSERT_TRUE(document["context"].contains(key)) << "context lacks " << key;
    EXPECT_TRUE(document["context"][key].is_string()) << key << " must be a string";
  }

  std::set<std::string> names;
  for (const auto& entry : document["benchmarks"])
    if (entry.value("run_type", "") == "iteration") names.insert(entry["name"].get<std::string>());
  for (const char* name : {"rk4/serial", "barrier/sync:std_barrier/pin:compact/threads:2",
                           "barrier/sync:futex_spin/pin:compact/threads:2",
                           "rk4/sync:std_barrier/layout:padded64/pin:compact/threads:2",
                           "rk4/sync:futex_spin/layout:per_thread/pin:compact/threads:2",
                           "rk4/sync:seqlock/layout:per_thread/pin:compact/threads:2",
                           "overhead/accounting:off/sync:seqlock/layout:per_thread/pin:compact/threads:2",
                           "overhead/accounting:on/sync:seqlock/layout:per_thread/pin:compact/threads:2"})
    EXPECT_TRUE(names.count(name)) << "missing entry " << name;
  if (lockstep::platform::affinity_cpu_count() >= 2) {
    EXPECT_TRUE(names.count("c2c/pin:compact/threads:2"));
  }
  // A dataflow channel on a shared layout is listed as not applicable, with the reason.
  const std::string not_applicable = document["context"].value("not_applicable", "");
  EXPECT_NE(not_applicable.find("rk4/sync:seqlock/layout:padded64/pin:compact/threads:2: "), std::string::npos)
      << not_applicable;
  const bool migrations = document["context"].value("migrations", "").rfind("available", 0) == 0;
  // The primitives that cannot count their futex waits are named in the context.
  EXPECT_EQ(document["context"].value("futex_waits_unavailable", ""), "std_barrier,pthread_barrier,omp_barrier");

  for (const auto& entry : document["benchmarks"]) {
    const std::string name = entry["name"];
    if (entry.value("run_type", "") != "iteration" || entry.value("error_occurred", false)) continue;
    if (name.rfind("barrier/", 0) == 0) {
      for (const char* counter : {"ns_per_episode", "timeouts", "oversubscribed"})
        EXPECT_TRUE(entry.contains(counter)) << name << " lacks " << counter;
      // The primitive's own counters: present exactly when it can count them (never a 0 nobody counted).
      const bool counts = primitive_of(name).counts_futex_waits;
      for (const char* counter : {"futex_waits_per_episode", "futex_wakes_per_episode", "yields_per_episode",
                                  "spins_exhausted_per_episode"})
        EXPECT_EQ(entry.contains(counter), counts) << name << ": " << counter;
      EXPECT_GT(entry["ns_per_episode"].get<double>(), 0.0) << name;
    }
    if (name.rfind("rk4/sync:", 0) == 0) {
      for (const char* counter : {"ns_per_step", "sync_ns_per_stage", "vs_serial", "csw_vol_per_kstep",
                                  "csw_invol_per_kstep", "timeouts", "oversubscribed"})
        EXPECT_TRUE(entry.contains(counter)) << name << " lacks " << counter;
      // futex_waits_per_step: exactly for the primitives that count it (futex_spin, seqlock here), absent
      // (unavailable) for those whose futex calls are hidden in a library (std_barrier here).
      EXPECT_EQ(entry.contains("futex_waits_per_step"), primitive_of(name).counts_futex_waits) << name;
      EXPECT_EQ(entry.contains("futex_waits_per_step"), name.find("/sync:std_barrier/") == std::string::npos) << name;
      if (lockstep::platform::affinity_cpu_count() >= 2) {
        EXPECT_TRUE(entry.contains("vs_c2c")) << name;
      }
      // Two threads pinned on two CPUs: the latency between them, measured in
      // the same call, and the stage sync against it.
      if (lockstep::platform::affinity_cpu_count() >= 2 && name.find("/pin:compact/threads:2") != std::string::npos) {
        EXPECT_GT(entry.value("c2c_paired_ns", 0.0), 0.0) << name;
        EXPECT_TRUE(entry.contains("vs_c2c_paired")) << name;
      }
      // Migrations: a counter when the machine gives them, absent (never 0 made up) when not.
      EXPECT_EQ(entry.contains("migrations_per_kstep"), migrations) << name;
      // The step split into compute, waiting for others and synchronisation
      // (docs/names-and-counters.md): the three together or none, and a
      // barrier's sampled syncs are always split (kernels/parallel_step.hpp),
      // so a barrier entry has them. They add up to the step unless compute
      // was clamped at 0.
      const char* const parts[] = {"compute_ns_per_step", "waiting_ns_per_step", "release_ns_per_step"};
      const auto present = std::count_if(std::begin(parts), std::end(parts),
                                         [&](const char* counter) { return entry.contains(counter); });
      EXPECT_TRUE(present == 0 || present == 3) << name << " has " << present << " of the step's three parts";
      if (primitive_of(name).kind == lockstep::sync::primitive_kind::barrier) {
        EXPECT_EQ(present, 3) << name;
      }
      if (present == 3) {
        const double compute = entry["compute_ns_per_step"].get<double>();
        const double waiting = entry["waiting_ns_per_step"].get<double>();
        const double release = entry["release_ns_per_step"].get<double>();
        EXPECT_GE(compute, 0.0) << name;
        EXPECT_GE(waiting, 0.0) << name;
        if (compute > 0.0) {
          EXPECT_NEAR(compute + waiting + release, entry["ns_per_step"].get<double>(),
                      1e-6 * entry["ns_per_step"].get<double>())
              << name;
        }
        EXPECT_NEAR(waiting + release, 4.0 * entry["sync_ns_per_stage"].get<double>(), 1e-6 * (1.0 + waiting))
            << name;
      }
    }
    if (name.rfind("overhead/accounting:off/", 0) == 0) {
      EXPECT_TRUE(entry.contains("ns_per_step")) << name;
      EXPECT_FALSE(entry.contains("sync_ns_per_stage")) << name << ": instrumentation must be off";
      EXPECT_FALSE(entry.contains("waiting_ns_per_step")) << name << ": instrumentation must be off";
      EXPECT_FALSE(entry.contains("csw_vol_per_kstep")) << name << ": accounting must be off";
    }
    if (name == "rk4/serial") {
      EXPECT_GT(entry["ns_per_step"].get<double>(), 0.0);
    }
  }
  expect_typed_entries(document);
}

// Every row, repetitions and aggregates alike, carries its entry's spec as
// values (bench/results/entry_spec.hpp), the same fields its name spells.
void expect_typed_entries(const nlohmann::json& document) {
  const nlohmann::json null;
  // name -> kind, sync, layout, pin, threads, accounting, unit
  const std::map<std::string, nlohmann::json> expected{
      {"rk4/serial", {"serial", null, null, null, 1, true, "step"}},
      {"c2c/pin:compact/threads:2", {"c2c", null, null, "compact", 2, true, "one_way"}},
      {"barrier/sync:futex_spin/pin:compact/threads:2", {"barrier", "futex_spin", null, "compact", 2, true, "episode"}},
      {"rk4/sync:seqlock/layout:per_thread/pin:compact/threads:2",
       {"rk4", "seqlock", "per_thread", "compact", 2, true, "step"}},
      {"overhead/accounting:off/sync:seqlock/layout:per_thread/pin:compact/threads:2",
       {"overhead", "seqlock", "per_thread", "compact", 2, false, "step"}}};
  std::set<std::string> seen;
  for (const auto& row : document["benchmarks"]) {
    const std::string name = row["run_name"];
    ASSERT_TRUE(row.contains("lockstep_entry")) << row["name"];
    const nlohmann::json& spec = row["lockstep_entry"];
    EXPECT_EQ(spec["model"], "") << name;
    EXPECT_EQ(spec["masses"], 0) << name;
    const auto found = expected.find(name);
    if (found == expected.end()) continue;
    seen.insert(name);
    const nlohmann::json& want = found->second;
    std::size_t field = 0;
    for (const char* key : {"kind", "sync", "layout", "pin", "threads", "accounting", "unit"})
      EXPECT_EQ(spec[key], want[field++]) << name << ": " << key;
  }
  EXPECT_GE(seen.size(), expected.size() - 1) << "c2c needs two CPUs; every other entry was measured";
}

// Every thread count the options accept runs, one included: `--threads 1`
// measures every primitive with every layout it applies to, unpinned and
// pinned (the instrumented entries and the overhead pair too), or lists the
// pair as not applicable; a run of one thread once ended in "internal error:
// thread 1 is not in a plan of 1 threads" (exit 3), from the 2-thread
// core-to-core pairing asking a 1-thread plan for its second thread.
TEST(RunCli, OneThreadRunsEveryPrimitiveAndLayout) {
  watchdog guard(std::chrono::seconds(200 * lockstep::testing::kSlowdown), "a one-thread lockstep run did not finish");
  scratch_directory scratch("lockstep-run-one-thread");
  const fs::path out = scratch.path() / "one.json";
  const auto result = run_command(run_args({"--quick", "--threads", "1", "--repetitions", "1", "--pairs", "0",
                                            "--out", out.string(), "--", "--benchmark_min_time=0.001"}));
  ASSERT_EQ(result.exit_status, 0) << result.err;
  std::ifstream file(out);
  const nlohmann::json document = nlohmann::json::parse(file);
  std::set<std::string> measured;
  for (const auto& entry : document["benchmarks"]) {
    if (entry.value("run_type", "") != "iteration") continue;
    const std::string name = entry["name"];
    EXPECT_FALSE(entry.value("error_occurred", false)) << name << ": " << entry.value("error_message", "");
    if (!entry.value("error_occurred", false)) measured.insert(name);
  }
  const std::string not_applicable = document["context"].value("not_applicable", "");
  for (const auto& primitive : lockstep::sync::all_primitive_info)
    for (const auto& layout : lockstep::layouts::all_layout_info)
      for (const char* pin : {"none", "compact"}) {
        const std::string name = "rk4/sync:" + std::string(primitive.name) + "/layout:" + std::string(layout.name) +
                                 "/pin:" + pin + "/threads:1";
        EXPECT_TRUE(measured.count(name) > 0 || not_applicable.find(name + ": ") != std::string::npos)
            << name << " neither measured nor listed as not applicable";
      }
  EXPECT_TRUE(measured.count("overhead/accounting:on/sync:seqlock/layout:per_thread/pin:compact/threads:1"))
      << "the instrumented overhead entry at one thread";
}

// The pace trace and the paired comparisons (bench/run: pace.hpp,
// paired_blocks.hpp), as reports/ reads them: a reading per repetition with
// its mode, the trace's modes and changes, and each summary ratio as pairs
// with an interval around its median and a verdict.
TEST(RunCli, RunWritesThePaceTraceAndThePairedRatios) {
  watchdog guard(std::chrono::seconds(150 * lockstep::testing::kSlowdown), "a paired lockstep run did not finish");
  scratch_directory scratch("lockstep-run-test");
  const fs::path out = scratch.path() / "paired.json";
  const auto result = run_command(run_args({"--quick", "--sync", "futex_spin,seqlock", "--layout", "per_thread,packed",
                                            "--threads", "2", "--pin", "compact", "--repetitions", "2", "--pairs", "4",
                                            "--verbose", "--out", out.string(), "--", "--benchmark_min_time=0.001"}));
  ASSERT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("Pace of the machine"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("Paired ratios"), std::string::npos) << result.out;
  std::ifstream file(out);
  const nlohmann::json document = nlohmann::json::parse(file);
  EXPECT_EQ(document["context"].value("lockstep_order", "").rfind("random interleaving", 0), 0u);

  ASSERT_TRUE(document.contains("lockstep_pace"));
  const nlohmann::json& pace = document["lockstep_pace"];
  ASSERT_FALSE(pace["readings"].empty());
  ASSERT_FALSE(pace["modes"].empty());
  const auto modes = static_cast<int>(pace["modes"].size());
  double last_t = 0.0;
  for (const auto& reading : pace["readings"]) {
    EXPECT_GE(reading["t_s"].get<double>(), last_t);
    last_t = reading["t_s"].get<double>();
    EXPECT_GT(reading["serial_ns"].get<double>(), 0.0);
    EXPECT_GE(reading["mode"].get<int>(), -1);
    EXPECT_LT(reading["mode"].get<int>(), modes);
  }
  EXPECT_EQ(document["context"].value("pace_summary", ""), pace["summary"].get<std::string>());

  std::size_t paced_rows = 0;
  for (const auto& row : document["benchmarks"]) {
    EXPECT_FALSE(row.contains("pace_reading_before")) << row.dump();
    EXPECT_FALSE(row.contains("pace_reading_after")) << row.dump();
    const std::string name = row["name"];
    const bool measured = name.rfind("rk4/sync:", 0) == 0 || name.rfind("barrier/", 0) == 0;
    if (!measured || row.value("error_occurred", false)) continue;
    if (row.value("run_type", "") == "iteration") {
      ++paced_rows;
      ASSERT_TRUE(row.contains("pace_mode")) << row.dump();
      EXPECT_TRUE(row["pace_mode"].is_number_integer()) << row.dump();
      EXPECT_GT(row["pace_serial_ns"].get<double>(), 0.0);
    } else {
      EXPECT_FALSE(row.contains("pace_mode")) << "an aggregate of mode indices means nothing: " << row.dump();
    }
  }
  EXPECT_GT(paced_rows, 0u);

  ASSERT_TRUE(document.contains("lockstep_pairs"));
  ASSERT_FALSE(document["lockstep_pairs"].empty());
  for (const auto& pair : document["lockstep_pairs"]) {
    const auto& ratios = pair["ratios"];
    ASSERT_GE(ratios.size(), 3u);
    EXPECT_LE(ratios.size(), 4u);
    EXPECT_EQ(pair["modes"].size(), ratios.size());
    EXPECT_LE(pair["ci_low"].get<double>(), pair["median"].get<double>());
    EXPECT_GE(pair["ci_high"].get<double>(), pair["median"].get<double>());
    const std::string verdict = pair["verdict"];
    EXPECT_TRUE(verdict == "penalty" || verdict == "gain" || verdict == "within noise" || verdict == "unsure")
        << verdict;
    if (verdict == "penalty") {
      EXPECT_GT(pair["ci_low"].get<double>(), 1.05);
    }
    if (verdict == "gain") {
      EXPECT_LT(pair["ci_high"].get<double>(), 1.0 / 1.05);
    }
    EXPECT_NE(pair["a"], pair["b"]);
  }
}

// With the repetitions shuffled over the run, a calibration may finish after
// the entries that divide by it: the ratios are derived after the run, so
// every repetition and every aggregate of every rk4 entry still has them, and
// each is its counter over the context's calibration.
TEST(RunCli, InterleavedRunDerivesRatiosFromTheWholeRun) {
  watchdog guard(std::chrono::seconds(150 * lockstep::testing::kSlowdown), "an interleaved lockstep run did not finish");
  scratch_directory scratch("lockstep-run-test");
  const fs::path out = scratch.path() / "interleaved.json";
  const auto result = run_command(run_args({"--quick", "--interleave", "--sync", "futex_spin,seqlock", "--layout",
                                            "per_thread", "--threads", "2", "--pin", "compact", "--repetitions", "3",
                                            "--verbose", "--out", out.string(), "--", "--benchmark_min_time=0.001"}));
  ASSERT_EQ(result.exit_status, 0) << result.err;
  std::ifstream file(out);
  const nlohmann::json document = nlohmann::json::parse(file);
  const nlohmann::json& context = document["context"];
  EXPECT_EQ(context.value("lockstep_order", "").rfind("random interleaving", 0), 0u) << context.dump();
  ASSERT_TRUE(context.contains("clock_read_ns"));
  EXPECT_GT(std::stod(context["clock_read_ns"].get<std::string>()), 0.0);
  const double serial = std::stod(context["serial_step_ns"].get<std::string>());
  const bool have_c2c = lockstep::platform::affinity_cpu_count() >= 2;
  std::size_t rows = 0;
  for (const auto& entry : document["benchmarks"]) {
    const std::string name = entry["name"];
    if (name.rfind("rk4/sync:", 0) != 0 || entry.value("error_occurred", false)) continue;
    ++rows;
    const bool cv = entry.value("aggregate_unit", "") == "percentage";
    // The context rounds the calibrations (0.1 ns, 0.01 ns): compare within 1%.
    const auto expect_ratio = [&](const char* ratio, const char* counter, double base) {
      ASSERT_TRUE(entry.contains(ratio)) << name << " " << entry.value("aggregate_name", "") << " lacks " << ratio;
      const double expected = cv ? entry[counter].get<double>() : entry[counter].get<double>() / base;
      EXPECT_NEAR(entry[ratio].get<double>(), expected, std::abs(expected) * 0.01) << name << " " << ratio;
    };
    expect_ratio("vs_serial", "ns_per_step", serial);
    if (have_c2c) expect_ratio("vs_c2c", "sync_ns_per_stage", std::stod(context["c2c_one_way_ns"].get<std::string>()));
  }
  // Two entries, three repetitions and four aggregates (mean, median, stddev, cv) each.
  EXPECT_EQ(rows, 14u) << result.out;
  EXPECT_NE(result.out.find("vs_c2c"), std::string::npos) << result.out;
}

TEST(RunCli, InterruptLeavesNoResultFile) {
  watchdog guard(std::chrono::seconds(120 * lockstep::testing::kSlowdown), "an interrupted run did not end");
  scratch_directory scratch("lockstep-run-test");
  const fs::path out = scratch.path() / "interrupted.json";
  std::vector<std::string> args = run_args({"--sync", "std_barrier", "--repetitions", "50", "--out", out.string()});
  std::vector<char*> argv;
  for (auto& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  ASSERT_EQ(::posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);

  // Wait until Google Benchmark writes into the temporary file, then interrupt.
  bool partial_seen = false;
  for (int poll = 0; poll < 600 && !partial_seen; ++poll) {
    for (const auto& entry : fs::directory_iterator(scratch.path()))
      if (entry.path().filename().string().find(".partial-") != std::string::npos) partial_seen = true;
    if (!partial_seen) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // mid-run
  ASSERT_EQ(::kill(pid, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(partial_seen) << "the run never started writing";
  ASSERT_TRUE(WIFEXITED(status)) << "the run died by a signal instead of handling it";
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGINT);
  EXPECT_TRUE(fs::is_empty(scratch.path())) << "an interrupted run left a file behind";
}

// The thread counts named on the lines of one section of the summary (from
// the line that starts with `heading` to the next blank line), in order.
std::vector<unsigned> threads_in_section(const std::string& text, const std::string& heading) {
  const std::size_t start = text.find(heading);
  if (start == std::string::npos) return {};
  const std::size_t end = text.find("\n\n", start);
  const std::string section = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
  std::vector<unsigned> found;
  const std::regex threads(R"(threads:(\d+))");
  for (auto match = std::sregex_iterator(section.begin(), section.end(), threads); match != std::sregex_iterator();
       ++match)
    found.push_back(static_cast<unsigned>(std::stoul((*match)[1])));
  return found;
}

// A run at 2, 4, 8 and 16 threads (oversubscribed on a small machine) prints
// every table in numeric thread order: the thread counts sorted as text put
// "16" before "2" in the bare primitives' table. Its own figures are not read.
TEST(RunCli, ARunOfTwoToSixteenThreadsPrintsEveryTableInThreadOrder) {
  watchdog guard(std::chrono::seconds(240 * lockstep::testing::kSlowdown), "the 2..16-thread run did not finish");
  scratch_directory scratch("lockstep-thread-order-test");
  const fs::path out = scratch.path() / "order.json";
  const auto result = run_command(run_args({"--quick", "--threads", "2,4,8,16", "--sync", "mailbox,std_barrier",
                                            "--layout", "per_thread,packed", "--pin", "compact", "--min-time", "1ms",
                                            "--repetitions", "1", "--pairs", "2", "--verbose", "--out",
                                            out.string()}));
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const std::vector<unsigned> all{2, 4, 8, 16};
  std::vector<unsigned> episodes = threads_in_section(result.out, "Bare primitives, median time per episode:");
  EXPECT_TRUE(std::is_sorted(episodes.begin(), episodes.end())) << result.out;
  episodes.erase(std::unique(episodes.begin(), episodes.end()), episodes.end());
  EXPECT_EQ(episodes, all) << result.out;
  // Per section, the lines that name a group: each kind's groups in order.
  for (const auto& [heading, prefix] : std::vector<std::pair<std::string, std::string>>{
           {"Each primitive against the best other", "  RK4 step"},
           {"Each primitive against the best other", "  bare episode"},
           {"Collapsed (", "  "},
           {"Ran oversubscribed", "Ran oversubscribed"},
           {"The answer on this machine", "  threads:"},
           {"The answer on this machine", "  model:"}}) {
    std::vector<unsigned> threads;
    const std::size_t start = result.out.find(heading);
    if (start == std::string::npos) continue;  // no such section in this run (nothing collapsed, say)
    std::istringstream lines(result.out.substr(start, result.out.find("\n\n", start) - start));
    for (std::string line; std::getline(lines, line);)
      if (line.rfind(prefix, 0) == 0)
        for (const unsigned count : threads_in_section(line, prefix)) threads.push_back(count);
    EXPECT_TRUE(std::is_sorted(threads.begin(), threads.end())) << heading << " / " << prefix << "\n" << result.out;
  }
}

// --runs K: K fresh processes, run-1.json .. run-K.json, each stating its
// place in the group as numbers (lockstep_run_index, lockstep_runs).
TEST(RunCli, RunsOfAGroupStateTheirIndexAndCountAsNumbers) {
  watchdog guard(std::chrono::seconds(240 * lockstep::testing::kSlowdown), "lockstep run --runs 2 did not finish");
  scratch_directory scratch("lockstep-runs-test");
  const fs::path group = scratch.path() / "group";
  const auto result = run_command(run_args({"--runs", "2", "--quick", "--threads", "2", "--sync", "mailbox",
                                            "--layout", "per_thread", "--pin", "compact", "--min-time", "1ms",
                                            "--repetitions", "1", "--pairs", "0", "--out", group.string()}));
  ASSERT_EQ(result.exit_status, 0) << result.err;
  for (const int index : {1, 2}) {
    std::ifstream file(group / ("run-" + std::to_string(index) + ".json"));
    ASSERT_TRUE(file) << "run-" << index << ".json missing: " << result.err;
    const nlohmann::json document = nlohmann::json::parse(file);
    EXPECT_EQ(document["context"]["lockstep_run_index"], index);
    EXPECT_TRUE(document["context"]["lockstep_run_index"].is_number_integer());
    EXPECT_EQ(document["context"]["lockstep_runs"], 2);
  }
  // A run's place in its group is the parent's data: set by hand, a wrong one is refused.
  const auto refused = run_command({"/usr/bin/env", "LOCKSTEP_RUN_INDEX=3", "LOCKSTEP_RUNS=2",
                                    "LOCKSTEP_RUN_OUT=" + (scratch.path() / "x.json").string(), LOCKSTEP_BINARY,
                                    "run", "--runs", "2", "--out", group.string()});
  EXPECT_EQ(refused.exit_status, 2) << refused.err;
  EXPECT_EQ(count_lines(refused.err), 1) << refused.err;
  EXPECT_FALSE(fs::exists(scratch.path() / "x.json"));
}

TEST(ListCli, NamesEverySyncAndPlacementOnALineEach) {
  watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown));
  const auto result = run_command({LOCKSTEP_BINARY, "list"});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const auto line_starting = [&](const std::string& name) {
    std::size_t lines = 0;
    std::size_t start = 0;
    while (start < result.out.size()) {
      std::size_t end = result.out.find('\n', start);
      if (end == std::string::npos) end = result.out.size();
      const std::string line = result.out.substr(start, end - start);
      if (line.rfind("  " + name + " ", 0) == 0 && line.size() > name.size() + 10) ++lines;
      start = end + 1;
    }
    return lines;
  };
  for (const auto& info : lockstep::sync::all_primitive_info)
    EXPECT_EQ(line_starting(std::string(info.name)), 1u) << info.name << " in:\n" << result.out;
  for (const auto& placement : lockstep::platform::placements())
    EXPECT_EQ(line_starting(std::string(placement.name)), 1u) << placement.name << " in:\n" << result.out;
}

TEST(ListCli, SaysWhichPrimitivesCountFutexWaits) {
  watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown));
  const auto result = run_command({LOCKSTEP_BINARY, "list", "sync"});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const auto line_of = [&](const std::string& name) {
    const std::size_t start = result.out.find("  " + name + " ");
    if (start == std::string::npos) return std::string();
    return result.out.substr(start, result.out.find('\n', start) - start);
  };
  for (const auto& info : lockstep::sync::all_primitive_info) {
    const std::string line = line_of(std::string(info.name));
    EXPECT_EQ(line.find("futex waits unavailable") != std::string::npos, !info.counts_futex_waits) << line;
  }
  EXPECT_NE(result.out.find("futex waits unavailable (inside the library; the counter is omitted): "
                            "std_barrier, pthread_barrier, omp_barrier"),
            std::string::npos)
      << result.out;
}

TEST(ListCli, UnknownGroupIsExitTwo) {
  watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown));
  const auto result = run_command({LOCKSTEP_BINARY, "list", "nonsense"});
  EXPECT_EQ(result.exit_status, 2);
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
}

}  // namespace
