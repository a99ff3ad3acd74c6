"""Runs as replicates: a side of a comparison measured in several fresh processes (`lockstep run --runs K`).

Kalibera and Jones ("Rigorous benchmarking in reasonable time", 2013) model the variance of a measurement at each
level of repetition as an independent component. lockstep's levels are the repetitions within a run and the runs
(fresh processes, each with its own start-up, placement and state of the machine). Per entry, the log step time of
repetition j of run i is mu + b_i + e_ij with Var(b) the between-run component and Var(e) the within-run one;
variance_components estimates both by the one-way random-effects ANOVA (method of moments).

A run's figure for an entry is the median of its repetitions' log times (run_summary), not their mean: the
repetitions inside one run are heavy-tailed (a repetition that caught the VM changing pace is slower by tens of
percent), and one such repetition in five moves a run's mean by several percent and its median little. Every
statistic on runs uses the same figure: each entry's interval, the aggregates, the A against A check and the
planner, so that what the planner predicts is what compare sees.

With K >= 2 runs a side, an entry's interval of B/A is on the ratio of the geometric means of its runs' medians:
each run's median log time is one observation, so whatever moves a whole run (the drift that repetitions inside
one run cannot see) is in the spread; the variance of the run medians is moderated towards the comparison's
(statistics.prior_variance, limma's empirical Bayes) and the interval is Student's t (run_interval). An aggregate
is the same on each run's mean, over the group's entries, of their run medians. With one run a side there is no
spread of runs: compare keeps the calibrated drift term (pace_statistics.pool_evidence) and says so.

The power of a plan (runs x repetitions) follows from the components of the run median: Var(log B/A) =
2 (Var(b) + Var_m(e) / n) / K, with Var_m(e) = MEDIAN_EFFICIENCY x the repetitions' robust variance
(summary_within_variance); the smallest uniform change it sees at 80 % power is where its interval's lower end
clears the noise band four times in five (detectable_at_power).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..common import statistics

# The power the planner and the comparison's "smallest change it could see" are stated at.
POWER = 0.80
# With a one-run pilot the between-run component is unknown: the drift compare's noise band stands for. Two runs
# back to back moved by 4-5 % (comparison.NOISE_RATIONALE); a between-run standard deviation of half the band's log
# puts two runs' difference beyond the band about one time in six.
ASSUMED_DRIFT_SHARE_OF_BAND = 0.5


@dataclass(frozen=True)
class Components:
    """The variance components of log time: between runs (Var(b)) and within a run (Var(e)), from `runs` runs of
    `repetitions` repetitions on average (n0 of the unbalanced ANOVA). From median_components, within is the
    within-run part of a run median's variance per repetition."""

    between: float
    within: float
    runs: int
    repetitions: float

    def plan_variance(self, runs: int, repetitions: int) -> float:
        """The variance of one side's mean over its runs (of their figures) under a plan of runs x repetitions."""
        return (self.between + self.within / repetitions) / runs


def variance_components(groups) -> Components | None:
    """The one-way random-effects ANOVA of values in groups (a run's log times): MSW = sum (y_ij - mean_i)^2 / (N - K),
    MSB = sum n_i (mean_i - mean)^2 / (K - 1), n0 = (N - sum n_i^2 / N) / (K - 1), Var(e) = MSW,
    Var(b) = max(0, (MSB - MSW) / n0). One group: Var(b) unknown, stated as NaN. None without two values in a group."""
    groups = [np.asarray(group, dtype=float) for group in groups if len(group) > 0]
    total = sum(len(group) for group in groups)
    if total - len(groups) < 1:
        return None
    within = float(sum(((group - group.mean()) ** 2).sum() for group in groups) / (total - len(groups)))
    if len(groups) < 2:
        return Components(math.nan, within, 1, float(total))
    grand = float(np.concatenate(groups).mean())
    between_mean_square = float(sum(len(g) * (g.mean() - grand) ** 2 for g in groups) / (len(groups) - 1))
    n0 = (total - sum(len(g) ** 2 for g in groups) / total) / (len(groups) - 1)
    return Components(max(0.0, (between_mean_square - within) / n0), within, len(groups), n0)


def nested_components(data) -> list[float]:
    """Kalibera and Jones's estimators for a balanced nested design of any depth: data[i][j]...[k] (the outermost
    level first). Returns the components from the lowest level up: T_1^2 = S_1^2, T_i^2 = S_i^2 - S_{i-1}^2 / n_{i-1}
    clipped at 0, with S_i^2 the unbiased variance of level i's values (the means of level i - 1) within their
    group, averaged over the groups, and n_{i-1} the count at level i - 1. NaN for a level of one."""
    array = np.asarray(data, dtype=float)
    components: list[float] = []
    spreads: list[float] = []
    means = array
    for level in range(array.ndim):
        count = means.shape[-1]
        spread = float(means.var(axis=-1, ddof=1).mean()) if count > 1 else math.nan
        if level == 0:
            components.append(spread)
        else:
            below = array.shape[array.ndim - level]
            components.append(max(0.0, spread - spreads[-1] / below) if count > 1 else math.nan)
        spreads.append(spread)
        means = means.mean(axis=-1)
    return components


# Var(median of n) / Var(mean of n) for normal values (asymptotically pi / 2; 1.43 at n = 5): the price of the
# median's robustness, in the planner's formula for a run median's variance (summary_within_variance).
MEDIAN_EFFICIENCY = math.pi / 2.0
# The standard deviation of normal values over their median absolute deviation.
MAD_TO_SD = 1.4826


def run_summary(logs) -> float | None:
    """A run's figure for an entry: the median of its repetitions' log times (None without one)."""
    values = [v for v in logs if math.isfinite(v)]
    return statistics.median(values) if values else None


def run_medians(values_per_run) -> list[float]:
    """Each run's median log time (run_summary; runs without a positive value left out)."""
    medians = []
    for values in values_per_run:
        found = run_summary([math.log(v) for v in values if v > 0 and math.isfinite(v)])
        if found is not None:
            medians.append(found)
    return medians


def summary_within_variance(groups) -> float | None:
    """The within-run part of a run median's variance, per repetition (divide by n for n repetitions): the
    repetitions' robust variance, (MAD_TO_SD x the median absolute deviation of every value from its run's median)
    squared, times MEDIAN_EFFICIENCY. Robust as the median is: a repetition that caught a change of pace widens it
    little, as it moves the median little. None without a group of two values."""
    deviations = []
    for group in groups:
        if len(group) < 2:
            continue
        centre = statistics.median(group)
        found = sorted(abs(v - centre) for v in group)
        # A run of odd length has its median among its values: that deviation is 0 by construction, not a spread.
        deviations += found[1:] if len(found) % 2 else found
    if not deviations:
        return None
    scale = MAD_TO_SD * statistics.median(deviations)
    return MEDIAN_EFFICIENCY * scale * scale


def median_components(groups) -> Components | None:
    """The components of a run median's variance from runs of log times (a pilot's): within =
    summary_within_variance (per repetition), between = max(0, the unbiased variance of the runs' medians -
    within / n) with n the mean repetitions a run. One run: between unknown, NaN. None without two values in a
    run."""
    groups = [[float(v) for v in group] for group in groups if len(group) > 0]
    within = summary_within_variance(groups)
    if within is None:
        return None
    repetitions = sum(len(group) for group in groups) / len(groups)
    if len(groups) < 2:
        return Components(math.nan, within, 1, repetitions)
    medians = [run_summary(group) for group in groups]
    spread = float(np.var(medians, ddof=1))
    return Components(max(0.0, spread - within / repetitions), within, len(groups), repetitions)


@dataclass(frozen=True)
class RunEvidence:
    """One entry's or group's runs on both sides: the runs' figures (run_summary: median log times, or a group's
    mean of them), the difference of their means, and the pooled variance of a run's figure with its degrees of
    freedom (before moderation)."""

    means_a: tuple[float, ...]
    means_b: tuple[float, ...]

    @property
    def log_ratio(self) -> float:
        return sum(self.means_b) / len(self.means_b) - sum(self.means_a) / len(self.means_a)

    @property
    def degrees(self) -> int:
        return len(self.means_a) + len(self.means_b) - 2

    @property
    def variance(self) -> float | None:
        if self.degrees < 1:
            return None
        squares = sum((m - sum(side) / len(side)) ** 2 for side in (self.means_a, self.means_b) for m in side)
        return squares / self.degrees

    @property
    def scale(self) -> float:
        """1/K_A + 1/K_B: a run mean's variance times this is the log ratio's."""
        return 1.0 / len(self.means_a) + 1.0 / len(self.means_b)


@functools.lru_cache(maxsize=256)
def t_quantile(probability: float, degrees: float) -> float:
    from scipy import stats

    return float(stats.norm.ppf(probability)) if math.isinf(degrees) else float(stats.t.ppf(probability, degrees))


def run_interval(log_ratio: float, variance: float, degrees: float,
                 confidence: float = statistics.CONFIDENCE) -> tuple[float, float]:
    """exp(log_ratio -+ t sqrt(variance)): the interval of B/A from the log ratio's variance (Student's t with
    `degrees`, the normal's when infinite)."""
    half = t_quantile(0.5 + confidence / 2.0, degrees) * math.sqrt(max(variance, 0.0))
    return math.exp(log_ratio - half), math.exp(log_ratio + half)


def two_sided_p(log_ratio: float, variance: float, degrees: float) -> float | None:
    from scipy import stats

    if variance <= 0:
        return None
    statistic = abs(log_ratio) / math.sqrt(variance)
    tail = stats.norm.sf(statistic) if math.isinf(degrees) else stats.t.sf(statistic, degrees)
    return float(min(1.0, 2.0 * tail))


def detectable_at_power(standard_error: float, degrees: float, noise: float, power: float = POWER,
                        confidence: float = statistics.CONFIDENCE) -> float:
    """The smallest uniform change (a fraction) whose interval's lower end clears the band 1 + noise with
    probability `power`: (1 + noise) exp((t_{(1+confidence)/2} + t_power) se) - 1."""
    width = t_quantile(0.5 + confidence / 2.0, degrees) + t_quantile(power, degrees)
    return (1.0 + noise) * math.exp(width * standard_error) - 1.0


def power_of(change: float, standard_error: float, degrees: float, noise: float,
             confidence: float = statistics.CONFIDENCE) -> float:
    """The probability that a uniform change (a fraction) is called slower: P(lower end > log(1 + noise))."""
    from scipy import stats

    if standard_error <= 0:
        return 1.0 if change > noise else 0.0
    shift = (math.log1p(change) - math.log1p(noise)) / standard_error - t_quantile(0.5 + confidence / 2.0, degrees)
    return float(stats.norm.cdf(shift) if math.isinf(degrees) else stats.t.cdf(shift, degrees))


def change_seen_by_share(standard_errors, degrees: float, noise: float, share: float = POWER) -> float | None:
    """The smallest uniform change (a fraction) of which `share` of the entries (their log ratio's standard errors)
    are expected to be called slower: the mean power over the entries reaches `share` (bisection)."""
    errors = [e for e in standard_errors if e is not None and math.isfinite(e)]
    if not errors:
        return None

    from scipy import stats

    errors = np.asarray(errors, dtype=float)
    seen = errors > 0
    critical = t_quantile(0.5 + statistics.CONFIDENCE / 2.0, degrees)
    distribution = stats.norm() if math.isinf(degrees) else stats.t(degrees)

    def mean_power(change: float) -> float:  # power_of of every entry at once, summed in their order
        powers = np.full(errors.size, 1.0 if change > noise else 0.0)
        powers[seen] = distribution.cdf((math.log1p(change) - math.log1p(noise)) / errors[seen] - critical)
        return sum(powers.tolist()) / errors.size

    low, high = noise, noise + 1.0
    while mean_power(high) < share:
        high = 2.0 * high + 1.0
        if high > 1e6:
            return None
    for _ in range(60):
        middle = (low + high) / 2.0
        low, high = (middle, high) if mean_power(middle) < share else (low, middle)
    return high


def assumed_drift(noise: float) -> float:
    """The between-run standard deviation of log time assumed where no pilot's runs show it (ASSUMED_DRIFT_SHARE_OF_BAND
    of the band's log)."""
    return ASSUMED_DRIFT_SHARE_OF_BAND * math.log1p(noise)


def allocation(costs, components) -> list[int]:
    """Kalibera and Jones's repetitions per level, lowest first: r_i = ceil(sqrt((c_{i+1} / c_i) T_i^2 / T_{i+1}^2))
    for every level but the top one (whose count the wanted precision sets). costs[i]: the cost of one more
    repetition at level i (c_1 a repetition, c_2 a run's fixed part); components[i]: T_i^2. An upper level with no
    variance of its own (T_{i+1}^2 = 0) asks for as many as the caller allows: math.inf."""
    counts = []
    for i in range(len(costs) - 1):
        if components[i + 1] <= 0:
            counts.append(math.inf)
            continue
        counts.append(math.ceil(math.sqrt((costs[i + 1] / costs[i]) * components[i] / components[i + 1])))
    return counts
