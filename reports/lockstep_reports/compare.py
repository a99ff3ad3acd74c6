"""`lockstep compare A.json B.json [more...]`: what changed between runs and machines, and whether it is real.

The first file is the baseline; every other file is compared with it. Within
one comparison, entries are matched by their parsed names (names.py); the
ones that are only in one file, or that errored, are listed, never dropped
and never counted as zero. Across files, each machine is shown by its
fingerprint and normalised by its own in-run core-to-core latency and serial
step time, so that effects can be read side by side.

Verdicts: the interval against the noise band. Each entry's B/A gets the
exact distribution-free 95 % interval of the shift between its repetitions
(statistics.shift_interval). "slower" / "faster" only when the whole interval
lies beyond the noise band (above 1 + NOISE/100, or below 1 / (1 + NOISE/100));
"within noise" when it lies wholly inside; "unsure" when it reaches across an
edge of the band (more repetitions would tell); "untested" with too few
repetitions for a 95 % interval. The Mann-Whitney p of each entry is shown
Benjamini-Hochberg-adjusted (q) over the entries of the comparison, and the
counts say how many calls also pass q < alpha. Repetitions inside one run
share that run's state of the machine; the band stands for the run-to-run
drift they cannot see.

Pace (docs/pace.md): when both files carry a pace trace, their modes are matched
by c2c within MODE_TOLERANCE, compare says whether the runs ran in the same
modes, and every entry also gets a pace-aware verdict: the raw one where all
its repetitions ran in one matching mode; else within the matching modes
(only the repetitions of the best-filled pair of matching modes) when each
side keeps MIN_IN_MODE there (MIN_REPETITIONS where the evidence is not
pooled, below); within one c2c state where the repetitions so chosen (all of
them when no mode matches) ran in more than one state of the machine and each
side keeps as many in one (their own c2c reading within STATE_WIDTH of one
reference: a mode of the trace can join two states its readings bridge); else
on the pace-normalised figure, each
repetition's time divided by the c2c reading taken around it (pace_c2c_ns)
to the power of its cluster's elasticity (pace_elasticities: how far the
cluster's times follow the readings inside each run; a sleeping primitive's
barely do).
The headline count of changed entries counts what changed beyond the pace:
the pace-aware verdict where there is one, else the raw one.

More evidence at the same run time, the drift kept in (statistics.py,
pooled_interval): when at least statistics.MIN_POOLED_ENTRIES entries of the
file pair have a pace-aware figure, their intervals are not each its own exact
one. Each entry's variance of log time within its runs is moderated towards the
whole file pair's (an entry borrows the degrees of freedom of hundreds, so 3
repetitions a side in a matching mode are enough: MIN_IN_MODE), and the drift
between the two runs, which repetitions inside one run cannot see, is
calibrated from the spread of every entry's log ratio and added to each
entry's variance. An entry whose interval reaches across the band says the
smallest change it could have shown (statistics.detectable_change).

The answer first: the geometric mean of B/A over the matched combinations
(the beyond-the-pace ratio of each; calibrations and collapsed entries apart)
with an interval and a verdict, overall and per primitive, thread count and
placement (Aggregate). A uniform change that no single entry can show is called
there. The interval is a two-stage bootstrap over clusters (cluster_key: a
primitive at one thread count), then the entries of each drawn cluster, because
between two runs whole clusters drift together: a block of primitives that
slowed reads as spread, a shift common to every cluster stays tight. A group of
fewer than MIN_AGGREGATE_CLUSTERS clusters (a primitive's own) also carries the
file pair's spread of whole clusters (cluster_drifts), which it cannot show. Entries that either file's headline
calls collapsed (they ran oversubscribed at 100 times the best of their kind
or more, with one repetition) are "collapsed", never "untested", and stay out
of the aggregates and --fail-above.

Calibrations: `rk4/serial` (and a chain's `rk4/model:chainS/serial`), `mpi/pingpong/...`, `c2c/...`
and the `overhead/...` pair measure the machine and the instrumentation, not a
combination of primitive, layout and placement. They are compared in a block of their own (c2c by its one_way_ns
counter: its iteration time is thread start-up plus the measurement), tested
as a family of their own, and kept out of the geometric mean, the verdict
counts and --fail-above. The context's in-run calibrations of the two files
give one line saying how far the machine itself moved between the runs; the
time comparisons are never rescaled by it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from . import statistics
from .fields import (BACK_TO_BACK_ORDER, C2C_CONTEXT, C2C_COUNTER, COUNTERS_SHOWN, FINGERPRINT_KEYS, MACHINE_KEYS,
                     PER_UNIT_TIMES_SCHEMA, SERIAL_CONTEXT, SYNC_COUNTER, UNAVAILABLE, VS_C2C_COUNTER,
                     VS_SERIAL_COUNTER)
from .formatting import format_ns, format_number
from .run_file import Run, RunFile
from .mpi_context import mpi_difference_lines
from .names import BenchmarkKey, parse_name

# The default noise threshold, percent (see NOISE_RATIONALE).
DEFAULT_NOISE_PERCENT = 5.0
NOISE_RATIONALE = (
    "between two back-to-back runs on a 2-vCPU KVM guest the machine's own calibrations and the fast "
    "rk4 entries moved by 4-5 % with tiny p (repetitions inside a run cannot see that drift); 5 % with the "
    "whole interval beyond it keeps such drift out of the verdicts while a change of 10 % or more still "
    "shows; on a quiet bare-metal machine --noise 1 (Criterion.rs's default) or 2 fits")

# Two pace modes of two runs are the same mode when their c2c medians (serial medians on a machine of one
# CPU) are within this factor of each other. This VM's modes are 2x apart or more (c2c one-way about 25,
# 55 and 120-270 ns), while one mode's median moves by 10-20 % from run to run; 1.5 keeps the second
# inside a mode and the first apart.
MODE_TOLERANCE = 1.5
# How a pace-aware figure was made (PaceAware.method).
PACE_ONE_MODE, PACE_MATCHING_MODES, PACE_NORMALISED = "one mode", "matching modes", "pace-normalised"
PACE_ONE_STATE = "one c2c state"
# One c2c state (PACE_ONE_STATE): the repetitions whose own c2c reading lies within this factor of one
# reference. This VM's c2c states are 14, 32 and 102 ns; one state's readings around a repetition spread by
# about +-7 % (10th to 90th percentile), and the spinning primitives' steps follow them (elasticity 0.8-1.2).
STATE_WIDTH = 1.2
COLLAPSED = "collapsed"
VERDICTS = ("slower", "faster", "unsure", "within noise", "untested", COLLAPSED)
# Within matching modes needs this many repetitions a side: the median of 3 when the file pair's pooled variance
# gives the interval its degrees of freedom (statistics.pooled_interval); each entry's own exact interval
# (a pair of files with fewer than statistics.MIN_POOLED_ENTRIES entries to pool) needs MIN_REPETITIONS.
MIN_IN_MODE = 3
# An aggregate (Aggregate) of fewer entries has no interval: the bootstrap over entries needs some to resample.
MIN_AGGREGATE_ENTRIES = 5
# A group spanning fewer clusters (cluster_key) than this adds the file pair's spread of whole clusters to its
# interval (statistics.cluster_geometric_mean_interval, borrowed): a per-primitive group holds one or two.
MIN_AGGREGATE_CLUSTERS = 5

# Families that measure the machine or the instrumentation, not a combination.
CALIBRATION_FAMILIES = ("c2c", "overhead")
# The in-run calibration entries: compared apart, and read when the context lacks the value.
SERIAL_ENTRY = "rk4/serial"
C2C_ENTRY = "c2c/pin:compact/threads:2"


# statistics.verdict's outcomes for a ratio B/A of times, in compare's words.
VERDICT_WORDS = {statistics.PENALTY: "slower", statistics.GAIN: "faster", statistics.WITHIN_NOISE: "within noise",
                 statistics.UNSURE: "unsure"}


def verdict_of(interval: tuple[float, float] | None, noise_percent: float) -> str:
    """The interval against the noise band (statistics.verdict): slower / faster (wholly beyond it), within
    noise (wholly inside it), unsure (across an edge); untested (no interval)."""
    if interval is None:
        return "untested"
    return VERDICT_WORDS[statistics.verdict(interval[0], interval[1], noise_percent / 100.0)]


@dataclass
class PaceAware:
    """An entry's comparison that the pace cannot explain: how it was made (PACE_ONE_MODE,
    PACE_MATCHING_MODES, PACE_ONE_STATE, PACE_NORMALISED), which modes or figure, B/A of the medians and its
    interval."""

    method: str
    detail: str
    ratio: float
    interval: tuple[float, float] | None
    repetitions_a: int
    repetitions_b: int
    # The selected figures (times, or times / pace), kept for the file pair's pooling (pool_evidence).
    values_a: tuple[float, ...] = ()
    values_b: tuple[float, ...] = ()
    pooled: bool = False  # the interval is statistics.pooled_interval's, not the entry's own exact one
    power: float = 1.0  # PACE_NORMALISED: the power of the c2c reading each time was divided by (its elasticity)


@dataclass
class Row:
    key: BenchmarkKey
    median_a: float
    median_b: float
    repetitions_a: int
    repetitions_b: int
    ratio: float
    interval: tuple[float, float] | None
    p_raw: float | None
    p_adjusted: float | None = None  # Benjamini-Hochberg q over the comparison's family
    counters: dict[str, tuple[float | None, float | None]] = field(default_factory=dict)
    measure: str = "time"  # what median_a / median_b are: "time", or a counter's name
    pace: PaceAware | None = None  # None: a file without the pace trace, or a repetition without its pace
    collapsed: bool = False  # either file's headline calls it collapsed: no verdict, no aggregate, no gate

    def significant(self, alpha: float) -> bool:
        return self.p_adjusted is not None and self.p_adjusted < alpha

    def verdict(self, noise_percent: float = DEFAULT_NOISE_PERCENT) -> str:
        """The raw verdict: this entry's interval against the noise band; "collapsed" for a collapsed entry."""
        return COLLAPSED if self.collapsed else verdict_of(self.interval, noise_percent)

    def pace_verdict(self, noise_percent: float = DEFAULT_NOISE_PERCENT) -> str | None:
        """The pace-aware verdict, None where the pace is unavailable."""
        if self.collapsed:
            return COLLAPSED
        return verdict_of(self.pace.interval, noise_percent) if self.pace else None

    def beyond_pace(self, noise_percent: float = DEFAULT_NOISE_PERCENT) -> str:
        """What changed beyond the pace: the pace-aware verdict where there is one, else the raw one."""
        return self.pace_verdict(noise_percent) or self.verdict(noise_percent)

    def beyond_pace_ratio(self) -> float:
        return self.pace.ratio if self.pace else self.ratio

    def beyond_pace_interval(self) -> tuple[float, float] | None:
        return self.pace.interval if self.pace else self.interval

    def detectable(self, noise_percent: float = DEFAULT_NOISE_PERCENT) -> float | None:
        """The smallest change, in percent, this entry could have shown beyond the band (its beyond-the-pace
        interval's width: statistics.detectable_change); None without an interval."""
        change = statistics.detectable_change(self.beyond_pace_interval(), noise_percent / 100.0)
        return None if change is None else change * 100.0


@dataclass
class Aggregate:
    """The geometric mean of B/A over a group of matched combinations (their beyond-the-pace ratios), its
    bootstrap interval over the entries and its verdict. group: "all", or a segment such as "threads:2"."""

    group: str
    entries: int
    ratio: float
    interval: tuple[float, float] | None
    verdict: str
    clusters: int = 1  # the primitive x thread count cells it spans (cluster_key)

    def detectable(self, noise_percent: float) -> float | None:
        change = statistics.detectable_change(self.interval, noise_percent / 100.0)
        return None if change is None else change * 100.0


def cluster_key(key: BenchmarkKey) -> tuple[str, str]:
    """The cell whose entries drift together between two runs: the primitive (an MPI file's exchange) at one
    thread count (rank count). Measured on this VM, two default runs of one build back to back: the sleeping
    primitives and the oversubscribed thread counts moved by 20-40 % as blocks while the spinning ones at
    threads:2 stayed within a few percent."""
    return (key.get("sync") or key.get("exchange") or key.family, key.get("threads") or key.get("ranks") or "")


def clustered(rows: list) -> list[list]:
    """The rows grouped by cluster_key, in the order of the keys."""
    cells: dict[tuple[str, str], list] = {}
    for row in rows:
        cells.setdefault(cluster_key(row.key), []).append(row)
    return [cells[cell] for cell in sorted(cells)]


def cluster_drifts(rows: list) -> list[float]:
    """The mean log ratio of each cluster of the rows (beyond the pace), less the mean of those means: how far
    whole clusters moved apart between the two runs; empty with fewer than two clusters."""
    means = []
    for cluster in clustered(rows):
        logs = [math.log(r) for r in (row.beyond_pace_ratio() for row in cluster) if math.isfinite(r) and r > 0]
        if logs:
            means.append(sum(logs) / len(logs))
    if len(means) < 2:
        return []
    centre = sum(means) / len(means)
    return [mean - centre for mean in means]


# The segments an aggregate groups by: per primitive, per thread count, per placement (an MPI file's
# exchanges group by exchange).
AGGREGATE_SEGMENTS = ("sync", "threads", "pin", "exchange")


@dataclass
class Comparison:
    baseline: RunFile
    contender: RunFile
    rows: list[Row]
    added: list[BenchmarkKey]
    removed: list[BenchmarkKey]
    errored: list[tuple[BenchmarkKey, str, str]]  # key, which file(s), message
    warnings: list[str]
    time_kind: str
    alpha: float
    noise_percent: float = DEFAULT_NOISE_PERCENT
    calibrations: list[Row] = field(default_factory=list)  # rk4/serial, c2c, overhead: their own family
    # The file pair's pooling (pool_evidence): the drift's standard deviation of log time between the runs and
    # how many entries' intervals are pooled; None: too few entries, each interval is the entry's own.
    drift: float | None = None
    pooled_entries: int = 0

    @property
    def combinations(self) -> list[Row]:
        """The matched combinations the aggregates and the gate read: every row but the collapsed ones."""
        return [row for row in self.rows if not row.collapsed]

    @property
    def geometric_mean(self) -> float | None:
        return statistics.geometric_mean([row.beyond_pace_ratio() for row in self.combinations])

    def aggregates(self) -> list[Aggregate]:
        """The geometric mean of B/A with its interval and verdict: over every matched combination ("all"),
        then per primitive, thread count and placement (AGGREGATE_SEGMENTS), each group in its name's order."""
        groups: dict[str, list[Row]] = {"all": self.combinations}
        for segment in AGGREGATE_SEGMENTS:
            values = sorted({row.key.get(segment) for row in self.combinations if row.key.get(segment)},
                            key=lambda value: (len(value), value) if segment == "threads" else (0, value))
            for value in values:
                groups[f"{segment}:{value}"] = [row for row in self.combinations if row.key.get(segment) == value]
        borrowed = cluster_drifts(self.combinations)
        result = []
        for group, rows in groups.items():
            clusters = clustered(rows)
            # A group of too few clusters cannot show how far whole clusters drift: it borrows the file pair's.
            few = group != "all" and len(clusters) < MIN_AGGREGATE_CLUSTERS
            estimate = statistics.cluster_geometric_mean_interval(
                [[row.beyond_pace_ratio() for row in cluster] for cluster in clusters], statistics.seed_of(group),
                borrowed=borrowed if few else ())
            if estimate is None:
                continue
            interval = estimate[1:] if len(rows) >= MIN_AGGREGATE_ENTRIES else None
            result.append(Aggregate(group, len(rows), estimate[0], interval,
                                    verdict_of(interval, self.noise_percent), len(clusters)))
        return result

    def failed_groups(self, percent: float) -> list[Aggregate]:
        """The aggregates --fail-above fails: slower (whole interval above the noise band) with a geometric
        mean above the band of half-width percent/100 (statistics.beyond_noise)."""
        band = percent / 100.0
        return [aggregate for aggregate in self.aggregates() if aggregate.verdict == "slower"
                and aggregate.ratio > 1.0 and statistics.beyond_noise(aggregate.ratio, band)]

    different_modes: bool | None = None  # None: a file has no pace trace

    def verdict(self, row: Row) -> str:
        return row.verdict(self.noise_percent)

    def pace_verdict(self, row: Row) -> str | None:
        return row.pace_verdict(self.noise_percent)

    def beyond_pace(self, row: Row) -> str:
        return row.beyond_pace(self.noise_percent)

    @property
    def paced(self) -> bool:
        """Both files carry the pace: the pace-aware verdicts are shown."""
        return self.different_modes is not None

    def _counts(self, verdict_of_row) -> dict[str, int]:
        counts = {name: 0 for name in VERDICTS}
        for row in self.rows:
            counts[verdict_of_row(row)] += 1
        return counts

    def verdict_counts(self) -> dict[str, int]:
        """The raw verdicts."""
        return self._counts(self.verdict)

    def pace_verdict_counts(self) -> dict[str, int]:
        """The headline: what changed beyond the pace (pace-aware where available, else raw)."""
        return self._counts(self.beyond_pace)

    def discoveries(self, verdict_of_row) -> tuple[int, int]:
        """(entries called slower or faster, how many of them also have Benjamini-Hochberg q < alpha)."""
        called = [row for row in self.rows if verdict_of_row(row) in ("slower", "faster")]
        return len(called), sum(row.significant(self.alpha) for row in called)

    def regressions_beyond(self, percent: float) -> list[Row]:
        """Combinations that are "slower" beyond the pace (whole interval above the noise band; pace-aware
        where both files carry the pace) with a ratio above the band of half-width percent/100
        (statistics.beyond_noise). Calibrations never count."""
        band = percent / 100.0
        return [row for row in self.combinations if self.beyond_pace(row) == "slower"
                and row.beyond_pace_ratio() > 1.0 and statistics.beyond_noise(row.beyond_pace_ratio(), band)]

    def calibration_moves(self) -> list[tuple[str, str, float | None, float | None, float | None]]:
        """(name, unit, A, B, change B/A - 1 in percent) of the context's in-run calibrations (the entries'
        medians when the context lacks them); the change is None when either side is unavailable."""
        moves = []
        for name, context_key in (("c2c one-way", C2C_CONTEXT), ("serial step", SERIAL_CONTEXT)):
            before, after = calibration(self.baseline, context_key), calibration(self.contender, context_key)
            change = (after / before - 1.0) * 100.0 if (before and after) else None
            moves.append((name, "ns", before, after, change))
        return moves

    def accounting_overheads(self) -> list[tuple[BenchmarkKey, float | None, float | None]]:
        """Per overhead combination: median time with accounting on / with it off, in A and in B."""
        result = []
        pairs = {}
        for run_file in (self.baseline, self.contender):
            for key in run_file.runs:
                if key.family == "overhead" and key.get("accounting") in ("on", "off"):
                    pairs.setdefault(key.without("accounting"), set()).add(key)
        for base in sorted(pairs, key=BenchmarkKey.sort_key):
            on, off = base.replaced("accounting", "on"), base.replaced("accounting", "off")
            result.append((base, median_ratio(self.baseline, on, off, self.time_kind),
                           median_ratio(self.contender, on, off, self.time_kind)))
        return result


def is_calibration(key: BenchmarkKey) -> bool:
    # The serial step of every model the run integrates: rk4/serial, and rk4/model:chainS/serial for a chain;
    # and `lockstep mpi`'s ping-pong (mpi/pingpong/...), the MPI counterpart of c2c.
    return (key.family in CALIBRATION_FAMILIES or key.without("model").display == SERIAL_ENTRY
            or (key.family == "mpi" and key.get("pingpong") == ""))


def sample(run, time_kind: str = "real") -> tuple[list[float], bool]:
    """The repetition times of a run, or its median aggregate alone (False: no repetitions)."""
    times = run.times_ns(time_kind)
    if times:
        return times, True
    for aggregate in ("median", "mean"):
        value = run.aggregate_time_ns(aggregate, time_kind)
        if value is not None:
            return [value], False
    return [], False


def _calibration_sample(key: BenchmarkKey, run, time_kind: str) -> tuple[list[float], bool, str]:
    """A calibration entry's values: c2c by its one_way_ns counter when every repetition has it."""
    if key.family == "c2c":
        values = [r.counters[C2C_COUNTER] for r in run.repetitions if C2C_COUNTER in r.counters]
        if values and len(values) == len(run.repetitions):
            return values, True, C2C_COUNTER
        aggregate = run.aggregates.get("median")
        if not run.repetitions and aggregate and C2C_COUNTER in aggregate.counters:
            return [aggregate.counters[C2C_COUNTER]], False, C2C_COUNTER
    times, repeated = sample(run, time_kind)
    return times, repeated, "time"


def _same_mode(mode_a, mode_b) -> bool:
    if mode_a.c2c_ns is not None and mode_b.c2c_ns is not None:
        a, b = mode_a.c2c_ns, mode_b.c2c_ns
    elif mode_a.c2c_ns is None and mode_b.c2c_ns is None:
        a, b = mode_a.serial_ns, mode_b.serial_ns
    else:
        return False
    return max(a, b) / min(a, b) <= MODE_TOLERANCE


def _mode_text(mode) -> str:
    value = f"c2c {mode.c2c_ns:.0f} ns" if mode.c2c_ns is not None else f"serial {mode.serial_ns:.1f} ns"
    return f"{value} ({mode.share * 100:.0f} %)"


def matching_modes(baseline: RunFile, contender: RunFile) -> list[tuple[int, int]]:
    """(mode of A, mode of B) for every two modes within MODE_TOLERANCE of each other."""
    return [(mode_a.mode, mode_b.mode) for mode_a in baseline.pace.modes for mode_b in contender.pace.modes
            if _same_mode(mode_a, mode_b)]


def pace_note(baseline: RunFile, contender: RunFile, letter: str) -> tuple[list[str], bool | None]:
    """Lines saying in which modes the two runs ran, and whether those differ (None: a file has no trace)."""
    missing = [f.label for f in (baseline, contender) if f.pace is None]
    if missing:
        return ([f"pace: {UNAVAILABLE} in {' and '.join(missing)} (no lockstep_pace: written before the pace trace); "
                 "raw verdicts only"], None)
    matches = matching_modes(baseline, contender)
    lines = [f"pace of {which}: {', '.join(_mode_text(m) for m in f.pace.modes)}; {f.pace.changes} "
             f"change{'' if f.pace.changes == 1 else 's'} of mode (from its lockstep_pace: {f.pace.summary})"
             for which, f in (("A", baseline), (letter, contender))]
    unmatched_a = [m for m in baseline.pace.modes if all(m.mode != a for a, _ in matches)]
    unmatched_b = [m for m in contender.pace.modes if all(m.mode != b for _, b in matches)]
    different = bool(unmatched_a or unmatched_b)
    rule = f"modes match when their c2c medians are within {MODE_TOLERANCE:g}x"
    if not matches:
        lines.append(f"the runs ran in different pace modes: no mode in common ({rule}); every entry's pace-aware "
                     f"verdict is on the pace-normalised figure (time / the pace_c2c_ns read around each repetition)")
    elif different:
        only = ([f"only A: {', '.join(_mode_text(m) for m in unmatched_a)}"] if unmatched_a else []) + \
               ([f"only {letter}: {', '.join(_mode_text(m) for m in unmatched_b)}"] if unmatched_b else [])
        lines.append(f"the runs ran in different pace modes ({'; '.join(only)}; {rule})")
    else:
        lines.append(f"the runs ran in the same pace modes ({rule})")
    return lines, different


def _paced_values(run, time_kind: str) -> list[tuple[float, object]] | None:
    """(time, pace) of each repetition, or None when a repetition has no pace."""
    values = []
    for repetition in run.repetitions:
        if repetition.pace is None:
            return None
        values.append((repetition.real_ns if time_kind == "real" else repetition.cpu_ns, repetition.pace))
    return values or None


def _one_state(values_a, values_b, need: int):
    """The repetitions of both sides whose own c2c reading (pace_c2c_ns) lies within STATE_WIDTH of one
    reference, the reference that keeps the most on the scarcer side (then the most in all, then the fastest):
    (reference ns, times of A, times of B), or None when a reading is missing or a side keeps fewer than
    `need`."""
    if any(pace.c2c_ns is None for _, pace in values_a + values_b):
        return None
    best = None
    for reference in sorted({pace.c2c_ns for _, pace in values_a + values_b}):
        kept = [[time for time, pace in values if reference / STATE_WIDTH <= pace.c2c_ns <= reference * STATE_WIDTH]
                for values in (values_a, values_b)]
        score = (min(len(kept[0]), len(kept[1])), len(kept[0]) + len(kept[1]))
        if best is None or score > best[0]:
            best = (score, reference, kept)
    (scarcer, _), reference, (times_a, times_b) = best
    return (reference, times_a, times_b) if scarcer >= need else None


def pace_elasticities(baseline: RunFile, contender: RunFile, time_kind: str) -> dict[tuple[str, str], float]:
    """Per cluster (cluster_key), how a step's time follows the c2c reading taken around its repetition: the
    slope of log time on log pace_c2c_ns over the repetitions of both files, each entry's and file's centred
    on their own means (least squares pooled over the cluster's entries), within [0, 1]. Only the readings'
    movement inside each run enters it, so a change between the runs is never taken for pace. A cluster
    whose readings did not move: absent (the plain division). Measured on this VM: 0.8-1.2 for the spinning
    primitives at threads:2, 0-0.5 for the sleeping ones and at threads:4, alike in four pairs of runs."""
    sums: dict[tuple[str, str], list[float]] = {}
    for run_file in (baseline, contender):
        for key in sorted(run_file.runs, key=BenchmarkKey.sort_key):  # sums in one order: the same bits always
            run = run_file.runs[key]
            if is_calibration(key) or run.errored:
                continue
            paced = sorted((r.real_ns if time_kind == "real" else r.cpu_ns, r.pace.c2c_ns) for r in run.repetitions
                           if r.pace is not None and r.pace.c2c_ns)
            if len(paced) < 2 or max(c for _, c in paced) <= min(c for _, c in paced) * (1.0 + 1e-9):
                continue  # readings that did not move say nothing of how the time follows them
            times = [math.log(time) for time, _ in paced]
            readings = [math.log(reading) for _, reading in paced]
            mean_time, mean_reading = sum(times) / len(times), sum(readings) / len(readings)
            cell = sums.setdefault(cluster_key(key), [0.0, 0.0])
            cell[0] += sum((t - mean_time) * (c - mean_reading) for t, c in zip(times, readings))
            cell[1] += sum((c - mean_reading) ** 2 for c in readings)
    return {cell: min(max(covariance / variance, 0.0), 1.0) for cell, (covariance, variance) in sums.items()
            if variance > 0.0}


def pace_aware(run_a, run_b, baseline: RunFile, contender: RunFile, matches, time_kind: str,
               min_in_mode: int = statistics.MIN_REPETITIONS, elasticity: float = 1.0) -> PaceAware | None:
    """The entry compared beyond the pace (see the module's text), or None where the pace is unavailable.
    Within matching modes when each side keeps `min_in_mode` repetitions there (MIN_IN_MODE when the file
    pair's evidence is pooled); within one c2c state (_one_state) where the repetitions so chosen, or all of
    them when no mode matches, ran in more than one state and each side keeps `min_in_mode` in one; else
    each time divided by its c2c reading to the power `elasticity` (pace_elasticities)."""
    values_a, values_b = _paced_values(run_a, time_kind), _paced_values(run_b, time_kind)
    if values_a is None or values_b is None:
        return None

    def in_mode(values, mode):
        return [(time, pace) for time, pace in values if pace.mode == mode]

    modes_a, modes_b = {pace.mode for _, pace in values_a}, {pace.mode for _, pace in values_b}
    chosen = None  # (method, detail, the chosen (time, pace) of A, of B)
    if len(modes_a) == 1 and len(modes_b) == 1 and (next(iter(modes_a)), next(iter(modes_b))) in matches:
        mode_a, mode_b = (f.pace.modes[next(iter(m))] for f, m in ((baseline, modes_a), (contender, modes_b)))
        chosen = (PACE_ONE_MODE, f"every repetition in one mode (c2c {_short(mode_a.c2c_ns)} / "
                                 f"{_short(mode_b.c2c_ns)} ns)", values_a, values_b)
    else:
        best = max(matches, key=lambda pair: (min(len(in_mode(values_a, pair[0])), len(in_mode(values_b, pair[1]))),
                                              -pair[0], -pair[1]), default=None)
        filled = best and min(len(in_mode(values_a, best[0])), len(in_mode(values_b, best[1])))
        if best and filled >= min_in_mode:
            chosen = (PACE_MATCHING_MODES,
                      f"the repetitions in matching modes A {best[0]} / B {best[1]} (c2c "
                      f"{_short(baseline.pace.modes[best[0]].c2c_ns)} / {_short(contender.pace.modes[best[1]].c2c_ns)} ns)",
                      in_mode(values_a, best[0]), in_mode(values_b, best[1]))
    # A mode of the trace can join two states of the machine that its readings bridge (this VM: c2c 14 and
    # 32 ns in one mode, the spinning primitives 2x apart between them); a repetition's own reading tells them
    # apart.
    pool_a, pool_b = (chosen[2], chosen[3]) if chosen else (values_a, values_b)
    state = _one_state(pool_a, pool_b, min_in_mode)
    power = 1.0
    if state and len(state[1]) + len(state[2]) < len(pool_a) + len(pool_b):
        reference, times_a, times_b = state
        method = PACE_ONE_STATE
        detail = (f"the repetitions whose c2c reading is within {STATE_WIDTH:g}x of {reference:.0f} ns "
                  f"(A {len(times_a)} of {len(values_a)}, B {len(times_b)} of {len(values_b)})")
    elif chosen:
        method, detail = chosen[0], chosen[1]
        times_a, times_b = [time for time, _ in chosen[2]], [time for time, _ in chosen[3]]
    else:
        by_c2c = all(p.c2c_ns is not None for _, p in values_a + values_b)
        by_serial = all(p.serial_ns is not None for _, p in values_a + values_b)
        if not (by_c2c or by_serial):
            return None
        reading = "c2c_ns" if by_c2c else "serial_ns"
        power = elasticity if by_c2c else 1.0
        times_a = [time / getattr(pace, reading) ** power for time, pace in values_a]
        times_b = [time / getattr(pace, reading) ** power for time, pace in values_b]
        detail = f"time / pace_{reading} of each repetition" + (f" to the power {power:.2f} (the cluster's "
                                                                  f"elasticity)" if power != 1.0 else "")
        method = PACE_NORMALISED
    ratio = statistics.median(times_b) / statistics.median(times_a)
    return PaceAware(method, detail, ratio, statistics.shift_interval(times_a, times_b), len(times_a), len(times_b),
                     tuple(times_a), tuple(times_b), power=power)


def _log_variance(values_a, values_b) -> tuple[float | None, int]:
    """The pooled variance of log values within the two sides, and its degrees of freedom (n_a + n_b - 2);
    None with no degree of freedom."""
    logs = [[math.log(value) for value in side] for side in (values_a, values_b)]
    degrees = sum(len(side) for side in logs) - 2
    if degrees < 1 or any(not side for side in logs):
        return None, 0
    squares = sum(sum((value - sum(side) / len(side)) ** 2 for value in side) for side in logs)
    return squares / degrees, degrees


def pool_evidence(rows: list[Row]) -> tuple[float | None, int]:
    """Give every row's pace-aware figure the file pair's interval (statistics.pooled_interval): its variance of
    log time moderated by the prior every row's variance fits, plus the drift calibrated from every row's log
    ratio. Returns (the drift, the rows pooled); (None, 0) and the rows' own exact intervals left as they are
    when fewer than statistics.MIN_POOLED_ENTRIES rows have a variance."""
    paced = [row for row in rows if row.pace is not None and not row.collapsed and row.pace.values_a
             and row.pace.values_b]
    variances = [_log_variance(row.pace.values_a, row.pace.values_b) for row in paced]
    prior = statistics.prior_variance([v for v, _ in variances], [d for _, d in variances])
    if prior is None:
        return None, 0
    sampling = []
    for row, (variance, degrees) in zip(paced, variances):
        moderated, total = statistics.moderated_variance(variance, degrees, prior)
        sampling.append((moderated * (1.0 / len(row.pace.values_a) + 1.0 / len(row.pace.values_b)), total))
    logs = [math.log(row.pace.ratio) for row in paced]
    drift = statistics.calibrated_drift(logs, [variance for variance, _ in sampling])
    for row, log_ratio, (variance, degrees) in zip(paced, logs, sampling):
        row.pace.interval = statistics.pooled_interval(log_ratio, variance, degrees, drift)
        row.pace.pooled = True
    return drift, len(paced)


def _short(value: float | None) -> str:
    return UNAVAILABLE if value is None else f"{value:.0f}"


def compare_pair(baseline: RunFile, contender: RunFile, time_kind: str = "real", alpha: float = 0.05,
                 noise_percent: float = DEFAULT_NOISE_PERCENT) -> Comparison:
    keys_a, keys_b = set(baseline.runs), set(contender.runs)
    rows, calibration_rows, errored, warnings = [], [], [], []
    _, different_modes = pace_note(baseline, contender, "B")
    matches = matching_modes(baseline, contender) if different_modes is not None else []
    elasticities = pace_elasticities(baseline, contender, time_kind) if different_modes is not None else {}
    collapsed = baseline.collapsed | contender.collapsed
    untested = []
    for key in sorted(keys_a & keys_b, key=BenchmarkKey.sort_key):
        run_a, run_b = baseline.runs[key], contender.runs[key]
        if run_a.errored or run_b.errored:
            where = " and ".join(label for label, run in ((baseline.label, run_a), (contender.label, run_b))
                                 if run.errored)
            message = "; ".join(run_a.errors + [e for e in run_b.errors if e not in run_a.errors])
            errored.append((key, where, message))
            continue
        calibrating = is_calibration(key)
        if calibrating:
            times_a, reps_a, measure_a = _calibration_sample(key, run_a, time_kind)
            times_b, reps_b, measure_b = _calibration_sample(key, run_b, time_kind)
            if measure_a != measure_b:  # one file has the counter, the other not: compare like with like
                times_a, reps_a = sample(run_a, time_kind)
                times_b, reps_b = sample(run_b, time_kind)
                measure_a = "time"
        else:
            times_a, reps_a = sample(run_a, time_kind)
            times_b, reps_b = sample(run_b, time_kind)
            measure_a = "time"
        if not times_a or not times_b:
            errored.append((key, baseline.label if not times_a else contender.label, "no usable time"))
            continue
        median_a, median_b = statistics.median(times_a), statistics.median(times_b)
        ratio = median_b / median_a  # inputs.py keeps every time within [SHORTEST_NS, LONGEST_NS]
        interval = statistics.shift_interval(times_a, times_b) if reps_a and reps_b else None
        p_raw = statistics.mann_whitney_p(times_a, times_b) if reps_a and reps_b else None
        if interval is None and not calibrating and key not in collapsed:
            untested.append(key)
        counters = {}
        for counter, _ in COUNTERS_SHOWN:
            values_a, values_b = run_a.counter_values(counter), run_b.counter_values(counter)
            if values_a or values_b:
                counters[counter] = (statistics.median(values_a) if values_a else None,
                                     statistics.median(values_b) if values_b else None)
        row = Row(key, median_a, median_b, len(times_a) if reps_a else 0, len(times_b) if reps_b else 0,
                  ratio, interval, p_raw, counters=counters, measure=measure_a,
                  collapsed=not calibrating and key in collapsed)
        if different_modes is not None and not calibrating and measure_a == "time":
            row.pace = pace_aware(run_a, run_b, baseline, contender, matches, time_kind, MIN_IN_MODE,
                                  elasticities.get(cluster_key(key), 1.0))
        (calibration_rows if calibrating else rows).append(row)
    drift, pooled_entries = pool_evidence(rows)
    if drift is None:  # too few entries to pool: each its own exact interval, within matching modes from 5
        for row in rows:
            if row.pace is not None:
                run_a, run_b = baseline.runs[row.key], contender.runs[row.key]
                row.pace = pace_aware(run_a, run_b, baseline, contender, matches, time_kind,
                                      elasticity=elasticities.get(cluster_key(row.key), 1.0))
    # Two families, each adjusted on its own: the combinations, and the calibrations.
    for family in (rows, calibration_rows):
        for row, adjusted in zip(family, statistics.benjamini_hochberg([row.p_raw for row in family])):
            row.p_adjusted = adjusted
    for key in sorted(keys_a - keys_b, key=BenchmarkKey.sort_key):
        if baseline.runs[key].errored:
            errored.append((key, baseline.label, "; ".join(baseline.runs[key].errors)))
    for key in sorted(keys_b - keys_a, key=BenchmarkKey.sort_key):
        if contender.runs[key].errored:
            errored.append((key, contender.label, "; ".join(contender.runs[key].errors)))
    back_to_back = [run_file.label for run_file in (baseline, contender)
                    if str(run_file.context.get("lockstep_order", "")).startswith(BACK_TO_BACK_ORDER)]
    if back_to_back:
        warnings.append(f"{' and '.join(back_to_back)} measured every entry's repetitions back to back "
                        f"(context lockstep_order): a drift of the machine during the run shifts the entries that "
                        f"ran at that moment, with a tiny p; `lockstep run` without --no-interleave (its default) "
                        f"spreads it over every entry")
    if time_kind == "cpu":
        batch_cpu = [run_file.label for run_file in (baseline, contender) if run_file.mpi is None
                     and int(run_file.context.get("lockstep_schema", PER_UNIT_TIMES_SCHEMA)) < PER_UNIT_TIMES_SCHEMA]
        if batch_cpu:
            warnings.append(f"{' and '.join(batch_cpu)} predate lockstep schema {PER_UNIT_TIMES_SCHEMA}: the "
                            f"cpu_time of their team entries is Google Benchmark's own thread, which only replayed "
                            f"the batch times, not the CPU time of a step (rk4/serial's is)")
    if untested:
        enough = max(statistics.MIN_REPETITIONS, 10)
        # A `lockstep mpi` file's repetitions are its rounds.
        more = (f"lockstep mpi --rounds {enough}" if baseline.mpi and contender.mpi
                else f"lockstep run --repetitions {enough}")
        warnings.append(f"{len(untested)} of {len(rows)} matched entries have too few repetitions for a "
                        f"{int(statistics.CONFIDENCE * 100)} % interval (fewer than 4 on a side, or fewer than "
                        f"{statistics.MIN_REPETITIONS} repetitions on a side for the Mann-Whitney U test): untested "
                        f"(`{more}` or more)")
    unpaced = [row for row in rows if different_modes is not None and row.pace is None]
    if unpaced:
        warnings.append(f"{len(unpaced)} of {len(rows)} matched entries have a repetition without its pace: their "
                        f"pace-aware verdict is {UNAVAILABLE} (the raw one counts for them)")
    errored.sort(key=lambda item: item[0].sort_key())
    return Comparison(baseline, contender, rows,
                      added=sorted(keys_b - keys_a, key=BenchmarkKey.sort_key),
                      removed=sorted(keys_a - keys_b, key=BenchmarkKey.sort_key),
                      errored=errored, warnings=warnings, time_kind=time_kind, alpha=alpha,
                      noise_percent=noise_percent, calibrations=calibration_rows,
                      different_modes=different_modes, drift=drift, pooled_entries=pooled_entries)


# ---------------------------------------------------------------- across machines

def fingerprint(run_file: RunFile) -> dict[str, str]:
    context = run_file.context
    return {key: ("" if context.get(key) is None else str(context.get(key))) for key in FINGERPRINT_KEYS}


def same_machine(a: RunFile, b: RunFile) -> bool:
    fa, fb = fingerprint(a), fingerprint(b)
    return all(fa[key] == fb[key] for key in MACHINE_KEYS)


def run_median(run_file: RunFile, key: BenchmarkKey, time_kind: str = "real") -> float | None:
    run = run_file.runs.get(key)
    if run is None or run.errored:
        return None
    times, _ = sample(run, time_kind)
    return statistics.median(times) if times else None


def median_ratio(run_file: RunFile, numerator: BenchmarkKey, denominator: BenchmarkKey, time_kind: str = "real",
                 collapsed=frozenset()) -> float | None:
    """median(numerator) / median(denominator) of one file's entries (run_median): the one ratio of two medians
    every table and figure shows. None when either entry is missing, errored, has a zero median or is in
    `collapsed`."""
    if numerator in collapsed or denominator in collapsed:
        return None
    top, bottom = run_median(run_file, numerator, time_kind), run_median(run_file, denominator, time_kind)
    return top / bottom if (top and bottom) else None


def per_mode_medians(run: Run) -> tuple[dict[int, tuple[float, int]], float | None, int]:
    """An entry's repetitions split by the pace mode they ran in (real time): {mode: (median, repetitions)},
    the slowest mode's median over the fastest's (the trace lists its modes fastest first: the highest mode's
    over the lowest's; None with fewer than two modes), and how many repetitions straddled a change of mode."""
    paced = [(r.pace.mode, r.real_ns) for r in run.repetitions if r.pace is not None and r.pace.mode is not None]
    by_mode: dict[int, list[float]] = {}
    for mode, value in paced:
        if mode >= 0:
            by_mode.setdefault(mode, []).append(value)
    medians = {mode: (statistics.median(values), len(values)) for mode, values in by_mode.items()}
    spread = medians[max(medians)][0] / medians[min(medians)][0] if len(medians) >= 2 else None
    return medians, spread, sum(1 for mode, _ in paced if mode < 0)


def calibration(run_file: RunFile, context_key: str) -> float | None:
    """serial_step_ns or c2c_one_way_ns: the context's value, else the median of the in-run entry
    (for c2c, of its one_way_ns counter when it has one: its iteration time includes thread start-up)."""
    value = run_file.context_number(context_key)
    if value is not None:
        return value
    if context_key == SERIAL_CONTEXT:
        return run_median(run_file, parse_name(SERIAL_ENTRY))
    key = parse_name(C2C_ENTRY)
    run = run_file.runs.get(key)
    if run is None or run.errored:
        return None
    one_way = run.counter_values(C2C_COUNTER)
    if one_way:
        return statistics.median(one_way)
    return run_median(run_file, key)


def model_serial(run_file: RunFile, key: BenchmarkKey) -> float | None:
    """The serial step an rk4 entry's step is divided by: its own model's. The paper's system (no model
    segment): the context's serial_step_ns, else rk4/serial; a chain: its in-run entry rk4/model:<model>/serial
    (the context holds the paper's system's only)."""
    model = key.get("model")
    if not model:
        return calibration(run_file, SERIAL_CONTEXT)
    return run_median(run_file, parse_name(f"rk4/model:{model}/serial"))


def normalised(run_file: RunFile, key: BenchmarkKey, time_kind: str = "real") -> tuple[float | None, float | None]:
    """(step time / serial step time of its model, stage sync time / one-way c2c latency) on that file's own
    machine.

    The entry's own vs_serial / vs_c2c counters, the median over its repetitions, as `lockstep run` derived them
    against its in-run calibrations (bench/results/derived_figures.hpp). Computed here only where the file lacks
    them (files written before the counters, or a run whose calibration was unavailable) or for CPU time (the
    counters divide the real ns_per_step): the same division, by the context's in-run calibrations (a chain's
    serial step: its rk4/model:<model>/serial entry). None ("unavailable") when neither exists."""
    run = run_file.runs.get(key)
    if run is None or run.errored:
        return None, None
    in_file = time_kind == "real"
    vs_serial = statistics.median(run.counter_values(VS_SERIAL_COUNTER)) if (
        in_file and run.counter_values(VS_SERIAL_COUNTER)) else None
    vs_c2c = statistics.median(run.counter_values(VS_C2C_COUNTER)) if run.counter_values(VS_C2C_COUNTER) else None
    if vs_serial is None:
        step = run_median(run_file, key, time_kind)
        serial = model_serial(run_file, key)
        vs_serial = step / serial if (step is not None and serial) else None
    if vs_c2c is None:
        sync = run.counter_values(SYNC_COUNTER)
        c2c = calibration(run_file, C2C_CONTEXT)
        vs_c2c = statistics.median(sync) / c2c if (sync and c2c) else None
    return vs_serial, vs_c2c


def rk4_keys(run_files: list[RunFile]) -> list[BenchmarkKey]:
    keys = set()
    for run_file in run_files:
        keys.update(key for key in run_file.runs if key.family == "rk4" and key.get("sync"))
    return sorted(keys, key=BenchmarkKey.sort_key)


def layout_effects(run_files: list[RunFile], reference: str = "packed", time_kind: str = "real"):
    """Rows (sync, pin, threads, layout, [speed-up over the reference layout per file]); a file where either
    entry collapsed (its headline's) has none."""
    rows = []
    for key in rk4_keys(run_files):
        layout = key.get("layout")
        if layout is None or layout == reference:
            continue
        reference_key = key.replaced("layout", reference)
        speedups = [median_ratio(run_file, reference_key, key, time_kind, run_file.collapsed)
                    for run_file in run_files]
        if any(s is not None for s in speedups):
            rows.append((key.get("sync"), key.get("pin"), key.get("threads"), layout, speedups))
    return rows


def rank_tables(run_files: list[RunFile], time_kind: str = "real", top: int = 10):
    """{(pin, threads): [per file: [(sync/layout, median ns, x serial), ...] fastest first]}; the entries a
    file's headline calls collapsed are not ranked."""
    groups: dict[tuple[str, int], list] = {}
    for key in rk4_keys(run_files):
        group = (key.get("pin") or "", key.threads or 0)
        groups.setdefault(group, [])
    tables = {}
    for group in sorted(groups):
        per_file = []
        for run_file in run_files:
            entries = []
            for key in rk4_keys([run_file]):
                if (key.get("pin") or "", key.threads or 0) != group or key in run_file.collapsed:
                    continue
                step = run_median(run_file, key, time_kind)
                if step is None:
                    continue
                entries.append((f"{key.get('sync')}/{key.get('layout')}", step, normalised(run_file, key, time_kind)[0]))
            entries.sort(key=lambda entry: (entry[1], entry[0]))
            per_file.append(entries[:top])
        tables[group] = per_file
    return tables


# ---------------------------------------------------------------- text output

def _number(value: float | None, digits: int = 2) -> str:
    """A cell of a numeric column: "-" where there is nothing to show."""
    return format_number(value, digits, missing="-")


def file_letter(index: int) -> str:
    """The letter of the index-th file: A is the baseline."""
    return chr(ord("A") + index)


def _p(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.2g}" if value >= 1e-4 else "<1e-4"


def _table(headings: list[str], rows: list[list[str]], right: set[int] | None = None) -> list[str]:
    right = right or set()
    widths = [len(h) for h in headings]
    for row in rows:
        widths = [max(w, len(cell)) for w, cell in zip(widths, row)]

    def line(cells):
        return "  ".join(cell.rjust(w) if i in right else cell.ljust(w)
                         for i, (cell, w) in enumerate(zip(cells, widths))).rstrip()

    return [line(headings), line(["-" * w for w in widths])] + [line(row) for row in rows]


def fingerprint_lines(run_files: list[RunFile]) -> list[str]:
    labels = [f"[{file_letter(i)}] {f.label}" for i, f in enumerate(run_files)]
    prints = [fingerprint(f) for f in run_files]
    rows = []
    for key in FINGERPRINT_KEYS:
        values = [p[key] or UNAVAILABLE for p in prints]
        mark = "*" if len(set(values)) > 1 else ""
        rows.append([key + mark] + values)
    return _table(["context (* differs)"] + labels, rows)


def _percent(value: float) -> str:
    return f"{value:+.1f} %"


def calibration_move_line(comparison: Comparison, letter: str) -> str:
    """How far the machine itself moved between the two runs, by the context's in-run calibrations."""
    parts, moves = [], []
    for name, unit, before, after, move in comparison.calibration_moves():
        if move is not None:
            moves.append((name, after / before))
            digits = 2 if max(before, after) < 100 and name.startswith("serial") else 1
            parts.append(f"{name} {before:.{digits}f} -> {after:.{digits}f} {unit} ({_percent(move)})")
        else:
            parts.append(f"{name} {UNAVAILABLE}")
    line = (f"calibrations moved, {letter} against A (in-run medians from each file's context, else from its "
            f"calibration entries; the comparisons below are not rescaled by them): " + ", ".join(parts))
    noise = comparison.noise_percent
    beyond = [name for name, ratio in moves if statistics.beyond_noise(ratio, noise / 100.0)]
    if not moves:
        return line + ": the machine's movement between the runs is unknown."
    if beyond:
        return (line + f". {' and '.join(beyond)} moved beyond the ±{noise:g} % noise threshold: the machine "
                "itself changed between the runs (or they are different machines), so shifts of that size below "
                "may be the machine, not the code.")
    return line + f": inside the ±{noise:g} % noise threshold."


def _interval(interval) -> str:
    return f"[{interval[0]:.3f}, {interval[1]:.3f}]" if interval else "-"


def _row_cells(comparison: Comparison, row: Row) -> list[str]:
    return [format_ns(row.median_a), format_ns(row.median_b), f"{row.ratio:.3f}", _interval(row.interval),
            f"{row.repetitions_a}/{row.repetitions_b}", _p(row.p_adjusted), comparison.verdict(row)]


PACE_HOW = {PACE_ONE_MODE: "one mode", PACE_MATCHING_MODES: "matching modes", PACE_ONE_STATE: "one c2c state",
            PACE_NORMALISED: "/ pace c2c"}


def pace_how(pace: PaceAware) -> str:
    """How a pace-aware figure was made, in a table's few characters: "/ pace c2c^0.35" for a time divided by
    its reading to its cluster's elasticity."""
    if "serial" in pace.detail:
        return "/ pace serial"
    if pace.method == PACE_NORMALISED and pace.power != 1.0:
        return f"/ pace c2c^{pace.power:.2f}"
    return PACE_HOW[pace.method]


def _pace_cells(comparison: Comparison, row: Row) -> list[str]:
    if row.pace is None:
        return [UNAVAILABLE, "-", "-", "-", "-"]
    return [pace_how(row.pace), f"{row.pace.ratio:.3f}", _interval(row.pace.interval), comparison.pace_verdict(row),
            _plus_minus(row.detectable(comparison.noise_percent))]


def _counts_text(counts: dict[str, int]) -> str:
    return (f"{counts['slower']} slower, {counts['faster']} faster, {counts['unsure']} unsure, "
            f"{counts['within noise']} within noise, {counts['untested']} untested"
            + (f", {counts[COLLAPSED]} {COLLAPSED}" if counts.get(COLLAPSED) else ""))


def _plus_minus(percent: float | None) -> str:
    return "-" if percent is None else f"±{percent:.0f} %"


def aggregate_line(comparison: Comparison, letter: str) -> str:
    """The answer: the geometric mean of B/A over every matched combination, its interval and verdict, and
    what it could not have seen when unsure. Printed the same way by the summary and --all."""
    overall = next((a for a in comparison.aggregates() if a.group == "all"), None)
    collapsed = len(comparison.rows) - len(comparison.combinations)
    apart = "calibrations" + (f" and {collapsed} collapsed" if collapsed else "") + " apart"
    head = (f"geometric mean of {letter}/A over the {len(comparison.combinations)} matched pairs (combinations "
            f"only, {apart}")
    if overall is None:
        return head + f"): {UNAVAILABLE}"
    line = head + ("; beyond the pace" if comparison.paced else "") + "): " + aggregate_text(comparison, overall)
    if overall.verdict in ("slower", "faster"):
        # Its interval is drawn over the entries of one run a side: a drift of the whole machine between
        # the two runs (a host that wakes sleeping vCPUs slower for a minute) moves every entry alike and
        # reads as a change. Two default runs of one build, back to back on the development VM, gave
        # 1.003 once and 1.109 ("slower") once.
        line += ("\n  (one run a side: a drift of the whole machine between the runs reads as a change here; "
                 "to see its size, run A again and compare A with its rerun)")
    return line


def aggregate_text(comparison: Comparison, aggregate: Aggregate) -> str:
    """"1.153, 95% interval [1.120, 1.184]: slower" (and, when unsure, the smallest change it could have
    shown); the one way an aggregate is written."""
    text = f"{aggregate.ratio:.3f}, 95% interval {_interval(aggregate.interval)}: {aggregate.verdict}"
    if aggregate.interval is None:
        return text + f" (fewer than {MIN_AGGREGATE_ENTRIES} entries)"
    if aggregate.verdict == "unsure":
        text += f" (could not have seen less than {_plus_minus(aggregate.detectable(comparison.noise_percent))})"
    return text


SHOWN_GROUPS = 5


def group_lines(comparison: Comparison) -> list[str]:
    """The groups whose geometric mean is slower or faster beyond the band (largest change first, at most
    SHOWN_GROUPS each way, each as aggregate_text writes it), and how many groups are within noise or unsure."""
    groups = [a for a in comparison.aggregates() if a.group != "all"]
    if not groups:
        return []
    out = []
    for verdict, largest in (("slower", True), ("faster", False)):
        called = sorted((a for a in groups if a.verdict == verdict), key=lambda a: (a.ratio, a.group),
                        reverse=largest)
        out += [f"  {a.group} ({a.entries} entries): {aggregate_text(comparison, a)}" for a in called[:SHOWN_GROUPS]]
        if len(called) > SHOWN_GROUPS:
            out.append(f"  ... and {len(called) - SHOWN_GROUPS} more {verdict} (--all lists every group)")
    rest = {name: sum(a.verdict == name for a in groups) for name in ("within noise", "unsure", "untested")}
    if any(rest.values()):
        out.append(("  the other groups: " if out else "  ") + ", ".join(f"{count} {name}" for name, count
                                                                      in rest.items() if count))
    return [f"by group (per primitive, thread count, placement; {len(groups)} groups):"] + out


def detectable_line(comparison: Comparison) -> str | None:
    """For the entries whose beyond-the-pace verdict is unsure: the smallest change they could have shown, and
    what would make it smaller. None when no entry is unsure."""
    unsure = [row for row in comparison.combinations if comparison.beyond_pace(row) == "unsure"]
    changes = sorted(change for change in (row.detectable(comparison.noise_percent) for row in unsure)
                     if change is not None)
    if not changes:
        return None
    median = statistics.median(changes)
    drift = comparison.drift
    line = (f"the {len(unsure)} unsure could not have seen less than {_plus_minus(median)} (median; "
            f"{_plus_minus(changes[0])} the best, {_plus_minus(changes[-1])} the worst). To see less: more "
            f"repetitions (lockstep run --repetitions 10 narrows the within-run part by about 1/sqrt(2))")
    if drift is not None and drift * 100 < 0.05:
        line += (", a quieter machine (between these runs the entries spread no more than their own repetitions "
                 "do: no drift beyond them)")
    elif drift is not None:
        floor = ((1.0 + comparison.noise_percent / 100.0) * math.exp(1.96 * drift) - 1.0) * 100.0
        line += (f", a quieter machine (the drift between these runs, {drift * 100:.1f} % of log time, calibrated "
                 f"from every entry, sets a floor of {_plus_minus(floor)} that repetitions do not lower)")
    else:
        line += ", a quieter machine"
    return line + (f", or a wider band (--noise; now {comparison.noise_percent:g} %); the aggregate above "
                   f"sees a uniform change that single entries cannot")


def _tool(run_file: RunFile) -> str:
    return "lockstep mpi" if run_file.mpi else "lockstep run"


def comparison_lines(comparison: Comparison, letter: str) -> list[str]:
    a, b = "A", letter
    noise = comparison.noise_percent
    limit = 1.0 + noise / 100.0
    out = [f"== {b} ({comparison.contender.label}) against A ({comparison.baseline.label})", ""]
    if not set(comparison.baseline.runs) & set(comparison.contender.runs):
        out += [f"no entries in common: A ({_tool(comparison.baseline)}) and {b} ({_tool(comparison.contender)}) "
                f"name different benchmarks, so nothing below is compared; each file's entries are listed at the "
                f"end", ""]
    out.append(calibration_move_line(comparison, b))
    out.append("")
    kind = "real" if comparison.time_kind == "real" else "CPU"
    out += pace_note(comparison.baseline, comparison.contender, b)[0]
    out.append("")
    out.append(f"time: {kind} time (the ns_per_step or ns_per_episode counter where an entry has it, else per iteration), median of "
               f"the repetitions; ratio {b}/A of the medians (> 1: {b} is slower); interval: the exact "
               f"distribution-free {int(statistics.CONFIDENCE * 100)}% interval of the shift {b}/A between the "
               f"repetitions (Mann-Whitney U inverted on log time); q: two-sided Mann-Whitney U p, Benjamini-Hochberg "
               f"adjusted (false discovery rate) over the {sum(r.p_raw is not None for r in comparison.rows)} tests of "
               f"this comparison's combinations; counters are medians, {a} -> {b}.")
    out.append(f"verdict: the interval against the noise band of {noise:g} % (--noise PCT): slower / faster = the "
               f"whole interval beyond it ({b}/A above {limit:.3f} or below {1.0 / limit:.3f}); within noise = the "
               f"whole interval inside it (a shift no larger than the machine's own run-to-run drift); unsure = the "
               f"interval reaches across an edge of the band (more repetitions would tell); untested = too few "
               f"repetitions for an interval.")
    if comparison.paced:
        out.append(f"pace-aware (pace columns): how = one mode (every repetition of both sides in one matching mode: "
                   f"the raw comparison), matching modes (only the repetitions in the best-filled pair of matching "
                   f"modes, when each side keeps {MIN_IN_MODE if comparison.drift is not None else statistics.MIN_REPETITIONS}), "
                   f"or / pace c2c (each repetition's time "
                   f"divided by the c2c reading around it, pace_c2c_ns: the pace-normalised figure); its ratio, "
                   f"interval and verdict as above.")
    out.append("")
    counters_present = [(c, h) for c, h in COUNTERS_SHOWN if any(c in row.counters for row in comparison.rows)]
    pace_headings = (["pace: how", f"{b}/A paced", "paced interval", "paced verdict", "could see"]
                     if comparison.paced else [])
    headings = ["benchmark", f"{a} median", f"{b} median", f"{b}/A", "95% interval", "reps", "q (BH)",
                "verdict"] + pace_headings + [h for _, h in counters_present]
    rows = []
    for row in comparison.rows:
        cells = [row.key.display] + _row_cells(comparison, row)
        if comparison.paced:
            cells += _pace_cells(comparison, row)
        for counter, _ in counters_present:
            before, after = row.counters.get(counter, (None, None))
            # Absent on both sides: the entry cannot have it (lockstep omits, e.g., the futex waits
            # of a primitive that hides them in a library), never a 0.
            cells.append(UNAVAILABLE if before is None and after is None
                         else f"{format_number(before)} -> {format_number(after)}")
        rows.append(cells)
    out += _table(headings, rows, right={1, 2, 3, 6} | ({9} if comparison.paced else set()))
    out.append("")
    out.append(aggregate_line(comparison, b))
    groups = [aggregate for aggregate in comparison.aggregates() if aggregate.group != "all"]
    if groups:
        out += _table(["group", "entries", f"{b}/A geometric mean", "95% interval", "verdict", "could see"],
                      [[a.group, str(a.entries), f"{a.ratio:.3f}", _interval(a.interval), a.verdict,
                        _plus_minus(a.detectable(noise))] for a in groups], right={1, 2})
    if comparison.drift is not None:
        out.append(f"pooled intervals ({comparison.pooled_entries} entries): each pace-aware interval from the "
                   f"entry's variance of log time moderated towards the file pair's, plus the drift between the "
                   f"runs calibrated from every entry's log ratio: {comparison.drift * 100:.1f} % (log time)")
    raw_called, raw_discovered = comparison.discoveries(comparison.verdict)
    out.append(f"raw verdicts at the {noise:g} % noise band: {_counts_text(comparison.verdict_counts())} "
               f"({raw_discovered} of the {raw_called} slower or faster also have BH q < alpha {comparison.alpha:g})")
    if comparison.paced:
        paced_rows = [row for row in comparison.rows if row.pace]
        pace_counts = {name: sum(comparison.pace_verdict(row) == name for row in paced_rows) for name in VERDICTS}
        methods = ", ".join(f"{sum(row.pace.method == method for row in paced_rows)} {method}"
                            for method in (PACE_ONE_MODE, PACE_MATCHING_MODES, PACE_ONE_STATE,
                                                   PACE_NORMALISED))
        unpaced = len(comparison.rows) - len(paced_rows)
        out.append(f"pace-aware verdicts: {_counts_text(pace_counts)} ({methods}"
                   + (f"; {unpaced} {UNAVAILABLE}" if unpaced else "") + ")")
    headline = comparison.pace_verdict_counts()
    called, discovered = comparison.discoveries(comparison.beyond_pace)
    what = ("beyond the pace (pace-aware verdicts; the raw one where an entry has no pace)" if comparison.paced
            else f"(raw verdicts: pace {UNAVAILABLE})")
    out.append(f"changed {what}: {headline['slower'] + headline['faster']} of {len(comparison.rows)} "
               f"({headline['slower']} slower, {headline['faster']} faster; {discovered} of them with BH q < alpha "
               f"{comparison.alpha:g})")
    if comparison.calibrations:
        out.append("")
        out.append(f"calibrations ({len(comparison.calibrations)}): the machine and the instrumentation, not a "
                   f"combination; c2c compared by its {C2C_COUNTER} counter (its iteration time is thread start-up "
                   f"plus the measurement), the overhead pair, rk4/serial and the MPI ping-pong (its OSU-style mean "
                   f"one-way time) by their time (they measure the pace: raw only); q Benjamini-Hochberg over these "
                   f"{sum(r.p_raw is not None for r in comparison.calibrations)} tests on their own; not in the "
                   f"geometric mean, the counts above or --fail-above.")
        calibration_rows = [[row.key.display, row.measure] + _row_cells(comparison, row)
                            for row in comparison.calibrations]
        out += _table(["calibration", "measure", f"{a} median", f"{b} median", f"{b}/A", "95% interval", "reps",
                       "q (BH)", "verdict"], calibration_rows, right={2, 3, 4, 7})
        for key, ratio_a, ratio_b in comparison.accounting_overheads():
            out.append(f"accounting overhead of {key.display} (time with accounting:on / off): "
                       f"A {_number(ratio_a, 3)}, {b} {_number(ratio_b, 3)}")
    out.append("")
    for title, keys in ((f"only in A ({comparison.baseline.label}): removed", comparison.removed),
                        (f"only in {b} ({comparison.contender.label}): added", comparison.added)):
        out.append(f"{title}: {len(keys)}")
        out += [f"  {key.display}" for key in keys]
    out.append(f"errored (not compared): {len(comparison.errored)}")
    out += [f"  {key.display} in {where}: {message}" for key, where, message in comparison.errored]
    for warning in comparison.warnings:
        out.append(f"warning: {warning}")
    return out


def across_machines_lines(run_files: list[RunFile], time_kind: str = "real") -> list[str]:
    letters = [file_letter(i) for i in range(len(run_files))]
    out = ["== Across machines: each file normalised by its own machine", ""]
    out.append("x serial: step time / that run's serial RK4 step of the entry's model (context serial_step_ns; "
               "a chain's: its rk4/model:chainS/serial entry); "
               "x c2c: stage sync time / that run's one-way core-to-core latency (context c2c_one_way_ns).")
    rows = []
    for key in rk4_keys(run_files):
        cells = [key.display]
        for run_file in run_files:
            vs_serial, vs_c2c = normalised(run_file, key, time_kind)
            cells += [_number(vs_serial), _number(vs_c2c)]
        rows.append(cells)
    headings = ["benchmark"]
    for letter in letters:
        headings += [f"{letter} x serial", f"{letter} x c2c"]
    out += _table(headings, rows, right=set(range(1, len(headings))))
    out.append("")
    out.append("Layouts against packed (speed-up = packed time / layout time, on each machine):")
    effect_rows = [[sync, pin, str(threads), layout] + [(_number(s) + "x") if s else "-" for s in speedups]
                   for sync, pin, threads, layout, speedups in layout_effects(run_files, time_kind=time_kind)]
    out += _table(["sync", "pin", "threads", "layout"] + [f"{letter} vs packed" for letter in letters],
                  effect_rows, right=set(range(4, 4 + len(letters))))
    out.append("")
    out.append("Rank per machine (fastest first; sync/layout, step time, x serial):")
    for (pin, threads), per_file in rank_tables(run_files, time_kind).items():
        out.append(f"-- pin:{pin} threads:{threads}")
        depth = max((len(entries) for entries in per_file), default=0)
        rank_rows = []
        for rank in range(depth):
            cells = [str(rank + 1)]
            for entries in per_file:
                if rank < len(entries):
                    name, step, vs_serial = entries[rank]
                    cells.append(f"{name} {format_ns(step)} ({_number(vs_serial)}x)")
                else:
                    cells.append("")
            rank_rows.append(cells)
        out += _table(["rank"] + [f"[{letter}] {f.label}" for letter, f in zip(letters, run_files)], rank_rows)
    return out


# The default output (render_text without everything) lists at most this many changed entries each way.
SHOWN_CHANGES = 6
ALL_HINT = ("(lockstep compare --all prints every entry with its interval, q and counters, the calibrations, the "
            "whole context and the across-machines tables)")


def differing_context_lines(files) -> list[str]:
    """The fingerprint's keys whose values differ between the files, as a table (A, B, ... side by side), or
    one line saying they are all the same."""
    labels = [f"[{file_letter(i)}] {f.label}" for i, f in enumerate(files)]
    prints = [fingerprint(f) for f in files]
    rows = []
    for key in FINGERPRINT_KEYS:
        values = [p[key] or UNAVAILABLE for p in prints]
        if len(set(values)) > 1:
            rows.append([key + "*"] + values)
    if not rows:
        return [f"context: the same {len(FINGERPRINT_KEYS)} fingerprint keys in every file"]
    return _table(["context (* differs)"] + labels, rows)


def _collapsed_mark(comparison: Comparison, key: BenchmarkKey) -> str:
    where = [letter for letter, run_file in (("A", comparison.baseline), ("B", comparison.contender))
             if key in run_file.collapsed]
    return f" (collapsed in {' and '.join(where)})" if where else ""


def _listed(keys, limit: int = 5) -> list[str]:
    shown = [f"  {key.display}" for key in keys[:limit]]
    return shown + ([f"  ... and {len(keys) - limit} more"] if len(keys) > limit else [])


def summary_lines(comparison: Comparison, letter: str) -> list[str]:
    """One comparison in a few lines: how far the machine moved, the pace, the verdict counts, the geometric
    mean, the entries that changed beyond the pace (largest first), what was added, removed or errored."""
    b = letter
    noise = comparison.noise_percent
    out = [f"== {b} ({comparison.contender.label}) against A ({comparison.baseline.label})"]
    if not set(comparison.baseline.runs) & set(comparison.contender.runs):
        out.append(f"no entries in common: A ({_tool(comparison.baseline)}) and {b} ({_tool(comparison.contender)}) "
                   f"name different benchmarks, so nothing is compared")
    out.append(aggregate_line(comparison, b))
    out += group_lines(comparison)
    out.append(calibration_move_line(comparison, b))
    out += pace_note(comparison.baseline, comparison.contender, b)[0]
    counts = comparison.pace_verdict_counts()
    called, discovered = comparison.discoveries(comparison.beyond_pace)
    what = "beyond the pace" if comparison.paced else f"(raw verdicts: pace {UNAVAILABLE})"
    out.append(f"changed {what}: {counts['slower'] + counts['faster']} of {len(comparison.rows)} "
               f"({counts['slower']} slower, {counts['faster']} faster; {discovered} of them with Benjamini-Hochberg "
               f"q < alpha {comparison.alpha:g}); {counts['unsure']} unsure, {counts['within noise']} within noise, "
               f"{counts['untested']} untested"
               + (f", {counts[COLLAPSED]} {COLLAPSED} (in a file's headline: oversubscribed, one repetition)"
                  if counts[COLLAPSED] else "")
               + f" (verdict: the 95% interval of {b}/A against the {noise:g} % noise band)")
    unsure = detectable_line(comparison)
    if unsure:
        out.append(unsure)
    for verdict, order in (("slower", True), ("faster", False)):
        changed = sorted((row for row in comparison.rows if comparison.beyond_pace(row) == verdict),
                         key=lambda row: (row.beyond_pace_ratio(), row.key.sort_key()), reverse=order)
        if not changed:
            continue
        out.append(f"{verdict} {what if comparison.paced else ''}".rstrip()
                   + f" ({len(changed)}, {'largest first' if order else 'largest gain first'}):")
        rows = []
        for row in changed[:SHOWN_CHANGES]:
            shown = row.pace if row.pace else row
            how = pace_how(row.pace) if row.pace \
                else "raw"
            rows.append([row.key.display + _collapsed_mark(comparison, row.key), format_ns(row.median_a),
                         format_ns(row.median_b), f"{shown.ratio:.3f}", _interval(shown.interval), how])
        out += ["  " + line for line in _table(["benchmark", "A median", f"{b} median", f"{b}/A", "95% interval",
                                                "how"], rows, right={1, 2, 3})]
        if len(changed) > SHOWN_CHANGES:
            out.append(f"  ... and {len(changed) - SHOWN_CHANGES} more {verdict} (--all lists every entry)")
    if comparison.calibrations:
        verdicts = [comparison.verdict(row) for row in comparison.calibrations]
        moved = [row.key.display for row in comparison.calibrations if comparison.verdict(row) in ("slower", "faster")]
        out.append(f"calibrations, compared apart ({len(verdicts)}): "
                   + ", ".join(f"{verdicts.count(name)} {name}" for name in VERDICTS if verdicts.count(name))
                   + (f" (moved: {', '.join(moved)})" if moved else ""))
    for title, keys in ((f"only in A ({comparison.baseline.label}): removed", comparison.removed),
                        (f"only in {b} ({comparison.contender.label}): added", comparison.added)):
        out.append(f"{title}: {len(keys)}")
        out += _listed(keys)
    out.append(f"errored (not compared): {len(comparison.errored)}")
    errored = [f"  {key.display} in {where}: {message}" for key, where, message in comparison.errored]
    out += errored[:5] + ([f"  ... and {len(errored) - 5} more"] if len(errored) > 5 else [])
    for warning in comparison.warnings:
        out.append(f"warning: {warning}")
    return out


def render_text(run_files: list[RunFile], comparisons: list[Comparison], time_kind: str = "real",
                context_files=(), everything: bool = False) -> str:
    """The comparison as text: by default the summary (summary_lines per comparison, the context's differences),
    everything: every table. `context_files`: results of other kinds (inputs.ContextFile), shown in the
    fingerprint only, after the run files (so a run file's letter is its place among the compared files)."""
    if not everything:
        return render_summary(run_files, comparisons, context_files)
    all_files = list(run_files) + list(context_files)
    out = ["lockstep compare: " + "  ".join(f"[{file_letter(i)}] {f.label}" for i, f in enumerate(all_files))]
    if comparisons:
        noise = comparisons[0].noise_percent
        if noise == DEFAULT_NOISE_PERCENT:
            out.append(f"noise threshold: {noise:g} % (the default, --noise PCT to change it: {NOISE_RATIONALE})")
        else:
            out.append(f"noise threshold: {noise:g} % (--noise; the default is {DEFAULT_NOISE_PERCENT:g} %)")
    out.append("")
    out += fingerprint_lines(all_files)
    machines = {tuple(fingerprint(f)[key] for key in MACHINE_KEYS) for f in all_files}
    out.append(f"machines: {len(machines)} distinct (by {', '.join(MACHINE_KEYS)})")
    if context_files:
        out.append("fingerprint only (not benchmark results): " +
                   ", ".join(f"{f.label} (lockstep {f.kind})" for f in context_files))
    out.append("")
    warnings = [w for f in all_files for w in f.warnings]
    for index, comparison in enumerate(comparisons, start=1):
        out += comparison_lines(comparison, file_letter(index))
        out.append("")
    if run_files and not all(run_file.mpi for run_file in run_files):  # MPI files hold no rk4 entries to normalise
        out += across_machines_lines(run_files, time_kind)
    if warnings:
        out.append("")
        out += [f"warning: {w}" for w in warnings]
    return "\n".join(out) + "\n"


def render_summary(run_files: list[RunFile], comparisons: list[Comparison], context_files=()) -> str:
    all_files = list(run_files) + list(context_files)
    out = ["lockstep compare: " + "  ".join(f"[{file_letter(i)}] {f.label}" for i, f in enumerate(all_files))]
    if comparisons:
        noise = comparisons[0].noise_percent
        out.append(f"noise band: {noise:g} % " + ("(the default; --noise PCT changes it, --help says why 5)"
                                                   if noise == DEFAULT_NOISE_PERCENT else
                                                   f"(--noise; the default is {DEFAULT_NOISE_PERCENT:g} %)"))
    machines = {tuple(fingerprint(f)[key] for key in MACHINE_KEYS) for f in all_files}
    out.append(f"machines: {len(machines)} distinct (by {', '.join(MACHINE_KEYS)})")
    out += differing_context_lines(all_files)
    out += mpi_difference_lines(all_files)
    if context_files:
        out.append("fingerprint only (not benchmark results): " +
                   ", ".join(f"{f.label} (lockstep {f.kind})" for f in context_files))
    for index, comparison in enumerate(comparisons, start=1):
        out.append("")
        out += summary_lines(comparison, file_letter(index))
    warnings = [w for f in all_files for w in f.warnings]
    if warnings:
        out.append("")
        out += [f"warning: {w}" for w in warnings]
    out += ["", ALL_HINT]
    return "\n".join(out) + "\n"
