"""What one comparison of two run files holds (compare.compare_pair makes it, compare_text.py writes it): each
matched entry's row with its raw and pace-aware figures, the verdict words, the aggregates per group and the file
pair's pooling; the rules that turn an interval into a verdict and group entries into clusters."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..analysis.run_analysis import calibration, median_ratio
from ..common import statistics
from ..common.fields import C2C_CONTEXT, SERIAL_CONTEXT
from ..common.names import BenchmarkKey
from ..read.run_file import RunFile
from .comparability import unoptimised

# The default noise threshold, percent (see NOISE_RATIONALE).
DEFAULT_NOISE_PERCENT = 5.0
NOISE_RATIONALE = (
    "between two back-to-back runs on a 2-vCPU KVM guest the machine's own calibrations and the fast "
    "rk4 entries moved by 4-5 % with tiny p (repetitions inside a run cannot see that drift); 5 % with the "
    "whole interval beyond it keeps such drift out of the verdicts while a change of 10 % or more still "
    "shows; on a quiet bare-metal machine --noise 1 (Criterion.rs's default) or 2 fits")


COLLAPSED = "collapsed"
VERDICTS = ("slower", "faster", "unsure", "within noise", "untested", COLLAPSED)
# An aggregate (Aggregate) of fewer entries has no interval: the bootstrap over entries needs some to resample.
MIN_AGGREGATE_ENTRIES = 5
# A group spanning fewer clusters (cluster_key) than this adds the file pair's spread of whole clusters to its
# interval (statistics.cluster_geometric_mean_interval, borrowed): a per-primitive group holds one or two.
MIN_AGGREGATE_CLUSTERS = 5


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
    collapsed: bool = False  # either file's answer calls it collapsed: no verdict, no aggregate, no gate

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


def aggregate_groups(rows: list) -> dict[str, list]:
    """The groups an aggregate is taken over: every row ("all"), then per primitive, thread count and placement
    (AGGREGATE_SEGMENTS), each group in its name's order."""
    groups: dict[str, list] = {"all": list(rows)}
    for segment in AGGREGATE_SEGMENTS:
        values = sorted({row.key.get(segment) for row in rows if row.key.get(segment)},
                        key=lambda value: (len(value), value) if segment == "threads" else (0, value))
        for value in values:
            groups[f"{segment}:{value}"] = [row for row in rows if row.key.get(segment) == value]
    return groups


# The two ways a side's runs are split for A against A.
ALTERNATE, IN_TIME_ORDER = "alternate runs", "in time order"
# The share of entries the time-order split calls changed above which compare says the machine drifted: the rate
# a comparison's false positives are held to (alternate runs stay under it on a machine that keeps its pace).
DRIFT_SHOWN_ABOVE = 0.05


@dataclass(frozen=True)
class AgainstItself:
    """One side's A against A: the entries called changed (slower or faster) when its runs, split one way
    (ALTERNATE or IN_TIME_ORDER), are compared half against half."""

    split: str
    changed: int
    compared: int
    runs: tuple[int, int]  # the runs in each half


@dataclass(frozen=True)
class SideSpread:
    """How far one side's runs differ for an entry (median over the entries): the standard deviation of a run's
    figure (the median of its repetitions' log times) over every repetition and within the reference pace alone,
    and the parts of the latter (replicates.median_components: between runs, and within a run per repetition)."""

    runs: int
    runs_in_pace: int  # its runs with a repetition in the reference pace
    share: float | None  # the part of its repetitions in the reference pace
    every_pace: float | None
    one_pace: float | None
    between: float | None
    within: float | None
    repetitions: float | None  # a run's repetitions of an entry in the reference pace (median)

    @property
    def explained(self) -> float | None:
        """The part of the between-run variance of a run's figure the pace explained: 1 - (one pace / every pace)^2."""
        if not self.every_pace or self.one_pace is None:
            return None
        return max(0.0, 1.0 - (self.one_pace / self.every_pace) ** 2)


@dataclass(frozen=True)
class PaceAcrossRuns:
    """The pace of several runs a side (run_pace.py): the reference pace the entries are compared in (its reading,
    "c2c_ns" or "serial_ns", and its figure in ns), each side's spread, how many entries were compared in it and how
    many on every repetition (too few runs in it), and every pace one side's runs hold and the other's do not:
    (its figure in ns, the side that lacks it, the other side's runs holding it)."""

    reading: str
    reference_ns: float | None
    sides: tuple[SideSpread, SideSpread]
    entries_one_pace: int
    entries_every_pace: int
    missing: tuple[tuple[float, int, int], ...] = ()


@dataclass
class Replicated:
    """What the runs of both sides give a comparison."""

    runs_a: int
    runs_b: int
    aggregates: list[Aggregate]
    # The smallest uniform change (percent) of which POWER of the entries would be called slower, and the one the
    # "all" aggregate would be called slower on at POWER.
    entries_power: float | None = None
    aggregate_power: float | None = None
    against_itself: list[AgainstItself] = field(default_factory=list)  # per side and split
    pace: PaceAcrossRuns | None = None  # None: a run without a pace trace
    plan_check: PlanCheck | None = None  # with the pilot the runs were planned from (compare --pilot)

    def split(self, split: str) -> list[AgainstItself]:
        """Each side's A against A of one split (A's, then B's)."""
        return [check for check in self.against_itself if check.split == split]

    def total(self, split: str) -> tuple[int, int]:
        """(changed, compared) of one split over both sides."""
        checks = self.split(split)
        return sum(c.changed for c in checks), sum(c.compared for c in checks)


@dataclass(frozen=True)
class PlanCheck:
    """The plan checked after the fact (compare --pilot): the between-run standard deviation the plan assumed (the
    planner's, from the pilot), each side's realised one, and the change the plan should see; when a side's runs
    differed more than assumed, the plan that would see that change with the larger spread ((runs, repetitions); None:
    no plan of up to planner.MAX_PLAN_RUNS runs does)."""

    pilot: str
    assumed: float
    realised: tuple[float | None, float | None]
    target: float  # a fraction: 0.15 is 15 %
    exceeded: bool
    plan: tuple[int, int] | None = None
    plan_seconds: float | None = None


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
    # Both sides of several runs (replicated.apply_replicates): the intervals and aggregates from the variance
    # between runs, the power, the built-in A/A check; None: one run on a side, the calibrated drift kept.
    replicated: Replicated | None = None

    @property
    def combinations(self) -> list[Row]:
        """The matched combinations the aggregates and the gate read: every row but the collapsed ones."""
        return [row for row in self.rows if not row.collapsed]

    def unoptimised_sides(self) -> list[tuple[RunFile, str]]:
        """The sides whose times are not their machine's (comparability.unoptimised: a Debug build), with why."""
        return [(run_file, reason) for run_file, reason in ((f, unoptimised(f)) for f in (self.baseline,
                                                                                          self.contender)) if reason]

    @property
    def withheld(self) -> bool:
        """No aggregate verdict: a side's times are the build's, not its machine's (unoptimised_sides)."""
        return bool(self.unoptimised_sides())

    @property
    def geometric_mean(self) -> float | None:
        if self.withheld:
            return None
        return statistics.geometric_mean([row.beyond_pace_ratio() for row in self.combinations])

    def aggregates(self) -> list[Aggregate]:
        """The geometric mean of B/A with its interval and verdict: over every matched combination ("all"),
        then per primitive, thread count and placement (AGGREGATE_SEGMENTS), each group in its name's order. None
        when withheld: a Debug build's times would read as its machine's."""
        if self.withheld:
            return []
        if self.replicated is not None:
            return self.replicated.aggregates
        groups = aggregate_groups(self.combinations)
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
        """The summary's count: what changed beyond the pace (pace-aware where available, else raw)."""
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
