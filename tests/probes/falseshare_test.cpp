// The falseshare probe's known answers, true on any machine (no timing is
// measured or asserted): the pattern table is complete and consistent, each
// pattern's code performs the accesses it claims with the memory orders it
// claims (counted through a stand-in word), the plan sweeps only the patterns
// that sweep, and the analysis and the answer give the right verdicts and
// words on synthetic per-access times (bench/probes/falseshare.hpp,
// bench/probe_reports/falseshare_report.hpp).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "bench/probe_reports/falseshare_report.hpp"
#include "bench/probes/falseshare.hpp"

namespace {

namespace bench = lockstep::bench;
namespace probes = lockstep::bench::probes;

// ---------------------------------------------------------------------------
// The table.

TEST(FalseSharingPatterns, TheTableHoldsEachPatternAProgramMeetsOnce) {
  static_assert(probes::all_access_patterns.size() == std::tuple_size_v<probes::access_patterns>);
  std::set<std::string> names;
  std::size_t older_files_figures = 0;
  for (std::size_t index = 0; index < probes::all_access_patterns.size(); ++index) {
    const auto& info = probes::all_access_patterns[index];
    SCOPED_TRACE(std::string(info.name));
    EXPECT_FALSE(info.words.empty());
    EXPECT_FALSE(info.description.empty());
    EXPECT_TRUE(names.insert(std::string(info.name)).second) << "a name twice";
    EXPECT_EQ(probes::find_access_pattern(info.name), index);
    if (info.older_files_figure) {
      ++older_files_figures;
      EXPECT_TRUE(info.sweeps_strides) << "the older files' figure came from the sweep";
    }
  }
  // Plain stores, atomic read-modify-writes, sequentially consistent stores,
  // and one writer beside a reader of another word of the line.
  EXPECT_EQ(names, (std::set<std::string>{"plain_store", "atomic_rmw", "seq_cst_store", "writer_beside_reader"}));
  EXPECT_EQ(older_files_figures, 1u);
  EXPECT_EQ(probes::find_access_pattern("no_such_pattern"), std::nullopt);
}

// ---------------------------------------------------------------------------
// The kernels, through a word that records what was done to it.

enum class operation { load, store, fetch_add };
struct call {
  operation what;
  std::memory_order order;
  bool operator==(const call&) const = default;
};

struct recording_word {
  std::uint64_t value = 0;
  std::vector<call> calls;
  std::uint64_t load(std::memory_order order) {
    calls.push_back({operation::load, order});
    return value;
  }
  void store(std::uint64_t next, std::memory_order order) {
    calls.push_back({operation::store, order});
    value = next;
  }
  std::uint64_t fetch_add(std::uint64_t add, std::memory_order order) {
    calls.push_back({operation::fetch_add, order});
    const std::uint64_t old = value;
    value += add;
    return old;
  }
};

// What one access of each pattern must do: a writer's, and a reader's where
// the pattern has readers. A pattern without its expectation here does not
// compile (the primary template is deleted).
struct expected_access {
  std::vector<call> write;
  std::vector<call> read;  // empty: no thread reads
};
template <class Pattern>
expected_access expected() = delete;
template <>
expected_access expected<probes::plain_store>() {
  return {{{operation::load, std::memory_order_relaxed}, {operation::store, std::memory_order_relaxed}}, {}};
}
template <>
expected_access expected<probes::atomic_rmw>() {
  return {{{operation::fetch_add, std::memory_order_relaxed}}, {}};
}
template <>
expected_access expected<probes::seq_cst_store>() {
  return {{{operation::load, std::memory_order_relaxed}, {operation::store, std::memory_order_seq_cst}}, {}};
}
template <>
expected_access expected<probes::writer_beside_reader>() {
  return {{{operation::load, std::memory_order_relaxed}, {operation::store, std::memory_order_relaxed}},
          {{operation::load, std::memory_order_relaxed}}};
}

template <class Pattern>
void check_pattern() {
  SCOPED_TRACE(std::string(Pattern::kName));
  const expected_access want = expected<Pattern>();
  constexpr int kAccesses = 1000;
  // A writer's access: the calls it claims, and one increment each.
  recording_word word;
  for (int access = 0; access < kAccesses; ++access) Pattern::write(word);
  EXPECT_EQ(word.value, static_cast<std::uint64_t>(kAccesses));
  ASSERT_EQ(word.calls.size(), want.write.size() * kAccesses);
  for (std::size_t index = 0; index < word.calls.size(); ++index)
    EXPECT_EQ(word.calls[index], want.write[index % want.write.size()]) << "call " << index;
  // The same on a real atomic word: every access counted.
  std::atomic<std::uint64_t> atomic_word{0};
  for (int access = 0; access < kAccesses; ++access) Pattern::write(atomic_word);
  EXPECT_EQ(atomic_word.load(), static_cast<std::uint64_t>(kAccesses));
  // Readers: only where the pattern declares them; a read leaves the word.
  EXPECT_EQ(probes::has_readers<Pattern>, !want.read.empty());
  EXPECT_EQ(Pattern::role(0), probes::access_role::writes);
  for (std::size_t thread = 1; thread < 4; ++thread)
    EXPECT_EQ(Pattern::role(thread), want.read.empty() ? probes::access_role::writes : probes::access_role::reads);
  if constexpr (probes::has_readers<Pattern>) {
    recording_word read_word;
    read_word.value = 7;
    std::uint64_t sum = 0;
    for (int access = 0; access < kAccesses; ++access) sum += Pattern::read(read_word);
    EXPECT_EQ(sum, 7u * kAccesses);
    EXPECT_EQ(read_word.value, 7u);
    EXPECT_EQ(read_word.calls, std::vector<call>(kAccesses, want.read.front()));
  }
}

template <class... Patterns>
void check_every_pattern(std::tuple<Patterns...>* /*list*/) {
  (check_pattern<Patterns>(), ...);
}

TEST(FalseSharingPatterns, EachPatternsCodeDoesTheAccessesItClaims) {
  check_every_pattern(static_cast<probes::access_patterns*>(nullptr));
}

// ---------------------------------------------------------------------------
// The plan.

TEST(FalseSharingPatterns, ThePlanSweepsOnlyThePatternsThatSweepAndPairsTheOthers) {
  const std::vector<std::size_t> strides{8, 16, 64, 128, 256};
  const auto plans = probes::plan_patterns(strides);
  ASSERT_EQ(plans.size(), probes::all_access_patterns.size());
  for (std::size_t index = 0; index < plans.size(); ++index) {
    EXPECT_EQ(plans[index].pattern, index);
    const bool sweeps = probes::all_access_patterns[index].sweeps_strides;
    EXPECT_EQ(plans[index].strides, (sweeps ? strides : std::vector<std::size_t>{8, 128}));
  }
  // Whichever of the penalty's two strides the list holds.
  for (const auto& [given, paired] : std::vector<std::pair<std::vector<std::size_t>, std::vector<std::size_t>>>{
           {{64, 128}, {128}}, {{8, 64}, {8}}, {{64}, {}}, {{32, 512, 256}, {32, 512}}})
    for (const auto& plan : probes::plan_patterns(given))
      EXPECT_EQ(plan.strides, probes::all_access_patterns[plan.pattern].sweeps_strides ? given : paired);
}

// ---------------------------------------------------------------------------
// The analysis, on synthetic per-access times.

// A pattern's two strides (8 and 128) whose repeat means are `sharing[r]` and
// `apart[r]`; nullopt: no thread was scheduled in that window.
probes::pattern_cost synthetic(std::size_t pattern, const std::vector<std::optional<double>>& sharing,
                               const std::vector<std::optional<double>>& apart) {
  probes::pattern_cost cost{pattern, {{8, true, true, {}, sharing}, {128, false, false, {}, apart}}};
  for (auto& stride : cost.strides)
    for (const auto& mean : stride.repeat_mean_ns)
      if (mean) stride.ns_per_access.insert(stride.ns_per_access.end(), {*mean, *mean});
  return cost;
}

std::size_t index_of(std::string_view name) { return probes::find_access_pattern(name).value(); }

TEST(FalseshareAnalysis, SyntheticTimesGiveTheKnownVerdicts) {
  const std::vector<probes::pattern_cost> costs{
      // plain stores: one line as fast as apart, within 2 %.
      synthetic(index_of("plain_store"), {0.50, 0.51, 0.49, 0.50, 0.505, 0.50, 0.495},
                {0.50, 0.50, 0.50, 0.50, 0.50, 0.50, 0.50}),
      // fetch_add: 30 ns on one line against 7 apart.
      synthetic(index_of("atomic_rmw"), {30.0, 31.0, 29.0, 30.5, 29.5, 30.0, 31.5}, {7.0, 7.1, 6.9, 7.0, 7.0, 7.2, 7.0}),
      // seq_cst stores: a repeat in which no thread was scheduled apart is no pair.
      synthetic(index_of("seq_cst_store"), {29.0, 30.0, 31.0, 30.0, 28.0, 30.0, 30.0},
                {6.5, std::nullopt, 6.7, 6.6, 6.5, 6.6, 6.5}),
      // a writer beside a reader: ratios from 0.8 to 1.4, unsure.
      synthetic(index_of("writer_beside_reader"), {0.8, 1.4, 1.0, 1.2, 0.9, 1.3, 1.1}, {1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0}),
  };
  const bench::falseshare_analysis analysis = bench::analyse_falseshare(costs);
  ASSERT_EQ(analysis.patterns.size(), 4u);
  const auto verdict = [&](std::size_t index) { return analysis.patterns.at(index).penalty.value().verdict; };
  EXPECT_EQ(verdict(0), bench::ratio_verdict::within_noise);
  EXPECT_EQ(verdict(1), bench::ratio_verdict::penalty);
  EXPECT_EQ(verdict(2), bench::ratio_verdict::penalty);
  EXPECT_EQ(verdict(3), bench::ratio_verdict::unsure);
  EXPECT_EQ(analysis.patterns[2].penalty->ratios.size(), 6u);  // the unscheduled repeat left out
  EXPECT_NEAR(analysis.patterns[1].penalty->estimate.median, 30.0 / 7.0, 0.1);
  EXPECT_EQ(analysis.patterns[1].penalty->sharing_stride_bytes, 8u);
  EXPECT_EQ(analysis.patterns[1].penalty->apart_stride_bytes, 128u);
  // The one statistics vocabulary: the estimate is the bootstrap of the ratios.
  const auto& rmw = *analysis.patterns[1].penalty;
  const bench::ratio_estimate again = bench::bootstrap_median(rmw.ratios);
  EXPECT_EQ(rmw.estimate.median, again.median);
  EXPECT_EQ(rmw.estimate.low, again.low);
  EXPECT_EQ(rmw.estimate.high, again.high);
  EXPECT_EQ(bench::reading_of(verdict(0)), bench::falseshare_reading::hidden);
  EXPECT_EQ(bench::reading_of(verdict(1)), bench::falseshare_reading::pays);
  EXPECT_EQ(bench::reading_of(verdict(3)), bench::falseshare_reading::unsure);
  EXPECT_EQ(bench::reading_of(bench::ratio_verdict::gain), bench::falseshare_reading::hidden);
}

TEST(FalseshareAnalysis, NoPenaltyWithoutBothStridesOrWithoutAPair) {
  probes::pattern_cost one_stride{0, {{8, true, true, {0.5}, {0.5}}}};
  probes::pattern_cost never_together = synthetic(0, {1.0, std::nullopt}, {std::nullopt, 1.0});
  probes::pattern_cost nobody{0, {{8, true, true, {}, {std::nullopt}}, {128, false, false, {}, {std::nullopt}}}};
  const bench::falseshare_analysis analysis = bench::analyse_falseshare({one_stride, never_together, nobody});
  for (const auto& pattern : analysis.patterns) EXPECT_FALSE(pattern.penalty);
  EXPECT_FALSE(analysis.patterns[2].ns_per_access[0]);  // no sample: no distribution, not a zero
}

// ---------------------------------------------------------------------------
// The answer's words.

bench::pattern_figure figure(std::string_view name, double median, double low, double high) {
  const bench::ratio_estimate estimate{median, low, high};
  return {index_of(name), estimate, bench::verdict_of(estimate)};
}

const bench::falseshare_evidence kEvidence{"0,1", "shared L3", 74.0};

TEST(FalseshareAnswer, APatternWithinNoiseIsOneThisCoreHidesAndThePayingOnesComeFirst) {
  const bench::falseshare_answer answer = bench::falseshare_answer_of(
      {figure("plain_store", 1.01, 0.97, 1.04), figure("atomic_rmw", 4.40, 4.10, 4.80),
       figure("seq_cst_store", 4.61, 4.40, 4.90), figure("writer_beside_reader", 0.98, 0.96, 1.03)},
      kEvidence);
  EXPECT_EQ(answer.figures,
            (std::vector<std::string>{"seq_cst stores 4.61x [4.40, 4.90] penalty",
                                      "atomic read-modify-writes 4.40x [4.10, 4.80] penalty",
                                      "plain stores 1.01x [0.97, 1.04] within noise",
                                      "a writer beside a reader 0.98x [0.96, 1.03] within noise"}));
  EXPECT_EQ(answer.conclusion, "this core hides it for plain stores and a writer beside a reader");
}

TEST(FalseshareAnswer, AGainIsHiddenToo) {
  const bench::falseshare_answer answer = bench::falseshare_answer_of(
      {figure("plain_store", 0.85, 0.80, 0.90), figure("atomic_rmw", 4.4, 4.1, 4.8)}, kEvidence);
  EXPECT_EQ(answer.conclusion, "this core hides it for plain stores");
}

TEST(FalseshareAnswer, WhenNoPatternPaysItSaysWhatThatMeansWithTheEvidence) {
  const bench::falseshare_answer answer = bench::falseshare_answer_of(
      {figure("plain_store", 1.0, 0.98, 1.02), figure("atomic_rmw", 1.01, 0.99, 1.03)}, kEvidence);
  EXPECT_EQ(answer.conclusion.rfind("no pattern pays: ", 0), 0u) << answer.conclusion;
  EXPECT_NE(answer.conclusion.find("SMT siblings"), std::string::npos) << answer.conclusion;
  EXPECT_NE(answer.conclusion.find("took turns on one physical CPU"), std::string::npos) << answer.conclusion;
  EXPECT_NE(answer.conclusion.find("hwloc calls CPUs 0,1 shared L3"), std::string::npos) << answer.conclusion;
  EXPECT_NE(answer.conclusion.find("74.0 ns one way"), std::string::npos) << answer.conclusion;
  // Without evidence, the meaning alone.
  const bench::falseshare_answer bare =
      bench::falseshare_answer_of({figure("plain_store", 1.0, 0.98, 1.02)}, {"0,1", "", std::nullopt});
  EXPECT_EQ(bare.conclusion.find("hwloc"), std::string::npos) << bare.conclusion;
  EXPECT_EQ(bare.conclusion.find("one way"), std::string::npos) << bare.conclusion;
  EXPECT_TRUE(bare.conclusion.ends_with("took turns on one physical CPU")) << bare.conclusion;
}

TEST(FalseshareAnswer, EveryPatternPaysAndUnsureOnesAreNamed) {
  EXPECT_EQ(bench::falseshare_answer_of({figure("plain_store", 3.0, 2.4, 4.3), figure("atomic_rmw", 4.4, 4.1, 4.8)},
                                        kEvidence)
                .conclusion,
            "every pattern measured pays");
  EXPECT_EQ(bench::falseshare_answer_of({figure("plain_store", 1.0, 0.98, 1.02), figure("atomic_rmw", 4.4, 4.1, 4.8),
                                         figure("writer_beside_reader", 1.1, 0.9, 1.4)},
                                        kEvidence)
                .conclusion,
            "this core hides it for plain stores; unsure for a writer beside a reader (more repetitions would tell)");
  EXPECT_EQ(bench::falseshare_answer_of({}, kEvidence).conclusion, "no pattern was measured both on one line and apart");
}

}  // namespace
