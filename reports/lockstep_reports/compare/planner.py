"""`lockstep compare --plan PILOT [PILOT ...] [--detect PCT]`: what a plan of runs x repetitions can see, from a pilot.

A pilot is any earlier `lockstep run` file, or a group of runs (a directory of `lockstep run --runs K`, or files
given together). Per entry, the variance components of a run's median log step time, compare's figure for a run
(replicates.median_components: between runs, within a run from the repetitions' robust spread) give each plan's
standard error of a log ratio B/A, two sides alike: Var = 2 (Var(b) + Var_m(e) / n) / K. Per thread count and
overall the planner states the smallest uniform change of which 80 % of the entries would be called slower
(replicates.change_seen_by_share, two-sided at compare's confidence, against its noise band), and the aggregate's.

--detect PCT: the cheapest plan that sees a uniform change of PCT in 80 % of the entries. The repetitions per run
follow Kalibera and Jones's allocation (replicates.allocation) from the pooled components and the costs: a
repetition of the whole matrix (the pilot's lockstep_matrix_s over its repetitions) against a run's fixed part (its
lockstep_wall_s less lockstep_matrix_s: start-up, calibrations, pairs, probes); then the fewest runs a side that
reach the target, with the time it takes on the pilot's machine. A pilot of one run cannot show the between-run
component: the planner assumes replicates.assumed_drift and says so.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..analysis.run_analysis import is_calibration
from ..common import statistics
from ..common.fields import MATRIX_SECONDS_CONTEXT, WALL_SECONDS_CONTEXT
from ..common.text_layout import wrapped
from ..read.run_file import RunFile
from .comparison import aggregate_groups
from .replicates import (MEDIAN_EFFICIENCY, POWER, Components, allocation, assumed_drift, change_seen_by_share,
                         detectable_at_power, median_components, run_summary)

# The plans the planner searches: repetitions per run and runs a side.
MIN_PLAN_REPETITIONS = 3
MAX_PLAN_REPETITIONS = 200
MAX_PLAN_RUNS = 100


@dataclass(frozen=True)
class _Entry:
    key: object
    components: Components
    run_medians: tuple[float, ...]  # each pilot run's median log time (run_summary), in the pilot's order


@dataclass(frozen=True)
class Pilot:
    """What a pilot gives the planner: each combination's components, the pilot's plan (runs, repetitions), the
    costs in seconds (a repetition of the matrix, a run's fixed part; None where the file does not state them),
    whether the between-run component was assumed."""

    entries: list[_Entry]
    runs: int
    repetitions: int
    repetition_s: float | None
    fixed_s: float | None
    assumed_between: bool


def read_pilot(files: list[RunFile], time_kind: str, noise: float) -> Pilot:
    """The pilot's components per combination (calibrations and collapsed entries apart) and its costs."""
    keys = sorted({key for f in files for key in f.runs if not is_calibration(key) and key not in f.collapsed},
                  key=lambda key: key.sort_key())
    entries = []
    for key in keys:
        groups = [[math.log(t) for t in f.runs[key].times_ns(time_kind) if t > 0] for f in files
                  if key in f.runs and not f.runs[key].errored]
        found = median_components(groups)
        if found is None:
            continue
        if math.isnan(found.between):
            found = Components(assumed_drift(noise) ** 2, found.within, found.runs, found.repetitions)
        medians = (run_summary(g) for g in groups)
        entries.append(_Entry(key, found, tuple(math.nan if m is None else m for m in medians)))
    entries = _moderated(entries)
    repetitions = round(statistics.median([e.components.repetitions for e in entries])) if entries else 0
    matrix = [f.context_number(MATRIX_SECONDS_CONTEXT) for f in files]
    wall = [f.context_number(WALL_SECONDS_CONTEXT) for f in files]
    repetition_s = fixed_s = None
    if all(matrix) and all(wall) and repetitions:
        repetition_s = statistics.median(matrix) / repetitions
        fixed_s = max(statistics.median(wall) - statistics.median(matrix), 0.0)
    return Pilot(entries, len(files), repetitions, repetition_s, fixed_s, assumed_between=len(files) < 2)


def _moderated(entries: list[_Entry]) -> list[_Entry]:
    """With two or more pilot runs, each entry's variance of its run medians (K - 1 degrees: a few runs estimate it
    poorly) moderated towards the entries' (statistics.prior_variance, as compare moderates it), and its between-run
    component taken from that: max(0, moderated - Var(e) / n0). Unchanged with one run or too few entries."""
    spreads = []
    for entry in entries:
        means = [m for m in entry.run_medians if math.isfinite(m)]
        spreads.append((float(np.var(means, ddof=1)), len(means) - 1) if len(means) >= 2 else (None, 0))
    prior = statistics.prior_variance([v for v, _ in spreads], [d for _, d in spreads])
    if prior is None:
        return entries
    result = []
    for entry, (variance, degrees) in zip(entries, spreads):
        if variance is None:
            result.append(entry)
            continue
        moderated, _ = statistics.moderated_variance(variance, degrees, prior)
        found = entry.components
        between = max(0.0, moderated - found.within / found.repetitions)
        result.append(_Entry(entry.key, Components(between, found.within, found.runs, found.repetitions),
                             entry.run_medians))
    return result


def plan_errors(entries: list[_Entry], runs: int, repetitions: int) -> list[float]:
    """Each entry's standard error of log B/A under a plan, both sides alike."""
    return [math.sqrt(2.0 * e.components.plan_variance(runs, repetitions)) for e in entries]


def _degrees(runs: int) -> float:
    # With one run a side the drift is assumed, not estimated: normal quantiles.
    return 2.0 * runs - 2.0 if runs >= 2 else math.inf


def entries_change(entries: list[_Entry], runs: int, repetitions: int, noise: float) -> float | None:
    """The smallest uniform change (a fraction) of which POWER of the entries are called slower under the plan."""
    return change_seen_by_share(plan_errors(entries, runs, repetitions), _degrees(runs), noise, POWER)


def aggregate_change(entries: list[_Entry], runs: int, repetitions: int, noise: float) -> float | None:
    """The smallest uniform change (a fraction) the geometric mean of the entries is called slower on at POWER.
    Its between-run component is the spread of the pilot's runs' means of their medians over the entries (a whole
    run drifts together) less what the repetitions explain; with a one-run pilot, the assumed drift (the median
    entry's)."""
    if not entries:
        return None
    within = sum(e.components.within for e in entries) / len(entries) / len(entries)
    pilot_runs = {len(e.run_medians) for e in entries}
    if len(pilot_runs) == 1 and min(pilot_runs) >= 2:
        means = [sum(e.run_medians[i] for e in entries) / len(entries) for i in range(min(pilot_runs))]
        centre = sum(means) / len(means)
        spread = sum((m - centre) ** 2 for m in means) / (len(means) - 1)
        pilot_repetitions = statistics.median([e.components.repetitions for e in entries])
        between = max(0.0, spread - within / pilot_repetitions)
    else:
        between = statistics.median([e.components.between for e in entries])
    error = math.sqrt(2.0 * (between + within / repetitions) / runs)
    return detectable_at_power(error, _degrees(runs), noise)


def plan_seconds(pilot: Pilot, runs: int, repetitions: int) -> float | None:
    """A side's time under a plan: runs x (fixed part + repetitions x a repetition of the matrix)."""
    if pilot.repetition_s is None or pilot.fixed_s is None:
        return None
    return runs * (pilot.fixed_s + repetitions * pilot.repetition_s)


def allocated_repetitions(pilot: Pilot) -> int:
    """Kalibera and Jones's repetitions per run from the pooled components and the costs, within
    MIN_PLAN_REPETITIONS..MAX_PLAN_REPETITIONS; the pilot's own count without costs."""
    if pilot.repetition_s is None or not pilot.repetition_s > 0 or not pilot.entries:
        return max(pilot.repetitions, MIN_PLAN_REPETITIONS)
    within = sum(e.components.within for e in pilot.entries) / len(pilot.entries)
    between = sum(e.components.between for e in pilot.entries) / len(pilot.entries)
    count = allocation([pilot.repetition_s, max(pilot.fixed_s, pilot.repetition_s)], [within, between])[0]
    return int(min(max(count, MIN_PLAN_REPETITIONS), MAX_PLAN_REPETITIONS))


def cheapest_plan(pilot: Pilot, target: float, noise: float) -> tuple[int, int] | None:
    """(runs, repetitions) a side: the allocated repetitions, then the fewest runs whose plan sees `target` (a
    fraction) in POWER of the entries; None when MAX_PLAN_RUNS do not."""
    repetitions = allocated_repetitions(pilot)
    for runs in range(2, MAX_PLAN_RUNS + 1):
        change = entries_change(pilot.entries, runs, repetitions, noise)
        if change is not None and change <= target:
            return runs, repetitions
    return None


def _group_lines(pilot: Pilot, runs: int, repetitions: int, noise: float) -> list[str]:
    out = []
    groups = {name: rows for name, rows in aggregate_groups(pilot.entries).items()
              if name == "all" or name.startswith("threads:")}
    for name, entries in groups.items():
        each = entries_change(entries, runs, repetitions, noise)
        overall = aggregate_change(entries, runs, repetitions, noise)
        out.append(f"  {name} ({len(entries)} entries): {_percent(each)} in {POWER:.0%} of the entries, "
                   f"{_percent(overall)} on their geometric mean")
    return out


def _percent(change: float | None) -> str:
    return "-" if change is None else f"{change * 100:.1f} %"


def _duration(seconds: float | None) -> str:
    if seconds is None:
        return "unknown (the pilot predates lockstep_matrix_s and lockstep_wall_s)"
    whole = round(seconds)
    return f"{whole // 60} min {whole % 60:02d} s" if whole >= 60 else f"{whole} s"


def plan_text(files: list[RunFile], time_kind: str, noise_percent: float, detect_percent: float | None) -> str:
    """The planner's report: the pilot, its components, what its own plan sees, and the plan for --detect."""
    noise = noise_percent / 100.0
    pilot = read_pilot(files, time_kind, noise)
    if not pilot.entries:
        return "lockstep compare --plan: the pilot holds no combination with two repetitions: nothing to plan from\n"
    between = statistics.median([e.components.between for e in pilot.entries])
    within = statistics.median([e.components.within for e in pilot.entries])
    out = [f"lockstep compare --plan: pilot of {pilot.runs} run(s) x {pilot.repetitions} repetitions, "
           f"{len(pilot.entries)} combinations; power {POWER:.0%}, two-sided {statistics.CONFIDENCE:.0%} intervals "
           f"against the {noise_percent:g} % noise band, the same change on both sides' plan",
           f"variance of log time (median over the entries): between runs {math.sqrt(between) * 100:.2f} % "
           f"(standard deviation), within a run {math.sqrt(within / MEDIAN_EFFICIENCY) * 100:.2f} % per repetition "
           f"(robust: from the median absolute deviation; a run's figure is its repetitions' median)"
           + (" (one run: the between-run part is assumed, half the band's log, the drift compare's band stands for;"
              " a pilot of 2 or more runs measures it)" if pilot.assumed_between else ""),
           f"costs: a repetition of the matrix {_duration(pilot.repetition_s)}, a run's fixed part (start-up, "
           f"calibrations, pairs, probes) {_duration(pilot.fixed_s)}"]
    own_runs = max(pilot.runs, 1)
    out.append(f"the pilot's own plan ({own_runs} run(s) a side x {pilot.repetitions} repetitions) sees:")
    out += _group_lines(pilot, own_runs, pilot.repetitions, noise)
    if detect_percent is not None:
        plan = cheapest_plan(pilot, detect_percent / 100.0, noise)
        if plan is None:
            out.append(f"--detect {detect_percent:g}%: no plan of up to {MAX_PLAN_RUNS} runs a side sees it in "
                       f"{POWER:.0%} of the entries (the between-run part alone is too wide for it)")
        else:
            runs, repetitions = plan
            seconds = plan_seconds(pilot, runs, repetitions)
            out.append(f"--detect {detect_percent:g}%: {runs} runs a side x {repetitions} repetitions "
                       f"(repetitions by Kalibera and Jones's allocation, runs the fewest that reach it): "
                       f"{_duration(seconds)} a side, {_duration(None if seconds is None else 2 * seconds)} for "
                       f"both; it sees:")
            out += _group_lines(pilot, runs, repetitions, noise)
            out.append(f"  run it: the sides' runs alternated, lockstep run ... --repetitions {repetitions} --out "
                       f"DIR_A/run-I.json then the same for B, I = 1 .. {runs} (or --runs {runs} --out DIR for each "
                       f"side, if the machine holds its pace between them), then lockstep compare DIR_A DIR_B")
    return "\n".join(wrapped(out)) + "\n"
