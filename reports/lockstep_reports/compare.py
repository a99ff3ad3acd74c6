"""`lockstep compare A.json B.json [more...]`: what changed between runs and machines, and whether it is real.

The first file is the baseline; every other file is compared with it. Within
one comparison, entries are matched by their parsed names (names.py); the
ones that are only in one file, or that errored, are listed, never dropped
and never counted as zero. Across files, each machine is shown by its
fingerprint and normalised by its own in-run core-to-core latency and serial
step time, so that effects can be read side by side.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from . import statistics
from .inputs import RunFile
from .names import BenchmarkKey

# Context keys that identify a machine and a build, in the order shown.
FINGERPRINT_KEYS = (
    "cpu_model", "topology", "hypervisor", "kernel", "num_cpus", "mhz_per_cpu", "host_name",
    "compiler", "cxx_flags", "build_type", "lockstep_version", "lockstep_schema", "git_revision",
    "benchmark_version", "hwloc_version", "boost_version", "c2c_one_way_ns", "serial_step_ns",
    "oversubscribed_note", "date",
)
# Keys whose difference means "another machine" rather than "another run".
MACHINE_KEYS = ("cpu_model", "topology", "hypervisor", "kernel", "num_cpus")

# Counters shown beside the time (when present), with short headings.
COUNTERS_SHOWN = (
    ("csw_vol_per_kstep", "csw vol/kstep"),
    ("csw_invol_per_kstep", "csw invol/kstep"),
    ("migrations_per_kstep", "migr/kstep"),
    ("futex_waits_per_step", "futex/step"),
    ("timeouts", "timeouts"),
)


@dataclass
class Row:
    key: BenchmarkKey
    median_a: float
    median_b: float
    repetitions_a: int
    repetitions_b: int
    ratio: float
    interval: tuple[float, float] | None
    p_raw: float | None
    p_adjusted: float | None = None
    counters: dict[str, tuple[float | None, float | None]] = field(default_factory=dict)

    def significant(self, alpha: float) -> bool:
        return self.p_adjusted is not None and self.p_adjusted < alpha

    def verdict(self, alpha: float) -> str:
        if self.p_adjusted is None:
            return "untested"
        if not self.significant(alpha):
            return "same"
        return "slower" if self.ratio > 1.0 else "faster"


@dataclass
class Comparison:
    baseline: RunFile
    contender: RunFile
    rows: list[Row]
    added: list[BenchmarkKey]
    removed: list[BenchmarkKey]
    errored: list[tuple[BenchmarkKey, str, str]]  # key, which file(s), message
    warnings: list[str]
    time_kind: str
    alpha: float

    @property
    def geometric_mean(self) -> float | None:
        return statistics.geometric_mean([row.ratio for row in self.rows])

    def regressions_beyond(self, percent: float) -> list[Row]:
        limit = 1.0 + percent / 100.0
        return [row for row in self.rows if row.significant(self.alpha) and row.ratio > limit]


def _sample(run, time_kind: str) -> tuple[list[float], bool]:
    """The repetition times of a run, or its median aggregate alone (False: no repetitions)."""
    times = run.times_ns(time_kind)
    if times:
        return times, True
    for aggregate in ("median", "mean"):
        value = run.aggregate_time_ns(aggregate, time_kind)
        if value is not None:
            return [value], False
    return [], False


def compare_pair(baseline: RunFile, contender: RunFile, time_kind: str = "real", alpha: float = 0.05) -> Comparison:
    keys_a, keys_b = set(baseline.runs), set(contender.runs)
    rows, errored, warnings = [], [], []
    untested = []
    for key in sorted(keys_a & keys_b, key=BenchmarkKey.sort_key):
        run_a, run_b = baseline.runs[key], contender.runs[key]
        if run_a.errored or run_b.errored:
            where = " and ".join(label for label, run in ((baseline.label, run_a), (contender.label, run_b))
                                 if run.errored)
            message = "; ".join(run_a.errors + [e for e in run_b.errors if e not in run_a.errors])
            errored.append((key, where, message))
            continue
        times_a, reps_a = _sample(run_a, time_kind)
        times_b, reps_b = _sample(run_b, time_kind)
        if not times_a or not times_b:
            errored.append((key, baseline.label if not times_a else contender.label, "no usable time"))
            continue
        median_a, median_b = statistics.median(times_a), statistics.median(times_b)
        ratio = median_b / median_a if median_a > 0 else math.inf
        interval = statistics.ratio_interval(times_a, times_b, key.display) if reps_a and reps_b else None
        p_raw = statistics.mann_whitney_p(times_a, times_b) if reps_a and reps_b else None
        if p_raw is None:
            untested.append(key)
        counters = {}
        for counter, _ in COUNTERS_SHOWN:
            values_a, values_b = run_a.counter_values(counter), run_b.counter_values(counter)
            if values_a or values_b:
                counters[counter] = (statistics.median(values_a) if values_a else None,
                                     statistics.median(values_b) if values_b else None)
        rows.append(Row(key, median_a, median_b, len(times_a) if reps_a else 0, len(times_b) if reps_b else 0,
                        ratio, interval, p_raw, counters=counters))
    for row, adjusted in zip(rows, statistics.holm([row.p_raw for row in rows])):
        row.p_adjusted = adjusted
    tested = [row for row in rows if row.p_raw is not None]
    powerless = [row for row in tested
                 if statistics.smallest_p(row.repetitions_a, row.repetitions_b) * len(tested) >= alpha]
    if powerless:
        needed = statistics.MIN_REPETITIONS
        while statistics.smallest_p(needed, needed) * len(tested) >= alpha:
            needed += 1
        warnings.append(f"{len(powerless)} of {len(tested)} tested entries have too few repetitions to ever be "
                        f"significant after Holm's correction over {len(tested)} tests (smallest possible p "
                        f"too large): use at least {needed} repetitions a side")
    for key in sorted(keys_a - keys_b, key=BenchmarkKey.sort_key):
        if baseline.runs[key].errored:
            errored.append((key, baseline.label, "; ".join(baseline.runs[key].errors)))
    for key in sorted(keys_b - keys_a, key=BenchmarkKey.sort_key):
        if contender.runs[key].errored:
            errored.append((key, contender.label, "; ".join(contender.runs[key].errors)))
    if untested:
        warnings.append(f"{len(untested)} of {len(rows)} matched entries have fewer than "
                        f"{statistics.MIN_REPETITIONS} repetitions on a side: no Mann-Whitney U test for them "
                        f"(`lockstep run --repetitions {max(statistics.MIN_REPETITIONS, 10)}` or more)")
    errored.sort(key=lambda item: item[0].sort_key())
    return Comparison(baseline, contender, rows,
                      added=sorted(keys_b - keys_a, key=BenchmarkKey.sort_key),
                      removed=sorted(keys_a - keys_b, key=BenchmarkKey.sort_key),
                      errored=errored, warnings=warnings, time_kind=time_kind, alpha=alpha)


# ---------------------------------------------------------------- across machines

def fingerprint(run_file: RunFile) -> dict[str, str]:
    context = run_file.context
    return {key: ("" if context.get(key) is None else str(context.get(key))) for key in FINGERPRINT_KEYS}


def same_machine(a: RunFile, b: RunFile) -> bool:
    fa, fb = fingerprint(a), fingerprint(b)
    return all(fa[key] == fb[key] for key in MACHINE_KEYS)


def run_median(run_file: RunFile, key: BenchmarkKey, time_kind: str = "real") -> float | None:
    run = run_file.runs.get(key)
    if run is None or run.errored:
        return None
    times, _ = _sample(run, time_kind)
    return statistics.median(times) if times else None


# The in-run calibration entries, used when the context lacks the value.
SERIAL_ENTRY = "rk4/serial"
C2C_ENTRY = "c2c/pin:compact/threads:2"


def calibration(run_file: RunFile, context_key: str) -> float | None:
    """serial_step_ns or c2c_one_way_ns: the context's value, else the median of the in-run entry."""
    value = run_file.context_number(context_key)
    if value is not None:
        return value
    from .names import parse_name

    entry = SERIAL_ENTRY if context_key == "serial_step_ns" else C2C_ENTRY
    return run_median(run_file, parse_name(entry))


def normalised(run_file: RunFile, key: BenchmarkKey, time_kind: str = "real") -> tuple[float | None, float | None]:
    """(step time / serial step time, stage sync time / one-way c2c latency) on that file's own machine.

    Uses the in-run calibrations of the context; falls back to the entry's own
    vs_serial / vs_c2c counters; None ("unavailable") when neither exists."""
    run = run_file.runs.get(key)
    if run is None or run.errored:
        return None, None
    step = run_median(run_file, key, time_kind)
    serial = calibration(run_file, "serial_step_ns")
    c2c = calibration(run_file, "c2c_one_way_ns")
    vs_serial = step / serial if (step is not None and serial) else None
    if vs_serial is None and run.counter_values("vs_serial"):
        vs_serial = statistics.median(run.counter_values("vs_serial"))
    sync = run.counter_values("sync_ns_per_stage")
    vs_c2c = statistics.median(sync) / c2c if (sync and c2c) else None
    if vs_c2c is None and run.counter_values("vs_c2c"):
        vs_c2c = statistics.median(run.counter_values("vs_c2c"))
    return vs_serial, vs_c2c


def rk4_keys(run_files: list[RunFile]) -> list[BenchmarkKey]:
    keys = set()
    for run_file in run_files:
        keys.update(key for key in run_file.runs if key.family == "rk4" and key.get("sync"))
    return sorted(keys, key=BenchmarkKey.sort_key)


def layout_effects(run_files: list[RunFile], reference: str = "packed", time_kind: str = "real"):
    """Rows (sync, pin, threads, layout, [speed-up over the reference layout per file])."""
    rows = []
    for key in rk4_keys(run_files):
        layout = key.get("layout")
        if layout is None or layout == reference:
            continue
        reference_key = key.replaced("layout", reference)
        speedups = []
        for run_file in run_files:
            this, base = run_median(run_file, key, time_kind), run_median(run_file, reference_key, time_kind)
            speedups.append(base / this if (this and base) else None)
        if any(s is not None for s in speedups):
            rows.append((key.get("sync"), key.get("pin"), key.get("threads"), layout, speedups))
    return rows


def rank_tables(run_files: list[RunFile], time_kind: str = "real", top: int = 10):
    """{(pin, threads): [per file: [(sync/layout, median ns, x serial), ...] fastest first]}."""
    groups: dict[tuple[str, int], list] = {}
    for key in rk4_keys(run_files):
        group = (key.get("pin") or "", key.threads or 0)
        groups.setdefault(group, [])
    tables = {}
    for group in sorted(groups):
        per_file = []
        for run_file in run_files:
            entries = []
            for key in rk4_keys([run_file]):
                if (key.get("pin") or "", key.threads or 0) != group:
                    continue
                step = run_median(run_file, key, time_kind)
                if step is None:
                    continue
                serial = calibration(run_file, "serial_step_ns")
                entries.append((f"{key.get('sync')}/{key.get('layout')}", step, step / serial if serial else None))
            entries.sort(key=lambda entry: (entry[1], entry[0]))
            per_file.append(entries[:top])
        tables[group] = per_file
    return tables


# ---------------------------------------------------------------- text output

def format_ns(value: float | None) -> str:
    if value is None or not math.isfinite(value):
        return "unavailable"
    if value >= 1e6:
        return f"{value / 1e6:.3f} ms"
    if value >= 1e3:
        return f"{value / 1e3:.3f} us"
    return f"{value:.1f} ns"


def _number(value: float | None, digits: int = 2) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    return f"{value:.{digits}f}"


def _p(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.2g}" if value >= 1e-4 else "<1e-4"


def _table(headings: list[str], rows: list[list[str]], right: set[int] | None = None) -> list[str]:
    right = right or set()
    widths = [len(h) for h in headings]
    for row in rows:
        widths = [max(w, len(cell)) for w, cell in zip(widths, row)]

    def line(cells):
        return "  ".join(cell.rjust(w) if i in right else cell.ljust(w)
                         for i, (cell, w) in enumerate(zip(cells, widths))).rstrip()

    return [line(headings), line(["-" * w for w in widths])] + [line(row) for row in rows]


def fingerprint_lines(run_files: list[RunFile]) -> list[str]:
    labels = [f"[{chr(ord('A') + i)}] {f.label}" for i, f in enumerate(run_files)]
    prints = [fingerprint(f) for f in run_files]
    rows = []
    for key in FINGERPRINT_KEYS:
        values = [p[key] or "unavailable" for p in prints]
        mark = "*" if len(set(values)) > 1 else ""
        rows.append([key + mark] + values)
    return _table(["context (* differs)"] + labels, rows)


def comparison_lines(comparison: Comparison, letter: str) -> list[str]:
    a, b = "A", letter
    out = [f"== {b} ({comparison.contender.label}) against A ({comparison.baseline.label})", ""]
    kind = "real" if comparison.time_kind == "real" else "CPU"
    out.append(f"time: {kind} time (the ns_per_step counter where an entry has it, else per iteration), median of the repetitions; ratio {b}/A of the medians "
               f"(> 1: {b} is slower) with a {int(statistics.CONFIDENCE * 100)}% bootstrap interval "
               f"({statistics.BOOTSTRAP_RESAMPLES} resamples, fixed seed); p: two-sided Mann-Whitney U, "
               f"Holm-corrected over the {sum(r.p_raw is not None for r in comparison.rows)} tests of this "
               f"comparison; verdict at alpha {comparison.alpha:g}; counters are medians, {a} -> {b}.")
    out.append("")
    counters_present = [(c, h) for c, h in COUNTERS_SHOWN if any(c in row.counters for row in comparison.rows)]
    headings = ["benchmark", f"{a} median", f"{b} median", f"{b}/A", "95% interval", "reps", "p (Holm)",
                "verdict"] + [h for _, h in counters_present]
    rows = []
    for row in comparison.rows:
        interval = f"[{row.interval[0]:.3f}, {row.interval[1]:.3f}]" if row.interval else "-"
        cells = [row.key.display, format_ns(row.median_a), format_ns(row.median_b), f"{row.ratio:.3f}", interval,
                 f"{row.repetitions_a}/{row.repetitions_b}", _p(row.p_adjusted), row.verdict(comparison.alpha)]
        for counter, _ in counters_present:
            before, after = row.counters.get(counter, (None, None))
            # Absent on both sides: the entry cannot have it (lockstep omits, e.g., the futex waits
            # of a primitive that hides them in a library), never a 0.
            cells.append("unavailable" if before is None and after is None
                         else f"{_number(before)} -> {_number(after)}")
        rows.append(cells)
    out += _table(headings, rows, right={1, 2, 3, 6})
    out.append("")
    geometric_mean = comparison.geometric_mean
    out.append(f"geometric mean of {b}/A over the {len(comparison.rows)} matched pairs: "
               f"{_number(geometric_mean, 3) if geometric_mean else 'unavailable'}")
    significant = [row for row in comparison.rows if row.significant(comparison.alpha)]
    out.append(f"significant at alpha {comparison.alpha:g} (Holm): {len(significant)} "
               f"({sum(r.ratio > 1 for r in significant)} slower, {sum(r.ratio < 1 for r in significant)} faster)")
    for title, keys in ((f"only in A ({comparison.baseline.label}): removed", comparison.removed),
                        (f"only in {b} ({comparison.contender.label}): added", comparison.added)):
        out.append(f"{title}: {len(keys)}")
        out += [f"  {key.display}" for key in keys]
    out.append(f"errored (not compared): {len(comparison.errored)}")
    out += [f"  {key.display} in {where}: {message}" for key, where, message in comparison.errored]
    for warning in comparison.warnings:
        out.append(f"warning: {warning}")
    return out


def across_machines_lines(run_files: list[RunFile], time_kind: str = "real") -> list[str]:
    letters = [chr(ord("A") + i) for i in range(len(run_files))]
    out = ["== Across machines: each file normalised by its own machine", ""]
    out.append("x serial: step time / that run's serial RK4 step (context serial_step_ns); "
               "x c2c: stage sync time / that run's one-way core-to-core latency (context c2c_one_way_ns).")
    rows = []
    for key in rk4_keys(run_files):
        cells = [key.display]
        for run_file in run_files:
            vs_serial, vs_c2c = normalised(run_file, key, time_kind)
            cells += [_number(vs_serial), _number(vs_c2c)]
        rows.append(cells)
    headings = ["benchmark"]
    for letter in letters:
        headings += [f"{letter} x serial", f"{letter} x c2c"]
    out += _table(headings, rows, right=set(range(1, len(headings))))
    out.append("")
    out.append("Layouts against packed (speed-up = packed time / layout time, on each machine):")
    effect_rows = [[sync, pin, str(threads), layout] + [(_number(s) + "x") if s else "-" for s in speedups]
                   for sync, pin, threads, layout, speedups in layout_effects(run_files, time_kind=time_kind)]
    out += _table(["sync", "pin", "threads", "layout"] + [f"{letter} vs packed" for letter in letters],
                  effect_rows, right=set(range(4, 4 + len(letters))))
    out.append("")
    out.append("Rank per machine (fastest first; sync/layout, step time, x serial):")
    for (pin, threads), per_file in rank_tables(run_files, time_kind).items():
        out.append(f"-- pin:{pin} threads:{threads}")
        depth = max((len(entries) for entries in per_file), default=0)
        rank_rows = []
        for rank in range(depth):
            cells = [str(rank + 1)]
            for entries in per_file:
                if rank < len(entries):
                    name, step, vs_serial = entries[rank]
                    cells.append(f"{name} {format_ns(step)} ({_number(vs_serial)}x)")
                else:
                    cells.append("")
            rank_rows.append(cells)
        out += _table(["rank"] + [f"[{letter}] {f.label}" for letter, f in zip(letters, run_files)], rank_rows)
    return out


def render_text(run_files: list[RunFile], comparisons: list[Comparison], time_kind: str = "real") -> str:
    out = ["lockstep compare: " + "  ".join(f"[{chr(ord('A') + i)}] {f.label}" for i, f in enumerate(run_files)),
           ""]
    out += fingerprint_lines(run_files)
    machines = {tuple(fingerprint(f)[key] for key in MACHINE_KEYS) for f in run_files}
    out.append(f"machines: {len(machines)} distinct (by {', '.join(MACHINE_KEYS)})")
    out.append("")
    warnings = [w for f in run_files for w in f.warnings]
    for index, comparison in enumerate(comparisons, start=1):
        out += comparison_lines(comparison, chr(ord("A") + index))
        out.append("")
    out += across_machines_lines(run_files, time_kind)
    if warnings:
        out.append("")
        out += [f"warning: {w}" for w in warnings]
    return "\n".join(out) + "\n"
