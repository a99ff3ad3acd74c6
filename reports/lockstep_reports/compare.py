"""`lockstep compare A.json B.json [more...]`: what changed between runs and machines, and whether it is real.

The first file is the baseline; every other file is compared with it. Within
one comparison, entries are matched by their parsed names (names.py); the
ones that are only in one file, or that errored, are listed, never dropped
and never counted as zero. Across files, each machine is shown by its
fingerprint and normalised by its own in-run core-to-core latency and serial
step time, so that effects can be read side by side.

Verdicts (Criterion.rs's rule, with its noise threshold): an entry is
"slower" or "faster" only when its Mann-Whitney test is significant after
Holm's correction AND the whole confidence interval of its ratio lies beyond
the noise threshold (above 1 + NOISE/100, or below 1 / (1 + NOISE/100)). A
significant shift whose interval reaches inside the threshold is "within
noise": real in the statistical sense, too small to tell from the machine
drifting between runs. Repetitions inside one run share that run's state of
the machine, so the test alone calls a between-run shift of a few percent
"significant"; the threshold is what stands for the run-to-run variance the
repetitions cannot see.

Calibrations: `rk4/serial`, `c2c/...` and the `overhead/...` pair measure the
machine and the instrumentation, not a combination of primitive, layout and
placement. They are compared in a block of their own (c2c by its one_way_ns
counter: its iteration time is thread start-up plus the measurement), tested
as a family of their own, and kept out of the geometric mean, the verdict
counts and --fail-above. The context's in-run calibrations of the two files
give one line saying how far the machine itself moved between the runs; the
time comparisons are never rescaled by it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from . import statistics
from .fields import (BACK_TO_BACK_ORDER, C2C_CONTEXT, C2C_COUNTER, COUNTERS_SHOWN, FINGERPRINT_KEYS, MACHINE_KEYS,
                     SERIAL_CONTEXT, SYNC_COUNTER, UNAVAILABLE, VS_C2C_COUNTER, VS_SERIAL_COUNTER)
from .formatting import format_ns, format_number
from .inputs import RunFile
from .names import BenchmarkKey, parse_name

# The default noise threshold, percent (see NOISE_RATIONALE).
DEFAULT_NOISE_PERCENT = 5.0
NOISE_RATIONALE = (
    "between two back-to-back runs on a 2-vCPU KVM guest the machine's own calibrations and the fast "
    "rk4 entries moved by 4-5 % with tiny p (repetitions inside a run cannot see that drift); 5 % with the "
    "whole interval beyond it keeps such drift out of the verdicts while a change of 10 % or more still "
    "shows; on a quiet bare-metal machine --noise 1 (Criterion.rs's default) or 2 fits")

# Families that measure the machine or the instrumentation, not a combination.
CALIBRATION_FAMILIES = ("c2c", "overhead")
# The in-run calibration entries: compared apart, and read when the context lacks the value.
SERIAL_ENTRY = "rk4/serial"
C2C_ENTRY = "c2c/pin:compact/threads:2"


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
    measure: str = "time"  # what median_a / median_b are: "time", or a counter's name

    def significant(self, alpha: float) -> bool:
        return self.p_adjusted is not None and self.p_adjusted < alpha

    def beyond_noise(self, noise_percent: float) -> str | None:
        """"slower" / "faster" when the whole interval (the ratio itself when there is none) lies beyond
        the threshold, else None."""
        upper_limit = 1.0 + noise_percent / 100.0
        low, high = self.interval if self.interval else (self.ratio, self.ratio)
        if low > upper_limit:
            return "slower"
        if high < 1.0 / upper_limit:
            return "faster"
        return None

    def verdict(self, alpha: float, noise_percent: float = 0.0) -> str:
        """untested, same (not significant), within noise (significant, interval reaches inside the
        threshold), slower or faster (significant and beyond the threshold)."""
        if self.p_adjusted is None:
            return "untested"
        if not self.significant(alpha):
            return "same"
        return self.beyond_noise(noise_percent) or "within noise"


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
    noise_percent: float = DEFAULT_NOISE_PERCENT
    calibrations: list[Row] = field(default_factory=list)  # rk4/serial, c2c, overhead: their own family

    @property
    def geometric_mean(self) -> float | None:
        return statistics.geometric_mean([row.ratio for row in self.rows])

    def verdict(self, row: Row) -> str:
        return row.verdict(self.alpha, self.noise_percent)

    def verdict_counts(self) -> dict[str, int]:
        counts = {name: 0 for name in ("slower", "faster", "within noise", "same", "untested")}
        for row in self.rows:
            counts[self.verdict(row)] += 1
        return counts

    def regressions_beyond(self, percent: float) -> list[Row]:
        """Combinations that are "slower" (significant, whole interval beyond the noise threshold) with a
        ratio above 1 + percent/100. Calibrations never count."""
        limit = 1.0 + percent / 100.0
        return [row for row in self.rows if self.verdict(row) == "slower" and row.ratio > limit]

    def calibration_moves(self) -> list[tuple[str, str, float | None, float | None, float | None]]:
        """(name, unit, A, B, change B/A - 1 in percent) of the context's in-run calibrations (the entries'
        medians when the context lacks them); the change is None when either side is unavailable."""
        moves = []
        for name, context_key in (("c2c one-way", C2C_CONTEXT), ("serial step", SERIAL_CONTEXT)):
            before, after = calibration(self.baseline, context_key), calibration(self.contender, context_key)
            change = (after / before - 1.0) * 100.0 if (before and after) else None
            moves.append((name, "ns", before, after, change))
        return moves

    def accounting_overheads(self) -> list[tuple[BenchmarkKey, float | None, float | None]]:
        """Per overhead combination: median time with accounting on / with it off, in A and in B."""
        result = []
        pairs = {}
        for run_file in (self.baseline, self.contender):
            for key in run_file.runs:
                if key.family == "overhead" and key.get("accounting") in ("on", "off"):
                    pairs.setdefault(key.without("accounting"), set()).add(key)
        for base in sorted(pairs, key=BenchmarkKey.sort_key):
            on, off = base.replaced("accounting", "on"), base.replaced("accounting", "off")
            ratios = []
            for run_file in (self.baseline, self.contender):
                time_on = run_median(run_file, on, self.time_kind)
                time_off = run_median(run_file, off, self.time_kind)
                ratios.append(time_on / time_off if (time_on and time_off) else None)
            result.append((base, ratios[0], ratios[1]))
        return result


def is_calibration(key: BenchmarkKey) -> bool:
    return key.family in CALIBRATION_FAMILIES or key.display == SERIAL_ENTRY


def sample(run, time_kind: str = "real") -> tuple[list[float], bool]:
    """The repetition times of a run, or its median aggregate alone (False: no repetitions)."""
    times = run.times_ns(time_kind)
    if times:
        return times, True
    for aggregate in ("median", "mean"):
        value = run.aggregate_time_ns(aggregate, time_kind)
        if value is not None:
            return [value], False
    return [], False


def _calibration_sample(key: BenchmarkKey, run, time_kind: str) -> tuple[list[float], bool, str]:
    """A calibration entry's values: c2c by its one_way_ns counter when every repetition has it."""
    if key.family == "c2c":
        values = [r.counters[C2C_COUNTER] for r in run.repetitions if C2C_COUNTER in r.counters]
        if values and len(values) == len(run.repetitions):
            return values, True, C2C_COUNTER
        aggregate = run.aggregates.get("median")
        if not run.repetitions and aggregate and C2C_COUNTER in aggregate.counters:
            return [aggregate.counters[C2C_COUNTER]], False, C2C_COUNTER
    times, repeated = sample(run, time_kind)
    return times, repeated, "time"


def compare_pair(baseline: RunFile, contender: RunFile, time_kind: str = "real", alpha: float = 0.05,
                 noise_percent: float = DEFAULT_NOISE_PERCENT) -> Comparison:
    keys_a, keys_b = set(baseline.runs), set(contender.runs)
    rows, calibration_rows, errored, warnings = [], [], [], []
    untested = []
    for key in sorted(keys_a & keys_b, key=BenchmarkKey.sort_key):
        run_a, run_b = baseline.runs[key], contender.runs[key]
        if run_a.errored or run_b.errored:
            where = " and ".join(label for label, run in ((baseline.label, run_a), (contender.label, run_b))
                                 if run.errored)
            message = "; ".join(run_a.errors + [e for e in run_b.errors if e not in run_a.errors])
            errored.append((key, where, message))
            continue
        calibrating = is_calibration(key)
        if calibrating:
            times_a, reps_a, measure_a = _calibration_sample(key, run_a, time_kind)
            times_b, reps_b, measure_b = _calibration_sample(key, run_b, time_kind)
            if measure_a != measure_b:  # one file has the counter, the other not: compare like with like
                times_a, reps_a = sample(run_a, time_kind)
                times_b, reps_b = sample(run_b, time_kind)
                measure_a = "time"
        else:
            times_a, reps_a = sample(run_a, time_kind)
            times_b, reps_b = sample(run_b, time_kind)
            measure_a = "time"
        if not times_a or not times_b:
            errored.append((key, baseline.label if not times_a else contender.label, "no usable time"))
            continue
        median_a, median_b = statistics.median(times_a), statistics.median(times_b)
        ratio = median_b / median_a  # inputs.py keeps every time within [SHORTEST_NS, LONGEST_NS]
        interval = statistics.ratio_interval(times_a, times_b, key.display) if reps_a and reps_b else None
        p_raw = statistics.mann_whitney_p(times_a, times_b) if reps_a and reps_b else None
        if p_raw is None and not calibrating:
            untested.append(key)
        counters = {}
        for counter, _ in COUNTERS_SHOWN:
            values_a, values_b = run_a.counter_values(counter), run_b.counter_values(counter)
            if values_a or values_b:
                counters[counter] = (statistics.median(values_a) if values_a else None,
                                     statistics.median(values_b) if values_b else None)
        row = Row(key, median_a, median_b, len(times_a) if reps_a else 0, len(times_b) if reps_b else 0,
                  ratio, interval, p_raw, counters=counters, measure=measure_a)
        (calibration_rows if calibrating else rows).append(row)
    # Two families, each Holm-corrected on its own: the combinations, and the calibrations.
    for family in (rows, calibration_rows):
        for row, adjusted in zip(family, statistics.holm([row.p_raw for row in family])):
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
    back_to_back = [run_file.label for run_file in (baseline, contender)
                    if str(run_file.context.get("lockstep_order", "")).startswith(BACK_TO_BACK_ORDER)]
    if back_to_back:
        warnings.append(f"{' and '.join(back_to_back)} measured every entry's repetitions back to back "
                        f"(context lockstep_order): a drift of the machine during the run shifts the entries that "
                        f"ran at that moment, with a tiny p; `lockstep run --interleave` spreads it over every "
                        f"entry")
    if untested:
        warnings.append(f"{len(untested)} of {len(rows)} matched entries have fewer than "
                        f"{statistics.MIN_REPETITIONS} repetitions on a side: no Mann-Whitney U test for them "
                        f"(`lockstep run --repetitions {max(statistics.MIN_REPETITIONS, 10)}` or more)")
    errored.sort(key=lambda item: item[0].sort_key())
    return Comparison(baseline, contender, rows,
                      added=sorted(keys_b - keys_a, key=BenchmarkKey.sort_key),
                      removed=sorted(keys_a - keys_b, key=BenchmarkKey.sort_key),
                      errored=errored, warnings=warnings, time_kind=time_kind, alpha=alpha,
                      noise_percent=noise_percent, calibrations=calibration_rows)


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
    times, _ = sample(run, time_kind)
    return statistics.median(times) if times else None


def calibration(run_file: RunFile, context_key: str) -> float | None:
    """serial_step_ns or c2c_one_way_ns: the context's value, else the median of the in-run entry
    (for c2c, of its one_way_ns counter when it has one: its iteration time includes thread start-up)."""
    value = run_file.context_number(context_key)
    if value is not None:
        return value
    if context_key == SERIAL_CONTEXT:
        return run_median(run_file, parse_name(SERIAL_ENTRY))
    key = parse_name(C2C_ENTRY)
    run = run_file.runs.get(key)
    if run is None or run.errored:
        return None
    one_way = run.counter_values(C2C_COUNTER)
    if one_way:
        return statistics.median(one_way)
    return run_median(run_file, key)


def normalised(run_file: RunFile, key: BenchmarkKey, time_kind: str = "real") -> tuple[float | None, float | None]:
    """(step time / serial step time, stage sync time / one-way c2c latency) on that file's own machine.

    Uses the in-run calibrations of the context; falls back to the entry's own
    vs_serial / vs_c2c counters; None ("unavailable") when neither exists."""
    run = run_file.runs.get(key)
    if run is None or run.errored:
        return None, None
    step = run_median(run_file, key, time_kind)
    serial = calibration(run_file, SERIAL_CONTEXT)
    c2c = calibration(run_file, C2C_CONTEXT)
    vs_serial = step / serial if (step is not None and serial) else None
    if vs_serial is None and run.counter_values(VS_SERIAL_COUNTER):
        vs_serial = statistics.median(run.counter_values(VS_SERIAL_COUNTER))
    sync = run.counter_values(SYNC_COUNTER)
    vs_c2c = statistics.median(sync) / c2c if (sync and c2c) else None
    if vs_c2c is None and run.counter_values(VS_C2C_COUNTER):
        vs_c2c = statistics.median(run.counter_values(VS_C2C_COUNTER))
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
                serial = calibration(run_file, SERIAL_CONTEXT)
                entries.append((f"{key.get('sync')}/{key.get('layout')}", step, step / serial if serial else None))
            entries.sort(key=lambda entry: (entry[1], entry[0]))
            per_file.append(entries[:top])
        tables[group] = per_file
    return tables


# ---------------------------------------------------------------- text output

def _number(value: float | None, digits: int = 2) -> str:
    """A cell of a numeric column: "-" where there is nothing to show."""
    return format_number(value, digits, missing="-")


def file_letter(index: int) -> str:
    """The letter of the index-th file: A is the baseline."""
    return chr(ord("A") + index)


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
    labels = [f"[{file_letter(i)}] {f.label}" for i, f in enumerate(run_files)]
    prints = [fingerprint(f) for f in run_files]
    rows = []
    for key in FINGERPRINT_KEYS:
        values = [p[key] or UNAVAILABLE for p in prints]
        mark = "*" if len(set(values)) > 1 else ""
        rows.append([key + mark] + values)
    return _table(["context (* differs)"] + labels, rows)


def _percent(value: float) -> str:
    return f"{value:+.1f} %"


def calibration_move_line(comparison: Comparison, letter: str) -> str:
    """How far the machine itself moved between the two runs, by the context's in-run calibrations."""
    parts, moves = [], []
    for name, unit, before, after, move in comparison.calibration_moves():
        if move is not None:
            moves.append((name, move))
            digits = 2 if max(before, after) < 100 and name.startswith("serial") else 1
            parts.append(f"{name} {before:.{digits}f} -> {after:.{digits}f} {unit} ({_percent(move)})")
        else:
            parts.append(f"{name} {UNAVAILABLE}")
    line = (f"calibrations moved, {letter} against A (in-run medians from each file's context, else from its "
            f"calibration entries; the comparisons below are not rescaled by them): " + ", ".join(parts))
    noise = comparison.noise_percent
    limit = 1.0 + noise / 100.0
    beyond = [name for name, move in moves if not (1.0 / limit <= 1.0 + move / 100.0 <= limit)]
    if not moves:
        return line + ": the machine's movement between the runs is unknown."
    if beyond:
        return (line + f". {' and '.join(beyond)} moved beyond the ±{noise:g} % noise threshold: the machine "
                "itself changed between the runs (or they are different machines), so shifts of that size below "
                "may be the machine, not the code.")
    return line + f": inside the ±{noise:g} % noise threshold."


def _row_cells(comparison: Comparison, row: Row) -> list[str]:
    interval = f"[{row.interval[0]:.3f}, {row.interval[1]:.3f}]" if row.interval else "-"
    return [format_ns(row.median_a), format_ns(row.median_b), f"{row.ratio:.3f}", interval,
            f"{row.repetitions_a}/{row.repetitions_b}", _p(row.p_adjusted), comparison.verdict(row)]


def comparison_lines(comparison: Comparison, letter: str) -> list[str]:
    a, b = "A", letter
    noise = comparison.noise_percent
    limit = 1.0 + noise / 100.0
    out = [f"== {b} ({comparison.contender.label}) against A ({comparison.baseline.label})", ""]
    out.append(calibration_move_line(comparison, b))
    out.append("")
    kind = "real" if comparison.time_kind == "real" else "CPU"
    out.append(f"time: {kind} time (the ns_per_step or ns_per_episode counter where an entry has it, else per iteration), median of "
               f"the repetitions; ratio {b}/A of the medians (> 1: {b} is slower) with a "
               f"{int(statistics.CONFIDENCE * 100)}% bootstrap interval ({statistics.BOOTSTRAP_RESAMPLES} resamples, "
               f"fixed seed); p: two-sided Mann-Whitney U, Holm-corrected over the "
               f"{sum(r.p_raw is not None for r in comparison.rows)} tests of this comparison's combinations; "
               f"counters are medians, {a} -> {b}.")
    out.append(f"verdict: slower / faster = Holm p < alpha {comparison.alpha:g} and the whole interval beyond "
               f"the noise threshold of {noise:g} % ({b}/A above {limit:.3f} or below {1.0 / limit:.3f}; "
               f"--noise PCT); within noise = significant, but the interval reaches inside the threshold (a shift "
               f"the size of the machine's own run-to-run drift); same = not significant; untested = too few "
               f"repetitions.")
    out.append("")
    counters_present = [(c, h) for c, h in COUNTERS_SHOWN if any(c in row.counters for row in comparison.rows)]
    headings = ["benchmark", f"{a} median", f"{b} median", f"{b}/A", "95% interval", "reps", "p (Holm)",
                "verdict"] + [h for _, h in counters_present]
    rows = []
    for row in comparison.rows:
        cells = [row.key.display] + _row_cells(comparison, row)
        for counter, _ in counters_present:
            before, after = row.counters.get(counter, (None, None))
            # Absent on both sides: the entry cannot have it (lockstep omits, e.g., the futex waits
            # of a primitive that hides them in a library), never a 0.
            cells.append(UNAVAILABLE if before is None and after is None
                         else f"{format_number(before)} -> {format_number(after)}")
        rows.append(cells)
    out += _table(headings, rows, right={1, 2, 3, 6})
    out.append("")
    geometric_mean = comparison.geometric_mean
    out.append(f"geometric mean of {b}/A over the {len(comparison.rows)} matched pairs (combinations only, "
               f"calibrations apart): {format_number(geometric_mean, 3)}")
    counts = comparison.verdict_counts()
    out.append(f"verdicts at alpha {comparison.alpha:g} (Holm) and the {noise:g} % noise threshold: "
               f"{counts['slower']} slower, {counts['faster']} faster, {counts['within noise']} within noise "
               f"(significant, inside the threshold), {counts['same']} same, {counts['untested']} untested")
    if comparison.calibrations:
        out.append("")
        out.append(f"calibrations ({len(comparison.calibrations)}): the machine and the instrumentation, not a "
                   f"combination; c2c compared by its {C2C_COUNTER} counter (its iteration time is thread start-up "
                   f"plus the measurement), the overhead pair and rk4/serial by their time; Holm-corrected over "
                   f"these {sum(r.p_raw is not None for r in comparison.calibrations)} tests on their own; not in "
                   f"the geometric mean, the counts above or --fail-above.")
        calibration_rows = [[row.key.display, row.measure] + _row_cells(comparison, row)
                            for row in comparison.calibrations]
        out += _table(["calibration", "measure", f"{a} median", f"{b} median", f"{b}/A", "95% interval", "reps",
                       "p (Holm)", "verdict"], calibration_rows, right={2, 3, 4, 7})
        for key, ratio_a, ratio_b in comparison.accounting_overheads():
            out.append(f"accounting overhead of {key.display} (time with accounting:on / off): "
                       f"A {_number(ratio_a, 3)}, {b} {_number(ratio_b, 3)}")
    out.append("")
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
    letters = [file_letter(i) for i in range(len(run_files))]
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


def render_text(run_files: list[RunFile], comparisons: list[Comparison], time_kind: str = "real",
                context_files=()) -> str:
    """`context_files`: results of other kinds (inputs.ContextFile), shown in the fingerprint only, after the
    run files (so a run file's letter is its place among the compared files)."""
    all_files = list(run_files) + list(context_files)
    out = ["lockstep compare: " + "  ".join(f"[{file_letter(i)}] {f.label}" for i, f in enumerate(all_files))]
    if comparisons:
        noise = comparisons[0].noise_percent
        if noise == DEFAULT_NOISE_PERCENT:
            out.append(f"noise threshold: {noise:g} % (the default, --noise PCT to change it: {NOISE_RATIONALE})")
        else:
            out.append(f"noise threshold: {noise:g} % (--noise; the default is {DEFAULT_NOISE_PERCENT:g} %)")
    out.append("")
    out += fingerprint_lines(all_files)
    machines = {tuple(fingerprint(f)[key] for key in MACHINE_KEYS) for f in all_files}
    out.append(f"machines: {len(machines)} distinct (by {', '.join(MACHINE_KEYS)})")
    if context_files:
        out.append("fingerprint only (not benchmark results): " +
                   ", ".join(f"{f.label} (lockstep {f.kind})" for f in context_files))
    out.append("")
    warnings = [w for f in all_files for w in f.warnings]
    for index, comparison in enumerate(comparisons, start=1):
        out += comparison_lines(comparison, file_letter(index))
        out.append("")
    if run_files:
        out += across_machines_lines(run_files, time_kind)
    if warnings:
        out.append("")
        out += [f"warning: {w}" for w in warnings]
    return "\n".join(out) + "\n"
