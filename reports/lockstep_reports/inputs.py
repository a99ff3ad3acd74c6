"""Reading lockstep's result files: every field the tools use is checked here, once.

Four kinds of file reach the tools:
  run      Google Benchmark JSON (1.7 and later) written by `lockstep run --json`
  c2c      `lockstep c2c --out`   {"kind": "c2c", ...}
  delay    `lockstep delay --out` {"kind": "delay", ...}
  verify   `lockstep verify --csv` (header t,x1,x2)

Each field the tools read (fields.py) is checked for its type and its range
as it is read: a time is a positive number of ns below about eleven days, a
count is a whole number of 0 or more, a name is text, an entry appears once,
the repetitions of one benchmark carry the same counters. The tools read
nothing else, and a field they do not read is ignored whatever it holds.

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

from . import fields
from .names import BenchmarkKey, parse_name


class InputError(Exception):
    """A file the tools cannot use. str() is one line: '<file>: <problem>'."""

    def __init__(self, path: str, problem: str):
        super().__init__(f"{path}: {' '.join(problem.split())}")
        self.path = path
        self.problem = problem


# ---------------------------------------------------------------- one JSON object, field by field

def json_kind(value) -> str:
    """A JSON value's type, as an error message names it."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, str):
        return "text"
    if isinstance(value, list):
        return "a list"
    return "an object"


def _shown(value) -> str:
    """A value as an error message quotes it: short, one line, numbers as JSON spells them."""
    if isinstance(value, float):
        if math.isnan(value):
            return "NaN"
        if math.isinf(value):
            return "Infinity" if value > 0 else "-Infinity"
        return f"{value:g}"
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value) if abs(value) < 10 ** 30 else "a number of more than 30 digits"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class _Object:
    """One JSON object of a file, read field by field. `where` names it in an error ("benchmark entry 3
    ('rk4/serial')"); every reader checks the type and the range of what it returns."""

    def __init__(self, path: str, value, where: str):
        if not isinstance(value, dict):
            raise InputError(path, f"{where} is {json_kind(value)}, not an object")
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

    def text(self, key: str, required: bool = True, empty: bool = True) -> str | None:
        value = self._get(key, required)
        if value is None:
            return None
        if not isinstance(value, str):
            self.fail(key, f"is {json_kind(value)}, not text")
        if not empty and not value.strip():
            self.fail(key, "is empty")
        return value

    def choice(self, key: str, choices) -> str:
        value = self.text(key)
        if value not in choices:
            self.fail(key, f"is {_shown(value)}, not one of {', '.join(choices)}")
        return value

    def flag(self, key: str) -> bool:
        """true/false; absent is false."""
        value = self._get(key, required=False)
        if value is not None and not isinstance(value, bool):
            self.fail(key, f"is {json_kind(value)}, not true/false")
        return bool(value)

    def integer(self, key: str, required: bool = True, nullable: bool = False, low: int = 0,
                high: float = fields.LARGEST_AMOUNT) -> int | None:
        value = self._get(key, required, nullable)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer() and low <= value <= high:
                return int(value)  # a writer that prints 3.0 for 3
            self.fail(key, f"is {_shown(value) if isinstance(value, float) else json_kind(value)}, "
                           f"not a whole number")
        if not low <= value <= high:
            self.fail(key, f"is {_shown(value)}, outside {low}..{_shown(high)}")
        return value

    def number(self, key: str, low: float, high: float, required: bool = True, nullable: bool = False,
               unit: str = "", non_finite: bool = False) -> float | None:
        """A number in [low, high]; NaN or an infinity is returned as it is when `non_finite` (the caller
        counts it as unavailable), else it is an error."""
        value = self._get(key, required, nullable)
        if value is None:
            return None
        return _checked_number(self, key, value, low, high, unit, non_finite)

    def object(self, key: str, required: bool = True, nullable: bool = False) -> "_Object | None":
        value = self._get(key, required, nullable)
        if value is None:
            return None
        return _Object(self.path, value, f"{self.where}: {key}" if self.where else key)

    def array(self, key: str, required: bool = True, nonempty: bool = True) -> list | None:
        value = self._get(key, required)
        if value is None:
            return None
        if not isinstance(value, list):
            self.fail(key, f"is {json_kind(value)}, not a list")
        if nonempty and not value:
            self.fail(key, "is an empty list")
        return value


def _checked_number(owner: _Object, key: str, value, low: float, high: float, unit: str = "",
                    non_finite: bool = False, scale: float = 1.0) -> float:
    """value * scale, checked to lie in [low, high] (given in the unit of the product)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        owner.fail(key, f"is {json_kind(value)}, not a number")
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
    """The file's "lockstep_scaling" (`lockstep run --scaling`), as the run computed it (bench/harness/scaling.hpp)."""
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
    mpi: "MpiDetails | None" = None  # a `lockstep mpi` file's exchanges and settings; None: another kind

    def context_number(self, key: str) -> float | None:
        """A numeric context value (lockstep writes them as text), or None when unavailable."""
        value = self.context.get(key)
        try:
            number = float(value)
        except (TypeError, ValueError):
            return None
        return number if math.isfinite(number) and number > 0 else None


def _read_context(path: str, label: str, raw) -> tuple[dict, list[str]]:
    context = _Object(path, raw, "the context")
    values = {}
    for key in fields.FINGERPRINT_KEYS:
        if key in fields.CONTEXT_INTEGERS:
            value = context.integer(key, required=False)
        else:
            value = context.text(key, required=False)
        if value is not None:
            values[key] = value
    for key in fields.CALIBRATION_CONTEXT:
        if key in values and values[key] != fields.UNAVAILABLE:
            try:
                number = float(values[key])
            except ValueError:
                context.fail(key, f"is {_shown(values[key])}: neither a number of ns nor "
                                  f"{fields.UNAVAILABLE!r}")
            if not fields.SHORTEST_NS <= number <= fields.LONGEST_NS:  # NaN fails this too
                context.fail(key, f"is {_shown(values[key])}: not a measured time in ns")

    warnings = []
    schema = context.integer("json_schema_version", required=False)
    if schema is not None and schema > fields.KNOWN_GB_JSON_SCHEMA:
        warnings.append(f"{label}: Google Benchmark JSON schema {schema} is newer than this tool knows "
                        f"({fields.KNOWN_GB_JSON_SCHEMA}); reading the fields it knows")
    lockstep_schema = values.get("lockstep_schema")
    if lockstep_schema is None:
        warnings.append(f"{label}: no lockstep keys in the context (not written by `lockstep run`?): "
                        "no machine fingerprint or normalisation for it")
    elif not lockstep_schema.isdigit():
        context.fail("lockstep_schema", f"is {_shown(lockstep_schema)}, not a whole number")
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


def _read_pace(path: str, document: dict) -> PaceTrace | None:
    """The top-level "lockstep_pace", checked field by field; None when the file has none (an older file)."""
    if fields.PACE_KEY not in document:
        return None
    trace = _Object(path, document[fields.PACE_KEY], fields.PACE_KEY)
    reference = trace.text("reference", empty=False)
    cpus = []
    for index, cpu in enumerate(trace.array("cpus", nonempty=False)):
        if isinstance(cpu, bool) or not isinstance(cpu, int) or not 0 <= cpu < fields.CPU_LIMIT:
            trace.fail("cpus", f"holds {_shown(cpu)} at {index}: a CPU number is a whole number of 0 or more")
        cpus.append(cpu)
    if len(cpus) not in (0, 2) or len(set(cpus)) != len(cpus):
        trace.fail("cpus", f"is {_shown(cpus)}: the pinned pair of two different CPUs, or [] on a machine of one")

    raw_modes = trace.array("modes")
    modes = []
    for index, raw in enumerate(raw_modes):
        mode = _Object(path, raw, f"{fields.PACE_KEY}: mode {index}")
        number = mode.integer("mode", high=fields.CPU_LIMIT)
        if number != index:
            mode.fail("mode", f"is {number}, not {index}: the modes are listed in the order of their index")
        c2c = mode.number("c2c_ns", fields.SHORTEST_NS, fields.LONGEST_NS, nullable=True, unit=" ns")
        if modes and (c2c is None) != (modes[0].c2c_ns is None):
            mode.fail("c2c_ns", "is null in some modes and a number in others: either the machine has a pair of "
                                "CPUs to measure or it has not")
        if modes and c2c is not None and c2c < modes[-1].c2c_ns:
            mode.fail("c2c_ns", f"is {c2c:g} ns, below the {modes[-1].c2c_ns:g} ns of the mode before: the modes "
                                "are sorted fastest first")
        modes.append(PaceMode(index, c2c,
                              mode.number("serial_ns", fields.SHORTEST_NS, fields.LONGEST_NS, unit=" ns"),
                              mode.number("share", 0.0, 1.0), mode.integer("readings")))
    if sum(mode.share for mode in modes) > 1.0 + fields.SHARE_SLACK:
        trace.fail("modes", f"have shares adding up to {sum(mode.share for mode in modes):g}, more than the whole "
                            "run")

    readings = []
    for index, raw in enumerate(trace.array("readings")):
        reading = _Object(path, raw, f"{fields.PACE_KEY}: reading {index}")
        t_s = reading.number("t_s", 0.0, fields.LONGEST_NS / 1e9, unit=" s")
        if readings and t_s < readings[-1].t_s:
            reading.fail("t_s", f"is {t_s:g} s, before the {readings[-1].t_s:g} s of the reading before: the "
                                "readings are in time order")
        readings.append(PaceReading(
            t_s, reading.number("c2c_ns", fields.SHORTEST_NS, fields.LONGEST_NS, nullable=True, unit=" ns"),
            reading.number("serial_ns", fields.SHORTEST_NS, fields.LONGEST_NS, unit=" ns"),
            reading.integer("mode", low=fields.OUTLIER_MODE, high=len(modes) - 1)))
    changes = trace.integer("changes", high=len(readings) - 1)
    return PaceTrace(reference, tuple(cpus), tuple(readings), tuple(modes), changes, trace.text("summary"))


def _read_pairs(path: str, document: dict, trace: PaceTrace | None) -> list[PacePair]:
    """The top-level "lockstep_pairs", checked field by field; [] when the file has none (an older file)."""
    if fields.PAIRS_KEY not in document:
        return []
    raw_pairs = document[fields.PAIRS_KEY]
    if not isinstance(raw_pairs, list):
        raise InputError(path, f"{fields.PAIRS_KEY} is {json_kind(raw_pairs)}, not a list")
    pairs, seen = [], {}
    highest_mode = len(trace.modes) - 1 if trace else fields.OUTLIER_MODE
    for index, raw in enumerate(raw_pairs):
        pair = _Object(path, raw, f"{fields.PAIRS_KEY} entry {index}")
        comparison = pair.choice("comparison", fields.PAIR_COMPARISONS)
        names = {}
        for side in ("a", "b"):
            name = pair.text(side, empty=False)
            key = parse_name(name)
            if not key.family:
                pair.fail(side, f"is {_shown(name)}: no benchmark family")
            names[side] = (name, key)
        identity = (comparison, names["a"][1], names["b"][1])
        if identity in seen:
            raise InputError(path, f"{pair.where} repeats entry {seen[identity]} (the same {comparison} pair of "
                                   f"{names['a'][0]} and {names['b'][0]}): a damaged or concatenated file")
        seen[identity] = index
        ratios = tuple(_checked_number(pair, f"ratios[{at}]", value, fields.SMALLEST_RATIO, fields.LARGEST_AMOUNT)
                       for at, value in enumerate(pair.array("ratios")))
        raw_modes = pair.array("modes")
        if len(raw_modes) != len(ratios):
            pair.fail("modes", f"has {len(raw_modes)} values for {len(ratios)} ratios: one mode per pair")
        modes = []
        for at, value in enumerate(raw_modes):
            if isinstance(value, bool) or not isinstance(value, int) or not fields.OUTLIER_MODE <= value <= highest_mode:
                where = (f"one of the {highest_mode + 1} modes of {fields.PACE_KEY} or -1" if trace
                         else f"-1: the file has no {fields.PACE_KEY}")
                pair.fail("modes", f"holds {_shown(value)} at {at}, not {where}")
            modes.append(value)
        median = pair.number("median", fields.SMALLEST_RATIO, fields.LARGEST_AMOUNT)
        ci_low = pair.number("ci_low", fields.SMALLEST_RATIO, fields.LARGEST_AMOUNT)
        ci_high = pair.number("ci_high", fields.SMALLEST_RATIO, fields.LARGEST_AMOUNT)
        if ci_low > ci_high:
            pair.fail("ci_low", f"is {ci_low:g}, above ci_high {ci_high:g}")
        confidence = pair.number("confidence", 0.0, 1.0)
        if not 0.0 < confidence < 1.0:
            pair.fail("confidence", f"is {confidence:g}: a confidence lies strictly between 0 and 1")
        pairs.append(PacePair(comparison, pair.text("group"), names["a"][0], names["b"][0], names["a"][1],
                              names["b"][1], ratios, tuple(modes), median, ci_low, ci_high, confidence,
                              pair.number("noise", 0.0, fields.LARGEST_NOISE), pair.choice("verdict", fields.PAIR_VERDICTS),
                              pair.number("block_ms", fields.SHORTEST_NS / 1e6, fields.LONGEST_NS / 1e6, unit=" ms")))
    return pairs


def _scaling_range(point: "_Object") -> tuple[float, float] | None:
    """A scaling point's min..max of the counter over repetitions, when the file carries it."""
    low = point.number("repetitions_min", -fields.LONGEST_NS, fields.LONGEST_NS, required=False, unit=" ns")
    high = point.number("repetitions_max", -fields.LONGEST_NS, fields.LONGEST_NS, required=False, unit=" ns")
    return (low, high) if low is not None and high is not None else None


def _read_scaling(path: str, document: dict) -> ScalingCurve | None:
    """The top-level "lockstep_scaling", checked field by field; None when the file has none."""
    if fields.SCALING_KEY not in document:
        return None
    curve = _Object(path, document[fields.SCALING_KEY], fields.SCALING_KEY)
    counter = curve.choice("counter", fields.SCALING_COUNTERS)
    threads = tuple(_checked_number(curve, f"threads[{at}]", value, 1, fields.LARGEST_AMOUNT)
                    for at, value in enumerate(curve.array("threads", nonempty=False)))
    points = []
    for index, raw in enumerate(curve.array("points", nonempty=False)):
        point = _Object(path, raw, f"{fields.SCALING_KEY} point {index}")
        points.append(ScalingPoint(point.text("sync", empty=False), point.integer("threads", low=1),
                                   point.text("layout", empty=False), point.text("model", empty=False),
                                   point.number(counter, -fields.LONGEST_NS, fields.LONGEST_NS, unit=" ns"),
                                   point.flag("oversubscribed"), _scaling_range(point)))
    best = curve.text("best", required=False, empty=False) if curve.value.get("best") is not None else None
    return ScalingCurve(curve.text("pin", empty=False), counter, tuple(int(t) for t in threads), tuple(points), best,
                        curve.number("c2c_one_way_ns", fields.SHORTEST_NS, fields.LONGEST_NS, required=False,
                                     nullable=True, unit=" ns"))


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


def _mpi_distribution(owner: _Object, key: str, required: bool = True) -> dict:
    values = owner.object(key, required=required)
    if values is None:
        return {}
    return {name: values.number(name, 0.0, fields.LONGEST_NS, unit=" ns") for name in MPI_DISTRIBUTION_KEYS}


def _read_mpi(path: str, document: dict) -> MpiDetails:
    top = _Object(path, document, "the file")
    settings = top.object("settings")
    ranks, hosts = settings.integer("ranks", low=1), settings.integer("hosts", low=1)
    exchanges, labels = [], {}
    for index, raw in enumerate(top.array("exchanges")):
        entry = _Object(path, raw, f"exchanges entry {index}")
        exchange = entry.text("exchange", empty=False)
        sync = entry.text("sync", required=False) or ""
        # label and name: what `lockstep mpi` writes; a file that holds only exchange (and sync) gets them
        # as the writer makes them (bench/cli/mpi.cpp, exchange_name).
        label = entry.text("label", required=False, empty=False) or (f"{exchange}/{sync}" if sync else exchange)
        name = entry.text("name", required=False, empty=False) or (
            f"mpi/exchange:{exchange}" + (f"/sync:{sync}" if sync else "") + f"/ranks:{ranks}/hosts:{hosts}")
        if label in labels:
            entry.fail("label", f"{_shown(label)} is also exchanges entry {labels[label]}'s: an exchange appears once")
        labels[label] = index
        counts = entry.array("slowest_rank_counts")
        if not all(isinstance(count, int) and not isinstance(count, bool) and count >= 0 for count in counts):
            entry.fail("slowest_rank_counts", "holds something that is not a count")
        if len(counts) != ranks:
            entry.fail("slowest_rank_counts", f"holds {len(counts)} counts for {ranks} ranks (settings): one per rank")
        exchanges.append(MpiExchange(label, name,
                                     _mpi_distribution(entry, "stage_latency_ns"), _mpi_distribution(entry, "skew_ns"),
                                     _mpi_distribution(entry, "transfer_ns", required=False), tuple(counts)))
    not_applicable = top.object("not_applicable", required=False)
    reasons = tuple(sorted((key, not_applicable.text(key)) for key in (not_applicable.value if not_applicable else {})))
    return MpiDetails(ranks, hosts, settings.text("transport", empty=False), settings.text("model", empty=False),
                      tuple(exchanges), reasons)


def run_file_from_document(path: str, label: str, document) -> RunFile:
    if not isinstance(document, dict):
        raise InputError(path, f"not Google Benchmark JSON: the top level is {json_kind(document)}, "
                               "not an object with \"context\" and \"benchmarks\"")
    kind = document.get("kind")
    if kind in ("c2c", "delay"):
        raise InputError(path, f"is `lockstep {kind}` output, not benchmark results: compare takes the JSON "
                               "of `lockstep run`")
    benchmarks = document.get("benchmarks")
    context = document.get("context")
    if not isinstance(benchmarks, list) or not isinstance(context, dict):
        missing = "\"benchmarks\" list" if not isinstance(benchmarks, list) else "\"context\" object"
        tool = "lockstep mpi" if document.get("kind") == "mpi" else "lockstep run"
        raise InputError(path, f"not Google Benchmark JSON (no {missing}): not a `{tool}` result file")
    if not benchmarks:
        raise InputError(path, "holds no benchmark entries (did the filter match nothing?)")
    context_values, warnings = _read_context(path, label, context)
    lockstep_schema = context_values.get("lockstep_schema")
    batch_times = lockstep_schema is not None and int(lockstep_schema) < fields.PER_UNIT_TIMES_SCHEMA
    pace = _read_pace(path, document)
    pairs = _read_pairs(path, document, pace)

    runs: dict[BenchmarkKey, Run] = {}
    seen: dict[tuple, int] = {}  # an entry's identity -> its index: each appears once
    first_repetition: dict[BenchmarkKey, tuple[int, frozenset]] = {}  # index, the read counters it carries
    first_read: dict[BenchmarkKey, tuple[int, frozenset]] = {}  # index, the per-unit counters it carries
    for index, raw in enumerate(benchmarks):
        entry = _Object(path, raw, f"benchmark entry {index}")
        name = entry.text("name", empty=False)
        entry.where = f"benchmark entry {index} ({_shown(name)})"
        run_name = entry.text("run_name", required=False, empty=False)
        run_type = entry.choice("run_type", ("iteration", "aggregate"))
        aggregate = entry.text("aggregate_name", empty=False) if run_type == "aggregate" else None
        base = run_name or (name[: -(len(aggregate) + 1)] if aggregate and name.endswith("_" + aggregate) else name)
        key = parse_name(base)
        if not key.family:
            entry.fail("name", "has no benchmark family")
        if aggregate is None:
            repetition_index = entry.integer("repetition_index", required=False)
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
            on, message = entry.flag(flag), entry.text(message_key, required=False)
            if message is not None and not on:
                entry.fail(message_key, f"is there but {flag} is not true")
            if on and failure is None:
                failure = message or f"{flag.replace('_', ' ')} (message {fields.UNAVAILABLE})"
        if failure is not None:
            if failure not in run.errors:
                run.errors.append(failure)
                run.errors.sort()  # the file's order of entries is not part of the result
            continue
        scale = fields.TIME_UNIT_NS[entry.choice("time_unit", tuple(fields.TIME_UNIT_NS))]
        if aggregate is not None and aggregate not in fields.READ_AGGREGATES:
            continue  # stddev, cv and other statistics: not read
        # The repetitions of one benchmark carry the same read counters, and every entry read (repetitions,
        # median, mean) the same per-unit counter: a counter missing from one of them is a damaged file,
        # and a time per batch read as a time per step would be off by the batch size.
        present = frozenset(name for name in fields.READ_COUNTERS if name in entry.value)
        if aggregate is None:
            paced = present | frozenset(name for name in fields.PACE_COUNTERS if name in entry.value)
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
                   pairs=pairs, scaling=_read_scaling(path, document),
                   mpi=_read_mpi(path, document) if document.get("kind") == "mpi" else None)


def _same_counters(entry: _Object, counters: frozenset, first: tuple[int, frozenset]) -> None:
    index, expected = first
    if counters != expected:
        missing, extra = sorted(expected - counters), sorted(counters - expected)
        problem = (f"lacks {', '.join(missing)}, which entry {index} of the same benchmark has" if missing
                   else f"has {', '.join(extra)}, which entry {index} of the same benchmark lacks")
        raise InputError(entry.path, f"{entry.where} {problem}: the entries of one benchmark carry the same "
                                     "counters")


def load_run_file(path: str, label: str | None = None) -> RunFile:
    label = label or os.path.basename(path)
    return run_file_from_document(path, label, parse_json(path, read_text(path)))


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
    document = parse_json(path, read_text(path))
    kind = document.get("kind") if isinstance(document, dict) else None
    if kind in CONTEXT_ONLY_KINDS:
        if not isinstance(document.get("context"), dict):
            raise InputError(path, f"is `lockstep {kind}` output without a \"context\" object")
        context, warnings = _read_context(path, label, document["context"])
        return ContextFile(path=path, label=label, kind=kind, context=context, warnings=warnings)
    if kind is not None and kind != "mpi":  # as load_any: a kind this reader does not know is not a run file
        raise InputError(path, f"unknown lockstep file kind {_shown(kind)}")
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


@dataclass
class DelayFile:
    path: str
    label: str
    settings: dict  # fields.DELAY_SETTINGS present in the file, checked
    pinned: PacedRun
    unpinned: PacedRun | None
    histogram: Histogram  # of the pinned run's wake-ups


def _distribution(owner: _Object, key: str, required: bool, statistics=fields.DISTRIBUTION_STATISTICS,
                  counted: bool = True) -> Distribution | None:
    """{min, p50, ..., count}: every statistic a number, or all null with count 0. `counted`: count is
    required (the delay files; older c2c files have none)."""
    summary = owner.object(key, required=required)
    if summary is None:
        return None
    count = summary.integer("count", required=counted)
    values = {}
    for name in statistics:
        value = summary.number(name, 0.0, fields.LONGEST_NS, required=False, nullable=True, unit=" ns")
        if value is not None and count == 0:
            summary.fail(name, "is a number though count is 0")
        if value is None and count != 0:
            summary.fail(name, "is missing or null" + (f" though count is {count}" if count else ""))
        values[name] = value
    known = [(name, values[name]) for name in statistics if values[name] is not None]
    for (low_name, low), (high_name, high) in zip(known, known[1:]):
        if low > high:
            summary.fail(high_name, f"is {high:g} ns, below {low_name} {low:g} ns: the statistics are out of order")
    return Distribution(count, values)


def _read_c2c(path: str, label: str, document: _Object) -> C2cFile:
    pairs, seen = [], {}
    for index, raw in enumerate(document.array("pairs")):
        pair = _Object(path, raw, f"c2c pair {index}")
        a = pair.integer("a", high=fields.CPU_LIMIT - 1)
        b = pair.integer("b", high=fields.CPU_LIMIT - 1)
        if a == b:
            pair.fail("b", f"is {b}, the same CPU as a")
        method = pair.text("method", empty=False)
        identity = (min(a, b), max(a, b), method)
        if identity in seen:
            raise InputError(path, f"c2c pair {index} repeats pair {seen[identity]} (CPUs {a} and {b}, method "
                                   f"{method})")
        seen[identity] = index
        p50 = _distribution(pair, "one_way_ns", required=True, statistics=("p50",), counted=False).statistics["p50"]
        if p50 is not None and p50 < fields.SHORTEST_NS:
            pair.fail("one_way_ns", f"p50 is {p50:g} ns: a time is positive")
        pairs.append(C2cPair(a, b, method, pair.text("relation", empty=False), p50))
    return C2cFile(path=path, label=label, pairs=pairs, sampled=document.flag("sampled"))


def _figure5(owner: _Object, key: str) -> list[Figure5Row]:
    rows, threads = [], {}
    raw_rows = owner.array(key)
    for index, raw in enumerate(raw_rows):
        row = _Object(owner.path, raw, f"{key} row {index}")
        thread = row.text("thread", empty=False)
        if thread in threads:
            raise InputError(owner.path, f"{key} row {index} repeats the thread {thread!r} of row {threads[thread]}")
        threads[thread] = index
        total = row.integer("total_csw")
        cross = row.integer("cross_core_csw", nullable=True, high=total)
        rows.append(Figure5Row(thread, row.text("role"), cross, total,
                               row.number("pct", 0.0, 100.0, nullable=True, unit=" %")))
    return rows


def _settings(document: _Object) -> dict:
    settings = document.object("settings", required=False)
    values = {}
    if settings is None:
        return values
    for key, kind in fields.DELAY_SETTINGS:
        if kind == "duration":
            value = settings.number(key, fields.SHORTEST_NS, fields.LONGEST_NS, required=False, unit=" ns")
            value = int(value) if value is not None and value.is_integer() else value
        elif kind == "seconds":
            # null: the run had no fixed length (`lockstep delay --find-period` writes duration_s null)
            value = settings.number(key, 0.0, fields.LONGEST_NS / 1e9, required=False, nullable=True, unit=" s")
        elif kind == "count":
            value = settings.integer(key, required=False)
        elif kind == "priority":
            value = settings.integer(key, required=False, nullable=True, low=1, high=99)
            if key in settings.value and value is None:
                values[key] = None  # SCHED_OTHER
                continue
        elif kind == "flag":
            value = settings.flag(key) if key in settings.value else None  # absent: not said, not false
        else:
            value = settings.text(key, required=False)
        if value is not None:
            values[key] = value
    return values


def _paced_run(summaries: _Object, document: _Object, figure5_key: str) -> PacedRun:
    return PacedRun(wakeup=_distribution(summaries, "wakeup_latency_ns", required=True),
                    completion=_distribution(summaries, "completion_ns", required=False),
                    deadline_misses=summaries.integer("deadline_misses", required=False),
                    figure5=_figure5(document, figure5_key))


def _read_delay(path: str, label: str, document: _Object) -> DelayFile:
    pinned = _paced_run(document, document, "figure5")
    # `lockstep delay --compare-pinning` writes both, without it neither: one alone is a damaged file.
    unpinned = document.object("unpinned", required=False)
    if (unpinned is None) != ("figure5_unpinned" not in document.value):
        document.fail("unpinned", "and figure5_unpinned come together (`lockstep delay --compare-pinning` writes "
                                  "both), but the file has one of them only")
    wakeup = pinned.wakeup
    histogram = document.object("histogram")
    counts = histogram.array("counts")
    for index, count in enumerate(counts):
        if isinstance(count, bool) or not isinstance(count, int) or not 0 <= count <= fields.LARGEST_AMOUNT:
            histogram.fail("counts", f"holds {_shown(count)} at {index}: a count is a whole number of 0 or more")
    below, above = (histogram.integer(key, required=False) or 0 for key in ("below", "above"))
    if sum(counts) + below + above != wakeup.count:
        histogram.fail("counts", f"add up to {sum(counts) + below + above} (with below and above), not to the "
                                 f"{wakeup.count} wake-ups of wakeup_latency_ns: a damaged file")
    bucket = histogram.number("bucket_ns", fields.SHORTEST_NS, fields.LONGEST_NS, unit=" ns")
    first = histogram.number("first_ns", 0.0, fields.LONGEST_NS, required=False, unit=" ns") or 0.0
    # `lockstep delay` sizes the histogram to its samples (platform/stats.hpp, histogram::covering): when it
    # holds every wake-up, the shortest falls in the first bucket and the longest in the last, so a bucket
    # too many or too few (an empty one included) is a damaged file, not another histogram.
    if below == above == 0 and wakeup.count:
        shortest, longest = (math.floor(wakeup.statistics[name]) for name in ("min", "max"))
        if not (first <= shortest < first + bucket and first + bucket * (len(counts) - 1) <= longest
                < first + bucket * len(counts)):
            histogram.fail("counts", f"has {len(counts)} buckets of {bucket:g} ns from {first:g} ns, which do not "
                                     f"span the wake-ups from {shortest} to {longest} ns bucket for bucket: a "
                                     "damaged file")
    return DelayFile(path=path, label=label, settings=_settings(document), pinned=pinned,
                     unpinned=_paced_run(unpinned, document, "figure5_unpinned") if unpinned else None,
                     histogram=Histogram(bucket, first, counts))


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
    document = parse_json(path, text)
    kind = document.get("kind") if isinstance(document, dict) else None
    if kind == "c2c":
        return _read_c2c(path, label, _Object(path, document, ""))
    if kind == "delay":
        return _read_delay(path, label, _Object(path, document, ""))
    if kind == "mpi":
        return run_file_from_document(path, label, document)
    if kind is not None:
        raise InputError(path, f"unknown lockstep file kind {_shown(kind)}")
    return run_file_from_document(path, label, document)


def unique_labels(paths: list[str]) -> list[str]:
    """Short names for files: the base name, or more of the path where base names collide."""
    labels = [os.path.basename(p) for p in paths]
    if len(set(labels)) == len(labels):
        return labels
    return [os.path.normpath(p) for p in paths]
