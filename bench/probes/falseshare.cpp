// The falseshare probe (falseshare.hpp).
#include "bench/probes/falseshare.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <new>
#include <stdexcept>
#include <string>
#include <thread>

#include "platform/cache_line.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"

namespace lockstep::bench::probes {
namespace {

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
// main thread lets them run for `window_ns` once all are pinned and ready.
std::vector<double> measure_stride(const std::vector<int>& cpus, std::size_t stride, std::int64_t window_ns) {
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
  std::this_thread::sleep_for(std::chrono::nanoseconds(window_ns));
  stop.value.store(1, std::memory_order_relaxed);  // relaxed: see the writers' loop
  for (auto& writer : writers) writer.join();
  for (const auto& error : errors)
    if (!error.empty()) throw std::runtime_error(error);

  // A writer that was not scheduled during the whole window has no sample
  // (its time per write is unknown, not infinite).
  std::vector<double> ns_per_write;
  for (std::size_t t = 0; t < threads; ++t)
    if (results[t].writes > 0)
      ns_per_write.push_back(static_cast<double>(results[t].elapsed_ns) / static_cast<double>(results[t].writes));
  return ns_per_write;
}

}  // namespace

std::vector<stride_cost> measure_false_sharing(const falseshare_settings& settings) {
  std::vector<stride_cost> costs;
  for (std::size_t stride : settings.strides)
    costs.push_back({stride, stride < platform::kCacheLine, stride < platform::kPrefetchPair, {}, {}});
  for (int repeat = 0; repeat < settings.repeats; ++repeat) {
    if (settings.on_repeat) settings.on_repeat(repeat);
    for (auto& cost : costs) {
      const auto samples = measure_stride(settings.cpus, cost.stride_bytes, settings.window_ns);
      cost.ns_per_write.insert(cost.ns_per_write.end(), samples.begin(), samples.end());
      std::optional<double> mean;
      if (!samples.empty()) {
        double sum = 0.0;
        for (double sample : samples) sum += sample;
        mean = sum / static_cast<double>(samples.size());
      }
      cost.repeat_mean_ns.push_back(mean);
    }
  }
  return costs;
}

}  // namespace lockstep::bench::probes
