"""A comparison whose sides hold several runs each (`lockstep run --runs K`, a directory or comma list a side).

merged_side joins a side's runs into one RunFile (every repetition of every run, the first run's context and
answer; no pace trace: each run has its own modes) for compare_pair's rows, medians and counters. Then
apply_replicates replaces each entry's verdict interval with the one from the variance between runs
(replicates.py: each run's median log time is one observation, the runs' spread moderated over the entries), the
aggregates likewise on each run's mean over a group's entries of those medians, states the smallest uniform change
the comparison could see at 80 % power, and, with MIN_HALVES_RUNS or more runs a side, compares the halves of
each side with the same statistics (A against A), split two ways. Alternate runs (1, 3, 5 ... against 2, 4, 6
...) spread over the same time as each other, as two sides measured alternately do: the comparison's own
false-positive rate. In time order (1..K/2 against K/2+1..K): whether the machine drifted while a side ran, which
a side measured as one block cannot tell from a change (the text says so when it did).
"""
from __future__ import annotations

import dataclasses
import math
from collections import Counter
from dataclasses import dataclass

import numpy as np

from ..common import statistics
from ..common.fields import C2C_CONTEXT, SERIAL_CONTEXT
from ..read.run_file import Run, RunFile
from .compare import compare_pair
from .comparison import (ALTERNATE, DEFAULT_NOISE_PERCENT, IN_TIME_ORDER, AgainstItself, Aggregate, Comparison,
                         PaceAcrossRuns, PaceAware, Replicated, SideSpread, aggregate_groups, clustered, verdict_of)
from .replicates import (MEDIAN_EFFICIENCY, POWER, RunEvidence, change_seen_by_share, detectable_at_power,
                         median_components, run_interval, run_summary, t_quantile, two_sided_p)
from .run_pace import MIN_RUNS, RunPace, every_group, matched_groups, run_pace

# PaceAware.method of an interval from the spread of the runs: each run's figure over every repetition, or over its
# repetitions in the reference pace of every run (run_pace.py).
BETWEEN_RUNS = "between runs"
ONE_PACE = "between runs, one pace"
RUNS_METHODS = (BETWEEN_RUNS, ONE_PACE)
# Runs a side from which compare also compares each side's halves (A against A).
MIN_HALVES_RUNS = 4


def _merged_run(key, runs: list[Run]) -> Run:
    """The runs' repetitions together; a run in which the entry errored is left out (its times are not a
    measurement), and the entry is errored only when it errored in every run."""
    measured = [run for run in runs if not run.errored]
    runs = measured or runs
    first = runs[0]
    return Run(key, entry=first.entry, names=list(first.names),
               repetitions=[dataclasses.replace(r, pace=None) for run in runs for r in run.repetitions],
               aggregates=dict(first.aggregates),
               errors=[error for run in runs for error in run.errors],
               failed=sum(run.failed for run in runs),
               unavailable=sum((run.unavailable for run in runs), Counter()),
               step_splits=[split for run in runs for split in run.step_splits])


def _merged_context(files: list[RunFile]) -> dict:
    """The first run's context, its in-run calibrations (the serial step, the c2c one-way latency) the median over the
    runs: a side's runs alternate with the other side's, and its first run's reading is one of many."""
    context = dict(files[0].context)
    for key in (SERIAL_CONTEXT, C2C_CONTEXT):
        values = [value for value in (run_file.context_number(key) for run_file in files) if value is not None]
        if values:
            context[key] = f"{statistics.median(values):.2f}"
    return context


def merged_side(files: list[RunFile], label: str, path: str) -> RunFile:
    """One side of several runs as one RunFile (replicates: the runs), or the file itself when it is one."""
    if len(files) == 1:
        return dataclasses.replace(files[0], label=label)
    keys: dict = {}
    for run_file in files:
        for key in run_file.runs:
            keys.setdefault(key, []).append(run_file.runs[key])
    warnings = [warning for run_file in files for warning in run_file.warnings]
    return dataclasses.replace(files[0], path=path, label=label, warnings=warnings, context=_merged_context(files),
                               runs={key: _merged_run(key, runs) for key, runs in keys.items()}, pace=None, pairs=[],
                               mode_medians=None, replicates=tuple(files))


@dataclass(frozen=True)
class _Figures:
    """One entry's runs on both sides: each run's figure (the median of its repetitions' log times, in the reference
    pace or over every repetition: `method`) by the run's place in its side."""

    a: dict[int, float]
    b: dict[int, float]
    method: str

    def evidence(self) -> RunEvidence | None:
        if len(self.a) < 1 or len(self.b) < 1 or len(self.a) + len(self.b) < 3:
            return None
        return RunEvidence(tuple(self.a.values()), tuple(self.b.values()))


def _side_figures(side: RunFile, key, time_kind: str, pace: RunPace | None) -> tuple[dict, dict]:
    """({run's place: its figure in the reference pace}, {run's place: its figure over every repetition})."""
    one, every = {}, {}
    for place, run_file in enumerate(side.replicates):
        if key not in run_file.runs or run_file.runs[key].errored:
            continue
        found = run_summary(every_group([run_file], key, time_kind)[0]) if run_file.runs[key].repetitions else None
        if found is not None:
            every[place] = found
        if pace is not None and pace.reference is not None:
            groups = matched_groups([run_file], key, time_kind, pace)
            if groups:
                one[place] = run_summary(groups[0])
    return one, every


def _figures(comparison: Comparison, time_kind: str, pace: RunPace | None) -> dict:
    """{row key: _Figures}: within the reference pace where each side keeps run_pace.MIN_RUNS runs of the entry
    there, else over every repetition."""
    figures = {}
    for row in comparison.combinations:
        one_a, every_a = _side_figures(comparison.baseline, row.key, time_kind, pace)
        one_b, every_b = _side_figures(comparison.contender, row.key, time_kind, pace)
        if min(len(one_a), len(one_b)) >= MIN_RUNS:
            figures[row.key] = _Figures(one_a, one_b, ONE_PACE)
        else:
            figures[row.key] = _Figures(every_a, every_b, BETWEEN_RUNS)
    return figures


def _entry_intervals(comparison: Comparison, figures: dict) -> dict:
    """Each combination's interval from its runs, set as its beyond-the-pace figure (PaceAware: ONE_PACE, or
    BETWEEN_RUNS over every repetition) with its t-test p; returns {row key: (standard error of the log ratio,
    degrees)}."""
    evidence = {key: found.evidence() for key, found in figures.items()}
    evidence = {key: found for key, found in evidence.items() if found is not None and found.variance is not None}
    prior = statistics.prior_variance([e.variance for e in evidence.values()], [e.degrees for e in evidence.values()])
    errors = {}
    for row in comparison.combinations:
        found = evidence.get(row.key)
        if found is None:
            continue
        variance, degrees = (statistics.moderated_variance(found.variance, found.degrees, prior) if prior
                             else (found.variance, float(found.degrees)))
        sampling = variance * found.scale
        row.pace = PaceAware(figures[row.key].method, f"{len(found.means_a)} and {len(found.means_b)} runs",
                             math.exp(found.log_ratio), run_interval(found.log_ratio, sampling, degrees),
                             row.repetitions_a, row.repetitions_b, pooled=True)
        row.p_raw = two_sided_p(found.log_ratio, sampling, degrees)
        errors[row.key] = (math.sqrt(sampling), degrees)
    for row, adjusted in zip(comparison.rows, statistics.benjamini_hochberg([row.p_raw for row in comparison.rows])):
        row.p_adjusted = adjusted
    return errors


def _group_means(figures: list[_Figures], side: str, runs: int) -> list[float]:
    """Each run's mean, over the group's entries it has a figure for (at least half of them), of its figure less the
    entry's mean over every run of both sides: entries a run lacks (no repetition in the reference pace) leave the
    others' figures comparable."""
    centres = [float(np.mean(list(f.a.values()) + list(f.b.values()))) for f in figures]
    means = []
    for place in range(runs):
        values = [getattr(f, side)[place] - centre for f, centre in zip(figures, centres) if place in getattr(f, side)]
        if values and 2 * len(values) >= len(figures):
            means.append(sum(values) / len(values))
    return means


def _aggregates(comparison: Comparison, figures: dict) -> tuple[list[Aggregate], float | None]:
    """Each group's geometric mean of B/A from its runs' means of their figures (Student's t on the runs), and the
    "all" group's standard error of the log ratio (None without one)."""
    result, error = [], None
    runs = (len(comparison.baseline.replicates), len(comparison.contender.replicates))
    for group, rows in aggregate_groups(comparison.combinations).items():
        found_figures = [figures[row.key] for row in rows if row.pace is not None and row.pace.method in RUNS_METHODS]
        if not found_figures:
            continue
        found = RunEvidence(tuple(_group_means(found_figures, "a", runs[0])),
                            tuple(_group_means(found_figures, "b", runs[1])))
        if not found.means_a or not found.means_b:
            continue
        variance = found.variance
        interval = (run_interval(found.log_ratio, variance * found.scale, found.degrees)
                    if variance is not None else None)
        if group == "all" and variance is not None:
            error = (math.sqrt(variance * found.scale), found.degrees)
        result.append(Aggregate(group, len(found_figures), math.exp(found.log_ratio), interval,
                                verdict_of(interval, comparison.noise_percent), len(clustered(rows))))
    return result, error


def side_spread(runs: list[RunFile], keys, time_kind: str, pace: RunPace | None, side: int) -> SideSpread:
    """How far one side's runs differ, median over the entries: a run's figure over every repetition and in the
    reference pace alone (standard deviations of log time), and the latter's parts between runs and within a run."""
    every, one, between, within, counts = [], [], [], [], []
    for key in keys:
        groups = every_group(runs, key, time_kind)
        medians = [run_summary(group) for group in groups if group]
        if len(medians) >= 2:
            every.append(float(np.std(medians, ddof=1)))
        if pace is None or pace.reference is None:
            continue
        matched = matched_groups(runs, key, time_kind, pace)
        if len(matched) >= 2:
            one.append(float(np.std([run_summary(group) for group in matched], ddof=1)))
            found = median_components(matched)
            if found is not None:
                between.append(found.between)
                within.append(found.within)
                counts.append(found.repetitions)
    middle = (lambda values: statistics.median(values) if values else None)
    return SideSpread(len(runs), pace.reference.runs[side] if pace and pace.reference else 0,
                      pace.share(side) if pace else None, middle(every), middle(one),
                      math.sqrt(middle(between)) if between else None,
                      math.sqrt(middle(within) / MEDIAN_EFFICIENCY) if within else None, middle(counts))


def _pace_across(comparison: Comparison, time_kind: str, pace: RunPace | None, figures: dict) -> PaceAcrossRuns | None:
    if pace is None:
        return None
    keys = [row.key for row in comparison.combinations]
    sides = tuple(side_spread(list(f.replicates), keys, time_kind, pace, index)
                  for index, f in enumerate((comparison.baseline, comparison.contender)))
    one = sum(found.method == ONE_PACE for found in figures.values())
    return PaceAcrossRuns(pace.reading, pace.reference.reading_ns if pace.reference else None, sides, one,
                          len(figures) - one, tuple((c.reading_ns, side, c.runs[other])
                                                    for c, side, other in pace.missing()))


def compare_sides(baseline: RunFile, contender: RunFile, time_kind: str = "real", alpha: float = 0.05,
                  noise_percent: float = DEFAULT_NOISE_PERCENT, halves: bool = True) -> Comparison:
    """B against A (compare.compare_pair), and where both sides hold two or more runs (merged_side), the intervals
    from the runs (apply_replicates; halves: also each side's halves against each other)."""
    comparison = compare_pair(baseline, contender, time_kind, alpha, noise_percent)
    if len(baseline.replicates) >= 2 and len(contender.replicates) >= 2:
        apply_replicates(comparison, time_kind, halves)
    return comparison


def apply_replicates(comparison: Comparison, time_kind: str, halves: bool = True) -> None:
    """Turn a comparison of two merged sides (merged_side, two or more runs each) into one of runs: intervals,
    p and q, aggregates and power from the runs (Replicated); with MIN_HALVES_RUNS runs a side, the halves too."""
    runs_a, runs_b = len(comparison.baseline.replicates), len(comparison.contender.replicates)
    pace = run_pace([list(comparison.baseline.replicates), list(comparison.contender.replicates)])
    figures = _figures(comparison, time_kind, pace)
    errors = _entry_intervals(comparison, figures)
    aggregates, aggregate_error = _aggregates(comparison, figures)
    noise = comparison.noise_percent / 100.0
    replicated = Replicated(runs_a, runs_b, aggregates, pace=_pace_across(comparison, time_kind, pace, figures))
    if errors:
        degrees = statistics.median([d for _, d in errors.values()])
        change = change_seen_by_share([e for e, _ in errors.values()], degrees, noise, POWER)
        replicated.entries_power = None if change is None else change * 100.0
    if aggregate_error is not None:
        replicated.aggregate_power = detectable_at_power(aggregate_error[0], aggregate_error[1], noise) * 100.0
    comparison.replicated = replicated
    if halves and min(runs_a, runs_b) >= MIN_HALVES_RUNS:
        replicated.against_itself = [against_itself(side, split, time_kind, comparison)
                                     for split in (ALTERNATE, IN_TIME_ORDER)
                                     for side in (comparison.baseline, comparison.contender)]


def against_itself(side: RunFile, split: str, time_kind: str, comparison: Comparison) -> AgainstItself:
    """One side's runs split in two (alternate runs, or in time order), half against half, with the comparison's
    statistics and band."""
    runs = list(side.replicates)
    numbers = list(range(1, len(runs) + 1))
    if split == ALTERNATE:
        parts = [(runs[0::2], numbers[0::2]), (runs[1::2], numbers[1::2])]
    else:
        half = len(runs) // 2
        parts = [(runs[:half], numbers[:half]), (runs[half:], numbers[half:])]
    first, second = (merged_side(part, f"{side.label} runs {','.join(map(str, which))}", side.path)
                     for part, which in parts)
    halves = compare_sides(first, second, time_kind, comparison.alpha, comparison.noise_percent, halves=False)
    called = [row for row in halves.combinations if halves.beyond_pace(row) in ("slower", "faster")]
    return AgainstItself(split, len(called), len(halves.combinations), (len(parts[0][0]), len(parts[1][0])))


def one_run_power(comparison: Comparison) -> tuple[float | None, float | None]:
    """A comparison of one run a side: the smallest uniform change of which POWER of the entries would be called
    slower, and the "all" aggregate's, each from its interval's width (normal quantiles), in percent."""
    noise = comparison.noise_percent / 100.0
    z = t_quantile(0.5 + statistics.CONFIDENCE / 2.0, math.inf)
    errors = [math.log(i[1] / i[0]) / (2.0 * z) for i in (row.beyond_pace_interval() for row in
                                                         comparison.combinations) if i and i[0] > 0]
    change = change_seen_by_share(errors, math.inf, noise, POWER) if errors else None
    overall = next((a for a in comparison.aggregates() if a.group == "all" and a.interval), None)
    aggregate = (detectable_at_power(math.log(overall.interval[1] / overall.interval[0]) / (2.0 * z), math.inf, noise)
                 if overall else None)
    return (None if change is None else change * 100.0), (None if aggregate is None else aggregate * 100.0)
