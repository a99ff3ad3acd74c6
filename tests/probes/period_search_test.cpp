// The period search (bench/probes/period_search.hpp) on stand-in steps whose
// miss rate is a known function of the period: the bound against reference
// values, the bisection's answer, and the budget, floor and ceiling stops.
// Nothing here runs a clock: the stand-in reports its own elapsed time.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "bench/probes/delay.hpp"
#include "bench/probes/paced.hpp"
#include "bench/probes/period_search.hpp"

namespace {

namespace probes = lockstep::bench::probes;

// Reference values: scipy.stats.beta.ppf(0.95, m + 1, n - m) (the
// Clopper-Pearson one-sided upper bound), computed with Debian's scipy.
TEST(MissRateUpperBound, MatchesTheClopperPearsonReference) {
  struct reference {
    std::uint64_t misses, periods;
    double bound;
  };
  for (const reference& r : {reference{0, 2996, 0.000999410894640585}, reference{1, 10, 0.39416330243650466},
                             reference{4, 10000, 0.0009151160584710777}, reference{5, 10000, 0.0010510137186384818},
                             reference{0, 1, 0.95}, reference{50, 100, 0.5863782853690883},
                             reference{1, 6000, 0.0007903974572224964}, reference{2, 6000, 0.001048923369197836}}) {
    EXPECT_NEAR(probes::miss_rate_upper_bound(r.misses, r.periods, 0.95), r.bound, 1e-9 * std::max(1.0, r.bound))
        << r.misses << " of " << r.periods;
  }
  EXPECT_EQ(probes::miss_rate_upper_bound(3, 3, 0.95), 1.0);
  EXPECT_THROW((void)probes::miss_rate_upper_bound(0, 0, 0.95), std::invalid_argument);
  EXPECT_THROW((void)probes::miss_rate_upper_bound(4, 3, 0.95), std::invalid_argument);
}

TEST(MissRateUpperBound, GrowsWithTheMissesAndShrinksWithThePeriods) {
  double previous = 0;
  for (std::uint64_t misses = 0; misses < 20; ++misses) {
    const double bound = probes::miss_rate_upper_bound(misses, 1000, 0.95);
    EXPECT_GT(bound, previous);
    EXPECT_GT(bound, static_cast<double>(misses) / 1000.0);
    previous = bound;
  }
  EXPECT_LT(probes::miss_rate_upper_bound(3, 20000, 0.95), probes::miss_rate_upper_bound(3, 2000, 0.95));
}

TEST(MinimumTrialPeriods, IsTheRuleOfThree) {
  EXPECT_EQ(probes::minimum_trial_periods(1e-3, 0.95), 2995);
  EXPECT_EQ(probes::minimum_trial_periods(0.5, 0.95), 5);
  EXPECT_EQ(probes::minimum_trial_periods(1e-2, 0.95), 299);
  // Zero misses in that many periods holds; one period fewer does not.
  EXPECT_LE(probes::miss_rate_upper_bound(0, 2995, 0.95), 1e-3);
  EXPECT_GT(probes::miss_rate_upper_bound(0, 2994, 0.95), 1e-3);
}

// A step that misses every period shorter than `threshold_ns` and none from
// there on; each run "takes" periods x max(period, step) ns.
struct threshold_step {
  std::int64_t threshold_ns;
  std::int64_t step_ns = 50'000;
  int runs = 0;
  int confirming_runs = 0;
  int ended_early = 0;
  probes::trial_outcome operator()(std::int64_t period_ns, std::int64_t periods,
                                   std::optional<std::uint64_t> stop_after_misses, bool confirming) {
    ++runs;
    confirming_runs += confirming ? 1 : 0;
    EXPECT_EQ(confirming, !stop_after_misses.has_value());  // the confirming run runs its whole length
    probes::trial_outcome outcome;
    outcome.periods = periods;
    outcome.misses = period_ns < threshold_ns ? static_cast<std::uint64_t>(periods) : 0;
    if (stop_after_misses && outcome.misses >= *stop_after_misses) {
      // every period misses: the run ends after the limit's period
      ++ended_early;
      outcome.periods = static_cast<std::int64_t>(*stop_after_misses);
      outcome.misses = *stop_after_misses;
    }
    outcome.completion_p50_ns = static_cast<double>(step_ns);
    outcome.elapsed_ns = outcome.periods * std::max(period_ns, step_ns);
    return outcome;
  }
};

probes::period_search_settings quick_settings() {
  probes::period_search_settings settings;
  settings.miss_rate = 1e-2;  // 299 periods a trial
  settings.start_period_ns = 1'000'000;
  settings.budget_ns = 3'600'000'000'000;
  settings.lead_ns = 0;
  return settings;
}

TEST(FindPeriod, BisectsToTheThreshold) {
  for (std::int64_t threshold : {137'000LL, 1'000'000LL, 4'321'000LL, 12'000LL}) {
    threshold_step step{threshold};
    const auto result = probes::find_period(quick_settings(), std::ref(step));
    ASSERT_TRUE(result.found_period_ns.has_value()) << threshold;
    EXPECT_GE(*result.found_period_ns, threshold);
    EXPECT_LE(static_cast<double>(*result.found_period_ns), static_cast<double>(threshold) * 1.05 + 1000);
    ASSERT_TRUE(result.failed_period_ns.has_value()) << threshold;
    EXPECT_LT(*result.failed_period_ns, threshold);
    EXPECT_EQ(result.stopped_because, "converged");
    EXPECT_FALSE(result.budget_cut);
    EXPECT_EQ(result.trial_periods, 299);
    ASSERT_TRUE(result.confirm.has_value());
    EXPECT_EQ(result.confirm->period_ns, *result.found_period_ns);
    EXPECT_TRUE(result.confirm->holds);
    EXPECT_EQ(step.confirming_runs, 1);
    EXPECT_EQ(step.runs, static_cast<int>(result.trials.size()) + 1);
    for (const auto& trial : result.trials) {
      EXPECT_EQ(trial.period_ns % 1000, 0);  // the resolution
      EXPECT_EQ(trial.holds, trial.period_ns >= threshold);
    }
  }
}

TEST(AllowedMisses, IsTheLargestCountThatStillHolds) {
  EXPECT_EQ(probes::allowed_misses(2995, 1e-3, 0.95), 0);
  EXPECT_EQ(probes::allowed_misses(2994, 1e-3, 0.95), -1);
  EXPECT_EQ(probes::allowed_misses(10'000, 1e-3, 0.95), 4);  // 5 in 10000: bound 0.00105
  EXPECT_EQ(probes::allowed_misses(6000, 1e-3, 0.95), 1);
}

TEST(FindPeriod, FailingTrialsEndAtTheMissThatDecidesThem) {
  threshold_step step{137'000};
  const auto result = probes::find_period(quick_settings(), std::ref(step));
  int failing = 0;
  for (const auto& trial : result.trials) {
    if (trial.holds) continue;
    ++failing;
    EXPECT_EQ(trial.outcome.misses, 1u);  // 299 periods allow none: the first miss decides
    EXPECT_EQ(trial.outcome.periods, 1);
  }
  EXPECT_EQ(step.ended_early, failing);
  EXPECT_GT(failing, 0);
}

TEST(FindPeriod, StopsAtTheFloorAndTheCeiling) {
  threshold_step easy{1};  // holds everywhere
  const auto floor = probes::find_period(quick_settings(), std::ref(easy));
  EXPECT_EQ(floor.stopped_because, "floor");
  EXPECT_EQ(floor.found_period_ns, 10'000);

  auto settings = quick_settings();
  settings.ceiling_period_ns = 8'000'000;
  threshold_step hopeless{1'000'000'000'000};  // fails everywhere
  const auto ceiling = probes::find_period(settings, std::ref(hopeless));
  EXPECT_EQ(ceiling.stopped_because, "ceiling");
  EXPECT_FALSE(ceiling.found_period_ns.has_value());
  EXPECT_FALSE(ceiling.confirm.has_value());
  EXPECT_EQ(ceiling.failed_period_ns, 8'000'000);
  EXPECT_EQ(hopeless.confirming_runs, 0);
}

TEST(FindPeriod, TheBudgetCutsTheSearchAndLeavesRoomForTheConfirmingRun) {
  auto settings = quick_settings();
  // 299 periods of 1 ms = 0.3 s a trial at the start; 0.7 s leaves room for
  // it and its confirmation, not for the next trial (0.15 s) as well.
  settings.budget_ns = 700'000'000;
  threshold_step step{137'000};
  const auto result = probes::find_period(settings, std::ref(step));
  EXPECT_TRUE(result.budget_cut);
  EXPECT_EQ(result.stopped_because, "budget");
  ASSERT_TRUE(result.found_period_ns.has_value());
  ASSERT_TRUE(result.confirm.has_value());
  EXPECT_LE(result.elapsed_ns, settings.budget_ns);
  EXPECT_EQ(result.trials.size(), 1u);
  EXPECT_EQ(result.found_period_ns, 1'000'000);
}

TEST(FindPeriod, ABudgetTooSmallForOneTrialRunsNothing) {
  auto settings = quick_settings();
  settings.budget_ns = 100'000'000;  // 0.1 s: one trial at 1 ms needs 0.3 s
  threshold_step step{137'000};
  const auto result = probes::find_period(settings, std::ref(step));
  EXPECT_TRUE(result.budget_cut);
  EXPECT_TRUE(result.trials.empty());
  EXPECT_FALSE(result.found_period_ns.has_value());
  EXPECT_EQ(step.runs, 0);
}

// A trial that allows misses: a longer trial holds with a few.
TEST(FindPeriod, LongerTrialsAllowSomeMisses) {
  auto settings = quick_settings();
  settings.miss_rate = 1e-3;
  settings.trial_periods = 10'000;
  const auto few_misses = [](std::int64_t, std::int64_t periods, std::optional<std::uint64_t>, bool) {
    probes::trial_outcome outcome;
    outcome.periods = periods;
    outcome.misses = 4;
    outcome.elapsed_ns = 1;
    return outcome;
  };
  const auto result = probes::find_period(settings, few_misses);
  ASSERT_FALSE(result.trials.empty());
  EXPECT_TRUE(result.trials.front().holds);  // the bound of 4 in 10000 is 0.000915
}

TEST(FindPeriod, RefusesSettingsThatCannotSearch) {
  auto settings = quick_settings();
  settings.trial_periods = 100;  // below the 299 that 1e-2 needs
  EXPECT_NE(probes::period_search_problem(settings), "");
  EXPECT_THROW((void)probes::find_period(settings, threshold_step{1}), std::invalid_argument);
  settings = quick_settings();
  settings.miss_rate = 0;
  EXPECT_NE(probes::period_search_problem(settings), "");
  settings = quick_settings();
  settings.start_period_ns = 1'000;  // below the floor
  EXPECT_NE(probes::period_search_problem(settings), "");
  EXPECT_EQ(probes::period_search_problem(quick_settings()), "");
}

// What a run whose schedule re-anchored tells the search (delay.hpp,
// trial_of): a schedule of 8 periods of 1 ms, steps in periods 0, 3, 4 and 7
// (the ones in 0 and 4 took 2.5 ms and overran, each making the schedule
// skip two periods): 8 periods, 6 misses (2 overruns, 4 skipped periods).
TEST(TrialOf, ASkippedPeriodIsAMiss) {
  probes::paced_result run;
  run.participants = 1;
  run.periods = 4;
  run.completion_ns = {2'500'000, 400'000, 2'500'000, 400'000};
  run.period_index = {0, 3, 4, 7};
  run.deadline_misses = 2;
  run.periods_scheduled = 8;
  run.skipped_periods = 4;
  for (std::size_t k = 1; k < run.period_index.size(); ++k)
    EXPECT_EQ(run.period_index[k],
              probes::next_period(run.period_index[k - 1], static_cast<std::int64_t>(run.completion_ns[k - 1]), 1'000'000));
  const probes::trial_outcome trial = probes::trial_of(run, 42);
  EXPECT_EQ(trial.periods, 8);
  EXPECT_EQ(trial.misses, 6u);
  EXPECT_EQ(trial.skipped, 4u);
  EXPECT_EQ(trial.elapsed_ns, 42);
  EXPECT_DOUBLE_EQ(trial.completion_p50_ns, (400'000.0 + 2'500'000.0) / 2);
}

}  // namespace
