"""A `lockstep run` (or `lockstep mpi`) file as the tools hold it: its entries and their repetitions, the pace
trace, the paired ratios, the scaling curve, what the run derived, and the run's answer and crossover sweep
(run_answer.py); run_reader.py reads them."""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

from ..common import fields, statistics
from ..common.names import BenchmarkKey, EntrySpec
from .mpi_reader import MpiDetails
from .run_answer import Answer, CrossoverSweep


@dataclass(frozen=True)
class RepetitionPace:
    """The pace measured around one repetition (fields.PACE_COUNTERS): the mean of the readings before and
    after it. None where the file says NaN (unavailable: c2c on a machine of one CPU); mode is an index into
    the file's PaceTrace.modes, or fields.OUTLIER_MODE when the two readings disagree (a change of pace
    during the repetition)."""

    c2c_ns: float | None
    serial_ns: float | None
    mode: int | None

    @property
    def straddles(self) -> bool:
        return self.mode == fields.OUTLIER_MODE


@dataclass
class Repetition:
    """One measured value set: real_ns is the per-unit counter (fields.UNIT_COUNTERS) where the entry has
    one, else Google Benchmark's real_time; cpu_ns is its cpu_time; counters holds the read counters that
    are finite numbers; pace the pace around it (None in a file written before the pace trace)."""

    real_ns: float
    cpu_ns: float
    counters: dict[str, float]
    pace: RepetitionPace | None = None
    # Its split of the step (fields.STEP_SPLIT_COUNTERS: compute, waiting, release) beside its own step
    # (real_ns), where it carries all three (run_reader.step_split); None otherwise.
    split: tuple[float, ...] | None = None


@dataclass
class Run:
    """Everything one file says about one benchmark (its repetitions and the aggregates the tools read)."""

    key: BenchmarkKey
    # Its spec (kind, primitive, layout, placement, threads, model, what its time counts): the file's lockstep_entry,
    # or what its name implies in a file written before it; None for an entry of no `lockstep run` kind (`mpi`).
    entry: EntrySpec | None = None
    names: list[str] = field(default_factory=list)  # names as written in the file
    repetitions: list[Repetition] = field(default_factory=list)
    aggregates: dict[str, Repetition] = field(default_factory=dict)  # fields.READ_AGGREGATES
    errors: list[str] = field(default_factory=list)
    failed: int = 0  # its repetitions (iteration rows) that errored: each says why in errors
    unavailable: Counter = field(default_factory=Counter)  # what was NaN or infinite -> how many values
    # The split of a step (fields.STEP_SPLIT_COUNTERS, in their order) of each repetition that carries all three
    # parts as finite numbers; empty for an entry or a file without it (run_reader.step_split).
    step_splits: list[tuple[float, ...]] = field(default_factory=list)

    @property
    def errored(self) -> bool:
        return bool(self.errors)

    def times_ns(self, time_kind: str = "real") -> list[float]:
        """Per-repetition times: per unit (RK4 step, barrier episode) where the entry has the counter,
        else per Google Benchmark iteration; CPU time per iteration for time_kind "cpu"."""
        return [r.real_ns if time_kind == "real" else r.cpu_ns for r in self.repetitions]

    def aggregate_time_ns(self, aggregate: str, time_kind: str = "real") -> float | None:
        entry = self.aggregates.get(aggregate)
        if entry is None:
            return None
        return entry.real_ns if time_kind == "real" else entry.cpu_ns

    def counter_values(self, counter: str) -> list[float]:
        """The counter's value in each repetition that has it, else its median aggregate's."""
        values = [r.counters[counter] for r in self.repetitions if counter in r.counters]
        if not values and "median" in self.aggregates and counter in self.aggregates["median"].counters:
            values = [self.aggregates["median"].counters[counter]]
        return values


@dataclass(frozen=True)
class PaceReading:
    """One reference reading of the pace trace, taken between blocks of measurement."""

    t_s: float  # seconds since the run started
    c2c_ns: float | None  # one-way core-to-core latency on the pinned pair; None on a machine of one CPU
    serial_ns: float  # the serial RK4 step
    mode: int  # index into PaceTrace.modes, fields.OUTLIER_MODE for a reading that belongs to no mode


@dataclass(frozen=True)
class PaceMode:
    """One pace the machine ran at: the medians of its readings, and its share of the run's time."""

    mode: int
    c2c_ns: float | None
    serial_ns: float
    share: float  # 0..1
    readings: int


@dataclass(frozen=True)
class PaceTrace:
    """The file's "lockstep_pace": the reference, the readings in time order, the modes fastest first."""

    reference: str
    cpus: tuple[int, ...]  # the pinned pair of the c2c reading; () on a machine of one CPU
    readings: tuple[PaceReading, ...]
    modes: tuple[PaceMode, ...]
    changes: int
    summary: str


@dataclass(frozen=True)
class PacePair:
    """One entry of "lockstep_pairs": a ratio a/b measured as a pair, both sides in alternating short blocks,
    one ratio per adjacent pair of blocks."""

    comparison: str  # fields.PAIR_COMPARISONS
    group: str
    a: str  # the numerator entry's name, as written
    b: str
    a_key: BenchmarkKey
    b_key: BenchmarkKey
    ratios: tuple[float, ...]
    modes: tuple[int, ...]  # the pace mode of each pair, fields.OUTLIER_MODE when unknown
    median: float
    ci_low: float
    ci_high: float
    confidence: float
    noise: float  # a fraction: 0.05 is 5 %
    verdict: str  # fields.PAIR_VERDICTS
    block_ms: float
    inverted: bool = False  # the pair read the other way round (inverse): b / a

    def inverse(self) -> "PacePair":
        """The same comparison read the other way round, b / a: each ratio and the median inverted, the
        interval [1 / ci_high, 1 / ci_low], the verdict mirrored by statistics.inverse_verdict (penalty and
        gain swapped; within noise and unsure stay), not recomputed."""
        return PacePair(self.comparison, self.group, self.b, self.a, self.b_key, self.a_key,
                        tuple(1.0 / ratio for ratio in self.ratios), self.modes, 1.0 / self.median,
                        1.0 / self.ci_high, 1.0 / self.ci_low, self.confidence, self.noise,
                        statistics.inverse_verdict(self.verdict), self.block_ms, not self.inverted)


@dataclass(frozen=True)
class ScalingPoint:
    sync: str
    threads: int
    layout: str  # the best layout at this count
    model: str
    value_ns: float  # the curve's counter
    oversubscribed: bool
    range_ns: tuple[float, float] | None = None  # its min..max over repetitions (None: an earlier file)


@dataclass(frozen=True)
class ScalingCurve:
    """The file's "lockstep_scaling" (`lockstep run --scaling`), as the run computed it (bench/run/scaling.hpp)."""
    pin: str
    counter: str
    threads: tuple[int, ...]
    points: tuple[ScalingPoint, ...]
    best: str | None
    c2c_one_way_ns: float | None


# ---------------------------------------------------------------- what the run derived (derived_reader.py)

@dataclass(frozen=True)
class LayoutFacts:
    """One layout of the registry as the run's file states it (lockstep_layouts), or as words.LAYOUTS states it for
    a file written before: its kind ("shared": the participants write into one state; "private_copy": each
    computes from its own copy) and its writer isolation in bytes (0: writers share cache lines on purpose)."""

    name: str
    kind: str
    writer_isolation: int

    @property
    def shares_lines(self) -> bool:
        return self.kind == "shared" and self.writer_isolation == 0


@dataclass(frozen=True)
class PlannedPair:
    """One comparison the run planned (lockstep_planned_pairs), measured as a pair or not: lockstep_pairs holds
    the ones measured."""

    comparison: str  # fields.PAIR_COMPARISONS
    group: str
    a: str
    b: str
    a_key: BenchmarkKey
    b_key: BenchmarkKey


@dataclass(frozen=True)
class ModeMedians:
    """An entry whose repetitions ran in more than one pace mode, as the run grouped them (lockstep_pace's
    entry_medians): {mode: (median time per unit, repetitions)} and the repetitions that straddled a change."""

    key: BenchmarkKey
    medians: dict[int, tuple[float, int]]
    straddling: int


@dataclass(frozen=True)
class Ranking:
    """One group's ranking as the run wrote it (lockstep_rankings): its rk4 entries fastest first, each with its
    median step and its step over the serial step of its model (None: unavailable); collapsed entries out."""

    pin: str
    threads: int
    entries: tuple[tuple[BenchmarkKey, float, float | None], ...]


@dataclass(frozen=True)
class ModelConstants:
    """The model the run integrated, as the run states it (lockstep_model): C/m, the initial positions, the
    normal modes' angular frequencies (fast, slow), the paper's printed ones and the C/m they imply, and the
    derivative evaluations of one serial RK4 step."""

    c_over_m: float
    positions: tuple[float, ...]
    roots_rad_s: tuple[float, float]
    paper_roots_rad_s: tuple[float, float]
    paper_implied_c_over_m: float
    evaluations_per_step: int


@dataclass
class RunFile:
    path: str
    label: str
    context: dict  # the context keys the tools read (fields.FINGERPRINT_KEYS), checked
    runs: dict[BenchmarkKey, Run]
    warnings: list[str] = field(default_factory=list)
    pace: PaceTrace | None = None  # None: written before the pace trace
    pairs: list[PacePair] = field(default_factory=list)  # empty: no paired ratios in the file
    scaling: ScalingCurve | None = None  # None: not a --scaling run
    answer: Answer | None = None  # None: written before the run's answer (lockstep_answer, lockstep_headline)
    mpi: MpiDetails | None = None  # a `lockstep mpi` file's exchanges and settings; None: another kind
    # What the run derived and wrote (derived_reader.py); None: a file written before the writer gave it.
    layouts: tuple[LayoutFacts, ...] | None = None
    planned: tuple[PlannedPair, ...] | None = None
    mode_medians: dict[BenchmarkKey, ModeMedians] | None = None
    rankings: tuple[Ranking, ...] | None = None
    model: ModelConstants | None = None
    crossover: CrossoverSweep | None = None  # None: a file without lockstep_crossover (no --crossover)
    # A side of several runs (`lockstep run --runs K`, or files given together): the runs it merges, each as read;
    # empty for a single file (replicates.merged_side).
    replicates: tuple["RunFile", ...] = ()

    def context_number(self, key: str) -> float | None:
        """A numeric context value (lockstep writes them as text), or None when unavailable."""
        value = self.context.get(key)
        try:
            number = float(value)
        except (TypeError, ValueError):
            return None
        return number if math.isfinite(number) and number > 0 else None

    @property
    def collapsed(self) -> frozenset:
        """The entries (BenchmarkKey) the run found collapsed: out of every ranking, ratio and colour scale."""
        return self.answer.collapsed_keys if self.answer else frozenset()
