"""Reading lockstep's result files: every JSON file through read_document, once.

The kinds of file that reach the tools:
  run      Google Benchmark JSON (1.7 and later) written by `lockstep run`
  mpi      `lockstep mpi --out`   {"kind": "mpi", ...}: benchmark entries in the same shape
  c2c      `lockstep c2c --out`   {"kind": "c2c", ...}
  delay    `lockstep delay --out` {"kind": "delay", ...}
  verify   `lockstep verify --csv` (header t,x1,x2)
and, for compare's machine fingerprint only, the context of `lockstep falseshare`, `migrate` and `verify --out`.

read_document checks a JSON file against its kind's schema (docs/schemas/<kind>.schema.json, through
schemas.py) before anything reads it: the types, what is required, the ranges that need no other field. What
a schema cannot express is checked here as the file is read: an entry appears once, the repetitions of one
benchmark carry the same counters, a histogram adds up to its wake-ups, a mode names one of the trace's, a
time in a unit lies within fields.SHORTEST_NS..LONGEST_NS. A key no schema names is ignored, whatever it holds.

NaN and Infinity: Google Benchmark writes them for a value it could not
compute, so in a benchmark entry's time or counter they make that one value
unavailable (never zero, never a number in a table) and the file's warnings
count what was left out. Anywhere else a value that is not a finite number
is a damaged file.

A file that is unreadable, truncated, of another kind, or holds a value that
cannot be right raises InputError, whose text is one line naming the file,
the place in it and the problem; the command line turns it into exit status 2.
"""
from __future__ import annotations

import csv
import io
import json
import math
import os
from collections import Counter
from dataclasses import dataclass, field

from . import fields, schemas, statistics
from .names import BenchmarkKey, parse_name
from .schemas import json_kind, shown as _shown  # noqa: F401 (json_kind: the fuzz test names kinds by it)


class InputError(Exception):
    """A file the tools cannot use. str() is one line: '<file>: <problem>'."""

    def __init__(self, path: str, problem: str):
        super().__init__(f"{path}: {' '.join(problem.split())}")
        self.path = path
        self.problem = problem


# ---------------------------------------------------------------- what the schema cannot say

class _Object:
    """One JSON object of a file that its kind's schema has checked (read_document): what is left to check is
    what a schema cannot express (a range that depends on the unit, NaN in a benchmark entry). `where` names
    it in an error ("benchmark entry 3 ('rk4/serial')")."""

    def __init__(self, path: str, value: dict, where: str):
        self.path, self.value, self.where = path, value, where

    def fail(self, key: str, problem: str):
        raise InputError(self.path, f"{self.where}: {key} {problem}" if self.where else f"{key} {problem}")

    def _get(self, key: str, required: bool, nullable: bool = False):
        if key not in self.value:
            if required:
                self.fail(key, "is missing")
            return None
        value = self.value[key]
        if value is None and not nullable:
            self.fail(key, "is null")
        return value

    def number(self, key: str, low: float, high: float, required: bool = True, nullable: bool = False,
               unit: str = "", non_finite: bool = False) -> float | None:
        """A number in [low, high]; NaN or an infinity is returned as it is when `non_finite` (the caller
        counts it as unavailable), else it is an error."""
        value = self._get(key, required, nullable)
        if value is None:
            return None
        return _checked_number(self, key, value, low, high, unit, non_finite)


def _checked_number(owner: _Object, key: str, value, low: float, high: float, unit: str = "",
                    non_finite: bool = False, scale: float = 1.0) -> float:
    """value * scale, checked to lie in [low, high] (given in the unit of the product)."""
    if isinstance(value, int) and abs(value) > high / scale:  # before float(): an int may exceed the floats
        owner.fail(key, f"is {_shown(value)}, beyond any measured value (above {high:g}{unit})")
    if not math.isfinite(value):
        if non_finite:
            return float(value)
        owner.fail(key, f"is {_shown(value)}, not a finite number")
    number = float(value) * scale
    if number < low:
        why = (": a time is positive" if low > 0 else ": it cannot be negative" if low == 0
               else ", beyond any measured value")
        owner.fail(key, f"is {_shown(number)}{unit}, below {low:g}{unit}{why}")
    if number > high:
        owner.fail(key, f"is {_shown(number)}{unit}, beyond any measured value (above {high:g}{unit})")
    return number


# ---------------------------------------------------------------- files as text

def read_text(path: str) -> str:
    if os.path.isdir(path):
        raise InputError(path, "is a directory, not a result file")
    try:
        with open(path, "rb") as stream:
            raw = stream.read()
    except OSError as error:
        raise InputError(path, f"cannot read: {error.strerror or error}") from None
    if not raw.strip():
        raise InputError(path, "is empty (an interrupted run?)")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as error:
        raise InputError(path, f"is not text (byte {error.start} is not UTF-8): not a lockstep result "
                               "file") from None


def parse_json(path: str, text: str):
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        if error.pos >= len(text.rstrip()) - 1:
            raise InputError(path, f"truncated: the JSON ends at byte {len(text)} before it closes "
                                   "(an interrupted or still-running run?)") from None
        raise InputError(path, f"not valid JSON at line {error.lineno} column {error.colno} "
                               f"({error.msg})") from None
    except RecursionError:
        raise InputError(path, "not a lockstep result file: its JSON nests too deeply to read") from None
    except ValueError as error:  # e.g. an integer longer than Python converts
        raise InputError(path, f"not a lockstep result file: {error}") from None


# ---------------------------------------------------------------- run files (Google Benchmark JSON)

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


@dataclass
class Run:
    """Everything one file says about one benchmark (its repetitions and the aggregates the tools read)."""

    key: BenchmarkKey
    names: list[str] = field(default_factory=list)  # names as written in the file
    repetitions: list[Repetition] = field(default_factory=list)
    aggregates: dict[str, Repetition] = field(default_factory=dict)  # fields.READ_AGGREGATES
    errors: list[str] = field(default_factory=list)
    unavailable: Counter = field(default_factory=Counter)  # what was NaN or infinite -> how many values

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


def _best_other_group(pair: PacePair) -> tuple:
    """Which "each primitive against the best other" group a pair belongs to: its kind of entry (an RK4 step,
    a bare episode), model, placement and thread count, read from its numerator's name."""
    key = pair.a_key
    return key.family, key.get("model") or "", key.get("pin") or "", key.threads or 0


def against_best_other_views(pairs: list[PacePair]) -> list[PacePair]:
    """Every primitive's line of "each primitive against the best other", group by group in the file's order.

    Since lockstep run measures each unordered comparison once (docs/pace.md), a group's leader (its fastest
    primitive by median) has no pair of its own: every pair of the group has the leader as its denominator,
    and the leader's line is its pair with the runner-up read the other way round (PacePair.inverse), put
    first. The runner-up's pair is the group's first in the file (lockstep run writes them in its plan's
    order, the runner-up first: bench/run/paired_blocks.hpp). A file written before that, where every
    primitive has a pair of its own, leader included, gives its pairs as they are."""
    groups: dict[tuple, list[PacePair]] = {}
    for pair in pairs:
        if pair.comparison == "against_best_other":
            groups.setdefault(_best_other_group(pair), []).append(pair)
    views = []
    for members in groups.values():
        leaders = {pair.b_key for pair in members}
        leader = next(iter(leaders))
        if len(leaders) == 1 and all(pair.a_key != leader for pair in members):
            views.append(members[0].inverse())
        views += members
    return views


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
    headline: Headline | None = None  # None: written before lockstep_headline
    mpi: "MpiDetails | None" = None  # a `lockstep mpi` file's exchanges and settings; None: another kind

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
        return self.headline.collapsed_keys if self.headline else frozenset()


def _read_context(path: str, label: str, raw: dict) -> tuple[dict, list[str]]:
    """The fingerprint keys of a context the schema has checked. A key of another kind's context (date in a
    c2c file) is read when it holds what it holds in its own kind, else ignored as any unknown key."""
    values = {}
    for key in fields.FINGERPRINT_KEYS:
        value = raw.get(key)
        if key in fields.CONTEXT_INTEGERS and isinstance(value, (int, float)) and not isinstance(value, bool):
            values[key] = int(value)
        elif key not in fields.CONTEXT_INTEGERS and isinstance(value, str):
            values[key] = value
    for key in fields.CALIBRATION_CONTEXT:
        if key in values and values[key] != fields.UNAVAILABLE:
            try:
                number = float(values[key])
            except ValueError:
                raise InputError(path, f"context.{key}: is {_shown(values[key])}: neither a number of ns nor "
                                       f"{fields.UNAVAILABLE!r}") from None
            if not fields.SHORTEST_NS <= number <= fields.LONGEST_NS:  # NaN fails this too
                raise InputError(path, f"context.{key}: is {_shown(values[key])}: not a measured time in ns")

    warnings = []
    schema = raw.get("json_schema_version")
    if isinstance(schema, int) and schema > fields.KNOWN_GB_JSON_SCHEMA:
        warnings.append(f"{label}: Google Benchmark JSON schema {schema} is newer than this tool knows "
                        f"({fields.KNOWN_GB_JSON_SCHEMA}); reading the fields it knows")
    lockstep_schema = values.get("lockstep_schema")
    if lockstep_schema is None:
        warnings.append(f"{label}: no lockstep keys in the context (not written by `lockstep run`?): "
                        "no machine fingerprint or normalisation for it")
    elif int(lockstep_schema) > fields.KNOWN_LOCKSTEP_SCHEMA:
        warnings.append(f"{label}: lockstep result schema {lockstep_schema} is newer than this tool knows "
                        f"({fields.KNOWN_LOCKSTEP_SCHEMA}); reading the fields it knows")
    return values, warnings


def _measured_values(entry: _Object, run: Run, scale: float, least: float,
                     batch_times: bool = False) -> Repetition | None:
    """An entry's times (in ns: scale is its time unit's size) and read counters, checked; None when its
    time is NaN or infinite (counted in run.unavailable). `least`: the smallest time it may hold.
    `batch_times`: a file written before lockstep schema fields.PER_UNIT_TIMES_SCHEMA, whose real_time and
    cpu_time of an entry with a per-unit counter are per batch; its cpu_time is then rescaled per unit by the
    batch size the two say (real_time / the counter). From that schema on both are per unit already."""
    times = {key: _checked_number(entry, key, entry._get(key, required=True), least, fields.LONGEST_NS, " ns",
                                  non_finite=True, scale=scale)
             for key in ("real_time", "cpu_time")}
    counters = {}
    for name in fields.READ_COUNTERS:
        if name not in entry.value:
            continue
        if name in fields.DURATION_COUNTERS:
            low, high = fields.SHORTEST_NS, fields.LONGEST_NS
        elif name in fields.SIGNED_COUNTERS:
            low, high = -fields.LONGEST_NS, fields.LONGEST_NS
        else:
            low, high = 0.0, fields.LARGEST_AMOUNT
        counters[name] = entry.number(name, low, high, non_finite=True)
    unit_counter = next((name for name in fields.UNIT_COUNTERS if name in counters), None)
    real = counters[unit_counter] if unit_counter else times["real_time"]
    if batch_times and unit_counter and math.isfinite(times["real_time"]):
        times["cpu_time"] *= real / times["real_time"]
    if not (math.isfinite(real) and math.isfinite(times["cpu_time"])):
        run.unavailable["repetition time"] += 1
        return None
    finite = {}
    for name, value in counters.items():
        if math.isfinite(value):
            finite[name] = value
        else:
            run.unavailable[f"{name} value"] += 1
    return Repetition(real, times["cpu_time"], finite)


def _repetition_pace(entry: _Object, run: Run, trace: "PaceTrace | None") -> RepetitionPace | None:
    """The pace counters of one repetition (iteration row), checked; None when it carries none. They come
    together, only in a file with a pace trace, and a mode names one of its modes (or -1)."""
    present = [name for name in fields.PACE_COUNTERS if name in entry.value]
    if not present:
        return None
    if len(present) != len(fields.PACE_COUNTERS):
        missing = [name for name in fields.PACE_COUNTERS if name not in present]
        entry.fail(missing[0], f"is missing beside {', '.join(present)}: the pace counters come together")
    if trace is None:
        entry.fail(present[0], f"is there but the file has no {fields.PACE_KEY}: a repetition's pace names a "
                               "mode of the file's pace trace")
    values = {}
    for name in (fields.PACE_C2C_COUNTER, fields.PACE_SERIAL_COUNTER):
        value = entry.number(name, fields.SHORTEST_NS, fields.LONGEST_NS, unit=" ns", non_finite=True)
        if not math.isfinite(value):
            run.unavailable[f"{name} value"] += 1
            value = None
        values[name] = value
    mode = entry.number(fields.PACE_MODE_COUNTER, -fields.LARGEST_AMOUNT, fields.LARGEST_AMOUNT, non_finite=True)
    if not math.isfinite(mode):
        run.unavailable[f"{fields.PACE_MODE_COUNTER} value"] += 1
        mode = None
    elif not mode.is_integer() or not fields.OUTLIER_MODE <= mode < len(trace.modes):
        entry.fail(fields.PACE_MODE_COUNTER, f"is {_shown(mode)}, not one of the {len(trace.modes)} modes of "
                                             f"{fields.PACE_KEY} (0..{len(trace.modes) - 1}) or -1 (a change of "
                                             "pace during the repetition)")
    return RepetitionPace(values[fields.PACE_C2C_COUNTER], values[fields.PACE_SERIAL_COUNTER],
                          None if mode is None else int(mode))


def _fail(path: str, place: tuple, problem: str):
    """A problem the schema cannot express, at a place given as JSON path parts."""
    raise InputError(path, f"{schemas.json_path(place)}: {problem}")


def _read_pace(path: str, document: dict) -> PaceTrace | None:
    """The top-level "lockstep_pace" (its fields checked by the schema, what ties them together here); None
    when the file has none (an older file)."""
    if fields.PACE_KEY not in document:
        return None
    trace, at = document[fields.PACE_KEY], (fields.PACE_KEY,)
    cpus = trace["cpus"]
    if len(cpus) not in (0, 2) or len(set(cpus)) != len(cpus) or max(cpus, default=0) >= fields.CPU_LIMIT:
        _fail(path, at + ("cpus",), f"is {cpus}: the pinned pair of two different CPUs, or [] on a machine of one")

    modes = []
    for index, raw in enumerate(trace["modes"]):
        here = at + ("modes", index)
        if raw["mode"] != index:
            _fail(path, here + ("mode",), f"is {_shown(raw['mode'])}, not {index}: the modes are listed in the order "
                                          "of their index")
        c2c = raw["c2c_ns"]
        if modes and (c2c is None) != (modes[0].c2c_ns is None):
            _fail(path, here + ("c2c_ns",), "is null in some modes and a number in others: either the machine has a "
                                            "pair of CPUs to measure or it has not")
        if modes and c2c is not None and c2c < modes[-1].c2c_ns:
            _fail(path, here + ("c2c_ns",), f"is {c2c:g} ns, below the {modes[-1].c2c_ns:g} ns of the mode before: "
                                            "the modes are sorted fastest first")
        modes.append(PaceMode(index, c2c, raw["serial_ns"], raw["share"], int(raw["readings"])))
    if sum(mode.share for mode in modes) > 1.0 + fields.SHARE_SLACK:
        _fail(path, at + ("modes",), f"have shares adding up to {sum(mode.share for mode in modes):g}, more than "
                                     "the whole run")

    readings = []
    for index, raw in enumerate(trace["readings"]):
        here = at + ("readings", index)
        if readings and raw["t_s"] < readings[-1].t_s:
            _fail(path, here + ("t_s",), f"is {raw['t_s']:g} s, before the {readings[-1].t_s:g} s of the reading "
                                         "before: the readings are in time order")
        if raw["mode"] >= len(modes):
            _fail(path, here + ("mode",), f"is {_shown(raw['mode'])}, not one of the {len(modes)} modes (0.."
                                          f"{len(modes) - 1}) or -1")
        readings.append(PaceReading(raw["t_s"], raw["c2c_ns"], raw["serial_ns"], int(raw["mode"])))
    if trace["changes"] > len(readings) - 1:
        _fail(path, at + ("changes",), f"is {_shown(trace['changes'])}, more than the {len(readings)} readings "
                                       "can change")
    return PaceTrace(trace["reference"], tuple(cpus), tuple(readings), tuple(modes), int(trace["changes"]),
                     trace["summary"])


def _read_pairs(path: str, document: dict, trace: PaceTrace | None) -> list[PacePair]:
    """The top-level "lockstep_pairs" (checked by the schema but for what ties them to the entries and the
    trace); [] when the file has none (an older file)."""
    pairs, seen = [], {}
    highest_mode = len(trace.modes) - 1 if trace else fields.OUTLIER_MODE
    for index, pair in enumerate(document.get(fields.PAIRS_KEY, [])):
        at = (fields.PAIRS_KEY, index)
        comparison = pair["comparison"]
        names = {}
        for side in ("a", "b"):
            key = parse_name(pair[side])
            if not key.family:
                _fail(path, at + (side,), f"is {_shown(pair[side])}: no benchmark family")
            names[side] = (pair[side], key)
        identity = (comparison, names["a"][1], names["b"][1])
        if identity in seen:
            _fail(path, at, f"repeats entry {seen[identity]} (the same {comparison} pair of {names['a'][0]} and "
                            f"{names['b'][0]}): a damaged or concatenated file")
        seen[identity] = index
        ratios, modes = tuple(pair["ratios"]), tuple(pair["modes"])
        if len(modes) != len(ratios):
            _fail(path, at + ("modes",), f"has {len(modes)} values for {len(ratios)} ratios: one mode per pair")
        for place, mode in enumerate(modes):
            if mode > highest_mode:
                where = (f"one of the {highest_mode + 1} modes of {fields.PACE_KEY} or -1" if trace
                         else f"-1: the file has no {fields.PACE_KEY}")
                _fail(path, at + ("modes", place), f"is {_shown(mode)}, not {where}")
        if pair["ci_low"] > pair["ci_high"]:
            _fail(path, at + ("ci_low",), f"is {pair['ci_low']:g}, above ci_high {pair['ci_high']:g}")
        pairs.append(PacePair(comparison, pair["group"], names["a"][0], names["b"][0], names["a"][1], names["b"][1],
                              ratios, tuple(int(mode) for mode in modes), pair["median"], pair["ci_low"],
                              pair["ci_high"], pair["confidence"], pair["noise"], pair["verdict"], pair["block_ms"]))
    return pairs


def _read_scaling(path: str, document: dict) -> ScalingCurve | None:
    """The top-level "lockstep_scaling"; None when the file has none. Each point holds the curve's counter."""
    if fields.SCALING_KEY not in document:
        return None
    curve = document[fields.SCALING_KEY]
    counter = curve["counter"]
    points = []
    for index, point in enumerate(curve["points"]):
        if counter not in point:
            _fail(path, (fields.SCALING_KEY, "points", index, counter), "is missing: the curve's counter")
        low, high = point.get("repetitions_min"), point.get("repetitions_max")
        points.append(ScalingPoint(point["sync"], int(point["threads"]), point["layout"], point["model"],
                                   point[counter], bool(point.get("oversubscribed")),
                                   (low, high) if low is not None and high is not None else None))
    return ScalingCurve(curve["pin"], counter, tuple(int(t) for t in curve["threads"]), tuple(points),
                        curve.get("best"), curve.get("c2c_one_way_ns"))


# ---------------------------------------------------------------- the run's answer

@dataclass(frozen=True)
class Recommendation:
    """One of lockstep_headline's recommendations: the combination to use at one model, thread count and
    placement, as lockstep run chose it (bench/run/headline.hpp)."""

    threads: int
    pin: str
    model: str  # "": the paper's two-mass system
    entry: str  # its entry's name, as written
    entry_key: BenchmarkKey
    sync: str
    layout: str
    ns_per_step: float
    basis: str  # fields.HEADLINE_BASES: "paired" (its pair with the runner-up decided) or "medians"


@dataclass(frozen=True)
class Headline:
    """The file's "lockstep_headline": the run's answer as its terminal printed it (lines, shown verbatim:
    the same fact reads the same everywhere), the recommendations, and the entries that collapsed
    (oversubscribed and at least 100 times the best of their kind and thread count: kept out of rankings,
    ratios and colour scales)."""

    lines: tuple[str, ...]
    recommendations: tuple[Recommendation, ...]
    collapsed: tuple[str, ...]  # entry names as written, each once
    collapsed_keys: frozenset


def _headline_text(path: str, place: tuple, value) -> str:
    if not isinstance(value, str):
        _fail(path, place, f"is {json_kind(value)}, not text")
    return value


def _headline_list(path: str, block: dict, key: str) -> list:
    if key not in block:
        _fail(path, (fields.HEADLINE_KEY, key), "is missing")
    if not isinstance(block[key], list):
        _fail(path, (fields.HEADLINE_KEY, key), f"is {json_kind(block[key])}, not a list")
    return block[key]


def _read_headline(path: str, document: dict) -> Headline | None:
    """The top-level "lockstep_headline"; None when the file has none (written before it). Read leniently (a
    key it does not name is ignored) but whole: what it reads is checked here, whatever the schema says."""
    if fields.HEADLINE_KEY not in document:
        return None
    block = document[fields.HEADLINE_KEY]
    at = (fields.HEADLINE_KEY,)
    if not isinstance(block, dict):
        _fail(path, at, f"is {json_kind(block)}, not an object")
    lines = tuple(_headline_text(path, at + ("lines", index), line)
                  for index, line in enumerate(_headline_list(path, block, "lines")))
    if not lines:
        _fail(path, at + ("lines",), "is empty: a run's answer has at least its first line")
    collapsed, keys = [], set()
    for index, name in enumerate(_headline_list(path, block, "collapsed")):
        key = parse_name(_headline_text(path, at + ("collapsed", index), name))
        if not key.family:
            _fail(path, at + ("collapsed", index), f"is {_shown(name)}: no benchmark family")
        if key not in keys:
            collapsed.append(name)
            keys.add(key)
    recommendations = []
    for index, raw in enumerate(_headline_list(path, block, "recommendations")):
        here = at + ("recommendations", index)
        if not isinstance(raw, dict):
            _fail(path, here, f"is {json_kind(raw)}, not an object")
        item = _Object(path, raw, schemas.json_path(here))
        texts = {}
        for key in ("pin", "model", "entry", "sync", "layout", "basis"):
            texts[key] = _headline_text(path, here + (key,), item._get(key, required=True))
        if texts["basis"] not in fields.HEADLINE_BASES:
            _fail(path, here + ("basis",), f"is {_shown(texts['basis'])}, not one of {', '.join(fields.HEADLINE_BASES)}")
        threads = item._get("threads", required=True)
        if not isinstance(threads, int) or isinstance(threads, bool) or not 1 <= threads <= fields.CPU_LIMIT:
            _fail(path, here + ("threads",), f"is {_shown(threads)}, not a thread count (a whole number from 1)")
        entry_key = parse_name(texts["entry"])
        if not entry_key.family:
            _fail(path, here + ("entry",), f"is {_shown(texts['entry'])}: no benchmark family")
        step = item.number("ns_per_step", 0.0, fields.LONGEST_NS, unit=" ns")
        recommendations.append(Recommendation(threads, texts["pin"], texts["model"], texts["entry"], entry_key,
                                              texts["sync"], texts["layout"], step, texts["basis"]))
    return Headline(lines, tuple(recommendations), tuple(collapsed), frozenset(keys))


# ---------------------------------------------------------------- mpi files

@dataclass(frozen=True)
class MpiExchange:
    """One exchange of a `lockstep mpi` file, its last round's details (the "exchanges" list)."""
    label: str      # "p2p", "shm_window/mailbox"
    name: str       # its benchmark name, mpi/exchange:.../ranks:R/hosts:H
    stage: dict     # per-stage latency, ns: min, p50, p99, p999, max
    skew: dict      # per-stage arrival skew, ns: the same keys
    transfer: dict  # latest departure - latest arrival, ns (files before it: empty)
    slowest_counts: tuple[int, ...]  # per rank: stages where it arrived last


@dataclass(frozen=True)
class MpiDetails:
    ranks: int
    hosts: int
    transport: str
    model: str
    exchanges: tuple[MpiExchange, ...]
    not_applicable: tuple[tuple[str, str], ...]


MPI_DISTRIBUTION_KEYS = ("min", "p50", "p99", "p999", "max")


def _read_mpi(path: str, document: dict) -> MpiDetails:
    settings = document["settings"]
    ranks, hosts = int(settings["ranks"]), int(settings["hosts"])
    exchanges, labels = [], {}
    for index, entry in enumerate(document["exchanges"]):
        exchange, sync = entry["exchange"], entry.get("sync") or ""
        # label and name: what `lockstep mpi` writes; a file that holds only exchange (and sync) gets them
        # as the writer makes them (bench/cli/mpi.cpp, exchange_name).
        label = entry.get("label") or (f"{exchange}/{sync}" if sync else exchange)
        name = entry.get("name") or (
            f"mpi/exchange:{exchange}" + (f"/sync:{sync}" if sync else "") + f"/ranks:{ranks}/hosts:{hosts}")
        if label in labels:
            _fail(path, ("exchanges", index, "label"), f"{_shown(label)} is also exchanges[{labels[label]}]'s: an "
                                                       "exchange appears once")
        labels[label] = index
        counts = entry["slowest_rank_counts"]
        if len(counts) != ranks:
            _fail(path, ("exchanges", index, "slowest_rank_counts"), f"holds {len(counts)} counts for {ranks} ranks "
                                                                     "(settings): one per rank")
        exchanges.append(MpiExchange(label, name, *(
            {statistic: entry[key][statistic] for statistic in MPI_DISTRIBUTION_KEYS} if key in entry else {}
            for key in ("stage_latency_ns", "skew_ns", "transfer_ns")), tuple(int(count) for count in counts)))
    reasons = tuple(sorted(document.get("not_applicable", {}).items()))
    return MpiDetails(ranks, hosts, settings["transport"], settings["model"], tuple(exchanges), reasons)


def run_file_from_document(path: str, label: str, document: dict) -> RunFile:
    """A `lockstep run` or `lockstep mpi` document that read_document has checked against its schema."""
    if document.get("kind") not in (None, "mpi"):
        raise InputError(path, f"is `lockstep {document['kind']}` output, not benchmark results: compare takes "
                               "the JSON of `lockstep run`")
    context_values, warnings = _read_context(path, label, document["context"])
    lockstep_schema = context_values.get("lockstep_schema")
    batch_times = lockstep_schema is not None and int(lockstep_schema) < fields.PER_UNIT_TIMES_SCHEMA
    pace = _read_pace(path, document)
    pairs = _read_pairs(path, document, pace)

    runs: dict[BenchmarkKey, Run] = {}
    seen: dict[tuple, int] = {}  # an entry's identity -> its index: each appears once
    first_repetition: dict[BenchmarkKey, tuple[int, frozenset]] = {}  # index, the read counters it carries
    first_read: dict[BenchmarkKey, tuple[int, frozenset]] = {}  # index, the per-unit counters it carries
    for index, raw in enumerate(document["benchmarks"]):
        name = raw["name"]
        entry = _Object(path, raw, f"benchmarks[{index}] ({_shown(name)})")
        aggregate = raw["aggregate_name"] if raw["run_type"] == "aggregate" else None
        base = raw.get("run_name") or (name[: -(len(aggregate) + 1)] if aggregate and name.endswith("_" + aggregate)
                                       else name)
        key = parse_name(base)
        if not key.family:
            entry.fail("name", "has no benchmark family")
        if aggregate is None:
            repetition_index = raw.get("repetition_index")
            identity = (key, "repetition", repetition_index if repetition_index is not None
                        else json.dumps(raw, sort_keys=True))
        else:
            identity = (key, "aggregate", aggregate)
        if identity in seen:
            what = f"aggregate {aggregate}" if aggregate else "repetition"
            raise InputError(path, f"{entry.where} repeats entry {seen[identity]} (the same {what} of the same "
                                   "benchmark): a damaged or concatenated file")
        seen[identity] = index

        run = runs.setdefault(key, Run(key=key))
        if base not in run.names:
            run.names.append(base)
        failure = None  # Google Benchmark 1.8 writes error_occurred + error_message, or skipped + skip_message
        for flag, message_key in (("error_occurred", "error_message"), ("skipped", "skip_message")):
            if raw.get(flag) and failure is None:
                failure = raw.get(message_key) or f"{flag.replace('_', ' ')} (message {fields.UNAVAILABLE})"
        if failure is not None:
            if failure not in run.errors:
                run.errors.append(failure)
                run.errors.sort()  # the file's order of entries is not part of the result
            continue
        scale = fields.TIME_UNIT_NS[raw["time_unit"]]
        if aggregate is not None and aggregate not in fields.READ_AGGREGATES:
            continue  # stddev, cv and other statistics: not read
        # The repetitions of one benchmark carry the same read counters (but fields.PER_REPETITION_COUNTERS,
        # which the writer may omit from one repetition), and every entry read (repetitions,
        # median, mean) the same per-unit counter: a counter missing from one of them is a damaged file,
        # and a time per batch read as a time per step would be off by the batch size.
        present = frozenset(name for name in fields.READ_COUNTERS if name in entry.value)
        if aggregate is None:
            paced = (present - frozenset(fields.PER_REPETITION_COUNTERS)) | frozenset(
                name for name in fields.PACE_COUNTERS if name in entry.value)
            _same_counters(entry, paced, first_repetition.setdefault(key, (index, paced)))
        units = present & frozenset(fields.UNIT_COUNTERS)
        _same_counters(entry, units, first_read.setdefault(key, (index, units)))
        # An aggregate's pace counters (a median of mode indices) mean nothing: only repetitions carry a pace.
        repetition_pace = _repetition_pace(entry, run, pace) if aggregate is None else None
        values = _measured_values(entry, run, scale, fields.SHORTEST_NS, batch_times)
        if values is None:
            continue
        if aggregate is not None:
            run.aggregates[aggregate] = values
        else:
            values.pace = repetition_pace
            run.repetitions.append(values)
    for key in sorted(runs, key=BenchmarkKey.sort_key):
        left_out = runs[key].unavailable
        if left_out:
            counts = ", ".join(f"{count} {what}(s)" for what, count in sorted(left_out.items()))
            warnings.append(f"{label}: {key.display}: NaN or infinite in the file, left out as {fields.UNAVAILABLE}: "
                            f"{counts}")
    return RunFile(path=path, label=label, context=context_values, runs=runs, warnings=warnings, pace=pace,
                   pairs=pairs, scaling=_read_scaling(path, document), headline=_read_headline(path, document),
                   mpi=_read_mpi(path, document) if document.get("kind") == "mpi" else None)


def _same_counters(entry: _Object, counters: frozenset, first: tuple[int, frozenset]) -> None:
    index, expected = first
    if counters != expected:
        missing, extra = sorted(expected - counters), sorted(counters - expected)
        problem = (f"lacks {', '.join(missing)}, which entry {index} of the same benchmark has" if missing
                   else f"has {', '.join(extra)}, which entry {index} of the same benchmark lacks")
        raise InputError(entry.path, f"{entry.where} {problem}: the entries of one benchmark carry the same "
                                     "counters")


# ---------------------------------------------------------------- one reading function for every kind

def read_document(path: str, text: str | None = None) -> tuple[str, object]:
    """(kind, document) of a lockstep JSON result file, checked against its kind's schema
    (docs/schemas/<kind>.schema.json, schemas.py) before anything reads it. A file without "kind" is a
    `lockstep run` file (Google Benchmark JSON). Every tool reads JSON results through this."""
    document = parse_json(path, read_text(path) if text is None else text)
    if not isinstance(document, dict):
        raise InputError(path, f"not Google Benchmark JSON: the top level is {json_kind(document)}, "
                               "not an object with \"context\" and \"benchmarks\"")
    if "kind" in document and document["kind"] is None:
        raise InputError(path, "kind is null: a lockstep result names its kind (a `lockstep run` file, Google "
                               "Benchmark's JSON, has no kind at all)")
    kind = "run" if document.get("kind") is None else document["kind"]
    if kind not in schemas.KINDS or kind == "run" and document.get("kind") is not None:
        raise InputError(path, f"unknown lockstep file kind {_shown(kind)}")
    if kind in ("run", "mpi"):
        benchmarks, context = document.get("benchmarks"), document.get("context")
        if not isinstance(benchmarks, list) or not isinstance(context, dict):
            missing = "\"benchmarks\" list" if not isinstance(benchmarks, list) else "\"context\" object"
            raise InputError(path, f"not Google Benchmark JSON (no {missing}): not a `lockstep {kind}` result file")
        if not benchmarks:
            raise InputError(path, "holds no benchmark entries (did the filter match nothing?)")
    problem = schemas.problem(document, kind)
    if problem is not None:
        raise InputError(path, problem)
    return kind, document


def load_run_file(path: str, label: str | None = None) -> RunFile:
    label = label or os.path.basename(path)
    return run_file_from_document(path, label, read_document(path)[1])


# The kinds of lockstep result that carry the machine context but no benchmark entries.
CONTEXT_ONLY_KINDS = ("c2c", "delay", "falseshare", "migrate", "verify")


@dataclass
class ContextFile:
    """A `lockstep c2c`, `delay`, `falseshare`, `migrate` or `verify` result as compare reads it: only its
    machine context (the same fingerprint every lockstep command writes), so that compare can say whether
    files of different kinds come from one machine."""
    path: str
    label: str
    kind: str
    context: dict
    warnings: list[str]


def load_for_compare(path: str, label: str | None = None) -> "RunFile | ContextFile":
    """A `lockstep run` or `lockstep mpi` file, or the context of another kind of lockstep result."""
    label = label or os.path.basename(path)
    kind, document = read_document(path)
    if kind in CONTEXT_ONLY_KINDS:
        context, warnings = _read_context(path, label, document["context"])
        return ContextFile(path=path, label=label, kind=kind, context=context, warnings=warnings)
    if kind not in ("run", "mpi"):
        raise InputError(path, f"is `lockstep {kind}` output: neither results nor a machine context to compare")
    return run_file_from_document(path, label, document)


# ---------------------------------------------------------------- c2c and delay files

@dataclass(frozen=True)
class C2cPair:
    a: int
    b: int
    method: str
    relation: str
    p50_ns: float | None  # None: no samples


@dataclass
class C2cFile:
    path: str
    label: str
    pairs: list[C2cPair]
    sampled: bool

    def methods(self) -> list[str]:
        """The measuring methods present (`lockstep c2c --method both` writes cas and store_load pairs)."""
        return sorted({pair.method for pair in self.pairs})


@dataclass(frozen=True)
class Distribution:
    count: int | None
    statistics: dict[str, float | None]  # fields.DISTRIBUTION_STATISTICS -> ns, None when unavailable


@dataclass(frozen=True)
class Histogram:
    bucket_ns: float
    first_ns: float
    counts: list[int]


@dataclass(frozen=True)
class Figure5Row:
    thread: str
    role: str
    cross_core_csw: int | None
    total_csw: int
    pct: float | None


@dataclass(frozen=True)
class PacedRun:
    """One paced run of a delay file: the pinned one, or the unpinned one of `--compare-pinning`."""

    wakeup: Distribution
    completion: Distribution | None
    deadline_misses: int | None
    figure5: list[Figure5Row]


@dataclass(frozen=True)
class HistogramColumn:
    name: str
    cpu: int | None
    counts: list[int]  # counts[i]: wake-ups in [i, i + 1) buckets of bucket_us
    overflow: int  # wake-ups at bound_us or later


@dataclass(frozen=True)
class LatencyHistograms:
    """cyclictest's histogram (`latency_histogram`): 1 us buckets up to bound_us, a column per thread."""
    bucket_us: float
    bound_us: float
    columns: list[HistogramColumn]


@dataclass(frozen=True)
class CpuLatency:
    cpu: int | None
    wakeup: Distribution
    deadline_misses: int | None


@dataclass(frozen=True)
class PeriodTrial:
    period_ns: float
    periods: int
    misses: int
    miss_rate: float
    upper_bound: float | None
    holds: bool


@dataclass(frozen=True)
class PeriodSearch:
    """`lockstep delay --find-period`: the trials, the confirming run, and what the search found."""
    miss_rate: float
    confidence: float | None
    trials: list[PeriodTrial]
    confirm: PeriodTrial | None
    found_period_ns: float | None
    failed_period_ns: float | None
    budget_cut: bool
    stopped_because: str | None
    rule: str | None


@dataclass(frozen=True)
class DelayExtras:
    """What a delay file holds beside the paced runs: `latency_histogram`, `per_cpu` (--per-cpu),
    `find_period` (--find-period), `idle`, and the settings fields.DELAY_SETTINGS does not name."""
    histograms: LatencyHistograms | None = None
    per_cpu: list[CpuLatency] = field(default_factory=list)
    noisiest: tuple[int, str] | None = None  # (cpu, the rule that named it)
    search: PeriodSearch | None = None
    idle: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)


@dataclass
class DelayFile:
    path: str
    label: str
    settings: dict  # fields.DELAY_SETTINGS present in the file
    pinned: PacedRun
    unpinned: PacedRun | None
    histogram: Histogram  # of the pinned run's wake-ups
    extras: DelayExtras = field(default_factory=DelayExtras)


def _distribution(path: str, place: tuple, summary: dict, statistics=fields.DISTRIBUTION_STATISTICS,
                  time: bool = True) -> Distribution:
    """{min, p50, ..., count}: every statistic a number, or all null with count 0 (a file without count has
    samples). `time`: the statistics are durations, within fields.LONGEST_NS."""
    count = summary.get("count")
    values = {}
    for name in statistics:
        value = summary.get(name)
        if value is not None and count == 0:
            _fail(path, place + (name,), "is a number though count is 0")
        if value is None and count != 0:
            _fail(path, place + (name,), "is missing or null" + (f" though count is {count}" if count else ""))
        if value is not None and time and not 0.0 <= value <= fields.LONGEST_NS:
            _fail(path, place + (name,), f"is {_shown(value)} ns, not a measured time")
        values[name] = value
    known = [(name, values[name]) for name in statistics if values[name] is not None]
    for (low_name, low), (high_name, high) in zip(known, known[1:]):
        if low > high:
            _fail(path, place + (high_name,), f"is {high:g} ns, below {low_name} {low:g} ns: the statistics are out "
                                              "of order")
    return Distribution(None if count is None else int(count), values)


def _read_c2c(path: str, label: str, document: dict) -> C2cFile:
    pairs, seen = [], {}
    for index, pair in enumerate(document["pairs"]):
        a, b, method = pair["a"], pair["b"], pair["method"]
        if a == b:
            _fail(path, ("pairs", index, "b"), f"is {b}, the same CPU as a")
        identity = (min(a, b), max(a, b), method)
        if identity in seen:
            _fail(path, ("pairs", index), f"repeats pairs[{seen[identity]}] (CPUs {a} and {b}, method {method})")
        seen[identity] = index
        p50 = _distribution(path, ("pairs", index, "one_way_ns"), pair["one_way_ns"], ("p50",)).statistics["p50"]
        if p50 is not None and p50 < fields.SHORTEST_NS:
            _fail(path, ("pairs", index, "one_way_ns", "p50"), f"is {p50:g} ns: a time is positive")
        pairs.append(C2cPair(int(a), int(b), method, pair["relation"], p50))
    return C2cFile(path=path, label=label, pairs=pairs, sampled=bool(document.get("sampled")))


def _figure5(path: str, document: dict, key: str) -> list[Figure5Row]:
    rows, threads = [], {}
    for index, row in enumerate(document[key]):
        thread = row["thread"]
        if thread in threads:
            _fail(path, (key, index, "thread"), f"repeats the thread {thread!r} of {key}[{threads[thread]}]")
        threads[thread] = index
        cross, total = row["cross_core_csw"], row["total_csw"]
        if cross is not None and cross > total:
            _fail(path, (key, index, "cross_core_csw"), f"is {_shown(cross)}, more than total_csw {_shown(total)}")
        rows.append(Figure5Row(thread, row["role"], None if cross is None else int(cross), int(total), row["pct"]))
    return rows


def _settings(document: dict) -> dict:
    """The settings fields.DELAY_SETTINGS names that the file holds (null only where it means something:
    fifo_priority null is SCHED_OTHER; duration_s null a run of no fixed length, not shown)."""
    settings = document.get("settings", {})
    values = {}
    for key, kind in fields.DELAY_SETTINGS:
        value = settings.get(key)
        if kind == "duration" and isinstance(value, float) and value.is_integer():
            value = int(value)
        if value is not None or (kind == "priority" and key in settings):
            values[key] = value
    return values


def _paced_run(path: str, summaries: dict, document: dict, figure5_key: str, place: tuple) -> PacedRun:
    completion = summaries.get("completion_ns")
    return PacedRun(wakeup=_distribution(path, place + ("wakeup_latency_ns",), summaries["wakeup_latency_ns"]),
                    completion=(_distribution(path, place + ("completion_ns",), completion)
                                if completion is not None else None),
                    deadline_misses=summaries.get("deadline_misses"),
                    figure5=_figure5(path, document, figure5_key))


def _trial(raw: dict) -> PeriodTrial:
    return PeriodTrial(period_ns=raw["period_ns"], periods=int(raw["periods"]), misses=int(raw["misses"]),
                       miss_rate=raw["miss_rate"], upper_bound=raw.get("upper_bound"), holds=bool(raw.get("holds")))


def _delay_extras(path: str, document: dict) -> DelayExtras:
    histograms = None
    raw = document.get("latency_histogram")
    if raw is not None:
        bucket, bound = raw["bucket_us"], raw["bound_us"]
        columns = []
        for index, column in enumerate(raw["columns"]):
            counts = column["counts"]
            if abs(len(counts) * bucket - bound) > bucket:
                _fail(path, ("latency_histogram", "columns", index, "counts"),
                      f"has {len(counts)} buckets of {bucket:g} us, not the {bound:g} us of bound_us")
            columns.append(HistogramColumn(column["name"], column.get("cpu"), counts, column.get("overflow") or 0))
        histograms = LatencyHistograms(bucket, bound, columns)
    per_cpu, noisiest = [], None
    raw = document.get("per_cpu")
    if raw is not None:
        for index, row in enumerate(raw["cpus"]):
            per_cpu.append(CpuLatency(row["cpu"], _distribution(path, ("per_cpu", "cpus", index, "wakeup_latency_ns"),
                                                                row["wakeup_latency_ns"]),
                                      row.get("deadline_misses")))
        worst = raw.get("noisiest")
        if worst is not None:
            noisiest = (worst["cpu"], worst.get("rule") or "")
    search = None
    raw = document.get("find_period")
    if raw is not None:
        for index, trial in enumerate(raw["trials"] + ([raw["confirm"]] if raw.get("confirm") else [])):
            if trial["misses"] > trial["periods"]:
                place = ("find_period", "trials", index) if index < len(raw["trials"]) else ("find_period", "confirm")
                _fail(path, place + ("misses",), f"is {_shown(trial['misses'])}, more than its "
                                                 f"{_shown(trial['periods'])} periods")
        search = PeriodSearch(
            miss_rate=raw["miss_rate"], confidence=raw.get("confidence"),
            trials=[_trial(trial) for trial in raw["trials"]],
            confirm=_trial(raw["confirm"]) if raw.get("confirm") is not None else None,
            found_period_ns=raw.get("found_period_ns"), failed_period_ns=raw.get("failed_period_ns"),
            budget_cut=bool(raw.get("budget_cut")), stopped_because=raw.get("stopped_because"), rule=raw.get("rule"))
    idle = {}
    raw = document.get("idle")
    if raw is not None:
        idle = {"requested_us": raw.get("requested_us"), "held": bool(raw.get("held")),
                "in_force_us": raw.get("in_force_us")}
        for key in ("path", "problem", "cpuidle_driver", "cpuidle_governor", "clocksource"):
            if raw.get(key) is not None:
                idle[key] = raw[key]
    settings = {}
    raw = document.get("settings", {})
    for key in ("per_cpu", "compare_pinning"):
        if key in raw:
            settings[key] = raw[key]
    for key in ("dma_latency_us", "histogram_bound_us", "stop_above_ns"):
        if raw.get(key) is not None:
            settings[key] = raw[key]
    if raw.get("view"):
        settings["view"] = raw["view"]
    return DelayExtras(histograms, per_cpu, noisiest, search, idle, settings)


def _read_delay(path: str, label: str, document: dict) -> DelayFile:
    pinned = _paced_run(path, document, document, "figure5", ())
    wakeup = pinned.wakeup
    histogram = document["histogram"]
    counts = histogram["counts"]
    below, above = (histogram.get(key) or 0 for key in ("below", "above"))
    if sum(counts) + below + above != wakeup.count:
        _fail(path, ("histogram", "counts"), f"add up to {sum(counts) + below + above} (with below and above), not "
                                             f"to the {wakeup.count} wake-ups of wakeup_latency_ns: a damaged file")
    bucket = histogram["bucket_ns"]
    first = histogram.get("first_ns") or 0.0
    # `lockstep delay` sizes the histogram to its samples (platform/stats.hpp, histogram::covering): when it
    # holds every wake-up, the shortest falls in the first bucket and the longest in the last, so a bucket
    # too many or too few (an empty one included) is a damaged file, not another histogram.
    if below == above == 0 and wakeup.count:
        shortest, longest = (math.floor(wakeup.statistics[name]) for name in ("min", "max"))
        if not (first <= shortest < first + bucket and first + bucket * (len(counts) - 1) <= longest
                < first + bucket * len(counts)):
            _fail(path, ("histogram", "counts"), f"has {len(counts)} buckets of {bucket:g} ns from {first:g} ns, "
                                                 f"which do not span the wake-ups from {shortest} to {longest} ns "
                                                 "bucket for bucket: a damaged file")
    unpinned = document.get("unpinned")
    return DelayFile(path=path, label=label, settings=_settings(document), pinned=pinned,
                     unpinned=(_paced_run(path, unpinned, document, "figure5_unpinned", ("unpinned",))
                               if unpinned is not None else None),
                     histogram=Histogram(bucket, first, counts), extras=_delay_extras(path, document))


# ---------------------------------------------------------------- verify trajectories

@dataclass
class VerifyFile:
    path: str
    label: str
    t: list[float]
    x1: list[float]
    x2: list[float]


def load_verify_csv(path: str, text: str, label: str) -> VerifyFile:
    if not text.endswith("\n"):
        raise InputError(path, "the last line is cut (no newline at the end): an interrupted `lockstep verify`?")
    try:
        rows = list(csv.reader(io.StringIO(text)))
    except csv.Error as error:
        raise InputError(path, f"not a CSV trajectory: {error}") from None
    header = [cell.strip() for cell in rows[0]] if rows else []
    if tuple(header[:3]) != fields.VERIFY_HEADER:
        raise InputError(path, f"a CSV whose header is {','.join(header)!r}, not 't,x1,x2' "
                               "(`lockstep verify --csv` writes that)")
    t, x1, x2 = [], [], []
    for line_number, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        if len(row) < 3:
            raise InputError(path, f"line {line_number} has {len(row)} values, not 3 (truncated?)")
        try:
            values = [float(cell) for cell in row[:3]]
        except ValueError:
            raise InputError(path, f"line {line_number} is not three numbers: {_shown(','.join(row))}") from None
        if not all(math.isfinite(value) for value in values):
            raise InputError(path, f"line {line_number} holds a value that is not a finite number: "
                                   f"{_shown(','.join(row))}")
        if not 0.0 <= values[0] <= fields.LONGEST_NS / 1e9 or (t and values[0] <= t[-1]):
            raise InputError(path, f"line {line_number}: t = {values[0]:g} s does not follow the t before it "
                                   "(time runs forward from 0)")
        if max(abs(values[1]), abs(values[2])) > fields.LARGEST_DISPLACEMENT:
            raise InputError(path, f"line {line_number}: a displacement beyond {fields.LARGEST_DISPLACEMENT:g} "
                                   "is not this model's")
        t.append(values[0])
        x1.append(values[1])
        x2.append(values[2])
    if len(t) < 2:
        raise InputError(path, "a trajectory with fewer than two rows")
    return VerifyFile(path=path, label=label, t=t, x1=x1, x2=x2)


# ---------------------------------------------------------------- any file

def load_any(path: str, label: str | None = None):
    """Any of the five kinds (run and mpi results, c2c, delay, a verify trajectory), recognised by content
    (never by the file name)."""
    label = label or os.path.basename(path)
    text = read_text(path)
    if text.lstrip()[:1] not in ("{", "["):
        if text.lstrip().startswith("t,"):
            return load_verify_csv(path, text, label)
        raise InputError(path, "neither JSON nor a `lockstep verify --csv` trajectory")
    kind, document = read_document(path, text)
    if kind == "c2c":
        return _read_c2c(path, label, document)
    if kind == "delay":
        return _read_delay(path, label, document)
    if kind in ("run", "mpi"):
        return run_file_from_document(path, label, document)
    raise InputError(path, f"is `lockstep {kind}` output, which the report does not show (it takes run, mpi, c2c "
                           "and delay results, and verify --csv trajectories)")


def unique_labels(paths: list[str]) -> list[str]:
    """Short names for files: the base name, or more of the path where base names collide."""
    labels = [os.path.basename(p) for p in paths]
    if len(set(labels)) == len(labels):
        return labels
    return [os.path.normpath(p) for p in paths]
