"""The parts of a run's answer that compare sets side by side across machines, as the run's file states them
(nothing here is recomputed): each recommendation's baseline (the primitive `lockstep run` sets against the
chosen one, paired) and whether it ran oversubscribed, the known-answer probes (false sharing, migration),
false sharing per access pattern, and the crossover (the model size from which a parallel step pays off), whose
series and points the report draws (report.crossover_section).

Read leniently (a key not named here is ignored) but checked: what is read must hold what it says, else one line
naming its JSON path, as the headline's other parts (run_reader.py). A file without a part reads without it:
`lockstep_headline.false_sharing_patterns` (false sharing per access pattern) is written by `lockstep run` since
the probe measures each pattern (headline_json in bench/run/answer.cpp; tests/fixtures/run/quick-pairs.headline.json
is its output), the top-level `lockstep_crossover` by `lockstep run --crossover` (crossover_json in
bench/run/crossover.cpp; reports/tests/fixtures/crossover_a.json is its output). A crossover in the shape this
reader was written ahead of the writer for, {threads, pin, sync, masses, ci_low, ci_high}, still reads (its status,
layout and points empty). Their shapes are the ones below, in docs/schemas/run.schema.json and in reports/README.md
("compare", across machines).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..common import fields
from .checks import fail
from .schemas import json_kind, shown

HEADLINE = fields.HEADLINE_KEY
# In lockstep_headline: [{pattern, median, ci_low, ci_high, verdict}, with `words`, the pattern as the headline
# names it ("atomic read-modify-writes"), where lockstep run wrote them].
PATTERNS_KEY = "false_sharing_patterns"
PATTERN_WORDS = "words"
CROSSOVER_KEY = "lockstep_crossover"  # top level: {crossovers: [{threads, sync, masses, ci_low, ci_high, pin}]}
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


def _object(path: str, place: tuple, value) -> dict:
    if not isinstance(value, dict):
        fail(path, place, f"is {json_kind(value)}, not an object")
    return value


def _list(path: str, place: tuple, value) -> list:
    if not isinstance(value, list):
        fail(path, place, f"is {json_kind(value)}, not a list")
    return value


def _text(path: str, place: tuple, block: dict, key: str, required: bool = True) -> str | None:
    value = block.get(key)
    if value is None and not required:
        return None
    if not isinstance(value, str) or not value:
        fail(path, place + (key,), "is missing" if key not in block else f"is {shown(value)}, not text")
    return value


def _number(path: str, place: tuple, block: dict, key: str, low: float, high: float,
            nullable: bool = False) -> float | None:
    """A finite number in [low, high] (None where nullable and null or missing)."""
    value = block.get(key)
    if value is None and nullable:
        return None
    if key not in block:
        fail(path, place + (key,), "is missing")
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value) \
            or not low <= value <= high:
        fail(path, place + (key,), f"is {shown(value)}, not a number from {low:g} to {high:g}")
    return float(value)


def _paired(path: str, place: tuple, block, name_key: str, nullable: bool = False) -> PairedRatio:
    """{<name_key>, median, ci_low, ci_high, verdict}: the ratio and its interval positive, low <= median <= high."""
    block = _object(path, place, block)
    name = _text(path, place, block, name_key) if name_key else ""
    ratios = [_number(path, place, block, key, fields.SMALLEST_RATIO, fields.LARGEST_AMOUNT, nullable)
              for key in ("median", "ci_low", "ci_high")]
    median, low, high = ratios
    if None not in ratios and not low <= high:
        fail(path, place + ("ci_low",), f"is {low:g}, above ci_high {high:g}")
    verdict = _text(path, place, block, "verdict", required=median is not None)
    return PairedRatio(name, median, low, high, verdict)


def _pattern(path: str, place: tuple, block) -> PairedRatio:
    """One access pattern's false sharing, named by its words where the file has them ("plain stores"), else by
    its `pattern`."""
    ratio = _paired(path, place, block, "pattern")  # a pattern that could not be paired is left out, never null
    words = _text(path, place, block, PATTERN_WORDS, required=False)
    return PairedRatio(words, ratio.median, ratio.ci_low, ratio.ci_high, ratio.verdict) if words else ratio


def _reason(path: str, block: dict, key: str) -> str | None:
    """Why a probe was unavailable (its *_unavailable text), None when the file gives no reason."""
    value = block.get(key)
    if value is None or value == "":
        return None
    if not isinstance(value, str):
        fail(path, (HEADLINE, key), f"is {json_kind(value)}, not text")
    return value


def _recommendation_parts(path: str, block: dict) -> tuple[tuple, tuple]:
    """(baselines, oversubscribed), one each per recommendation in the headline's order."""
    baselines, oversubscribed = [], []
    for index, raw in enumerate(_list(path, (HEADLINE, "recommendations"), block.get("recommendations", []))):
        here = (HEADLINE, "recommendations", index)
        raw = _object(path, here, raw)
        baseline = raw.get("baseline")
        baselines.append(None if baseline is None else _paired(path, here + ("baseline",), baseline, "sync"))
        flag = raw.get("oversubscribed")
        if flag is not None and not isinstance(flag, bool):
            fail(path, here + ("oversubscribed",), f"is {json_kind(flag)}, not true or false")
        oversubscribed.append(flag)
    return tuple(baselines), tuple(oversubscribed)


def _migration(path: str, block: dict) -> Migration | None:
    raw = block.get("migration_probe")
    if raw is None:
        return None
    place = (HEADLINE, "migration_probe")
    raw = _object(path, place, raw)
    return Migration(_number(path, place, raw, "move_p50_ns", 0.0, fields.LONGEST_NS),
                     # A difference of two medians (a move with the refill against one without): below 0
                     # when the refill added nothing measurable, as lockstep run then writes it.
                     _number(path, place, raw, "refill_p50_ns", -fields.LONGEST_NS, fields.LONGEST_NS),
                     _text(path, place, raw, "cpus", required=False) or "")


def _line(path: str, place: tuple, value) -> str:
    if not isinstance(value, str) or not value:
        fail(path, place, f"is {shown(value)}, not a line of text")
    return value


def _whole(path: str, place: tuple, block: dict, key: str, low: int) -> int:
    value = block.get(key)
    if not isinstance(value, int) or isinstance(value, bool) or not low <= value <= fields.LARGEST_AMOUNT:
        fail(path, place + (key,), "is missing" if key not in block
             else f"is {shown(value)}, not a whole number from {low}")
    return value


def _flag(path: str, place: tuple, block: dict, key: str) -> bool:
    value = block.get(key, False)
    if not isinstance(value, bool):
        fail(path, place + (key,), f"is {json_kind(value)}, not true or false")
    return value


def _paired_parts(path: str, place: tuple, raw: dict, time_keys: tuple[str, str]) -> tuple[list, list, str]:
    """What a series point and a ceiling point share: their two times, the speedup with its interval, and why
    nothing was measured ("" when measured)."""
    times = [_number(path, place, raw, key, 0.0, fields.LONGEST_NS) for key in time_keys]
    ratios = [_number(path, place, raw, key, 0.0, fields.LARGEST_AMOUNT) for key in ("speedup", "ci_low", "ci_high")]
    failure = raw.get("failure", "")
    if not isinstance(failure, str):
        fail(path, place + ("failure",), f"is {json_kind(failure)}, not text")
    return times, ratios, failure


def _within_interval(path: str, place: tuple, point):
    """The point, once its speedup lies within its interval where it was measured."""
    if point.measured and not point.ci_low <= point.speedup <= point.ci_high:
        fail(path, place + ("speedup",), f"is {point.speedup:g}, outside its interval "
                                         f"[{point.ci_low:g}, {point.ci_high:g}]")
    return point


def _point(path: str, place: tuple, raw) -> CrossoverPoint:
    """One point of a series: every key the writer always writes is required (docs/schemas/run.schema.json)."""
    raw = _object(path, place, raw)
    times, ratios, failure = _paired_parts(path, place, raw, ("serial_ns", "parallel_ns"))
    model = [_number(path, place, raw, key, -fields.LONGEST_NS, fields.LONGEST_NS, nullable=True)
             for key in ("model_ns", "measured_over_model")]
    verdict = _text(path, place, raw, "verdict", required=False)
    if verdict is not None and verdict not in fields.PAIR_VERDICTS:
        fail(path, place + ("verdict",), f"is {shown(verdict)}, not one of {', '.join(fields.PAIR_VERDICTS)}")
    point = CrossoverPoint(_whole(path, place, raw, "masses", 1), *times, *ratios, verdict,
                           _whole(path, place, raw, "pairs", 0), _whole(path, place, raw, "pairs_set_aside", 0),
                           *model, failure,
                           _number(path, place, raw, "of_ceiling", 0.0, fields.LARGEST_AMOUNT, nullable=True))
    return _within_interval(path, place, point)


def _ceiling_point(path: str, place: tuple, raw) -> CeilingPoint:
    raw = _object(path, place, raw)
    times, ratios, failure = _paired_parts(path, place, raw, ("serial_ns", "blocks_ns"))
    return _within_interval(path, place, CeilingPoint(
        _whole(path, place, raw, "masses", 1), *times, *ratios, _whole(path, place, raw, "pairs", 0),
        _whole(path, place, raw, "pairs_set_aside", 0), failure))


def _ceiling(path: str, here: tuple, raw) -> Ceiling:
    raw = _object(path, here, raw)
    quoted = raw.get("quoted_masses")
    return Ceiling(_whole(path, here, raw, "threads", 1), _text(path, here, raw, "pin"),
                   tuple(_ceiling_point(path, here + ("points", index), point)
                         for index, point in enumerate(_list(path, here + ("points",), raw.get("points", [])))),
                   None if quoted is None else _whole(path, here, raw, "quoted_masses", 1))


def _crossover(path: str, here: tuple, raw) -> Crossover:
    raw = _object(path, here, raw)
    threads = raw.get("threads")
    if not isinstance(threads, int) or isinstance(threads, bool) or not 1 <= threads <= fields.CPU_LIMIT:
        fail(path, here + ("threads",), f"is {shown(threads)}, not a thread count (a whole number from 1)")
    masses = [_number(path, here, raw, key, 1.0, fields.LARGEST_AMOUNT, nullable=True)
              for key in ("masses", "ci_low", "ci_high", "confirmed_at", "contradicted_at")]
    status = _text(path, here, raw, "status", required=False) or ""
    if status and status not in CROSSOVER_STATUSES:
        fail(path, here + ("status",), f"is {shown(status)}, not one of {', '.join(CROSSOVER_STATUSES)}")
    points = tuple(_point(path, here + ("points", index), point)
                   for index, point in enumerate(_list(path, here + ("points",), raw.get("points", []))))
    return Crossover(threads, _text(path, here, raw, "pin", required=False) or "", _text(path, here, raw, "sync"),
                     *masses[:3], layout=_text(path, here, raw, "layout", required=False) or "",
                     leader=_flag(path, here, raw, "leader"), status=status, confirmed_at=masses[3],
                     contradicted_at=masses[4], stop_reason=_text(path, here, raw, "stop_reason", required=False) or "",
                     stage_sync_ns=_number(path, here, raw, "stage_sync_ns", -fields.LONGEST_NS, fields.LONGEST_NS,
                                           nullable=True),
                     points=points)


def _crossovers(path: str, document: dict) -> tuple[tuple[Crossover, ...], CrossoverSweep | None]:
    if CROSSOVER_KEY not in document:
        return (), None
    block = _object(path, (CROSSOVER_KEY,), document[CROSSOVER_KEY])
    crossovers = tuple(_crossover(path, (CROSSOVER_KEY, "crossovers", index), raw)
                       for index, raw in enumerate(_list(path, (CROSSOVER_KEY, "crossovers"),
                                                         block.get("crossovers", []))))
    lines = tuple(_line(path, (CROSSOVER_KEY, "lines", index), line)
                  for index, line in enumerate(_list(path, (CROSSOVER_KEY, "lines"), block.get("lines", []))))
    pairs = block.get("pairs_per_point")
    sweep = CrossoverSweep(_number(path, (CROSSOVER_KEY,), block, "budget_s", 0.0, fields.LARGEST_AMOUNT, True),
                           _number(path, (CROSSOVER_KEY,), block, "spent_s", 0.0, fields.LARGEST_AMOUNT, True),
                           None if pairs is None else _whole(path, (CROSSOVER_KEY,), block, "pairs_per_point", 0),
                           _text(path, (CROSSOVER_KEY,), block, "stop_reason", required=False) or "", lines,
                           tuple(_ceiling(path, (CROSSOVER_KEY, "ceilings", index), raw)
                                 for index, raw in enumerate(_list(path, (CROSSOVER_KEY, "ceilings"),
                                                                   block.get("ceilings", [])))))
    return crossovers, sweep


def read_answer(path: str, document: dict) -> RunAnswer | None:
    """The answer's parts compare shows side by side; None for a file with neither lockstep_headline nor
    lockstep_crossover (written before them)."""
    if HEADLINE not in document and CROSSOVER_KEY not in document:
        return None
    crossovers, sweep = _crossovers(path, document)
    if HEADLINE not in document:
        return RunAnswer(crossovers=crossovers, sweep=sweep)
    block = _object(path, (HEADLINE,), document[HEADLINE])
    baselines, oversubscribed = _recommendation_parts(path, block)
    probe = block.get("false_sharing_probe")
    patterns = tuple(_pattern(path, (HEADLINE, PATTERNS_KEY, index), raw)
                     for index, raw in enumerate(_list(path, (HEADLINE, PATTERNS_KEY),
                                                       block.get(PATTERNS_KEY, []))))
    return RunAnswer(baselines, oversubscribed,
                     None if probe is None else _paired(path, (HEADLINE, "false_sharing_probe"), probe, ""),
                     _reason(path, block, "false_sharing_probe_unavailable"), patterns, _migration(path, block),
                     _reason(path, block, "migration_probe_unavailable"), crossovers, sweep)
