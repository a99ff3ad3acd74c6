"""The reader of `lockstep run` files (Google Benchmark JSON with lockstep's keys) and of `lockstep mpi` files,
whose benchmarks have the same shape: run_file_from_document turns a document read_document (inputs.py) has
checked against its schema into a RunFile (run_file.py). What the schema cannot say of the lockstep_* sections is
checked first (run_checks.py); the sections are then built here (the pace, the pairs, the scaling curve),
in answer_reader.py (the answer, the crossover sweep) and in derived_reader.py. The benchmark entries are checked
as they are read: an entry appears once, the repetitions of one benchmark carry the same counters, a time in its
unit lies within fields.SHORTEST_NS..LONGEST_NS, a repetition's pace mode names one of the trace's.

NaN and Infinity in a benchmark entry (Google Benchmark writes them for a value it could not compute) make that
one value unavailable and the file's warnings count what was left out; anywhere else they are a damaged file.
"""
from __future__ import annotations

import json
import math

from ..common import fields
from ..common.names import BenchmarkKey, EntrySpec, entry_spec, parse_name, spec_of
from . import answer_reader, derived_reader
from .checks import CheckedObject, InputError, checked_number
from .context_reader import read_context
from .mpi_reader import read_mpi
from .run_file import (PaceMode, PacePair, PaceReading, PaceTrace, Repetition, RepetitionPace, Run, RunFile,
                       ScalingCurve, ScalingPoint)
from .run_checks import base_name, check_sections
from .schemas import shown


def _measured_values(entry: CheckedObject, run: Run, scale: float, least: float,
                     batch_times: bool = False, typed: bool = False) -> Repetition | None:
    """An entry's times (in ns: scale is its time unit's size) and read counters, checked; None when its
    time is NaN or infinite (counted in run.unavailable). `least`: the smallest time it may hold. Its time is its
    per-unit counter: the one its lockstep_entry's unit names (`typed`: a file that carries the spec), else the
    one of fields.UNIT_COUNTERS it has (a file written before the spec).
    `batch_times`: a file written before lockstep schema fields.PER_UNIT_TIMES_SCHEMA, whose real_time and
    cpu_time of an entry with a per-unit counter are per batch; its cpu_time is then rescaled per unit by the
    batch size the two say (real_time / the counter). From that schema on both are per unit already."""
    times = {key: checked_number(entry, key, entry.get(key, required=True), least, fields.LONGEST_NS, " ns",
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
    if typed:
        unit_counter = run.entry.unit_counter
        if unit_counter is not None and unit_counter not in counters:
            entry.fail(unit_counter, f"is missing: its lockstep_entry says its time counts a {run.entry.unit}")
    else:
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


def _repetition_pace(entry: CheckedObject, run: Run, trace: "PaceTrace | None") -> RepetitionPace | None:
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
        entry.fail(fields.PACE_MODE_COUNTER, f"is {shown(mode)}, not one of the {len(trace.modes)} modes of "
                                             f"{fields.PACE_KEY} (0..{len(trace.modes) - 1}) or -1 (a change of "
                                             "pace during the repetition)")
    return RepetitionPace(values[fields.PACE_C2C_COUNTER], values[fields.PACE_SERIAL_COUNTER],
                          None if mode is None else int(mode))


def _read_pace(document: dict) -> PaceTrace | None:
    """The top-level "lockstep_pace"; None when the file has none (an older file)."""
    if fields.PACE_KEY not in document:
        return None
    trace = document[fields.PACE_KEY]
    modes = tuple(PaceMode(raw["mode"], raw["c2c_ns"], raw["serial_ns"], raw["share"], int(raw["readings"]))
                  for raw in trace["modes"])
    readings = tuple(PaceReading(raw["t_s"], raw["c2c_ns"], raw["serial_ns"], int(raw["mode"]))
                     for raw in trace["readings"])
    return PaceTrace(trace["reference"], tuple(trace["cpus"]), readings, modes, int(trace["changes"]),
                     trace["summary"])


def _read_pairs(document: dict, key_of=parse_name) -> list[PacePair]:
    """The top-level "lockstep_pairs"; [] when the file has none (an older file)."""
    return [PacePair(pair["comparison"], pair["group"], pair["a"], pair["b"], key_of(pair["a"]),
                     key_of(pair["b"]), tuple(pair["ratios"]), tuple(int(mode) for mode in pair["modes"]),
                     pair["median"], pair["ci_low"], pair["ci_high"], pair["confidence"], pair["noise"],
                     pair["verdict"], pair["block_ms"])
            for pair in document.get(fields.PAIRS_KEY, [])]


def _read_scaling(document: dict) -> ScalingCurve | None:
    """The top-level "lockstep_scaling"; None when the file has none. Each point holds the curve's counter."""
    if fields.SCALING_KEY not in document:
        return None
    curve = document[fields.SCALING_KEY]
    counter = curve["counter"]
    points = []
    for point in curve["points"]:
        low, high = point.get("repetitions_min"), point.get("repetitions_max")
        points.append(ScalingPoint(point["sync"], int(point["threads"]), point["layout"], point["model"],
                                   point[counter], bool(point.get("oversubscribed")),
                                   (low, high) if low is not None and high is not None else None))
    return ScalingCurve(curve["pin"], counter, tuple(int(t) for t in curve["threads"]), tuple(points),
                        curve.get("best"), curve.get("c2c_one_way_ns"))


class _Entries:
    """The benchmark entries of one file, read one by one into a Run per benchmark: each entry once, a failed
    one's message kept, the counters read alike across a benchmark's entries, NaN counted as unavailable."""

    def __init__(self, path: str, pace: PaceTrace | None, batch_times: bool, typed: bool):
        self.path, self.pace, self.batch_times, self.typed = path, pace, batch_times, typed
        self.runs: dict[BenchmarkKey, Run] = {}
        self.seen: dict[tuple, int] = {}  # an entry's identity -> its index: each appears once
        self.first_repetition: dict[BenchmarkKey, tuple[int, frozenset]] = {}  # index, the read counters it carries
        self.first_read: dict[BenchmarkKey, tuple[int, frozenset]] = {}  # index, the per-unit counters it carries

    def _identify(self, index: int, raw: dict, entry: CheckedObject,
                  aggregate: str | None) -> tuple[str, BenchmarkKey, EntrySpec | None]:
        """(the benchmark's name as written, its key, its spec: lockstep_entry's values in a file that carries them,
        else what its name implies); a second entry of one repetition or aggregate is refused."""
        base = base_name(raw)
        if self.typed:
            spec = entry_spec(raw[fields.ENTRY_KEY])
            key = spec.key
        else:
            key = parse_name(base)
            if not key.family:
                entry.fail("name", "has no benchmark family")
            spec = spec_of(key)
        if aggregate is None:
            repetition_index = raw.get("repetition_index")
            identity = (key, "repetition", repetition_index if repetition_index is not None
                        else json.dumps(raw, sort_keys=True))
        else:
            identity = (key, "aggregate", aggregate)
        if identity in self.seen:
            what = f"aggregate {aggregate}" if aggregate else "repetition"
            raise InputError(self.path, f"{entry.where} repeats entry {self.seen[identity]} (the same {what} of the "
                                        "same benchmark): a damaged or concatenated file")
        self.seen[identity] = index
        return base, key, spec

    def _check_counters(self, index: int, entry: CheckedObject, key: BenchmarkKey, aggregate: str | None) -> None:
        """The repetitions of one benchmark carry the same read counters (but fields.PER_REPETITION_COUNTERS,
        which the writer may omit from one repetition), and every entry read (repetitions, median, mean) the same
        per-unit counter: a counter missing from one of them is a damaged file, and a time per batch read as a
        time per step would be off by the batch size."""
        present = frozenset(name for name in fields.READ_COUNTERS if name in entry.value)
        if aggregate is None:
            paced = (present - frozenset(fields.PER_REPETITION_COUNTERS)) | frozenset(
                name for name in fields.PACE_COUNTERS if name in entry.value)
            _same_counters(entry, paced, self.first_repetition.setdefault(key, (index, paced)))
        units = present & frozenset(fields.UNIT_COUNTERS)
        _same_counters(entry, units, self.first_read.setdefault(key, (index, units)))

    def read(self, index: int, raw: dict) -> None:
        entry = CheckedObject(self.path, raw, f"benchmarks[{index}] ({shown(raw['name'])})")
        aggregate = raw["aggregate_name"] if raw["run_type"] == "aggregate" else None
        base, key, spec = self._identify(index, raw, entry, aggregate)
        run = self.runs.setdefault(key, Run(key=key, entry=spec))
        if base not in run.names:
            run.names.append(base)
        failure = None  # Google Benchmark 1.8 writes error_occurred + error_message, or skipped + skip_message
        for flag, message_key in (("error_occurred", "error_message"), ("skipped", "skip_message")):
            if raw.get(flag) and failure is None:
                failure = raw.get(message_key) or f"{flag.replace('_', ' ')} (message {fields.UNAVAILABLE})"
        if failure is not None:
            run.failed += aggregate is None
            if failure not in run.errors:
                run.errors.append(failure)
                run.errors.sort()  # the file's order of entries is not part of the result
            return
        split = step_split(raw) if aggregate is None else None
        if split is not None:
            run.step_splits.append(split)
        if aggregate is not None and aggregate not in fields.READ_AGGREGATES:
            return  # stddev, cv and other statistics: not read
        self._check_counters(index, entry, key, aggregate)
        # An aggregate's pace counters (a median of mode indices) mean nothing: only repetitions carry a pace.
        repetition_pace = _repetition_pace(entry, run, self.pace) if aggregate is None else None
        values = _measured_values(entry, run, fields.TIME_UNIT_NS[raw["time_unit"]], fields.SHORTEST_NS,
                                  self.batch_times, self.typed)
        if values is None:
            return
        if aggregate is not None:
            run.aggregates[aggregate] = values
        else:
            values.pace = repetition_pace
            values.split = split
            run.repetitions.append(values)


def run_file_from_document(path: str, label: str, document: dict) -> RunFile:
    """A `lockstep run` or `lockstep mpi` document that read_document has checked against its schema."""
    if document.get("kind") not in (None, "mpi"):
        raise InputError(path, f"is `lockstep {document['kind']}` output, not benchmark results: compare takes "
                               "the JSON of `lockstep run`")
    context_values, warnings = read_context(path, label, document["context"])
    lockstep_schema = context_values.get("lockstep_schema")
    batch_times = lockstep_schema is not None and int(lockstep_schema) < fields.PER_UNIT_TIMES_SCHEMA
    check_sections(path, document)
    keys = typed_keys(document)
    key_of = parse_name if keys is None else keys.__getitem__  # run_checks: every name a section gives is there
    pace = _read_pace(document)
    pairs = _read_pairs(document, key_of)
    entries = _Entries(path, pace, batch_times, keys is not None)
    for index, raw in enumerate(document["benchmarks"]):
        entries.read(index, raw)
    runs = entries.runs
    for key in sorted(runs, key=BenchmarkKey.sort_key):
        left_out = runs[key].unavailable
        if left_out:
            counts = ", ".join(f"{count} {what}(s)" for what, count in sorted(left_out.items()))
            warnings.append(f"{label}: {key.display}: NaN or infinite in the file, left out as {fields.UNAVAILABLE}: "
                            f"{counts}")
    return RunFile(path=path, label=label, context=context_values, runs=runs, warnings=warnings, pace=pace,
                   pairs=pairs, scaling=_read_scaling(document), answer=answer_reader.read_answer(document, key_of),
                   mpi=read_mpi(path, document) if document.get("kind") == "mpi" else None,
                   layouts=derived_reader.read_layouts(document),
                   planned=derived_reader.read_planned(document, key_of),
                   mode_medians=derived_reader.read_mode_medians(document, key_of),
                   rankings=derived_reader.read_rankings(document, key_of), model=derived_reader.read_model(document),
                   crossover=answer_reader.read_crossover(document))


def typed_keys(document: dict) -> dict[str, BenchmarkKey] | None:
    """{an entry's name: its key from its lockstep_entry} of a file whose entries carry their spec (every one does:
    run_checks.py); None for a file written before the spec, whose names are parsed (names.parse_name)."""
    if not any(fields.ENTRY_KEY in raw for raw in document["benchmarks"]):
        return None
    return {base_name(raw): entry_spec(raw[fields.ENTRY_KEY]).key for raw in document["benchmarks"]}


def step_split(raw: dict) -> tuple[float, ...] | None:
    """A repetition's split of its step (fields.STEP_SPLIT_COUNTERS: compute, waiting, release), or None when it
    lacks a part or a part is not a finite number within fields.LONGEST_NS. Read apart from the counters, whose
    presence must agree across an entry's repetitions: the writer leaves the split out of a repetition with too
    few split syncs and keeps it in the next."""
    parts = [raw.get(counter) for counter, _ in fields.STEP_SPLIT_COUNTERS]
    if all(isinstance(part, (int, float)) and not isinstance(part, bool) and math.isfinite(part)
           and abs(part) <= fields.LONGEST_NS for part in parts):
        return tuple(float(part) for part in parts)
    return None


def _same_counters(entry: CheckedObject, counters: frozenset, first: tuple[int, frozenset]) -> None:
    index, expected = first
    if counters != expected:
        missing, extra = sorted(expected - counters), sorted(counters - expected)
        problem = (f"lacks {', '.join(missing)}, which entry {index} of the same benchmark has" if missing
                   else f"has {', '.join(extra)}, which entry {index} of the same benchmark lacks")
        raise InputError(entry.path, f"{entry.where} {problem}: the entries of one benchmark carry the same "
                                     "counters")
