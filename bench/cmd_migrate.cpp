// lockstep migrate: the cost of one forced migration, split into
//   move    the time from asking the kernel to move the calling thread to
//           another CPU (sched_setaffinity to that CPU alone) until the thread
//           runs there (sched_getcpu says so): system call, stopper thread,
//           context switch;
//   refill  the extra time of the first pass over a working set of --bytes on
//           the new CPU, against a pass whose lines are already local:
//           first pass after the move - the pass right after it.
// A baseline prices what the move includes but is not a migration: the same
// sched_setaffinity call naming the CPU the thread is already on.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <sched.h>
#include <sys/mman.h>

#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "bench/command.hpp"
#include "bench/delay_common.hpp"
#include "platform/cache_line.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"
#include "platform/stats.hpp"
#include "platform/topology.hpp"

namespace lockstep::cli {
namespace {

namespace delay = bench::delay;

struct migrate_options {
  std::string cores;  // two CPUs: from,to
  std::uint64_t bytes = 256 * 1024;
  int repeats = 200;
  std::string json;
};

// The working set: touched one 64-bit word per cache line, read-modify-write,
// so that a pass needs every line in the modified state in this core's cache
// (after a move every line must come from the old core's caches or beyond).
class working_set {
 public:
  explicit working_set(std::uint64_t bytes) : bytes_(bytes) {
    memory_ = ::mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (memory_ == MAP_FAILED) throw usage_error("--bytes: cannot map " + std::to_string(bytes) + " bytes");
    words_ = static_cast<std::uint64_t*>(memory_);
  }
  working_set(const working_set&) = delete;  // owns a mapping
  working_set& operator=(const working_set&) = delete;
  ~working_set() { ::munmap(memory_, bytes_); }

  // One pass; returns its duration in ns.
  std::int64_t pass() {
    constexpr std::size_t kWordsPerLine = platform::kCacheLine / sizeof(std::uint64_t);
    const std::size_t words = bytes_ / sizeof(std::uint64_t);
    const std::int64_t began = platform::now_ns();
    for (std::size_t i = 0; i < words; i += kWordsPerLine) words_[i] += 1;
    asm volatile("" ::: "memory");  // the writes are the measurement: keep them
    return platform::now_ns() - began;
  }

 private:
  void* memory_ = nullptr;
  std::uint64_t* words_ = nullptr;
  std::uint64_t bytes_ = 0;
};

// Moves the calling thread to `cpu`; returns ns until it runs there.
std::int64_t move_to(unsigned cpu) {
  const std::int64_t began = platform::now_ns();
  platform::pin_current_thread_to_pu(cpu);
  // sched_setaffinity returns once the kernel has moved the running task, so
  // this loop normally exits at once; it guards against a kernel that defers.
  while (platform::current_cpu() != cpu) std::this_thread::yield();
  return platform::now_ns() - began;
}

struct migrate_samples {
  std::vector<double> move_ns, refill_ns, stay_ns, cold_pass_ns, warm_pass_ns;
};

migrate_samples measure(unsigned from, unsigned to, std::uint64_t bytes, int repeats) {
  migrate_samples samples;
  std::string error;
  // A thread of its own: the caller's affinity stays untouched.
  std::thread mover([&] {
    try {
      working_set set(bytes);
      move_to(from);
      set.pass();
      set.pass();
      unsigned here = from;
      unsigned there = to;
      for (int repeat = 0; repeat < repeats; ++repeat) {
        samples.stay_ns.push_back(static_cast<double>(move_to(here)));  // no move: the baseline
        samples.move_ns.push_back(static_cast<double>(move_to(there)));
        const std::int64_t cold = set.pass();
        const std::int64_t warm = set.pass();
        samples.cold_pass_ns.push_back(static_cast<double>(cold));
        samples.warm_pass_ns.push_back(static_cast<double>(warm));
        samples.refill_ns.push_back(static_cast<double>(cold - warm));
        std::swap(here, there);  // alternate directions: each repeat is one migration
        if ((repeat + 1) % 100 == 0) fmt::print(stderr, "migrate: {}/{} migrations\n", repeat + 1, repeats);
      }
    } catch (const std::exception& e) {
      error = e.what();
    }
  });
  mover.join();
  if (!error.empty()) throw usage_error(error + "; choose usable CPUs with --cores");
  return samples;
}

void print_row(const char* what, const std::vector<double>& values) {
  const auto d = platform::summarize(values);
  fmt::print("{:<34} {:>10.0f} {:>10.0f} {:>10.0f} {:>10.0f}\n", what, d.min, d.p50, d.p99, d.max);
}

void run_migrate(const migrate_options& options, int& result) {
  if (options.bytes < platform::kCacheLine || options.bytes > (std::uint64_t{1} << 34))
    throw usage_error("--bytes must be in 64..17179869184");
  if (options.repeats < 1 || options.repeats > 1'000'000) throw usage_error("--repeats must be in 1..1000000");
  const platform::topology machine = platform::topology::this_machine();
  std::vector<int> cpus = delay::usable_cpus(machine, false);
  if (!options.cores.empty()) {
    cpus = delay::restrict_to(delay::usable_cpus(machine, true), delay::parse_cpu_list(options.cores, "--cores"),
                              "--cores");
    if (cpus.size() != 2) throw usage_error("--cores: name exactly two CPUs, the two ends of the move (e.g. 0,1)");
  }
  if (cpus.size() < 2) throw usage_error("migrate needs two usable CPUs, found " + std::to_string(cpus.size()));
  const auto from = static_cast<unsigned>(cpus[0]);
  const auto to = static_cast<unsigned>(cpus[1]);
  delay::check_writable(options.json);

  fmt::print(stderr, "migrate: {} migrations between CPU {} and CPU {}, working set {} bytes\n", options.repeats,
             from, to, options.bytes);
  const migrate_samples samples = measure(from, to, options.bytes, options.repeats);
  const std::string relation(platform::to_string(machine.relation(from, to)));

  fmt::print("forced migration between CPU {} and CPU {} ({}), working set {} bytes, {} migrations\n", from, to,
             relation, options.bytes, options.repeats);
  fmt::print("{:<34} {:>10} {:>10} {:>10} {:>10}\n", "ns", "min", "median", "p99", "max");
  print_row("move (setaffinity until there)", samples.move_ns);
  print_row("  baseline: setaffinity, no move", samples.stay_ns);
  print_row("refill (first pass - next pass)", samples.refill_ns);
  print_row("  first pass after the move", samples.cold_pass_ns);
  print_row("  next pass (lines local)", samples.warm_pass_ns);
  const auto move = platform::summarize(samples.move_ns);
  const auto refill = platform::summarize(samples.refill_ns);
  fmt::print("one migration ~ {:.0f} ns move + {:.0f} ns refill (medians)\n", move.p50, refill.p50);

  if (!options.json.empty()) {
    nlohmann::json document = {
        {"kind", "migrate"},
        {"lockstep_schema", build_info::kResultSchema},
        {"context", delay::result_context(machine)},
        {"settings", {{"from", from}, {"to", to}, {"relation", relation}, {"bytes", options.bytes},
                      {"repeats", options.repeats}}},
        {"move_ns", delay::distribution_json(samples.move_ns)},
        {"setaffinity_no_move_ns", delay::distribution_json(samples.stay_ns)},
        {"refill_ns", delay::distribution_json(samples.refill_ns)},
        {"first_pass_ns", delay::distribution_json(samples.cold_pass_ns)},
        {"next_pass_ns", delay::distribution_json(samples.warm_pass_ns)}};
    delay::write_file_atomically(options.json, document.dump(2) + "\n");
    fmt::print(stderr, "migrate: wrote {}\n", options.json);
  }
  result = kExitOk;
}

}  // namespace

void add_migrate(CLI::App& app, int& result) {
  auto options = std::make_shared<migrate_options>();
  auto* command = app.add_subcommand(
      "migrate", "Cost of one forced migration: the move itself, and the cache refill of a working set");
  command->add_option("--cores", options->cores, "The two CPUs to move between, e.g. 0,1 (default: first two cores)");
  command->add_option("--bytes", options->bytes, "Working set in bytes")->capture_default_str();
  command->add_option("--repeats", options->repeats, "Migrations measured")->capture_default_str();
  command->add_option("--json", options->json, "Write the result as JSON to this file (atomically)");
  command->callback([options, &result] { run_migrate(*options, result); });
}

}  // namespace lockstep::cli
