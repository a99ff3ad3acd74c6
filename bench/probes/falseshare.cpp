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
#include <type_traits>
#include <utility>

#include "layouts/registry.hpp"
#include "platform/cache_line.hpp"
#include "platform/clock.hpp"
#include "platform/placement.hpp"

namespace lockstep::bench::probes {
namespace {

// kInStepLayouts, proved: every layout's slots that other threads read are
// plain doubles (a shared layout's state and stage slots, a private_copy
// layout's board), so the step writes them with ordinary stores and reads
// them with ordinary loads; its atomics are the primitives' own, on their own
// lines. A layout whose slots became atomics would fail here, and the
// patterns' kInStepLayouts would need another look.
template <class Layout>
constexpr bool published_slots_are_plain_doubles() {
  if constexpr (Layout::kKind == layouts::layout_kind::shared)
    return std::is_same_v<decltype(std::declval<Layout&>().stage(0U, std::size_t{0})), double&> &&
           std::is_same_v<decltype(std::declval<Layout&>().state(0U, std::size_t{0})), double&>;
  else
    return std::is_same_v<decltype(std::declval<Layout&>().board(std::size_t{0}, std::size_t{0})), double&>;
}
template <class... Layouts>
constexpr bool all_published_slots_are_plain_doubles(std::tuple<Layouts...>* /*list*/) {
  return (published_slots_are_plain_doubles<Layouts>() && ...);
}
static_assert(all_published_slots_are_plain_doubles(static_cast<layouts::all_layouts*>(nullptr)),
              "the step's layouts publish plain doubles: the patterns' kInStepLayouts say so");

// Accesses between two looks at the stop flag: enough that the flag's line is
// read rarely (it would otherwise be a shared line of its own), few enough
// that a thread stops within microseconds.
constexpr std::uint64_t kAccessesPerCheck = 256;

// The page the words live in: page-aligned, so offset 0 starts a line and a
// 128-byte pair, and nothing else of the process shares it.
class word_page {
 public:
  explicit word_page(std::size_t bytes) : bytes_(bytes) {
    memory_ = ::mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (memory_ == MAP_FAILED) throw std::runtime_error("mmap of the page of the probe's words failed");
  }
  word_page(const word_page&) = delete;  // owns a mapping
  word_page& operator=(const word_page&) = delete;
  ~word_page() { ::munmap(memory_, bytes_); }
  std::atomic<std::uint64_t>* word_at(std::size_t offset) {
    return new (static_cast<char*>(memory_) + offset) std::atomic<std::uint64_t>(0);
  }

 private:
  void* memory_ = nullptr;
  std::size_t bytes_ = 0;
};

struct thread_result {
  std::uint64_t accesses = 0;
  std::int64_t elapsed_ns = 0;
  std::uint64_t read_sum = 0;  // what a reader read, kept so that its loads are not dead
};

// The control flags, on their own lines, away from the words' page.
struct alignas(platform::kCacheLine) flag {
  std::atomic<int> value{0};
};
struct window_flags {
  flag ready, start, running, window, stop;
};

// One thread's part of a measurement: accesses its word with `Access` (one
// access a call) until told to stop, counting the accesses made while the
// window was open.
template <class Access>
thread_result access_until_stopped(window_flags& flags, Access access) {
  std::uint64_t accesses = 0;
  std::uint64_t accesses_at_window = 0;
  std::uint64_t read_sum = 0;
  std::int64_t window_began = -1;
  bool announced = false;
  for (;;) {
    for (std::uint64_t i = 0; i < kAccessesPerCheck; ++i) read_sum += access();
    accesses += kAccessesPerCheck;
    if (!announced) {
      flags.running.value.fetch_add(1, std::memory_order_relaxed);  // relaxed: a count, no data
      announced = true;
    }
    // relaxed: the flags carry no data; the join publishes the results.
    if (window_began < 0 && flags.window.value.load(std::memory_order_relaxed) != 0) {
      window_began = platform::now_ns();
      accesses_at_window = accesses;
    }
    if (flags.stop.value.load(std::memory_order_relaxed) != 0) break;
  }
  if (window_began < 0) return {0, 0, read_sum};
  return {accesses - accesses_at_window, platform::now_ns() - window_began, read_sum};
}

template <class Pattern>
thread_result run_role(window_flags& flags, std::atomic<std::uint64_t>& word, std::size_t thread) {
  if constexpr (has_readers<Pattern>) {
    if (Pattern::role(thread) == access_role::reads)
      return access_until_stopped(flags, [&word] { return Pattern::read(word); });
  }
  return access_until_stopped(flags, [&word] {
    Pattern::write(word);
    return std::uint64_t{0};
  });
}

// One measurement: every thread accesses its word until told to stop; the
// main thread lets them run for `window_ns` once all are pinned and running.
template <class Pattern>
std::vector<double> measure_stride(const std::vector<int>& cpus, std::size_t stride, std::int64_t window_ns) {
  const std::size_t threads = cpus.size();
  word_page page(std::max<std::size_t>(static_cast<std::size_t>(::sysconf(_SC_PAGESIZE)), threads * stride + 64));
  std::vector<std::atomic<std::uint64_t>*> words;
  for (std::size_t t = 0; t < threads; ++t) words.push_back(page.word_at(t * stride));

  window_flags flags;
  std::vector<thread_result> results(threads);
  std::vector<std::string> errors(threads);
  std::vector<std::thread> workers;
  for (std::size_t t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] {
      try {
        platform::pin_current_thread_to_pu(static_cast<unsigned>(cpus[t]));
      } catch (const std::exception& e) {
        errors[t] = e.what();
      }
      // release: publishes errors[t] to the main thread's acquire load of ready.
      flags.ready.value.fetch_add(1, std::memory_order_release);
      // acquire: pairs with the main thread's release store of start.
      // (yield, not a pause: the main thread needs a CPU to set start)
      while (flags.start.value.load(std::memory_order_acquire) == 0) std::this_thread::yield();
      if (!errors[t].empty()) return;
      results[t] = run_role<Pattern>(flags, *words[t], t);
    });
  }
  // acquire: pairs with each thread's release increment of ready.
  while (flags.ready.value.load(std::memory_order_acquire) != static_cast<int>(threads)) std::this_thread::yield();
  flags.start.value.store(1, std::memory_order_release);  // release: pairs with the threads' acquire wait
  // The window opens only when every thread is accessing, so that the
  // accesses timed are contended ones (on a loaded machine a thread may start
  // late). relaxed (both): `running` is a count and `window` a signal;
  // neither carries data (the threads' results reach us through join).
  while (flags.running.value.load(std::memory_order_relaxed) != static_cast<int>(threads))
    std::this_thread::yield();
  flags.window.value.store(1, std::memory_order_relaxed);
  std::this_thread::sleep_for(std::chrono::nanoseconds(window_ns));
  flags.stop.value.store(1, std::memory_order_relaxed);  // relaxed: see access_until_stopped
  for (auto& worker : workers) worker.join();
  for (const auto& error : errors)
    if (!error.empty()) throw std::runtime_error(error);

  // A thread that was not scheduled during the whole window has no sample
  // (its time per access is unknown, not infinite).
  std::vector<double> ns_per_access;
  for (std::size_t t = 0; t < threads; ++t)
    if (results[t].accesses > 0)
      ns_per_access.push_back(static_cast<double>(results[t].elapsed_ns) / static_cast<double>(results[t].accesses));
  return ns_per_access;
}

using stride_measurement = std::vector<double> (*)(const std::vector<int>&, std::size_t, std::int64_t);

// measure_stride of each pattern, in all_access_patterns' order.
template <class... Patterns>
constexpr std::array<stride_measurement, sizeof...(Patterns)> measurements_of(std::tuple<Patterns...>* /*list*/) {
  return {&measure_stride<Patterns>...};
}
constexpr auto kMeasurements = measurements_of(static_cast<access_patterns*>(nullptr));
static_assert(kMeasurements.size() == all_access_patterns.size());

stride_cost cost_of(std::size_t stride) {
  return {stride, stride < platform::kCacheLine, stride < platform::kPrefetchPair, {}, {}};
}

}  // namespace

std::vector<pattern_plan> plan_patterns(const std::vector<std::size_t>& strides) {
  const auto sharing = std::find_if(strides.begin(), strides.end(),
                                    [](std::size_t stride) { return cost_of(stride).shares_line; });
  const auto apart = std::find_if(strides.begin(), strides.end(), [](std::size_t stride) {
    return !cost_of(stride).shares_line && !cost_of(stride).shares_line_pair;
  });
  std::vector<std::size_t> penalty_strides;
  if (sharing != strides.end()) penalty_strides.push_back(*sharing);
  if (apart != strides.end()) penalty_strides.push_back(*apart);
  std::vector<pattern_plan> plans;
  for (std::size_t index = 0; index < all_access_patterns.size(); ++index)
    plans.push_back({index, all_access_patterns[index].sweeps_strides ? strides : penalty_strides});
  return plans;
}

std::vector<pattern_cost> measure_false_sharing(const falseshare_settings& settings) {
  std::vector<pattern_cost> costs;
  for (const pattern_plan& plan : settings.patterns) {
    if (plan.pattern >= all_access_patterns.size()) throw std::runtime_error("falseshare: no such access pattern");
    pattern_cost cost{plan.pattern, {}};
    for (std::size_t stride : plan.strides) cost.strides.push_back(cost_of(stride));
    costs.push_back(std::move(cost));
  }
  for (int repeat = 0; repeat < settings.repeats; ++repeat) {
    if (settings.on_repeat) settings.on_repeat(repeat);
    for (auto& cost : costs) {
      const stride_measurement measure = kMeasurements[cost.pattern];
      const bool reversed = repeat % 2 == 1;
      for (std::size_t step = 0; step < cost.strides.size(); ++step) {
        stride_cost& stride = cost.strides[reversed ? cost.strides.size() - 1 - step : step];
        const auto samples = measure(settings.cpus, stride.stride_bytes, settings.window_ns);
        stride.ns_per_access.insert(stride.ns_per_access.end(), samples.begin(), samples.end());
        std::optional<double> mean;
        if (!samples.empty()) {
          double sum = 0.0;
          for (double sample : samples) sum += sample;
          mean = sum / static_cast<double>(samples.size());
        }
        stride.repeat_mean_ns.push_back(mean);
      }
    }
  }
  return costs;
}

}  // namespace lockstep::bench::probes
