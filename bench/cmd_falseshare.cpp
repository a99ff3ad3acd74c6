// lockstep falseshare: false sharing priced directly. Two or more pinned
// threads each increment their own counter; the counters sit `stride` bytes
// apart in one page, and the stride is swept from 8 to 256 bytes. Below the
// line size the writers share a line and every write needs the line back
// from another core; at 64 bytes they share a 128-byte pair (what adjacent-
// line prefetchers fetch together); from 128 bytes they share nothing.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
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

struct falseshare_options {
  int threads = 2;
  std::string cores;
  std::string strides = "8,16,32,64,128,256";
  int milliseconds = 100;
  int repeats = 5;
  std::string json;
};

// Writes between two looks at the stop flag: enough that the flag's line is
// read rarely (it would otherwise be a shared line of its own), few enough
// that a thread stops within microseconds.
constexpr std::uint64_t kWritesPerCheck = 256;

// The page the counters live in: page-aligned, so offset 0 starts a line and
// a 128-byte pair, and nothing else of the process shares it.
class counter_page {
 public:
  explicit counter_page(std::size_t bytes) : bytes_(bytes) {
    memory_ = ::mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (memory_ == MAP_FAILED) throw std::runtime_error("mmap of the counter page failed");
  }
  counter_page(const counter_page&) = delete;  // owns a mapping
  counter_page& operator=(const counter_page&) = delete;
  ~counter_page() { ::munmap(memory_, bytes_); }
  std::atomic<std::uint64_t>* counter_at(std::size_t offset) {
    return new (static_cast<char*>(memory_) + offset) std::atomic<std::uint64_t>(0);
  }

 private:
  void* memory_ = nullptr;
  std::size_t bytes_ = 0;
};

struct writer_result {
  std::uint64_t writes = 0;
  std::int64_t elapsed_ns = 0;
};

// One measurement: every thread writes its counter until told to stop; the
// main thread lets them run for `milliseconds` once all are pinned and ready.
std::vector<double> measure_stride(const std::vector<int>& cpus, std::size_t stride, int milliseconds) {
  const std::size_t threads = cpus.size();
  counter_page page(std::max<std::size_t>(static_cast<std::size_t>(::sysconf(_SC_PAGESIZE)), threads * stride + 64));
  std::vector<std::atomic<std::uint64_t>*> counters;
  for (std::size_t t = 0; t < threads; ++t) counters.push_back(page.counter_at(t * stride));

  // The control flags live on their own lines, away from the counters' page.
  struct alignas(platform::kCacheLine) flag {
    std::atomic<int> value{0};
  };
  flag ready, start, running, window, stop;
  std::vector<writer_result> results(threads);
  std::vector<std::string> errors(threads);
  std::vector<std::thread> writers;
  for (std::size_t t = 0; t < threads; ++t) {
    writers.emplace_back([&, t] {
      try {
        platform::pin_current_thread_to_pu(static_cast<unsigned>(cpus[t]));
      } catch (const std::exception& e) {
        errors[t] = e.what();
      }
      // release: publishes errors[t] to the main thread's acquire load of ready.
      ready.value.fetch_add(1, std::memory_order_release);
      // acquire: pairs with the main thread's release store of start.
      // (yield, not a pause: the main thread needs a CPU to set start)
      while (start.value.load(std::memory_order_acquire) == 0) std::this_thread::yield();
      if (!errors[t].empty()) return;
      std::atomic<std::uint64_t>& counter = *counters[t];
      std::uint64_t writes = 0;
      std::uint64_t writes_at_window = 0;
      std::int64_t window_began = -1;
      bool announced = false;
      for (;;) {
        for (std::uint64_t i = 0; i < kWritesPerCheck; ++i) {
          // relaxed load + store, not fetch_add: each counter has one writer,
          // and a plain store is what false sharing punishes (an RMW would
          // add the lock's own cost to every stride alike).
          counter.store(counter.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
        }
        writes += kWritesPerCheck;
        if (!announced) {
          running.value.fetch_add(1, std::memory_order_relaxed);  // relaxed: a count, no data
          announced = true;
        }
        // relaxed: the flags carry no data; the join publishes results.
        if (window_began < 0 && window.value.load(std::memory_order_relaxed) != 0) {
          window_began = platform::now_ns();
          writes_at_window = writes;
        }
        if (stop.value.load(std::memory_order_relaxed) != 0) break;
      }
      if (window_began >= 0) results[t] = {writes - writes_at_window, platform::now_ns() - window_began};
    });
  }
  // acquire: pairs with each writer's release increment of ready.
  while (ready.value.load(std::memory_order_acquire) != static_cast<int>(threads)) std::this_thread::yield();
  start.value.store(1, std::memory_order_release);  // release: pairs with the writers' acquire wait
  // The window opens only when every writer is writing, so that the writes
  // timed are contended writes (on a loaded machine a writer may start late).
  // relaxed (both): `running` is a count and `window` a signal; neither
  // carries data (the writers' results reach us through join).
  while (running.value.load(std::memory_order_relaxed) != static_cast<int>(threads)) std::this_thread::yield();
  window.value.store(1, std::memory_order_relaxed);
  std::this_thread::sleep_for(std::chrono::milliseconds(milliseconds));
  stop.value.store(1, std::memory_order_relaxed);  // relaxed: see the writers' loop
  for (auto& writer : writers) writer.join();
  for (const auto& error : errors)
    if (!error.empty()) throw usage_error(error + "; choose usable CPUs with --cores");

  // A writer that was not scheduled during the whole window has no sample
  // (its time per write is unknown, not infinite).
  std::vector<double> ns_per_write;
  for (std::size_t t = 0; t < threads; ++t)
    if (results[t].writes > 0)
      ns_per_write.push_back(static_cast<double>(results[t].elapsed_ns) / static_cast<double>(results[t].writes));
  return ns_per_write;
}

std::vector<std::size_t> parse_strides(const std::string& text) {
  std::vector<std::size_t> strides;
  for (int value : delay::parse_cpu_list(text, "--strides")) {
    if (value < 8 || value > 4096 || value % 8 != 0)
      throw usage_error("--strides: " + std::to_string(value) + " is not a multiple of 8 in 8..4096");
    strides.push_back(static_cast<std::size_t>(value));
  }
  return strides;
}

void run_falseshare(const falseshare_options& options, int& result) {
  if (options.threads < 2 || options.threads > 1024) throw usage_error("--threads must be in 2..1024");
  if (options.milliseconds < 1 || options.milliseconds > 60'000) throw usage_error("--ms must be in 1..60000");
  if (options.repeats < 1 || options.repeats > 1000) throw usage_error("--repeats must be in 1..1000");
  const auto strides = parse_strides(options.strides);
  const platform::topology machine = platform::topology::this_machine();
  std::vector<int> cpus = delay::usable_cpus(machine, false);
  if (!options.cores.empty()) cpus = delay::restrict_to(delay::usable_cpus(machine, true), delay::parse_cpu_list(options.cores, "--cores"), "--cores");
  if (cpus.size() < static_cast<std::size_t>(options.threads))
    throw usage_error("--threads " + std::to_string(options.threads) + " needs as many usable CPUs, found " +
                      std::to_string(cpus.size()) + " (each writer is pinned to its own CPU)");
  cpus.resize(static_cast<std::size_t>(options.threads));
  delay::check_writable(options.json);

  struct stride_result {
    std::size_t stride;
    std::vector<double> ns_per_write;
  };
  std::vector<stride_result> results;
  for (std::size_t s : strides) results.push_back({s, {}});
  // Repeats outermost: a slow phase of a loaded machine spreads over every
  // stride instead of landing on one.
  for (int repeat = 0; repeat < options.repeats; ++repeat) {
    fmt::print(stderr, "falseshare: repeat {}/{} ({} strides x {} ms)\n", repeat + 1, options.repeats, strides.size(),
               options.milliseconds);
    for (auto& r : results) {
      const auto samples = measure_stride(cpus, r.stride, options.milliseconds);
      r.ns_per_write.insert(r.ns_per_write.end(), samples.begin(), samples.end());
    }
  }

  std::string cpu_text;
  for (int cpu : cpus) cpu_text += (cpu_text.empty() ? "" : ",") + std::to_string(cpu);
  fmt::print("false sharing: {} writers pinned to CPUs {}, counters `stride` bytes apart\n", cpus.size(), cpu_text);
  fmt::print("time per write, ns ({} repeats x {} threads, {} ms each)\n", options.repeats, cpus.size(),
             options.milliseconds);
  fmt::print("{:>7}  {:<28} {:>9} {:>9} {:>9} {:>8}\n", "stride", "writers share", "min", "median", "max", "samples");
  for (const auto& r : results) {
    if (r.ns_per_write.empty()) {
      fmt::print("{:>7}  no writer was scheduled during any window (machine overloaded)\n", r.stride);
      continue;
    }
    const auto d = platform::summarize(r.ns_per_write);
    const char* sharing = r.stride < platform::kCacheLine        ? "a 64-byte line"
                          : r.stride < platform::kPrefetchPair ? "a 128-byte pair, not a line"
                                                                : "nothing";
    fmt::print("{:>7}  {:<28} {:>9.2f} {:>9.2f} {:>9.2f} {:>8}\n", r.stride, sharing, d.min, d.p50, d.max, d.count);
  }

  if (!options.json.empty()) {
    nlohmann::json document = {{"kind", "falseshare"},
                               {"lockstep_schema", build_info::kResultSchema},
                               {"context", delay::result_context(machine)},
                               {"settings",
                                {{"threads", options.threads},
                                 {"cpus", cpus},
                                 {"milliseconds", options.milliseconds},
                                 {"repeats", options.repeats}}},
                               {"strides", nlohmann::json::array()}};
    for (const auto& r : results)
      document["strides"].push_back({{"stride_bytes", r.stride},
                                     {"share_line", r.stride < platform::kCacheLine},
                                     {"share_line_pair", r.stride < platform::kPrefetchPair},
                                     {"ns_per_write", delay::distribution_json(r.ns_per_write)}});
    delay::write_file_atomically(options.json, document.dump(2) + "\n");
    fmt::print(stderr, "falseshare: wrote {}\n", options.json);
  }
  result = kExitOk;
}

}  // namespace

void add_falseshare(CLI::App& app, int& result) {
  auto options = std::make_shared<falseshare_options>();
  auto* command = app.add_subcommand(
      "falseshare", "False sharing priced directly: pinned threads write counters `stride` bytes apart, 8..256");
  command->add_option("--threads", options->threads, "Writers, each pinned to its own CPU (>= 2)")->capture_default_str();
  command->add_option("--cores", options->cores, "CPUs for the writers, e.g. 0,1 (default: one PU per core)");
  command->add_option("--strides", options->strides, "Strides in bytes (multiples of 8)")->capture_default_str();
  command->add_option("--ms", options->milliseconds, "Milliseconds per measurement")->capture_default_str();
  command->add_option("--repeats", options->repeats, "Measurements per stride")->capture_default_str();
  command->add_option("--json", options->json, "Write the result as JSON to this file (atomically)");
  command->callback([options, &result] { run_falseshare(*options, result); });
}

}  // namespace lockstep::cli
