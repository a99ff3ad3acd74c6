"""The reader of `lockstep delay --out` files: the paced runs (pinned, and unpinned with --compare-pinning), the
wake-up histogram checked against its wake-ups, Figure 5, and what --per-cpu, --find-period and the idle states
add."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..common import fields
from ..common.words import DELAY_CAUSES
from .checks import Distribution, fail, read_distribution
from .schemas import json_kind, shown


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


@dataclass(frozen=True)
class CauseRow:
    """One bar of the causes: a percentile of the tail ("above p99", steps summed) or one CPU's steps above p99,
    and the ns of excess per cause key."""
    label: str
    steps: int | None  # a tail row's steps; None for a CPU's row
    cpu: int | None  # a CPU's row's CPU; None for a tail row
    cause_ns: dict[str, float]


@dataclass(frozen=True)
class DelayCauses:
    """A delay file's `causes` (bench/delay/delay_report.cpp, causes_json): why the late steps were late.
    names: (key, words) of every cause in the order of the writer's enum (the file's cause_kinds; a file without
    it: words.DELAY_CAUSES)."""
    names: tuple[tuple[str, str], ...]
    rows: tuple[CauseRow, ...]


@dataclass
class DelayFile:
    path: str
    label: str
    settings: dict  # fields.DELAY_SETTINGS present in the file
    pinned: PacedRun
    unpinned: PacedRun | None
    histogram: Histogram  # of the pinned run's wake-ups
    extras: DelayExtras = field(default_factory=DelayExtras)
    causes: DelayCauses | None = None  # None: the run kept no record, or the file predates the causes


def _figure5(path: str, document: dict, key: str) -> list[Figure5Row]:
    rows, threads = [], {}
    for index, row in enumerate(document[key]):
        thread = row["thread"]
        if thread in threads:
            fail(path, (key, index, "thread"), f"repeats the thread {thread!r} of {key}[{threads[thread]}]")
        threads[thread] = index
        cross, total = row["cross_core_csw"], row["total_csw"]
        if cross is not None and cross > total:
            fail(path, (key, index, "cross_core_csw"), f"is {shown(cross)}, more than total_csw {shown(total)}")
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
    return PacedRun(wakeup=read_distribution(path, place + ("wakeup_latency_ns",), summaries["wakeup_latency_ns"]),
                    completion=(read_distribution(path, place + ("completion_ns",), completion)
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
                fail(path, ("latency_histogram", "columns", index, "counts"),
                     f"has {len(counts)} buckets of {bucket:g} us, not the {bound:g} us of bound_us")
            columns.append(HistogramColumn(column["name"], column.get("cpu"), counts, column.get("overflow") or 0))
        histograms = LatencyHistograms(bucket, bound, columns)
    per_cpu, noisiest = [], None
    raw = document.get("per_cpu")
    if raw is not None:
        for index, row in enumerate(raw["cpus"]):
            wakeup = read_distribution(path, ("per_cpu", "cpus", index, "wakeup_latency_ns"), row["wakeup_latency_ns"])
            per_cpu.append(CpuLatency(row["cpu"], wakeup, row.get("deadline_misses")))
        worst = raw.get("noisiest")
        if worst is not None:
            noisiest = (worst["cpu"], worst.get("rule") or "")
    search = None
    raw = document.get("find_period")
    if raw is not None:
        for index, trial in enumerate(raw["trials"] + ([raw["confirm"]] if raw.get("confirm") else [])):
            if trial["misses"] > trial["periods"]:
                place = ("find_period", "trials", index) if index < len(raw["trials"]) else ("find_period", "confirm")
                fail(path, place + ("misses",), f"is {shown(trial['misses'])}, more than its "
                                                f"{shown(trial['periods'])} periods")
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


def read_delay(path: str, label: str, document: dict) -> DelayFile:
    pinned = _paced_run(path, document, document, "figure5", ())
    wakeup = pinned.wakeup
    histogram = document["histogram"]
    counts = histogram["counts"]
    below, above = (histogram.get(key) or 0 for key in ("below", "above"))
    if sum(counts) + below + above != wakeup.count:
        fail(path, ("histogram", "counts"), f"add up to {sum(counts) + below + above} (with below and above), not "
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
            fail(path, ("histogram", "counts"), f"has {len(counts)} buckets of {bucket:g} ns from {first:g} ns, "
                                                f"which do not span the wake-ups from {shortest} to {longest} ns "
                                                "bucket for bucket: a damaged file")
    unpinned = document.get("unpinned")
    return DelayFile(path=path, label=label, settings=_settings(document), pinned=pinned,
                     unpinned=(_paced_run(path, unpinned, document, "figure5_unpinned", ("unpinned",))
                               if unpinned is not None else None),
                     histogram=Histogram(bucket, first, counts), extras=_delay_extras(path, document),
                     causes=read_causes(path, document))


def _cause_names(path: str, document: dict) -> tuple[tuple[str, str], ...]:
    """The causes' keys and words in the writer's order: the file's cause_kinds ([{"key", "words"}, ...], written
    by bench/delay/attribution_output.cpp from kCauseNaming in bench/delay/attribution.hpp); a file written before
    it gets words.DELAY_CAUSES, a copy of the writer's enum at the time. What is read is checked here."""
    raw = document.get("cause_kinds")
    if raw is None:
        return DELAY_CAUSES
    if not isinstance(raw, list) or not raw:
        fail(path, ("cause_kinds",), f"is {json_kind(raw)}, not a list of causes")
    names = []
    for index, item in enumerate(raw):
        if not isinstance(item, dict) or not all(isinstance(item.get(key), str) and item[key]
                                                 for key in ("key", "words")):
            fail(path, ("cause_kinds", index), "is not an object with the texts key and words")
        if any(item["key"] == key for key, _ in names):
            fail(path, ("cause_kinds", index, "key"), f"repeats {shown(item['key'])}: a cause is named once")
        names.append((item["key"], item["words"]))
    return tuple(names)


def read_causes(path: str, document: dict) -> DelayCauses | None:
    """The file's causes: each tail row, then each CPU's steps above p99; None when the run kept no record (null,
    or unavailable says why) or no row has a step."""
    causes = document.get("causes")
    if not causes or causes.get("unavailable"):
        return None
    rows = [CauseRow(row["label"], int(row["steps"]), None, dict(row["cause_ns"]))
            for row in causes.get("tail", [])]
    rows += [CauseRow("above p99", None, int(entry["cpu"]), dict(entry["cause_ns"]))
             for entry in causes.get("per_cpu", [])]
    return DelayCauses(_cause_names(path, document), tuple(rows)) if rows else None
