"""Reading lockstep's result files: what each holds, and one clear line when a file is unusable.

Four kinds of file reach the tools:
  run      Google Benchmark JSON (1.7 and later) written by `lockstep run --json`
  c2c      `lockstep c2c --out`   {"kind": "c2c", ...}
  delay    `lockstep delay --out` {"kind": "delay", ...}
  verify   `lockstep verify --csv` (header t,x1,x2)

Unknown fields are ignored and NaN/Infinity are accepted (Python's json reads
them; a NaN time makes that repetition unavailable, never zero). A file that
is unreadable, truncated, or not one of these kinds raises InputError, whose
text is one line naming the file and the problem; the command line turns it
into exit status 2.
"""
from __future__ import annotations

import csv
import io
import json
import math
import os
from dataclasses import dataclass, field

from .names import BenchmarkKey, parse_name

# Google Benchmark's JSON schema versions this reader was written against
# (1.7 writes none; 1.8 and later write "json_schema_version": 1).
KNOWN_GB_JSON_SCHEMA = 1
# lockstep's result schema (CMakeLists.txt, LOCKSTEP_RESULT_SCHEMA).
KNOWN_LOCKSTEP_SCHEMA = 1

# The per-unit time counters of lockstep's entries, in the order they are looked
# for: ns_per_step (rk4 entries, DESIGN.md, Measurements) and ns_per_episode
# (the bare barrier entries). Both time a batch of units per Google Benchmark
# iteration, and the batch size comes from each run's own probe, so only the
# per-unit counter compares across runs; the iteration time does not.
UNIT_COUNTERS = ("ns_per_step", "ns_per_episode")

TIME_UNIT_NS = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}

# Fields of a Google Benchmark entry that are not user counters.
GB_ENTRY_FIELDS = {
    "name", "family_index", "per_family_instance_index", "run_name", "run_type", "repetitions",
    "repetition_index", "threads", "iterations", "real_time", "cpu_time", "time_unit",
    "aggregate_name", "aggregate_unit", "error_occurred", "error_message", "skipped",
    "skip_message", "label", "big_o", "rms", "complexity",
}


class InputError(Exception):
    """A file the tools cannot use. str() is one line: '<file>: <problem>'."""

    def __init__(self, path: str, problem: str):
        super().__init__(f"{path}: {problem}")
        self.path = path
        self.problem = problem


@dataclass
class Repetition:
    real_ns: float
    cpu_ns: float
    counters: dict[str, float]


@dataclass
class Run:
    """Everything one file says about one benchmark (all its repetitions and aggregates)."""

    key: BenchmarkKey
    names: list[str] = field(default_factory=list)  # names as written in the file
    repetitions: list[Repetition] = field(default_factory=list)
    aggregates: dict[str, Repetition] = field(default_factory=dict)  # mean, median, stddev, cv, ...
    errors: list[str] = field(default_factory=list)
    unavailable: int = 0  # repetitions whose time was NaN or infinite

    @property
    def errored(self) -> bool:
        return bool(self.errors)

    def times_ns(self, time_kind: str = "real") -> list[float]:
        """Per-repetition times. lockstep's entries time a batch of units (RK4 steps, barrier
        episodes) per Google Benchmark iteration and report the unit itself in a counter
        (UNIT_COUNTERS): the real time is the first such counter every repetition has, else
        Google Benchmark's real_time."""
        if time_kind == "real":
            for counter in UNIT_COUNTERS:
                per_unit = [r.counters.get(counter) for r in self.repetitions]
                if per_unit and all(v is not None and math.isfinite(v) and v > 0 for v in per_unit):
                    return per_unit
            return [r.real_ns for r in self.repetitions]
        return [r.cpu_ns for r in self.repetitions]

    def aggregate_time_ns(self, aggregate: str, time_kind: str = "real") -> float | None:
        entry = self.aggregates.get(aggregate)
        if entry is None:
            return None
        if time_kind == "real":
            for counter in UNIT_COUNTERS:
                per_unit = entry.counters.get(counter)
                if per_unit is not None and math.isfinite(per_unit) and per_unit > 0:
                    return per_unit
            return entry.real_ns
        return entry.cpu_ns

    def counter_values(self, counter: str) -> list[float]:
        values = [r.counters[counter] for r in self.repetitions if counter in r.counters]
        values = [v for v in values if math.isfinite(v)]
        if not values and "median" in self.aggregates:
            value = self.aggregates["median"].counters.get(counter)
            if value is not None and math.isfinite(value):
                values = [value]
        return values

    def counters(self) -> set[str]:
        names: set[str] = set()
        for repetition in self.repetitions:
            names.update(repetition.counters)
        for aggregate in self.aggregates.values():
            names.update(aggregate.counters)
        return names


@dataclass
class RunFile:
    path: str
    label: str
    context: dict
    runs: dict[BenchmarkKey, Run]
    warnings: list[str] = field(default_factory=list)

    def context_number(self, key: str) -> float | None:
        """A numeric context value (lockstep writes them as strings), or None when unavailable."""
        value = self.context.get(key)
        try:
            number = float(value)
        except (TypeError, ValueError):
            return None
        return number if math.isfinite(number) and number > 0 else None


@dataclass
class C2cFile:
    path: str
    label: str
    document: dict


@dataclass
class DelayFile:
    path: str
    label: str
    document: dict


@dataclass
class VerifyFile:
    path: str
    label: str
    t: list[float]
    x1: list[float]
    x2: list[float]


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
    except UnicodeDecodeError:
        raise InputError(path, "is not text (binary data, or not UTF-8): not a lockstep result file") from None


def parse_json(path: str, text: str):
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        if error.pos >= len(text.rstrip()) - 1:
            raise InputError(path, f"truncated: the JSON ends at byte {len(text)} before it closes "
                                   "(an interrupted or still-running run?)") from None
        raise InputError(path, f"not valid JSON at line {error.lineno} column {error.colno} "
                               f"({error.msg})") from None


def _number(path: str, index: int, entry: dict, key: str) -> float:
    value = entry.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(path, f"benchmark entry {index} ({entry.get('name', '?')!r}) has no numeric "
                               f"{key!r}: not Google Benchmark output")
    return float(value)


def _counters(entry: dict) -> dict[str, float]:
    return {key: float(value) for key, value in entry.items()
            if key not in GB_ENTRY_FIELDS and isinstance(value, (int, float)) and not isinstance(value, bool)}


def _aggregate_name(entry: dict) -> str | None:
    if entry.get("run_type") == "aggregate":
        return str(entry.get("aggregate_name", "unknown"))
    if "run_type" not in entry:  # Google Benchmark before 1.5 marked aggregates only by a name suffix
        for suffix in ("mean", "median", "stddev", "cv"):
            if str(entry.get("name", "")).endswith("_" + suffix):
                return suffix
    return None


def run_file_from_document(path: str, label: str, document) -> RunFile:
    if not isinstance(document, dict):
        raise InputError(path, f"not Google Benchmark JSON: the top level is a {type(document).__name__}, "
                               "not an object with \"context\" and \"benchmarks\"")
    kind = document.get("kind")
    if kind in ("c2c", "delay"):
        raise InputError(path, f"is `lockstep {kind}` output, not benchmark results: compare takes the JSON "
                               "of `lockstep run`")
    benchmarks = document.get("benchmarks")
    context = document.get("context")
    if not isinstance(benchmarks, list) or not isinstance(context, dict):
        missing = "\"benchmarks\" list" if not isinstance(benchmarks, list) else "\"context\" object"
        raise InputError(path, f"not Google Benchmark JSON (no {missing}): not a `lockstep run` result file")
    if not benchmarks:
        raise InputError(path, "holds no benchmark entries (did the filter match nothing?)")

    warnings = []
    schema = context.get("json_schema_version")
    if isinstance(schema, (int, float)) and schema > KNOWN_GB_JSON_SCHEMA:
        warnings.append(f"{label}: Google Benchmark JSON schema {schema} is newer than this tool knows "
                        f"({KNOWN_GB_JSON_SCHEMA}); reading the fields it knows")
    lockstep_schema = context.get("lockstep_schema")
    try:
        if lockstep_schema is not None and int(str(lockstep_schema)) > KNOWN_LOCKSTEP_SCHEMA:
            warnings.append(f"{label}: lockstep result schema {lockstep_schema} is newer than this tool knows "
                            f"({KNOWN_LOCKSTEP_SCHEMA}); reading the fields it knows")
    except ValueError:
        warnings.append(f"{label}: lockstep_schema {lockstep_schema!r} is not a number")
    if lockstep_schema is None:
        warnings.append(f"{label}: no lockstep keys in the context (not written by `lockstep run`?): "
                        "no machine fingerprint or normalisation for it")

    runs: dict[BenchmarkKey, Run] = {}
    for index, entry in enumerate(benchmarks):
        if not isinstance(entry, dict) or "name" not in entry:
            raise InputError(path, f"benchmark entry {index} is not an object with a \"name\": "
                                   "not Google Benchmark output")
        name = str(entry.get("run_name") or entry["name"])
        aggregate = _aggregate_name(entry)
        if aggregate and "run_name" not in entry:
            name = name[: -(len(aggregate) + 1)]
        key = parse_name(name)
        run = runs.setdefault(key, Run(key=key))
        if name not in run.names:
            run.names.append(name)
        failed = entry.get("error_occurred") is True or entry.get("skipped") not in (None, False, 0)
        if failed:
            message = str(entry.get("error_message") or entry.get("skip_message") or "error (no message)")
            if message not in run.errors:
                run.errors.append(message)
            continue
        unit = entry.get("time_unit", "ns")
        if unit not in TIME_UNIT_NS:
            raise InputError(path, f"benchmark entry {index} ({name!r}) has an unknown time_unit {unit!r}")
        scale = TIME_UNIT_NS[unit]
        if aggregate == "cv" or entry.get("aggregate_unit") == "percentage":
            scale = 1.0
        real = _number(path, index, entry, "real_time") * scale
        cpu = _number(path, index, entry, "cpu_time") * scale
        repetition = Repetition(real, cpu, _counters(entry))
        if aggregate:
            run.aggregates[aggregate] = repetition
        elif math.isfinite(real) and math.isfinite(cpu):
            run.repetitions.append(repetition)
        else:
            run.unavailable += 1
    for run in runs.values():
        if run.unavailable:
            warnings.append(f"{label}: {run.key.display}: {run.unavailable} repetition(s) with a NaN or "
                            "infinite time left out")
    return RunFile(path=path, label=label, context=context, runs=runs, warnings=warnings)


def load_run_file(path: str, label: str | None = None) -> RunFile:
    label = label or os.path.basename(path)
    return run_file_from_document(path, label, parse_json(path, read_text(path)))


def _check_c2c(path: str, document: dict) -> None:
    pairs = document.get("pairs")
    if not isinstance(pairs, list):
        raise InputError(path, "a c2c file without a \"pairs\" list")
    for index, pair in enumerate(pairs):
        if not (isinstance(pair, dict) and isinstance(pair.get("a"), int) and isinstance(pair.get("b"), int)
                and isinstance(pair.get("one_way_ns"), dict)):
            raise InputError(path, f"c2c pair {index} lacks integer \"a\", \"b\" or a \"one_way_ns\" object")


def _check_delay(path: str, document: dict) -> None:
    for key in ("wakeup_latency_ns", "histogram"):
        if not isinstance(document.get(key), dict):
            raise InputError(path, f"a delay file without a \"{key}\" object")
    histogram = document["histogram"]
    if not isinstance(histogram.get("counts"), list) or not isinstance(histogram.get("bucket_ns"), (int, float)):
        raise InputError(path, "a delay file whose histogram lacks \"bucket_ns\" or \"counts\"")


def load_verify_csv(path: str, text: str, label: str) -> VerifyFile:
    reader = csv.reader(io.StringIO(text))
    header = [cell.strip() for cell in next(reader, [])]
    if header[:3] != ["t", "x1", "x2"]:
        raise InputError(path, f"a CSV whose header is {','.join(header)!r}, not 't,x1,x2' "
                               "(`lockstep verify --csv` writes that)")
    t, x1, x2 = [], [], []
    for line_number, row in enumerate(reader, start=2):
        if not row:
            continue
        try:
            values = [float(cell) for cell in row[:3]]
        except ValueError:
            raise InputError(path, f"line {line_number} is not three numbers: {','.join(row)!r}") from None
        if len(values) < 3:
            raise InputError(path, f"line {line_number} has {len(values)} values, not 3 (truncated?)")
        t.append(values[0])
        x1.append(values[1])
        x2.append(values[2])
    if len(t) < 2:
        raise InputError(path, "a trajectory with fewer than two rows")
    return VerifyFile(path=path, label=label, t=t, x1=x1, x2=x2)


def load_any(path: str, label: str | None = None):
    """Any of the four kinds, recognised by content (never by the file name)."""
    label = label or os.path.basename(path)
    text = read_text(path)
    if text.lstrip()[:1] not in ("{", "["):
        if text.lstrip().startswith("t,"):
            return load_verify_csv(path, text, label)
        raise InputError(path, "neither JSON nor a `lockstep verify --csv` trajectory")
    document = parse_json(path, text)
    kind = document.get("kind") if isinstance(document, dict) else None
    if kind == "c2c":
        _check_c2c(path, document)
        return C2cFile(path=path, label=label, document=document)
    if kind == "delay":
        _check_delay(path, document)
        return DelayFile(path=path, label=label, document=document)
    if kind is not None:
        raise InputError(path, f"unknown lockstep file kind {kind!r}")
    return run_file_from_document(path, label, document)


def unique_labels(paths: list[str]) -> list[str]:
    """Short names for files: the base name, or more of the path where base names collide."""
    labels = [os.path.basename(p) for p in paths]
    if len(set(labels)) == len(labels):
        return labels
    return [os.path.normpath(p) for p in paths]
