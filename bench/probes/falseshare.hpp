#pragma once
// The falseshare probe: false sharing priced directly, per access pattern.
// Pinned threads each access their own 8-byte word; the words sit `stride`
// bytes apart in one page, and the stride is swept. Below the line size the
// threads' words share a line and every write needs the line back from
// another core; at 64 bytes they share a 128-byte pair (what adjacent-line
// prefetchers fetch together); from 128 bytes they share nothing.
//
// Why patterns: a core does not pay for a shared line the same way whatever
// the access. One that forwards a thread's stores to its own loads and
// commits them in bursts while it holds the line can hide false sharing of
// plain stores entirely, while an atomic read-modify-write or a sequentially
// consistent store drains the store buffer and pays for every transfer of the
// line (on an Intel Xeon guest, two threads 8 B against 128 B apart: plain
// stores no penalty, fetch_add 4.1-4.8x, store(seq_cst) 4.4-4.6x; on an AMD
// EPYC guest plain stores 2.4-4.3x). So each pattern a program meets is
// measured, and each answers for itself.
//
// The patterns (one type each, listed in access_patterns below), each
// declaring:
//   kName           its name in result files
//   kWords          how the answers name it ("plain stores")
//   kDescription    what each thread does, one line
//   kSweepsStrides  `lockstep falseshare` sweeps every --strides for it; the
//                   others are measured at the penalty's two strides only
//                   (sweep_strides_of below), which keeps the command's time
//   kOlderFilesFigure  the probe's one pattern before it had several: result
//                   files keep its figure where older files had the only one
//   kInStepLayouts  the composed RK4 step's layouts exercise it: their
//                   slots are plain doubles (layouts/shared_slots.hpp), each
//                   written by its owner with an ordinary store and read by
//                   the other threads after the stage's sync
//                   (kernels/parallel_exchange.hpp); falseshare.cpp proves
//                   the slots' type with static_assert
//   role(thread)    whether thread `thread` writes or reads its word
//   write(word), and read(word) where some thread reads: one access of the
//                   thread's own word, as the pattern's code does it. Templates
//                   over the word's type, so that a test can count the calls
//                   and their memory orders (tests/probes/falseshare_test.cpp).
//
// Contract: measure_false_sharing blocks for about
//   repeats x (the strides of every pattern planned) x window
// and leaves the caller's affinity untouched. It throws std::runtime_error
// when a thread cannot be pinned to its CPU (naming it) or the page cannot be
// mapped.
#include <array>
#include <atomic>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string_view>
#include <tuple>
#include <vector>

namespace lockstep::bench::probes {

enum class access_role { writes, reads };

// Every thread: a relaxed load and a relaxed store of its own word.
struct plain_store {
  static constexpr std::string_view kName = "plain_store";
  static constexpr std::string_view kWords = "plain stores";
  static constexpr std::string_view kDescription =
      "each thread loads and stores its own word (relaxed: x86-64 mov, the code of an ordinary store)";
  static constexpr bool kSweepsStrides = true;
  static constexpr bool kOlderFilesFigure = true;
  static constexpr bool kInStepLayouts = true;
  static constexpr access_role role(std::size_t /*thread*/) noexcept { return access_role::writes; }
  template <class Word>
  static void write(Word& word) noexcept {
    // relaxed (both): the word has one writer, so the load reads that
    // thread's own last store, and nothing is published through it; atomic
    // only so that the probe's threads sharing a line is not a data race.
    // A relaxed store compiles to the plain store a program's data writes are.
    word.store(word.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  }
};

// Every thread: an atomic increment of its own word.
struct atomic_rmw {
  static constexpr std::string_view kName = "atomic_rmw";
  static constexpr std::string_view kWords = "atomic read-modify-writes";
  static constexpr std::string_view kDescription =
      "each thread fetch_adds its own word (x86-64: lock xadd), as a counter, a lock or a barrier's arrival does";
  static constexpr bool kSweepsStrides = false;
  static constexpr bool kOlderFilesFigure = false;
  static constexpr bool kInStepLayouts = false;
  static constexpr access_role role(std::size_t /*thread*/) noexcept { return access_role::writes; }
  template <class Word>
  static void write(Word& word) noexcept {
    // relaxed: the probe prices the locked read-modify-write itself, which
    // x86-64 emits the same (lock xadd) for every order; nothing is published
    // through the word, so no edge needs ordering.
    word.fetch_add(1, std::memory_order_relaxed);
  }
};

// Every thread: a sequentially consistent store to its own word.
struct seq_cst_store {
  static constexpr std::string_view kName = "seq_cst_store";
  static constexpr std::string_view kWords = "seq_cst stores";
  static constexpr std::string_view kDescription =
      "each thread stores its own word with memory_order_seq_cst (x86-64: xchg, which drains the store buffer)";
  static constexpr bool kSweepsStrides = false;
  static constexpr bool kOlderFilesFigure = false;
  static constexpr bool kInStepLayouts = false;
  static constexpr access_role role(std::size_t /*thread*/) noexcept { return access_role::writes; }
  template <class Word>
  static void write(Word& word) noexcept {
    // The load: relaxed, as plain_store's (the thread's own last store).
    // The store: seq_cst on purpose, the order is what this pattern prices;
    // it pairs with nothing (one writer, no reader of the word).
    word.store(word.load(std::memory_order_relaxed) + 1, std::memory_order_seq_cst);
  }
};

// Thread 0 writes its word as plain_store does; every other thread reads a
// word of its own, which nobody writes (on one line with the writer's when
// the stride is below a line).
struct writer_beside_reader {
  static constexpr std::string_view kName = "writer_beside_reader";
  static constexpr std::string_view kWords = "a writer beside a reader";
  static constexpr std::string_view kDescription =
      "thread 0 stores its word as plain_store does; the others load a word of their own that nobody writes";
  static constexpr bool kSweepsStrides = false;
  static constexpr bool kOlderFilesFigure = false;
  static constexpr bool kInStepLayouts = true;
  static constexpr access_role role(std::size_t thread) noexcept {
    return thread == 0 ? access_role::writes : access_role::reads;
  }
  template <class Word>
  static void write(Word& word) noexcept {
    plain_store::write(word);
  }
  template <class Word>
  static std::uint64_t read(Word& word) noexcept {
    // relaxed: the reader prices the line's travel, not an ordering; the
    // word it reads has no writer, so there is nothing to acquire.
    return word.load(std::memory_order_relaxed);
  }
};

// The list, in the order the answers print them when their verdicts agree
// (a std::tuple of the types, never instantiated). Exactly one declares
// kOlderFilesFigure (static_assert below).
using access_patterns = std::tuple<plain_store, atomic_rmw, seq_cst_store, writer_beside_reader>;

// A pattern type that some thread reads with.
template <class Pattern>
concept has_readers = requires(std::atomic<std::uint64_t>& word) {
  { Pattern::read(word) } -> std::same_as<std::uint64_t>;
};

struct access_pattern_info {
  std::string_view name;
  std::string_view words;
  std::string_view description;
  bool sweeps_strides = false;
  bool older_files_figure = false;
  bool in_step_layouts = false;
  bool has_readers = false;
};

template <class Pattern>
constexpr access_pattern_info info_of() noexcept {
  return {Pattern::kName,          Pattern::kWords,         Pattern::kDescription,  Pattern::kSweepsStrides,
          Pattern::kOlderFilesFigure, Pattern::kInStepLayouts, has_readers<Pattern>};
}

template <class List>
struct access_pattern_table;
template <class... Patterns>
struct access_pattern_table<std::tuple<Patterns...>> {
  static constexpr std::array<access_pattern_info, sizeof...(Patterns)> value{info_of<Patterns>()...};
};
inline constexpr auto all_access_patterns = access_pattern_table<access_patterns>::value;

// The index of the pattern named `name` in all_access_patterns; none when no
// pattern has that name (a result file's name read back).
constexpr std::optional<std::size_t> find_access_pattern(std::string_view name) noexcept {
  for (std::size_t index = 0; index < all_access_patterns.size(); ++index)
    if (all_access_patterns[index].name == name) return index;
  return std::nullopt;
}

namespace detail {
constexpr std::size_t older_files_figures() noexcept {
  std::size_t count = 0;
  for (const auto& info : all_access_patterns) count += info.older_files_figure ? 1 : 0;
  return count;
}
}  // namespace detail
static_assert(detail::older_files_figures() == 1, "exactly one pattern holds the figure older result files had");

// One pattern to measure, at these strides.
struct pattern_plan {
  std::size_t pattern = 0;           // index in all_access_patterns
  std::vector<std::size_t> strides;  // bytes between neighbouring words, multiples of 8
};

// Every pattern of the table: those that sweep at every one of `strides`, the
// others at the penalty's two (the first stride whose words share a line and
// the first that shares nothing; whichever of them `strides` holds).
std::vector<pattern_plan> plan_patterns(const std::vector<std::size_t>& strides);

struct falseshare_settings {
  std::vector<int> cpus;             // one thread pinned to each (>= 2)
  std::vector<pattern_plan> patterns;
  std::int64_t window_ns = 100'000'000;  // how long the threads access their words per measurement
  int repeats = 5;                   // measurements per pattern and stride
  // Called before each repeat (0-based) of all patterns and strides.
  std::function<void(int repeat)> on_repeat;
};

struct stride_cost {
  std::size_t stride_bytes = 0;
  bool shares_line = false;       // stride < platform::kCacheLine
  bool shares_line_pair = false;  // stride < platform::kPrefetchPair
  // ns per access, one sample per thread per repeat; a thread that was not
  // scheduled during a window has no sample (its cost is unknown, not infinite).
  std::vector<double> ns_per_access;
  // Per repeat: the mean over the threads that were scheduled (empty when
  // none was). A pattern's strides of one repeat ran a few windows apart, so
  // a ratio of two strides within a repeat is a pair (paired_ratio.hpp).
  std::vector<std::optional<double>> repeat_mean_ns;
};

struct pattern_cost {
  std::size_t pattern = 0;  // index in all_access_patterns
  std::vector<stride_cost> strides;
};

// Repeats outermost: a slow phase of a loaded machine spreads over every
// pattern and stride instead of landing on one. Within a repeat each pattern's
// strides run back to back, in the plan's order on even repeats and reversed
// on odd ones (A B, then B A: a drift does not favour one side).
std::vector<pattern_cost> measure_false_sharing(const falseshare_settings& settings);

}  // namespace lockstep::bench::probes
