"""The pace statistics of a comparison (docs/pace.md): which pace modes of two runs match, each entry's
figure beyond the pace (within matching modes, within one c2c state, or normalised by the c2c reading to its
cluster's elasticity), and the file pair's pooled intervals with the run-to-run drift kept in."""
from __future__ import annotations

import math

from ..analysis.run_analysis import is_calibration
from ..common import statistics
from ..common.fields import UNAVAILABLE
from ..common.names import BenchmarkKey
from ..read.run_file import RunFile
from .comparison import PaceAware, Row, cluster_key

# Two pace modes of two runs are the same mode when their c2c medians (serial medians on a machine of one
# CPU) are within this factor of each other. This VM's modes are 2x apart or more (c2c one-way about 25,
# 55 and 120-270 ns), while one mode's median moves by 10-20 % from run to run; 1.5 keeps the second
# inside a mode and the first apart.
MODE_TOLERANCE = 1.5
# How a pace-aware figure was made (PaceAware.method).
PACE_ONE_MODE, PACE_MATCHING_MODES, PACE_NORMALISED = "one mode", "matching modes", "pace-normalised"
PACE_ONE_STATE = "one c2c state"
# One c2c state (PACE_ONE_STATE): the repetitions whose own c2c reading lies within this factor of one
# reference. This VM's c2c states are 14, 32 and 102 ns; one state's readings around a repetition spread by
# about +-7 % (10th to 90th percentile), and the spinning primitives' steps follow them (elasticity 0.8-1.2).
STATE_WIDTH = 1.2
# Within matching modes needs this many repetitions a side: the median of 3 when the file pair's pooled variance
# gives the interval its degrees of freedom (statistics.pooled_interval); each entry's own exact interval
# (a pair of files with fewer than statistics.MIN_POOLED_ENTRIES entries to pool) needs MIN_REPETITIONS.
MIN_IN_MODE = 3


def same_mode(mode_a, mode_b) -> bool:
    if mode_a.c2c_ns is not None and mode_b.c2c_ns is not None:
        a, b = mode_a.c2c_ns, mode_b.c2c_ns
    elif mode_a.c2c_ns is None and mode_b.c2c_ns is None:
        a, b = mode_a.serial_ns, mode_b.serial_ns
    else:
        return False
    return max(a, b) / min(a, b) <= MODE_TOLERANCE


def matching_modes(baseline: RunFile, contender: RunFile) -> list[tuple[int, int]]:
    """(mode of A, mode of B) for every two modes within MODE_TOLERANCE of each other."""
    return [(mode_a.mode, mode_b.mode) for mode_a in baseline.pace.modes for mode_b in contender.pace.modes
            if same_mode(mode_a, mode_b)]


def modes_differ(baseline: RunFile, contender: RunFile) -> bool | None:
    """Whether the two runs ran in different pace modes (a mode of either without a matching mode in the other);
    None when a file has no pace trace."""
    if baseline.pace is None or contender.pace is None:
        return None
    matches = matching_modes(baseline, contender)
    return (any(all(m.mode != a for a, _ in matches) for m in baseline.pace.modes)
            or any(all(m.mode != b for _, b in matches) for m in contender.pace.modes))


def _paced_values(run, time_kind: str) -> list[tuple[float, object]] | None:
    """(time, pace) of each repetition, or None when a repetition has no pace."""
    values = []
    for repetition in run.repetitions:
        if repetition.pace is None:
            return None
        values.append((repetition.real_ns if time_kind == "real" else repetition.cpu_ns, repetition.pace))
    return values or None


def _one_state(values_a, values_b, need: int):
    """The repetitions of both sides whose own c2c reading (pace_c2c_ns) lies within STATE_WIDTH of one
    reference, the reference that keeps the most on the scarcer side (then the most in all, then the fastest):
    (reference ns, times of A, times of B), or None when a reading is missing or a side keeps fewer than
    `need`."""
    if any(pace.c2c_ns is None for _, pace in values_a + values_b):
        return None
    best = None
    for reference in sorted({pace.c2c_ns for _, pace in values_a + values_b}):
        kept = [[time for time, pace in values if reference / STATE_WIDTH <= pace.c2c_ns <= reference * STATE_WIDTH]
                for values in (values_a, values_b)]
        score = (min(len(kept[0]), len(kept[1])), len(kept[0]) + len(kept[1]))
        if best is None or score > best[0]:
            best = (score, reference, kept)
    (scarcer, _), reference, (times_a, times_b) = best
    return (reference, times_a, times_b) if scarcer >= need else None


def pace_elasticities(baseline: RunFile, contender: RunFile, time_kind: str) -> dict[tuple[str, str], float]:
    """Per cluster (cluster_key), how a step's time follows the c2c reading taken around its repetition: the
    slope of log time on log pace_c2c_ns over the repetitions of both files, each entry's and file's centred
    on their own means (least squares pooled over the cluster's entries), within [0, 1]. Only the readings'
    movement inside each run enters it, so a change between the runs is never taken for pace. A cluster
    whose readings did not move: absent (the plain division). Measured on this VM: 0.8-1.2 for the spinning
    primitives at threads:2, 0-0.5 for the sleeping ones and at threads:4, alike in four pairs of runs."""
    sums: dict[tuple[str, str], list[float]] = {}
    for run_file in (baseline, contender):
        for key in sorted(run_file.runs, key=BenchmarkKey.sort_key):  # sums in one order: the same bits always
            run = run_file.runs[key]
            if is_calibration(key) or run.errored:
                continue
            paced = sorted((r.real_ns if time_kind == "real" else r.cpu_ns, r.pace.c2c_ns) for r in run.repetitions
                           if r.pace is not None and r.pace.c2c_ns)
            if len(paced) < 2 or max(c for _, c in paced) <= min(c for _, c in paced) * (1.0 + 1e-9):
                continue  # readings that did not move say nothing of how the time follows them
            times = [math.log(time) for time, _ in paced]
            readings = [math.log(reading) for _, reading in paced]
            mean_time, mean_reading = sum(times) / len(times), sum(readings) / len(readings)
            cell = sums.setdefault(cluster_key(key), [0.0, 0.0])
            cell[0] += sum((t - mean_time) * (c - mean_reading) for t, c in zip(times, readings))
            cell[1] += sum((c - mean_reading) ** 2 for c in readings)
    return {cell: min(max(covariance / variance, 0.0), 1.0) for cell, (covariance, variance) in sums.items()
            if variance > 0.0}


def pace_aware(run_a, run_b, baseline: RunFile, contender: RunFile, matches, time_kind: str,
               min_in_mode: int = statistics.MIN_REPETITIONS, elasticity: float = 1.0) -> PaceAware | None:
    """The entry compared beyond the pace (see the module's text), or None where the pace is unavailable.
    Within matching modes when each side keeps `min_in_mode` repetitions there (MIN_IN_MODE when the file
    pair's evidence is pooled); within one c2c state (_one_state) where the repetitions so chosen, or all of
    them when no mode matches, ran in more than one state and each side keeps `min_in_mode` in one; else
    each time divided by its c2c reading to the power `elasticity` (pace_elasticities)."""
    values_a, values_b = _paced_values(run_a, time_kind), _paced_values(run_b, time_kind)
    if values_a is None or values_b is None:
        return None

    def in_mode(values, mode):
        return [(time, pace) for time, pace in values if pace.mode == mode]

    modes_a, modes_b = {pace.mode for _, pace in values_a}, {pace.mode for _, pace in values_b}
    chosen = None  # (method, detail, the chosen (time, pace) of A, of B)
    if len(modes_a) == 1 and len(modes_b) == 1 and (next(iter(modes_a)), next(iter(modes_b))) in matches:
        mode_a, mode_b = (f.pace.modes[next(iter(m))] for f, m in ((baseline, modes_a), (contender, modes_b)))
        chosen = (PACE_ONE_MODE, f"every repetition in one mode (c2c {_short(mode_a.c2c_ns)} / "
                                 f"{_short(mode_b.c2c_ns)} ns)", values_a, values_b)
    else:
        best = max(matches, key=lambda pair: (min(len(in_mode(values_a, pair[0])), len(in_mode(values_b, pair[1]))),
                                              -pair[0], -pair[1]), default=None)
        filled = best and min(len(in_mode(values_a, best[0])), len(in_mode(values_b, best[1])))
        if best and filled >= min_in_mode:
            chosen = (PACE_MATCHING_MODES,
                      f"the repetitions in matching modes A {best[0]} / B {best[1]} (c2c "
                      f"{_short(baseline.pace.modes[best[0]].c2c_ns)} / "
                      f"{_short(contender.pace.modes[best[1]].c2c_ns)} ns)",
                      in_mode(values_a, best[0]), in_mode(values_b, best[1]))
    # A mode of the trace can join two states of the machine that its readings bridge (this VM: c2c 14 and
    # 32 ns in one mode, the spinning primitives 2x apart between them); a repetition's own reading tells them
    # apart.
    pool_a, pool_b = (chosen[2], chosen[3]) if chosen else (values_a, values_b)
    state = _one_state(pool_a, pool_b, min_in_mode)
    power = 1.0
    if state and len(state[1]) + len(state[2]) < len(pool_a) + len(pool_b):
        reference, times_a, times_b = state
        method = PACE_ONE_STATE
        detail = (f"the repetitions whose c2c reading is within {STATE_WIDTH:g}x of {reference:.0f} ns "
                  f"(A {len(times_a)} of {len(values_a)}, B {len(times_b)} of {len(values_b)})")
    elif chosen:
        method, detail = chosen[0], chosen[1]
        times_a, times_b = [time for time, _ in chosen[2]], [time for time, _ in chosen[3]]
    else:
        by_c2c = all(p.c2c_ns is not None for _, p in values_a + values_b)
        by_serial = all(p.serial_ns is not None for _, p in values_a + values_b)
        if not (by_c2c or by_serial):
            return None
        reading = "c2c_ns" if by_c2c else "serial_ns"
        power = elasticity if by_c2c else 1.0
        times_a = [time / getattr(pace, reading) ** power for time, pace in values_a]
        times_b = [time / getattr(pace, reading) ** power for time, pace in values_b]
        detail = f"time / pace_{reading} of each repetition" + (f" to the power {power:.2f} (the cluster's "
                                                                  f"elasticity)" if power != 1.0 else "")
        method = PACE_NORMALISED
    ratio = statistics.median(times_b) / statistics.median(times_a)
    return PaceAware(method, detail, ratio, statistics.shift_interval(times_a, times_b), len(times_a), len(times_b),
                     tuple(times_a), tuple(times_b), power=power)


def _log_variance(values_a, values_b) -> tuple[float | None, int]:
    """The pooled variance of log values within the two sides, and its degrees of freedom (n_a + n_b - 2);
    None with no degree of freedom."""
    logs = [[math.log(value) for value in side] for side in (values_a, values_b)]
    degrees = sum(len(side) for side in logs) - 2
    if degrees < 1 or any(not side for side in logs):
        return None, 0
    squares = sum(sum((value - sum(side) / len(side)) ** 2 for value in side) for side in logs)
    return squares / degrees, degrees


def pool_evidence(rows: list[Row]) -> tuple[float | None, int]:
    """Give every row's pace-aware figure the file pair's interval (statistics.pooled_interval): its variance of
    log time moderated by the prior every row's variance fits, plus the drift calibrated from every row's log
    ratio. Returns (the drift, the rows pooled); (None, 0) and the rows' own exact intervals left as they are
    when fewer than statistics.MIN_POOLED_ENTRIES rows have a variance."""
    paced = [row for row in rows if row.pace is not None and not row.collapsed and row.pace.values_a
             and row.pace.values_b]
    variances = [_log_variance(row.pace.values_a, row.pace.values_b) for row in paced]
    prior = statistics.prior_variance([v for v, _ in variances], [d for _, d in variances])
    if prior is None:
        return None, 0
    sampling = []
    for row, (variance, degrees) in zip(paced, variances):
        moderated, total = statistics.moderated_variance(variance, degrees, prior)
        sampling.append((moderated * (1.0 / len(row.pace.values_a) + 1.0 / len(row.pace.values_b)), total))
    logs = [math.log(row.pace.ratio) for row in paced]
    drift = statistics.calibrated_drift(logs, [variance for variance, _ in sampling])
    for row, log_ratio, (variance, degrees) in zip(paced, logs, sampling):
        row.pace.interval = statistics.pooled_interval(log_ratio, variance, degrees, drift)
        row.pace.pooled = True
    return drift, len(paced)


def _short(value: float | None) -> str:
    return UNAVAILABLE if value is None else f"{value:.0f}"
