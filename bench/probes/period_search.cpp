// The period search (period_search.hpp).
#include "bench/probes/period_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace lockstep::bench::probes {
namespace {

// The continued fraction of the regularised incomplete beta function
// I_x(a, b) (modified Lentz; converges fast for x < (a + 1) / (a + b + 2)):
//   I_x(a, b) = x^a (1 - x)^b / (a B(a, b)) / (1 + d1 / (1 + d2 / (1 + ...)))
//   d_{2j+1} = -(a + j)(a + b + j) x / ((a + 2j)(a + 2j + 1))
//   d_{2j}   =  j (b - j) x / ((a + 2j - 1)(a + 2j))
double beta_continued_fraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300;
  constexpr double kEpsilon = 1e-15;
  double c = 1.0;
  double d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::fabs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double fraction = d;
  for (int j = 1; j <= 100000; ++j) {
    const double jd = static_cast<double>(j);
    const double even = jd * (b - jd) * x / ((a + 2 * jd - 1) * (a + 2 * jd));
    d = 1.0 + even * d;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = 1.0 + even / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    fraction *= d * c;
    const double odd = -(a + jd) * (a + b + jd) * x / ((a + 2 * jd) * (a + 2 * jd + 1));
    d = 1.0 + odd * d;
    if (std::fabs(d) < kTiny) d = kTiny;
    c = 1.0 + odd / c;
    if (std::fabs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double change = d * c;
    fraction *= change;
    if (std::fabs(change - 1.0) < kEpsilon) break;
  }
  return fraction;
}

// I_x(a, b), a, b > 0, x in [0, 1].
double regularized_incomplete_beta(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double log_front = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  if (x < (a + 1.0) / (a + b + 2.0)) return std::exp(log_front) * beta_continued_fraction(a, b, x) / a;
  return 1.0 - std::exp(log_front) * beta_continued_fraction(b, a, 1.0 - x) / b;
}

std::int64_t round_to(double value, std::int64_t resolution) {
  return std::max<std::int64_t>(resolution, std::llround(value / static_cast<double>(resolution)) * resolution);
}

}  // namespace

double miss_rate_upper_bound(std::uint64_t misses, std::uint64_t periods, double confidence) {
  if (periods == 0) throw std::invalid_argument("a miss-rate bound needs at least one period");
  if (misses > periods) throw std::invalid_argument("more misses than periods");
  if (!(confidence > 0.0 && confidence < 1.0)) throw std::invalid_argument("confidence outside (0, 1)");
  if (misses == periods) return 1.0;
  // P(X <= m | n, p) = 1 - I_p(m + 1, n - m): the bound is the p where
  // I_p(m + 1, n - m) = confidence, increasing in p; bisection to 1e-15.
  const auto a = static_cast<double>(misses) + 1.0;
  const auto b = static_cast<double>(periods - misses);
  if (misses == 0) return 1.0 - std::pow(1.0 - confidence, 1.0 / static_cast<double>(periods));  // closed form
  double low = static_cast<double>(misses) / static_cast<double>(periods);
  double high = 1.0;
  for (int iteration = 0; iteration < 200 && high - low > 1e-15 * high; ++iteration) {
    const double middle = 0.5 * (low + high);
    if (regularized_incomplete_beta(a, b, middle) < confidence)
      low = middle;
    else
      high = middle;
  }
  return 0.5 * (low + high);
}

std::int64_t minimum_trial_periods(double miss_rate, double confidence) {
  // (1 - R)^n <= 1 - c: zero misses in n periods then has probability at
  // most 1 - c at the rate R, the closed form of the bound for m = 0.
  return static_cast<std::int64_t>(std::ceil(std::log1p(-confidence) / std::log1p(-miss_rate) - 1e-9));
}

std::int64_t allowed_misses(std::int64_t periods, double miss_rate, double confidence) {
  std::int64_t misses = -1;
  while (misses + 1 <= periods &&
         miss_rate_upper_bound(static_cast<std::uint64_t>(misses + 1), static_cast<std::uint64_t>(periods), confidence) <=
             miss_rate)
    ++misses;
  return misses;
}

std::string period_search_problem(const period_search_settings& settings) {
  if (!(settings.miss_rate > 0.0 && settings.miss_rate < 1.0)) return "the miss rate must lie between 0 and 1";
  if (!(settings.confidence > 0.0 && settings.confidence < 1.0)) return "the confidence must lie between 0 and 1";
  const std::int64_t minimum = minimum_trial_periods(settings.miss_rate, settings.confidence);
  if (settings.trial_periods != 0 && settings.trial_periods < minimum)
    return "a trial of " + std::to_string(settings.trial_periods) + " periods cannot show a miss rate below " +
           std::to_string(settings.miss_rate) + " (at least " + std::to_string(minimum) + " periods)";
  if (settings.resolution_ns <= 0) return "the period resolution must be positive";
  if (settings.floor_period_ns < settings.resolution_ns || settings.floor_period_ns > settings.ceiling_period_ns)
    return "the shortest period to try must be at least the resolution and at most the longest";
  if (settings.start_period_ns < settings.floor_period_ns || settings.start_period_ns > settings.ceiling_period_ns)
    return "the starting period lies outside the periods the search may try";
  if (!(settings.tolerance > 0.0)) return "the search tolerance must be positive";
  if (settings.budget_ns <= 0) return "the search budget must be positive";
  return {};
}

period_search_result find_period(const period_search_settings& settings, const trial_runner& run,
                                 const trial_observer& observe) {
  if (const std::string problem = period_search_problem(settings); !problem.empty())
    throw std::invalid_argument(problem);
  period_search_result result;
  const std::int64_t periods = settings.trial_periods != 0
                                   ? settings.trial_periods
                                   : minimum_trial_periods(settings.miss_rate, settings.confidence);
  result.trial_periods = periods;
  // The miss that makes a trial fail whatever follows.
  const auto failing_misses = static_cast<std::uint64_t>(allowed_misses(periods, settings.miss_rate, settings.confidence) + 1);

  const auto judge = [&](std::int64_t period_ns, const trial_outcome& outcome) {
    period_trial trial;
    trial.period_ns = period_ns;
    trial.outcome = outcome;
    const auto run_periods = static_cast<std::uint64_t>(std::max<std::int64_t>(outcome.periods, 1));
    const std::uint64_t misses = std::min(outcome.misses, run_periods);
    trial.miss_rate = static_cast<double>(misses) / static_cast<double>(run_periods);
    trial.upper_bound = miss_rate_upper_bound(misses, run_periods, settings.confidence);
    trial.holds = trial.upper_bound <= settings.miss_rate;
    return trial;
  };
  // A trial lasts its n periods (a step that overruns makes the schedule
  // skip periods, not fall behind: paced.hpp), and its last step may end up
  // to the slowest step seen so far after its period's start.
  double slowest_step_ns = 0;
  const auto estimate = [&](std::int64_t period_ns) {
    return static_cast<double>(periods) * static_cast<double>(period_ns) + slowest_step_ns +
           static_cast<double>(settings.lead_ns);
  };

  std::optional<std::int64_t> held;    // shortest period that held
  std::optional<std::int64_t> failed;  // longest period that failed (below held, once both exist)
  for (;;) {
    std::int64_t period_ns = 0;
    if (!held && !failed) {
      period_ns = round_to(static_cast<double>(settings.start_period_ns), settings.resolution_ns);
    } else if (!failed) {
      if (*held <= settings.floor_period_ns) {
        result.stopped_because = "floor";
        break;
      }
      period_ns = std::max(settings.floor_period_ns, round_to(static_cast<double>(*held) / 2, settings.resolution_ns));
    } else if (!held) {
      if (*failed >= settings.ceiling_period_ns) {
        result.stopped_because = "ceiling";
        break;
      }
      period_ns =
          std::min(settings.ceiling_period_ns, round_to(static_cast<double>(*failed) * 2, settings.resolution_ns));
    } else {
      if (static_cast<double>(*held) <= static_cast<double>(*failed) * (1.0 + settings.tolerance) ||
          *held - *failed <= settings.resolution_ns) {
        result.stopped_because = "converged";
        break;
      }
      period_ns = round_to(std::sqrt(static_cast<double>(*held) * static_cast<double>(*failed)), settings.resolution_ns);
      if (period_ns <= *failed) period_ns = *failed + settings.resolution_ns;
      if (period_ns >= *held) period_ns = *held - settings.resolution_ns;
    }
    // The confirming run will be at the shortest hold: at most *held.
    const double confirm_estimate = estimate(held ? *held : period_ns);
    if (static_cast<double>(result.elapsed_ns) + estimate(period_ns) + confirm_estimate >
        static_cast<double>(settings.budget_ns)) {
      result.budget_cut = true;
      result.stopped_because = "budget";
      break;
    }
    const trial_outcome outcome = run(period_ns, periods, failing_misses, false);
    result.elapsed_ns += outcome.elapsed_ns;
    slowest_step_ns = std::max(slowest_step_ns, outcome.completion_p50_ns);
    const period_trial trial = judge(period_ns, outcome);
    result.trials.push_back(trial);
    if (observe) observe(trial, false);
    if (trial.holds) {
      held = held ? std::min(*held, period_ns) : period_ns;
    } else {
      // Only a failure below the shortest hold narrows the bracket; one above
      // it (the machine changed pace) is reported but does not move it.
      if (!held || period_ns < *held) failed = failed ? std::max(*failed, period_ns) : period_ns;
    }
  }
  result.found_period_ns = held;
  result.failed_period_ns = failed;
  if (held) {
    const trial_outcome outcome = run(*held, periods, std::nullopt, true);
    result.elapsed_ns += outcome.elapsed_ns;
    result.confirm = judge(*held, outcome);
    if (observe) observe(*result.confirm, true);
  }
  return result;
}

}  // namespace lockstep::bench::probes
