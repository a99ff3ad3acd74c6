"""Each machine by its own measure, for the tables across machines (compare --all, the report's machines
section): the context's fingerprint, every rk4 entry normalised by its own run's serial step and core-to-core
latency (the file's vs_serial / vs_c2c where it has them), each layout's speed-up per machine, and a ranking per
placement and thread count per machine."""
from __future__ import annotations

from ..common import statistics
from ..common.fields import (C2C_CONTEXT, FINGERPRINT_KEYS, MACHINE_KEYS, SERIAL_CONTEXT, SYNC_COUNTER, VS_C2C_COUNTER,
                             VS_SERIAL_COUNTER)
from ..common.names import BenchmarkKey, parse_name
from ..read.run_file import RunFile
from .run_analysis import calibration, median_ratio, run_median

def fingerprint(run_file: RunFile) -> dict[str, str]:
    context = run_file.context
    return {key: ("" if context.get(key) is None else str(context.get(key))) for key in FINGERPRINT_KEYS}


def same_machine(a: RunFile, b: RunFile) -> bool:
    fa, fb = fingerprint(a), fingerprint(b)
    return all(fa[key] == fb[key] for key in MACHINE_KEYS)


def model_serial(run_file: RunFile, key: BenchmarkKey) -> float | None:
    """The serial step an rk4 entry's step is divided by: its own model's. The paper's system (no model
    segment): the context's serial_step_ns, else rk4/serial; a chain: its in-run entry rk4/model:<model>/serial
    (the context holds the paper's system's only)."""
    model = key.get("model")
    if not model:
        return calibration(run_file, SERIAL_CONTEXT)
    return run_median(run_file, parse_name(f"rk4/model:{model}/serial"))


def normalised(run_file: RunFile, key: BenchmarkKey, time_kind: str = "real") -> tuple[float | None, float | None]:
    """(step time / serial step time of its model, stage sync time / one-way c2c latency) on that file's own
    machine.

    The entry's own vs_serial / vs_c2c counters, the median over its repetitions, as `lockstep run` derived them
    against its in-run calibrations (bench/results/derived_figures.hpp). Computed here only where the file lacks
    them (files written before the counters, or a run whose calibration was unavailable) or for CPU time (the
    counters divide the real ns_per_step): the same division, by the context's in-run calibrations (a chain's
    serial step: its rk4/model:<model>/serial entry). None ("unavailable") when neither exists."""
    run = run_file.runs.get(key)
    if run is None or run.errored:
        return None, None
    in_file = time_kind == "real"
    vs_serial = statistics.median(run.counter_values(VS_SERIAL_COUNTER)) if (
        in_file and run.counter_values(VS_SERIAL_COUNTER)) else None
    vs_c2c = statistics.median(run.counter_values(VS_C2C_COUNTER)) if run.counter_values(VS_C2C_COUNTER) else None
    if vs_serial is None:
        step = run_median(run_file, key, time_kind)
        serial = model_serial(run_file, key)
        vs_serial = step / serial if (step is not None and serial) else None
    if vs_c2c is None:
        sync = run.counter_values(SYNC_COUNTER)
        c2c = calibration(run_file, C2C_CONTEXT)
        vs_c2c = statistics.median(sync) / c2c if (sync and c2c) else None
    return vs_serial, vs_c2c


def rk4_keys(run_files: list[RunFile]) -> list[BenchmarkKey]:
    keys = set()
    for run_file in run_files:
        keys.update(key for key in run_file.runs if key.family == "rk4" and key.get("sync"))
    return sorted(keys, key=BenchmarkKey.sort_key)


def layout_effects(run_files: list[RunFile], reference: str | None, time_kind: str = "real"):
    """Rows (sync, pin, threads, layout, [speed-up over the reference layout per file]); a file where either
    entry collapsed (its answer's) has none. The reference is the layout whose writers share lines
    (run_analysis.sharing_layout); None: no rows."""
    rows = []
    if reference is None:
        return rows
    for key in rk4_keys(run_files):
        layout = key.get("layout")
        if layout is None or layout == reference:
            continue
        reference_key = key.replaced("layout", reference)
        speedups = [median_ratio(run_file, reference_key, key, time_kind, run_file.collapsed)
                    for run_file in run_files]
        if any(s is not None for s in speedups):
            rows.append((key.get("sync"), key.get("pin"), key.get("threads"), layout, speedups))
    return rows


def rank_tables(run_files: list[RunFile], time_kind: str = "real", top: int = 10):
    """{(pin, threads): [per file: [(sync/layout, median ns, x serial), ...] fastest first]}; the entries a
    file's answer calls collapsed are not ranked."""
    groups: dict[tuple[str, int], list] = {}
    for key in rk4_keys(run_files):
        group = (key.get("pin") or "", key.threads or 0)
        groups.setdefault(group, [])
    return {group: [_ranked(run_file, group, time_kind)[:top] for run_file in run_files] for group in sorted(groups)}


def _ranked(run_file: RunFile, group: tuple[str, int], time_kind: str) -> list[tuple[str, float, float | None]]:
    """One file's rk4 entries of a group (pin, threads), fastest first: (sync/layout, median ns, x serial). The
    run's own ranking where its file has it (lockstep_rankings, by real time); for CPU time, or a file written
    before the rankings, ranked here by the medians (collapsed entries left out)."""
    if time_kind == "real" and run_file.rankings is not None:
        ranking = next((item for item in run_file.rankings if (item.pin, item.threads) == group), None)
        return [(f"{key.get('sync')}/{key.get('layout')}", step, vs_serial)
                for key, step, vs_serial in (ranking.entries if ranking else ())]
    entries = []
    for key in rk4_keys([run_file]):
        if (key.get("pin") or "", key.threads or 0) != group or key in run_file.collapsed:
            continue
        step = run_median(run_file, key, time_kind)
        if step is not None:
            entries.append((f"{key.get('sync')}/{key.get('layout')}", step, normalised(run_file, key, time_kind)[0]))
    return sorted(entries, key=lambda entry: (entry[1], entry[0]))
