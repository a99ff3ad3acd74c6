// How the paired comparisons take their pairs (bench/harness/paired_blocks.hpp):
// in rounds, one pair of every running comparison per round, so that a
// comparison's pairs lie spread over the pairing phase; a stalled side ends
// its comparison with a failure; the time budget cuts a comparison only after
// its first kMinPairs pairs. Block runners here are stand-ins that return a
// fixed time per unit and log the order in which blocks ran: no timing is
// asserted.
#include <gtest/gtest.h>

#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bench/harness/paired_blocks.hpp"
#include "bench/harness/run_book.hpp"
#include "bench/harness/team_driver.hpp"

namespace {

namespace bench = lockstep::bench;

// A side that takes `ns_per_unit` per unit (or stalls: empty) and appends its
// entry's name to `log` for every block.
class scripted_side final : public bench::block_runner {
 public:
  scripted_side(std::string name, std::optional<double> ns_per_unit, std::vector<std::string>& log)
      : name_(std::move(name)), ns_per_unit_(ns_per_unit), log_(log) {}
  std::optional<double> run_block(std::uint64_t /*units*/) override {
    log_.push_back(name_);
    return ns_per_unit_;
  }

 private:
  std::string name_;
  std::optional<double> ns_per_unit_;
  std::vector<std::string>& log_;
};

struct scripted_run {
  bench::run_book book;
  bench::harness_state harness;
  std::vector<std::string> log;
  std::vector<bench::comparison> plan;

  scripted_run() { harness.book = &book; }

  // A comparison of entry `name`/a against `name`/b, a taking `ratio` times b's time.
  void compare(const std::string& name, std::optional<double> ratio) {
    const std::string a = name + "/a";
    const std::string b = name + "/b";
    harness.block_runners[a] = [this, a, ratio] {
      return std::make_unique<scripted_side>(a, ratio ? std::optional<double>(*ratio * 100.0) : std::nullopt, log);
    };
    harness.block_runners[b] = [this, b] { return std::make_unique<scripted_side>(b, 100.0, log); };
    plan.push_back({bench::comparison_kind::false_sharing, name, a, b});
  }

  const bench::paired_result& result_of(const std::string& name) const {
    for (const auto& pair : book.pairs)
      if (pair.what.group == name) return pair;
    throw std::runtime_error("no result for " + name);
  }
};

TEST(PairedRounds, EveryRoundTakesOnePairOfEveryComparison) {
  scripted_run run;
  run.compare("first", 2.0);
  run.compare("second", 0.5);
  run.compare("third", 1.0);
  bench::pairing_settings settings;
  settings.pairs = 6;
  settings.budget_ns = std::int64_t{1} << 60;
  std::size_t progress_calls = 0;  // once a round, counting the rounds
  bench::measure_pairs(run.harness, run.plan, settings, [&](std::size_t round, std::size_t rounds) {
    ++progress_calls;
    EXPECT_EQ(round, progress_calls);
    EXPECT_EQ(rounds, 6u);
  });
  EXPECT_EQ(progress_calls, 6u);
  ASSERT_EQ(run.log.size(), 3u * 6u * 2u);
  // Round r holds blocks [6 r, 6 r + 6): each comparison's two blocks, once.
  for (std::size_t round = 0; round < 6; ++round) {
    std::map<std::string, int> blocks;
    for (std::size_t index = 6 * round; index < 6 * round + 6; ++index) ++blocks[run.log[index]];
    for (const char* name : {"first/a", "first/b", "second/a", "second/b", "third/a", "third/b"})
      EXPECT_EQ(blocks[name], 1) << "round " << round << ", " << name;
  }
  // The order alternates within a comparison: A B on even pairs, B A on odd ones.
  std::string first;  // the first comparison's sides in order, one letter per block
  for (const auto& name : run.log)
    if (name.rfind("first/", 0) == 0) first += name.back();
  EXPECT_EQ(first.substr(0, 4), "abba");
  EXPECT_DOUBLE_EQ(run.result_of("first").estimate.median, 2.0);
  EXPECT_DOUBLE_EQ(run.result_of("second").estimate.median, 0.5);
  EXPECT_EQ(run.result_of("first").verdict, bench::ratio_verdict::penalty);
  EXPECT_EQ(run.result_of("second").verdict, bench::ratio_verdict::gain);
  EXPECT_EQ(run.result_of("third").verdict, bench::ratio_verdict::within_noise);
  EXPECT_EQ(run.result_of("third").ratios.size(), 6u);
}

TEST(PairedRounds, AStalledSideEndsItsComparisonOnly) {
  scripted_run run;
  run.compare("stalls", std::nullopt);
  run.compare("runs", 2.0);
  bench::pairing_settings settings;
  settings.pairs = 5;
  settings.budget_ns = std::int64_t{1} << 60;
  bench::measure_pairs(run.harness, run.plan, settings, {});
  EXPECT_FALSE(run.result_of("stalls").failure.empty());
  EXPECT_TRUE(run.result_of("stalls").ratios.empty());
  EXPECT_TRUE(run.result_of("runs").failure.empty());
  EXPECT_EQ(run.result_of("runs").ratios.size(), 5u);
}

TEST(PairedRounds, TheBudgetCutsOnlyAfterTheFirstPairs) {
  scripted_run run;
  run.compare("cut", 2.0);
  bench::pairing_settings settings;
  settings.pairs = 10;
  settings.budget_ns = 0;
  bench::measure_pairs(run.harness, run.plan, settings, {});
  EXPECT_EQ(run.result_of("cut").ratios.size(), bench::kMinPairs);
  EXPECT_TRUE(run.result_of("cut").budget_cut);
}

TEST(PairedRounds, NoPairsMeasuresNothing) {
  scripted_run run;
  run.compare("none", 2.0);
  bench::pairing_settings settings;
  settings.pairs = 0;
  bench::measure_pairs(run.harness, run.plan, settings, {});
  EXPECT_TRUE(run.book.pairs.empty());
  EXPECT_TRUE(run.log.empty());
}

TEST(PairedRounds, AComparisonWithoutRunnersSaysSo) {
  scripted_run run;
  run.plan.push_back({bench::comparison_kind::migration, "orphan", "x/a", "x/b"});
  bench::pairing_settings settings;
  bench::measure_pairs(run.harness, run.plan, settings, {});
  ASSERT_EQ(run.book.pairs.size(), 1u);
  EXPECT_FALSE(run.book.pairs[0].failure.empty());
}

}  // namespace
