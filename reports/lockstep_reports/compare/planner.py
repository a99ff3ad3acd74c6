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

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..analysis.run_analysis import is_calibration
from ..common import statistics
from ..common.fields import MATRIX_SECONDS_CONTEXT, WALL_SECONDS_CONTEXT
from ..common.text_layout import wrapped
from ..read.run_file import RunFile
from .comparison import Comparison, PlanCheck, aggregate_groups
from .replicates import (MEDIAN_EFFICIENCY, POWER, Components, allocation, assumed_drift, change_seen_by_share,
                         detectable_at_power, median_components, run_summary)
from .run_pace import RunPace, every_group, matched_groups, reading_spread, run_pace

# A pilot of fewer runs than this is told that its between-run part stands on few degrees of freedom.
FIRM_PILOT_RUNS = 6
# The plans the planner searches: repetitions per run and runs a side.
MIN_PLAN_REPETITIONS = 3
MAX_PLAN_REPETITIONS = 200
MAX_PLAN_RUNS = 100


@dataclass(frozen=True)
class _Entry:
    key: object
    components: Components
    run_medians: tuple[float, ...]  # each pilot run's median log time (run_summary), in the pilot's order; NaN: none
    share: float = 1.0  # the part of its repetitions in the reference pace: a planned run keeps repetitions x share


@dataclass(frozen=True)
class PilotPace:
    """The pilot's pace (run_pace.py): the reference pace its entries are planned in (its reading and figure in ns),
    the part of the repetitions there, the floor learnt from the pace trace (the spread of the readings inside that
    pace, a standard deviation of log), how many entries the floor set the between-run part of, and the median
    between-run standard deviation over every repetition and in the pace (what the pace explained)."""

    reading: str
    reference_ns: float
    share: float
    floor: float | None
    floored: int
    every_pace: float | None
    one_pace: float | None


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
    pace: PilotPace | None = None  # None: no pace every pilot run holds (or a pilot without the pace trace)
    estimate: float = 0.0  # the between-run variance the pilot's runs show, median over the entries, before the floor

    @property
    def between(self) -> float:
        """The between-run standard deviation of log time the plan assumes: the median over the entries."""
        return math.sqrt(statistics.median([e.components.between for e in self.entries]))


def _groups(files: list[RunFile], key, time_kind: str, pace: RunPace | None) -> tuple[list, list]:
    """(each run's log times of the entry in the reference pace, [] for a run without one; over every repetition)."""
    every = [group for f in files for group in every_group([f], key, time_kind)]
    if pace is None or pace.reference is None:
        return [], every
    return [next(iter(matched_groups([f], key, time_kind, pace)), []) for f in files], every


def _entry(key, groups: list, every: list, noise: float) -> _Entry | None:
    """An entry's components in the reference pace (over every repetition without one), its runs' medians and the
    part of its repetitions kept."""
    kept = [group for group in groups if group] if groups else every
    found = median_components(kept)
    if found is None:
        return None
    if math.isnan(found.between):
        found = Components(assumed_drift(noise) ** 2, found.within, found.runs, found.repetitions)
    medians = tuple(run_summary(group) if group else math.nan for group in (groups or every))
    share = sum(map(len, kept)) / max(sum(map(len, every)), 1)
    return _Entry(key, found, tuple(math.nan if m is None else m for m in medians), share)


def _between_spread(groups_per_entry: list[list]) -> float | None:
    """The median over the entries of the standard deviation of their runs' medians (None with fewer than 2 runs)."""
    spreads = [float(np.std([run_summary(g) for g in groups], ddof=1)) for groups in groups_per_entry
               if len(groups) >= 2]
    return statistics.median(spreads) if spreads else None


def _floored(entries: list[_Entry], floor: float | None) -> tuple[list[_Entry], int]:
    """Each entry's between-run part raised to the floor where the pilot's estimate lies below it; how many were."""
    if floor is None:
        return entries, 0
    raised = [e for e in entries if e.components.between < floor * floor]
    return [dataclasses.replace(e, components=dataclasses.replace(e.components, between=floor * floor))
            if e.components.between < floor * floor else e for e in entries], len(raised)


def read_pilot(files: list[RunFile], time_kind: str, noise: float) -> Pilot:
    """The pilot's components per combination (calibrations and collapsed entries apart) in its reference pace, the
    between-run part at least the floor learnt from the pace trace, and its costs."""
    keys = sorted({key for f in files for key in f.runs if not is_calibration(key) and key not in f.collapsed},
                  key=lambda key: key.sort_key())
    pace = run_pace([files])
    entries, in_pace, every_pace = [], [], []
    for key in keys:
        groups, every = _groups(files, key, time_kind, pace)
        found = _entry(key, groups, every, noise)
        if found is None:
            continue
        entries.append(found)
        in_pace.append([group for group in groups if group])
        every_pace.append(every)
    entries = _moderated(entries)
    estimate = statistics.median([e.components.between for e in entries]) if entries else 0.0
    floor = reading_spread(files, pace)
    entries, floored = _floored(entries, floor)
    pilot_pace = None
    if pace is not None and pace.reference is not None:
        pilot_pace = PilotPace(pace.reading, pace.reference.reading_ns, pace.share(0), floor, floored,
                               _between_spread(every_pace), _between_spread(in_pace))
    repetitions = round(statistics.median([e.components.repetitions / e.share for e in entries])) if entries else 0
    matrix = [f.context_number(MATRIX_SECONDS_CONTEXT) for f in files]
    wall = [f.context_number(WALL_SECONDS_CONTEXT) for f in files]
    repetition_s = fixed_s = None
    if all(matrix) and all(wall) and repetitions:
        repetition_s = statistics.median(matrix) / repetitions
        fixed_s = max(statistics.median(wall) - statistics.median(matrix), 0.0)
    return Pilot(entries, len(files), repetitions, repetition_s, fixed_s, assumed_between=len(files) < 2,
                 pace=pilot_pace, estimate=estimate)


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
                             entry.run_medians, entry.share))
    return result


def plan_errors(entries: list[_Entry], runs: int, repetitions: int) -> list[float]:
    """Each entry's standard error of log B/A under a plan, both sides alike."""
    return [math.sqrt(2.0 * e.components.plan_variance(runs, repetitions * e.share)) for e in entries]


def _degrees(runs: int) -> float:
    # With one run a side the drift is assumed, not estimated: normal quantiles.
    return 2.0 * runs - 2.0 if runs >= 2 else math.inf


def entries_change(entries: list[_Entry], runs: int, repetitions: int, noise: float) -> float | None:
    """The smallest uniform change (a fraction) of which POWER of the entries are called slower under the plan."""
    return change_seen_by_share(plan_errors(entries, runs, repetitions), _degrees(runs), noise, POWER)


def aggregate_change(entries: list[_Entry], runs: int, repetitions: int, noise: float,
                     floor: float | None = None) -> float | None:
    """The smallest uniform change (a fraction) the geometric mean of the entries is called slower on at POWER.
    Its between-run component is the spread of the pilot's runs' means of their medians over the entries (a whole
    run drifts together) less what the repetitions explain, at least the floor (Pilot.pace); with a one-run pilot,
    the assumed drift (the median entry's)."""
    if not entries:
        return None
    within = sum(e.components.within / e.share for e in entries) / len(entries) / len(entries)
    pilot_runs = {len(e.run_medians) for e in entries}
    between = None
    if len(pilot_runs) == 1 and min(pilot_runs) >= 2:
        means = [float(np.nanmean([e.run_medians[i] for e in entries])) for i in range(min(pilot_runs))
                 if any(math.isfinite(e.run_medians[i]) for e in entries)]
        if len(means) >= 2:
            spread = float(np.var(means, ddof=1))
            pilot_repetitions = statistics.median([e.components.repetitions for e in entries])
            between = max(0.0, spread - within * statistics.median([e.share for e in entries]) / pilot_repetitions)
    if between is None:
        between = statistics.median([e.components.between for e in entries])
    if floor is not None:
        between = max(between, floor * floor)
    error = math.sqrt(2.0 * (between + within / repetitions) / runs)
    return detectable_at_power(error, _degrees(runs), noise)


def plan_seconds(pilot: Pilot, runs: int, repetitions: int) -> float | None:
    """A side's time under a plan: runs x (fixed part + repetitions x a repetition of the matrix)."""
    if pilot.repetition_s is None or pilot.fixed_s is None:
        return None
    return runs * (pilot.fixed_s + repetitions * pilot.repetition_s)


def allocated_repetitions(pilot: Pilot) -> int:
    """Kalibera and Jones's repetitions per run from the pooled components and the costs, within
    MIN_PLAN_REPETITIONS (in the reference pace: more where a part of the repetitions falls in other paces) ..
    MAX_PLAN_REPETITIONS; the pilot's own count without costs."""
    # At least MIN_PLAN_REPETITIONS of a run's repetitions in the pace the runs are compared in (the rest fall in
    # other paces): with one or two there, a run's figure is one repetition's and many runs keep none of an entry.
    least = math.ceil(MIN_PLAN_REPETITIONS / statistics.median([e.share for e in pilot.entries])) \
        if pilot.entries else MIN_PLAN_REPETITIONS
    if pilot.repetition_s is None or not pilot.repetition_s > 0 or not pilot.entries:
        return max(pilot.repetitions, least)
    within = sum(e.components.within / e.share for e in pilot.entries) / len(pilot.entries)
    between = sum(e.components.between for e in pilot.entries) / len(pilot.entries)
    count = allocation([pilot.repetition_s, max(pilot.fixed_s, pilot.repetition_s)], [within, between])[0]
    return int(min(max(count, least), MAX_PLAN_REPETITIONS))


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
    floor = pilot.pace.floor if pilot.pace else None
    for name, entries in groups.items():
        each = entries_change(entries, runs, repetitions, noise)
        overall = aggregate_change(entries, runs, repetitions, noise, floor)
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


def _pace_lines(pilot: Pilot) -> list[str]:
    """The pace the pilot is planned in, and what the pace explained of its runs' spread."""
    pace = pilot.pace
    if pace is None:
        return [f"pace: no pace of the machine that every pilot run holds (or no pace trace): planned on every "
                f"repetition, as compare then compares"]
    what = f"c2c about {pace.reference_ns:.0f} ns" if pace.reading == "c2c_ns" else \
        f"a serial step of about {pace.reference_ns:.1f} ns"
    line = (f"pace: planned in the machine's pace at {what}, the one the pilot's runs share ({pace.share * 100:.0f} % "
            f"of the repetitions), as compare compares runs")
    if pace.every_pace and pace.one_pace is not None:
        line += (f"; the pace explained {max(0.0, 1.0 - (pace.one_pace / pace.every_pace) ** 2) * 100:.0f} % of the "
                 f"pilot's between-run variance (a run's figure spread {pace.every_pace * 100:.1f} % -> "
                 f"{pace.one_pace * 100:.1f} %, median over the entries)")
    return [line]


def _between_lines(pilot: Pilot, estimate: float) -> list[str]:
    """What the between-run part is planned on, and why: the pilot's estimate, or the floor the pace trace gives."""
    pace, out = pilot.pace, []
    if pace is not None and pace.floor is not None:
        reading = "core-to-core readings" if pace.reading == "c2c_ns" else "serial-step readings"
        out.append(f"between runs planned on {pilot.between * 100:.2f} % (median over the entries): the larger of "
                   f"the pilot's estimate ({math.sqrt(estimate) * 100:.2f} %) and a floor learnt from the pace trace, "
                   f"how far the {reading} move while the machine stays in that pace ({pace.floor * 100:.2f} %, "
                   f"standard deviation of log within each pilot run); the floor for {pace.floored} of "
                   f"{len(pilot.entries)} entries")
    if 2 <= pilot.runs < FIRM_PILOT_RUNS:
        out.append(f"a pilot of {pilot.runs} runs estimates the between-run part from {pilot.runs - 1} degree"
                   f"{'' if pilot.runs == 2 else 's'} of freedom: runs taken a minute apart can agree by chance. For "
                   f"a firm plan, a pilot of {FIRM_PILOT_RUNS} runs spread over 10 minutes or more (lockstep run ... "
                   f"--out PILOT/run-I.json, I = 1 .. {FIRM_PILOT_RUNS}, with a minute or more between them)")
    return out


def plan_text(files: list[RunFile], time_kind: str, noise_percent: float, detect_percent: float | None,
              pilot_words: str = "PILOT") -> str:
    """The planner's report: the pilot, its pace, its components and what the plan assumes of the between-run part,
    what its own plan sees, and the plan for --detect. pilot_words: the pilot as the command line named it."""
    noise = noise_percent / 100.0
    pilot = read_pilot(files, time_kind, noise)
    if not pilot.entries:
        return "lockstep compare --plan: the pilot holds no combination with two repetitions: nothing to plan from\n"
    estimate = pilot.estimate
    within = statistics.median([e.components.within for e in pilot.entries])
    out = [f"lockstep compare --plan: pilot of {pilot.runs} run(s) x {pilot.repetitions} repetitions, "
           f"{len(pilot.entries)} combinations; power {POWER:.0%}, two-sided {statistics.CONFIDENCE:.0%} intervals "
           f"against the {noise_percent:g} % noise band, the same change on both sides' plan"] + _pace_lines(pilot)
    per_repetition = math.sqrt(within / MEDIAN_EFFICIENCY) * 100
    out += [f"variance of log time (median over the entries): between runs {math.sqrt(estimate) * 100:.2f} % "
            f"(the pilot's estimate, standard deviation), within a run {per_repetition:.2f} % per repetition "
            f"(robust: from the median absolute deviation; a run's figure is its repetitions' median)"
            + (" (one run: the between-run part is assumed, half the band's log, the drift compare's band stands for;"
               " a pilot of 2 or more runs measures it)" if pilot.assumed_between else "")]
    out += _between_lines(pilot, estimate)
    out.append(f"costs: a repetition of the matrix {_duration(pilot.repetition_s)}, a run's fixed part (start-up, "
               f"calibrations, pairs, probes) {_duration(pilot.fixed_s)}")
    own_runs = max(pilot.runs, 1)
    out.append(f"the pilot's own plan ({own_runs} run(s) a side x {pilot.repetitions} repetitions) sees:")
    out += _group_lines(pilot, own_runs, pilot.repetitions, noise)
    if detect_percent is not None:
        out += _detect_lines(pilot, detect_percent, noise, pilot_words)
    return "\n".join(wrapped(out)) + "\n"


def _detect_lines(pilot: Pilot, detect_percent: float, noise: float, pilot_words: str) -> list[str]:
    plan = cheapest_plan(pilot, detect_percent / 100.0, noise)
    if plan is None:
        return [f"--detect {detect_percent:g}%: no plan of up to {MAX_PLAN_RUNS} runs a side sees it in "
                f"{POWER:.0%} of the entries (the between-run part alone is too wide for it)"]
    runs, repetitions = plan
    seconds = plan_seconds(pilot, runs, repetitions)
    return ([f"--detect {detect_percent:g}%: {runs} runs a side x {repetitions} repetitions "
             f"(repetitions by Kalibera and Jones's allocation, runs the fewest that reach it): "
             f"{_duration(seconds)} a side, {_duration(None if seconds is None else 2 * seconds)} for both; it sees:"]
            + _group_lines(pilot, runs, repetitions, noise)
            + [f"  run it: the sides' runs alternated, lockstep run ... --repetitions {repetitions} --out "
               f"DIR_A/run-I.json then the same for B, I = 1 .. {runs} (or --runs {runs} --out DIR for each side, if "
               f"the machine holds its pace between them), then lockstep compare DIR_A DIR_B --pilot {pilot_words} "
               f"--detect {detect_percent:g}% (it says whether the runs differed more than this plan assumed)"])


def check_plan(comparison: Comparison, files: list[RunFile], label: str, time_kind: str,
               detect_percent: float | None) -> PlanCheck | None:
    """The plan checked after the fact (compare --pilot): the between-run part the planner assumed from the pilot
    against each side's realised one (in the pace the sides were compared in: PaceAcrossRuns), and where a side's is
    larger, the cheapest plan that sees the change with it. The change: detect_percent, else what the pilot's plan
    said these sides (their runs, their repetitions) would see. None for sides of one run."""
    replicated = comparison.replicated
    if replicated is None:
        return None
    noise = comparison.noise_percent / 100.0
    pilot = read_pilot(files, time_kind, noise)
    if not pilot.entries:
        return None
    spreads = replicated.pace.sides if replicated.pace else ()
    realised = tuple(side.between for side in spreads) or (None, None)
    repetitions = max(1, round(statistics.median([side.repetitions / side.share for side in spreads
                                                  if side.repetitions and side.share]) if spreads else
                               pilot.repetitions))
    runs = min(replicated.runs_a, replicated.runs_b)
    target = (detect_percent / 100.0 if detect_percent is not None
              else entries_change(pilot.entries, runs, repetitions, noise))
    assumed = pilot.between
    largest = max((value for value in realised if value is not None), default=None)
    if target is None or largest is None or largest <= assumed:
        return PlanCheck(label, assumed, realised, target or 0.0, False)
    wider = dataclasses.replace(pilot, entries=[dataclasses.replace(e, components=dataclasses.replace(
        e.components, between=max(e.components.between, largest * largest))) for e in pilot.entries])
    plan = cheapest_plan(wider, target, noise)
    return PlanCheck(label, assumed, realised, target, True, plan,
                     plan_seconds(wider, *plan) if plan else None)


def plan_check_line(check: PlanCheck, letter: str) -> str:
    """compare's line on the plan checked after the fact."""
    names = ("A", letter)
    realised = ", ".join(f"{name}'s by {value * 100:.1f} %" for name, value in zip(names, check.realised)
                         if value is not None)
    line = (f"the plan (from {check.pilot}) assumed runs differ by {check.assumed * 100:.1f} % (between-run standard "
            f"deviation of log time in the pace compared, median over the entries); {realised}")
    if not check.exceeded:
        return line + ": within what it assumed"
    over = " and ".join(name for name, value in zip(names, check.realised)
                        if value is not None and value > check.assumed)
    line += (f": more than assumed in {over}; to see {check.target * 100:.1f} % in {POWER * 100:.0f} % of the entries "
             "now: ")
    if check.plan is None:
        return line + f"no plan of up to {MAX_PLAN_RUNS} runs a side"
    runs, repetitions = check.plan
    return line + f"{runs} runs a side x {repetitions} repetitions ({_duration(check.plan_seconds)} a side)"
