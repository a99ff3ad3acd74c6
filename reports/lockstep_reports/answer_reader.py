"""The parts of a run's answer that compare sets side by side across machines, as the run's file states them
(nothing here is recomputed): each recommendation's baseline (the primitive `lockstep run` sets against the
chosen one, paired) and whether it ran oversubscribed, the known-answer probes (false sharing, migration),
false sharing per access pattern, and the crossover (the model size from which a parallel step pays off).

Read leniently (a key not named here is ignored) but checked: what is read must hold what it says, else one line
naming its JSON path, as the headline's other parts (run_reader.py). A file without a part reads without it:
`lockstep_headline.false_sharing_patterns` (false sharing per access pattern) is written by `lockstep run` since
the probe measures each pattern (headline_json in bench/run/headline.cpp; tests/fixtures/run/quick-pairs.headline.json
is its output), the top-level `lockstep_crossover` by a later revision than the files in tests/fixtures; their
shapes are the ones below and in reports/README.md ("compare", across machines).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from . import fields
from .checks import fail
from .schemas import json_kind, shown

HEADLINE = fields.HEADLINE_KEY
# In lockstep_headline: [{pattern, median, ci_low, ci_high, verdict}, with `words`, the pattern as the headline
# names it ("atomic read-modify-writes"), where lockstep run wrote them].
PATTERNS_KEY = "false_sharing_patterns"
PATTERN_WORDS = "words"
CROSSOVER_KEY = "lockstep_crossover"  # top level: {crossovers: [{threads, sync, masses, ci_low, ci_high, pin}]}


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
class Crossover:
    """One crossover of lockstep_crossover: at this thread count (and placement, when the file gives one) and
    with this primitive, the model size (masses) from which the parallel step beats the serial one, with its
    interval; masses None: no crossover within what the run swept."""

    threads: int
    pin: str
    sync: str
    masses: float | None
    ci_low: float | None
    ci_high: float | None


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


def _crossovers(path: str, document: dict) -> tuple[Crossover, ...]:
    if CROSSOVER_KEY not in document:
        return ()
    block = _object(path, (CROSSOVER_KEY,), document[CROSSOVER_KEY])
    result = []
    for index, raw in enumerate(_list(path, (CROSSOVER_KEY, "crossovers"), block.get("crossovers", []))):
        here = (CROSSOVER_KEY, "crossovers", index)
        raw = _object(path, here, raw)
        threads = raw.get("threads")
        if not isinstance(threads, int) or isinstance(threads, bool) or not 1 <= threads <= fields.CPU_LIMIT:
            fail(path, here + ("threads",), f"is {shown(threads)}, not a thread count (a whole number from 1)")
        masses = [_number(path, here, raw, key, 1.0, fields.LARGEST_AMOUNT, nullable=True)
                  for key in ("masses", "ci_low", "ci_high")]
        result.append(Crossover(threads, _text(path, here, raw, "pin", required=False) or "",
                                _text(path, here, raw, "sync"), *masses))
    return tuple(result)


def read_answer(path: str, document: dict) -> RunAnswer | None:
    """The answer's parts compare shows side by side; None for a file with neither lockstep_headline nor
    lockstep_crossover (written before them)."""
    if HEADLINE not in document and CROSSOVER_KEY not in document:
        return None
    crossovers = _crossovers(path, document)
    if HEADLINE not in document:
        return RunAnswer(crossovers=crossovers)
    block = _object(path, (HEADLINE,), document[HEADLINE])
    baselines, oversubscribed = _recommendation_parts(path, block)
    probe = block.get("false_sharing_probe")
    patterns = tuple(_pattern(path, (HEADLINE, PATTERNS_KEY, index), raw)
                     for index, raw in enumerate(_list(path, (HEADLINE, PATTERNS_KEY),
                                                       block.get(PATTERNS_KEY, []))))
    return RunAnswer(baselines, oversubscribed,
                     None if probe is None else _paired(path, (HEADLINE, "false_sharing_probe"), probe, ""),
                     _reason(path, block, "false_sharing_probe_unavailable"), patterns, _migration(path, block),
                     _reason(path, block, "migration_probe_unavailable"), crossovers)
