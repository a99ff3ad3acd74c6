"""The parts of a run's answer that compare sets side by side across machines, as the run's file states them
(nothing here is recomputed): each recommendation's baseline (the primitive `lockstep run` sets against the
chosen one, paired) and whether it ran oversubscribed, the known-answer probes (false sharing, migration),
false sharing per access pattern, and the crossover (the model size from which a parallel step pays off), whose
series and points the report draws (report.crossover_section).

Their shapes are docs/schemas/run.schema.json's, checked with the rest of the file before they are read
(inputs.read_document), and what a schema cannot say (an interval in order, a measured speedup within its interval)
in run_checks.py: this module only builds them. A file without a part reads without it:
`lockstep_headline.false_sharing_patterns` (false sharing per access pattern) is written by `lockstep run` since
the probe measures each pattern (headline_json in bench/run/answer.cpp; tests/fixtures/run/quick-pairs.headline.json
is its output), the top-level `lockstep_crossover` by `lockstep run --crossover` (crossover_json in
bench/run/crossover.cpp; reports/tests/fixtures/crossover_a.json is its output). A crossover in the shape this
reader was written ahead of the writer for, {threads, pin, sync, masses, ci_low, ci_high}, still reads (its status,
layout and points empty). Their shapes are the ones below, in docs/schemas/run.schema.json and in reports/README.md
("compare", across machines).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..common import fields

HEADLINE = fields.HEADLINE_KEY
# In lockstep_headline: [{pattern, median, ci_low, ci_high, verdict}, with `words`, the pattern as the headline
# names it ("atomic read-modify-writes"), where lockstep run wrote them].
PATTERNS_KEY = "false_sharing_patterns"
PATTERN_WORDS = "words"
CROSSOVER_KEY = fields.CROSSOVER_KEY  # top level: {crossovers: [{threads, sync, masses, ci_low, ci_high, pin}]}
# What a crossover's status may say (docs/schemas/run.schema.json; bench/run/crossover.cpp, to_string): "" where
# the file has no status (written ahead of the writer, in the shape above).
CROSSOVER_STATUSES = ("crossed", "crossed_unconfirmed", "none_within_sweep", "always")


@dataclass(frozen=True)
class PairedRatio:
    """A ratio measured as a pair, with its interval and verdict (fields.PAIR_VERDICTS' words as the file wrote
    them): a recommendation's baseline (its step over the chosen one's; `name` the baseline's primitive), a
    false-sharing probe or pattern (an access's time on one shared line over its time on lines apart; `name` the
    pattern, in the headline's words where the file has them). median None: the file says it could not be
    measured."""

    name: str
    median: float | None
    ci_low: float | None
    ci_high: float | None
    verdict: str | None


@dataclass(frozen=True)
class Migration:
    """lockstep_headline.migration_probe: the medians of a forced move between two CPUs and of refilling the
    cache after it."""

    move_ns: float
    refill_ns: float
    cpus: str


@dataclass(frozen=True)
class CrossoverPoint:
    """One size of a crossover series (lockstep_crossover.crossovers[].points[]), as the run wrote it: the chain of
    `masses` masses, its serial step and the series' parallel step (medians of the pairs), the paired speedup
    serial / parallel with its interval and verdict, the pairs it stands on, and the model's step (serial / T +
    the stages' syncs; None: the file has none there) with the measured step over it. `failure` non-empty: no
    speedup was measured at this size, and why (its numbers are then the writer's zeros, never drawn)."""

    masses: int
    serial_ns: float
    parallel_ns: float
    speedup: float
    ci_low: float
    ci_high: float
    verdict: str | None
    pairs: int
    pairs_set_aside: int
    model_ns: float | None
    measured_over_model: float | None
    failure: str
    of_ceiling: float | None = None  # its speedup over the ceiling's at this size (None: not measured, or no ceiling)

    @property
    def measured(self) -> bool:
        """A speedup was measured here (bench/run/crossover.hpp, crossover_sweep_point::measured)."""
        return not self.failure and self.pairs > 0


@dataclass(frozen=True)
class CeilingPoint:
    """One size of the machine's ceiling (lockstep_crossover.ceilings[].points[]): the serial step paired with the
    chain's blocks stepped at once with no exchange and no sync (blocks_ns), the speedup serial / blocks with its
    interval; `failure` non-empty: not measured here."""

    masses: int
    serial_ns: float
    blocks_ns: float
    speedup: float
    ci_low: float
    ci_high: float
    pairs: int
    pairs_set_aside: int
    failure: str

    @property
    def measured(self) -> bool:
        return not self.failure and self.pairs > 0


@dataclass(frozen=True)
class Ceiling:
    """The machine's ceiling at one thread count and placement (bench/run/crossover.hpp, crossover_ceiling): the
    most an even split of the chain reaches there, per size."""

    threads: int
    pin: str
    points: tuple[CeilingPoint, ...] = ()
    quoted_masses: int | None = None  # the size the run's ceiling line quotes (None: nothing measured)

    def quoted(self) -> CeilingPoint | None:
        """The point the run's ceiling line quotes, as written."""
        return next((point for point in self.points if point.masses == self.quoted_masses and point.measured), None)


@dataclass(frozen=True)
class Crossover:
    """One crossover of lockstep_crossover: at this thread count (and placement, when the file gives one) and
    with this primitive, the model size (masses) from which the parallel step beats the serial one, with its
    interval; masses None: no crossover within what the run swept. Where the file has them (lockstep run writes
    them; a file in the earlier shape has none): the layout, whether the primitive is the run's leader, the
    status (CROSSOVER_STATUSES), the sizes that confirmed or contradicted it, why the series stopped, the
    measured sync of a stage the model uses, and every point in the order written."""

    threads: int
    pin: str
    sync: str
    masses: float | None
    ci_low: float | None
    ci_high: float | None
    layout: str = ""
    leader: bool = False
    status: str = ""
    confirmed_at: float | None = None
    contradicted_at: float | None = None
    stop_reason: str = ""
    stage_sync_ns: float | None = None
    points: tuple[CrossoverPoint, ...] = ()


@dataclass(frozen=True)
class CrossoverSweep:
    """The sweep as a whole (lockstep_crossover's top level, where the file has it): its budget and the time it
    spent in seconds, the pairs it asked per point, why it stopped (None: the file does not say), and its lines
    (the answer's crossover lines, as lockstep run wrote them)."""

    budget_s: float | None
    spent_s: float | None
    pairs_per_point: int | None
    stop_reason: str
    lines: tuple[str, ...]
    ceilings: tuple[Ceiling, ...] = ()  # none in a file written before the sweep measured them


@dataclass(frozen=True)
class RunAnswer:
    """What a run file's answer holds beyond Headline (run_file.py): per recommendation, in the headline's order,
    its baseline and whether it ran with more threads than CPUs (None: the file does not say); the probes, or
    why each was unavailable (None: the file says nothing); the false-sharing patterns; the crossovers."""

    baselines: tuple[PairedRatio | None, ...] = ()
    oversubscribed: tuple[bool | None, ...] = ()
    false_sharing: PairedRatio | None = None
    false_sharing_unavailable: str | None = None
    patterns: tuple[PairedRatio, ...] = ()
    migration: Migration | None = None
    migration_unavailable: str | None = None
    crossovers: tuple[Crossover, ...] = ()
    sweep: CrossoverSweep | None = None  # None: a file without lockstep_crossover


def _float(value) -> float | None:
    """A number the schema has checked, as the tools hold it (a float); None for null or missing."""
    return None if value is None else float(value)


def _paired(block: dict, name_key: str) -> PairedRatio:
    """{<name_key>, median, ci_low, ci_high, verdict}; a median of null: the file says it could not be measured."""
    return PairedRatio(block[name_key] if name_key else "", _float(block.get("median")), _float(block.get("ci_low")),
                       _float(block.get("ci_high")), block.get("verdict"))


def _pattern(block: dict) -> PairedRatio:
    """One access pattern's false sharing, named by its words where the file has them ("plain stores"), else by
    its `pattern`."""
    ratio = _paired(block, "pattern")
    words = block.get(PATTERN_WORDS)
    return PairedRatio(words, ratio.median, ratio.ci_low, ratio.ci_high, ratio.verdict) if words else ratio


def _migration(block: dict) -> Migration | None:
    raw = block.get("migration_probe")
    if raw is None:
        return None
    # refill_p50_ns: a difference of two medians (a move with the refill against one without), below 0 when the
    # refill added nothing measurable, as lockstep run then writes it.
    return Migration(float(raw["move_p50_ns"]), float(raw["refill_p50_ns"]), raw.get("cpus") or "")


def _point(raw: dict) -> CrossoverPoint:
    return CrossoverPoint(raw["masses"], float(raw["serial_ns"]), float(raw["parallel_ns"]), float(raw["speedup"]),
                          float(raw["ci_low"]), float(raw["ci_high"]), raw.get("verdict"), raw["pairs"],
                          raw["pairs_set_aside"], _float(raw.get("model_ns")), _float(raw.get("measured_over_model")),
                          raw.get("failure", ""), _float(raw.get("of_ceiling")))


def _ceiling(raw: dict) -> Ceiling:
    points = tuple(CeilingPoint(point["masses"], float(point["serial_ns"]), float(point["blocks_ns"]),
                                float(point["speedup"]), float(point["ci_low"]), float(point["ci_high"]),
                                point["pairs"], point["pairs_set_aside"], point["failure"])
                   for point in raw.get("points", []))
    return Ceiling(raw["threads"], raw["pin"], points, raw.get("quoted_masses"))


def _crossover(raw: dict) -> Crossover:
    return Crossover(raw["threads"], raw.get("pin") or "", raw["sync"], *(_float(raw.get(key)) for key in
                                                                         ("masses", "ci_low", "ci_high")),
                     layout=raw.get("layout") or "", leader=bool(raw.get("leader", False)),
                     status=raw.get("status") or "", confirmed_at=_float(raw.get("confirmed_at")),
                     contradicted_at=_float(raw.get("contradicted_at")), stop_reason=raw.get("stop_reason") or "",
                     stage_sync_ns=_float(raw.get("stage_sync_ns")),
                     points=tuple(_point(point) for point in raw.get("points", [])))


def _crossovers(document: dict) -> tuple[tuple[Crossover, ...], CrossoverSweep | None]:
    if CROSSOVER_KEY not in document:
        return (), None
    block = document[CROSSOVER_KEY]
    sweep = CrossoverSweep(_float(block.get("budget_s")), _float(block.get("spent_s")), block.get("pairs_per_point"),
                           block.get("stop_reason") or "", tuple(block.get("lines", [])),
                           tuple(_ceiling(raw) for raw in block.get("ceilings", [])))
    return tuple(_crossover(raw) for raw in block.get("crossovers", [])), sweep


def read_answer(document: dict) -> RunAnswer | None:
    """The answer's parts compare shows side by side; None for a file with neither lockstep_headline nor
    lockstep_crossover (written before them)."""
    if HEADLINE not in document and CROSSOVER_KEY not in document:
        return None
    crossovers, sweep = _crossovers(document)
    if HEADLINE not in document:
        return RunAnswer(crossovers=crossovers, sweep=sweep)
    block = document[HEADLINE]
    recommendations = block.get("recommendations", [])
    baselines = tuple(None if raw.get("baseline") is None else _paired(raw["baseline"], "sync")
                      for raw in recommendations)
    probe = block.get("false_sharing_probe")
    return RunAnswer(baselines, tuple(raw.get("oversubscribed") for raw in recommendations),
                     None if probe is None else _paired(probe, ""),
                     block.get("false_sharing_probe_unavailable") or None,
                     tuple(_pattern(raw) for raw in block.get(PATTERNS_KEY, [])), _migration(block),
                     block.get("migration_probe_unavailable") or None, crossovers, sweep)
