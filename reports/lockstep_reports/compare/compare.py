"""`lockstep compare A.json B.json [more...]`: what changed between runs and machines, and whether it is real.

The first file is the baseline; every other file is compared with it. Within
one comparison, entries are matched by their parsed names (names.py); the
ones that are only in one file, or that errored, are listed, never dropped
and never counted as zero. Across files, each machine is shown by its
fingerprint and normalised by its own in-run core-to-core latency and serial
step time, so that effects can be read side by side.

Verdicts: the interval against the noise band. Each entry's B/A gets the
exact distribution-free 95 % interval of the shift between its repetitions
(statistics.shift_interval). "slower" / "faster" only when the whole interval
lies beyond the noise band (above 1 + NOISE/100, or below 1 / (1 + NOISE/100));
"within noise" when it lies wholly inside; "unsure" when it reaches across an
edge of the band (more repetitions would tell); "untested" with too few
repetitions for a 95 % interval. The Mann-Whitney p of each entry is shown
Benjamini-Hochberg-adjusted (q) over the entries of the comparison, and the
counts say how many calls also pass q < alpha. Repetitions inside one run
share that run's state of the machine; the band stands for the run-to-run
drift they cannot see.

Pace (docs/pace.md): when both files carry a pace trace, their modes are matched
by c2c within MODE_TOLERANCE, compare says whether the runs ran in the same
modes, and every entry also gets a pace-aware verdict: the raw one where all
its repetitions ran in one matching mode; else within the matching modes
(only the repetitions of the best-filled pair of matching modes) when each
side keeps MIN_IN_MODE there (MIN_REPETITIONS where the evidence is not
pooled, below); within one c2c state where the repetitions so chosen (all of
them when no mode matches) ran in more than one state of the machine and each
side keeps as many in one (their own c2c reading within STATE_WIDTH of one
reference: a mode of the trace can join two states its readings bridge); else
on the pace-normalised figure, each
repetition's time divided by the c2c reading taken around it (pace_c2c_ns)
to the power of its cluster's elasticity (pace_elasticities: how far the
cluster's times follow the readings inside each run; a sleeping primitive's
barely do).
The summary's count of changed entries counts what changed beyond the pace:
the pace-aware verdict where there is one, else the raw one.

More evidence at the same run time, the drift kept in (statistics.py,
pooled_interval): when at least statistics.MIN_POOLED_ENTRIES entries of the
file pair have a pace-aware figure, their intervals are not each its own exact
one. Each entry's variance of log time within its runs is moderated towards the
whole file pair's (an entry borrows the degrees of freedom of hundreds, so 3
repetitions a side in a matching mode are enough: MIN_IN_MODE), and the drift
between the two runs, which repetitions inside one run cannot see, is
calibrated from the spread of every entry's log ratio and added to each
entry's variance. An entry whose interval reaches across the band says the
smallest change it could have shown (statistics.detectable_change).

The answer first: the geometric mean of B/A over the matched combinations
(the beyond-the-pace ratio of each; calibrations and collapsed entries apart)
with an interval and a verdict, overall and per primitive, thread count and
placement (Aggregate). A uniform change that no single entry can show is called
there. The interval is a two-stage bootstrap over clusters (cluster_key: a
primitive at one thread count), then the entries of each drawn cluster, because
between two runs whole clusters drift together: a block of primitives that
slowed reads as spread, a shift common to every cluster stays tight. A group of
fewer than MIN_AGGREGATE_CLUSTERS clusters (a primitive's own) also carries the
file pair's spread of whole clusters (cluster_drifts), which it cannot show. Entries that either file's answer
calls collapsed (they ran oversubscribed at 100 times the best of their kind
or more, with one repetition) are "collapsed", never "untested", and stay out
of the aggregates and --fail-above.

Calibrations: `rk4/serial` (and a chain's `rk4/model:chainS/serial`), `mpi/pingpong/...`, `c2c/...`
and the `overhead/...` pair measure the machine and the instrumentation, not a
combination of primitive, layout and placement. They are compared in a block of their own (c2c by its one_way_ns
counter: its iteration time is thread start-up plus the measurement), tested
as a family of their own, and kept out of the geometric mean, the verdict
counts and --fail-above. The context's in-run calibrations of the two files
give one line saying how far the machine itself moved between the runs; the
time comparisons are never rescaled by it.

This module makes one comparison (compare_pair); its parts live by job: comparison.py (what a comparison holds:
rows, aggregates, verdict words), pace_statistics.py (the pace), run_analysis.py (what one file gives: samples,
medians, calibrations), normalisation.py (each machine by its own measure) and compare_text.py (the text).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..analysis.run_analysis import is_calibration, sample
from ..common import statistics
from ..common.fields import BACK_TO_BACK_ORDER, C2C_COUNTER, COUNTERS_SHOWN, PER_UNIT_TIMES_SCHEMA, UNAVAILABLE
from ..common.names import BenchmarkKey
from ..read.run_file import RunFile
from .comparison import DEFAULT_NOISE_PERCENT, Comparison, Row, cluster_key
from .pace_statistics import MIN_IN_MODE, matching_modes, modes_differ, pace_aware, pace_elasticities, pool_evidence


def calibration_sample(key: BenchmarkKey, run, time_kind: str) -> tuple[list[float], bool, str]:
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


@dataclass(frozen=True)
class _Pace:
    """What the pace of two files gives every entry's comparison: whether the runs ran in different modes (None:
    a file has no pace trace), the matching modes, and each cluster's elasticity to the c2c reading."""
    different_modes: bool | None
    matches: list[tuple[int, int]]
    elasticities: dict[tuple[str, str], float]

    @classmethod
    def of(cls, baseline: RunFile, contender: RunFile, time_kind: str) -> "_Pace":
        different = modes_differ(baseline, contender)
        if different is None:
            return cls(None, [], {})
        return cls(different, matching_modes(baseline, contender), pace_elasticities(baseline, contender, time_kind))


def _samples(key: BenchmarkKey, run_a, run_b, time_kind: str):
    """(times of A, repeated in A, times of B, repeated in B, measure) of one matched entry: a calibration's by
    calibration_sample where both files have the same measure, else both sides' times."""
    if is_calibration(key):
        times_a, reps_a, measure_a = calibration_sample(key, run_a, time_kind)
        times_b, reps_b, measure_b = calibration_sample(key, run_b, time_kind)
        if measure_a == measure_b:
            return times_a, reps_a, times_b, reps_b, measure_a
        # One file has the counter, the other not: compare like with like.
    times_a, reps_a = sample(run_a, time_kind)
    times_b, reps_b = sample(run_b, time_kind)
    return times_a, reps_a, times_b, reps_b, "time"


def _counters(run_a, run_b) -> dict[str, tuple[float | None, float | None]]:
    """The median of each counter shown (fields.COUNTERS_SHOWN) in A and in B, where either file has it."""
    counters = {}
    for counter, _ in COUNTERS_SHOWN:
        values_a, values_b = run_a.counter_values(counter), run_b.counter_values(counter)
        if values_a or values_b:
            counters[counter] = (statistics.median(values_a) if values_a else None,
                                 statistics.median(values_b) if values_b else None)
    return counters


def _row(key: BenchmarkKey, baseline: RunFile, contender: RunFile, time_kind: str, pace: _Pace,
         collapsed: frozenset) -> Row | tuple[str, str]:
    """One matched entry's comparison (Row: the medians, their ratio, the exact interval, the Mann-Whitney p, the
    counters and, for a combination of two paced files, its figure beyond the pace), or (where, message) when it
    cannot be compared."""
    run_a, run_b = baseline.runs[key], contender.runs[key]
    if run_a.errored or run_b.errored:
        where = " and ".join(label for label, run in ((baseline.label, run_a), (contender.label, run_b))
                             if run.errored)
        return where, "; ".join(run_a.errors + [e for e in run_b.errors if e not in run_a.errors])
    times_a, reps_a, times_b, reps_b, measure = _samples(key, run_a, run_b, time_kind)
    if not times_a or not times_b:
        return (baseline.label if not times_a else contender.label), "no usable time"
    calibrating = is_calibration(key)
    median_a, median_b = statistics.median(times_a), statistics.median(times_b)
    row = Row(key, median_a, median_b, len(times_a) if reps_a else 0, len(times_b) if reps_b else 0,
              median_b / median_a,  # the readers keep every time within [SHORTEST_NS, LONGEST_NS]
              statistics.shift_interval(times_a, times_b) if reps_a and reps_b else None,
              statistics.mann_whitney_p(times_a, times_b) if reps_a and reps_b else None,
              counters=_counters(run_a, run_b), measure=measure, collapsed=not calibrating and key in collapsed)
    if pace.different_modes is not None and not calibrating and measure == "time":
        row.pace = pace_aware(run_a, run_b, baseline, contender, pace.matches, time_kind, MIN_IN_MODE,
                              pace.elasticities.get(cluster_key(key), 1.0))
    return row


def _pool(rows: list[Row], baseline: RunFile, contender: RunFile, time_kind: str, pace: _Pace):
    """The file pair's pooled intervals (pool_evidence): (drift, entries pooled). With too few entries to pool,
    each paced row gets its own exact interval again, within matching modes from MIN_REPETITIONS a side."""
    drift, pooled_entries = pool_evidence(rows)
    if drift is None:
        for row in rows:
            if row.pace is not None:
                elasticity = pace.elasticities.get(cluster_key(row.key), 1.0)
                row.pace = pace_aware(baseline.runs[row.key], contender.runs[row.key], baseline, contender,
                                      pace.matches, time_kind, elasticity=elasticity)
    return drift, pooled_entries


def _errored_alone(run_file: RunFile, keys) -> list[tuple[BenchmarkKey, str, str]]:
    """The errored entries among those only one file has."""
    return [(key, run_file.label, "; ".join(run_file.runs[key].errors))
            for key in sorted(keys, key=BenchmarkKey.sort_key) if run_file.runs[key].errored]


def _warnings(baseline: RunFile, contender: RunFile, time_kind: str, rows: list[Row], untested: int,
              paced: bool) -> list[str]:
    """What the reader of the comparison must know: runs measured back to back, CPU times of files before
    per-unit times, entries too few repetitions left untested, entries without their pace."""
    warnings = []
    back_to_back = [run_file.label for run_file in (baseline, contender)
                    if str(run_file.context.get("lockstep_order", "")).startswith(BACK_TO_BACK_ORDER)]
    if back_to_back:
        warnings.append(f"{' and '.join(back_to_back)} measured every entry's repetitions back to back "
                        f"(context lockstep_order): a drift of the machine during the run shifts the entries that "
                        f"ran at that moment, with a tiny p; `lockstep run` without --no-interleave (its default) "
                        f"spreads it over every entry")
    if time_kind == "cpu":
        batch_cpu = [run_file.label for run_file in (baseline, contender) if run_file.mpi is None
                     and int(run_file.context.get("lockstep_schema", PER_UNIT_TIMES_SCHEMA)) < PER_UNIT_TIMES_SCHEMA]
        if batch_cpu:
            warnings.append(f"{' and '.join(batch_cpu)} predate lockstep schema {PER_UNIT_TIMES_SCHEMA}: the "
                            f"cpu_time of their team entries is Google Benchmark's own thread, which only replayed "
                            f"the batch times, not the CPU time of a step (rk4/serial's is)")
    if untested:
        enough = max(statistics.MIN_REPETITIONS, 10)
        # A `lockstep mpi` file's repetitions are its rounds.
        more = (f"lockstep mpi --rounds {enough}" if baseline.mpi and contender.mpi
                else f"lockstep run --repetitions {enough}")
        warnings.append(f"{untested} of {len(rows)} matched entries have too few repetitions for a "
                        f"{int(statistics.CONFIDENCE * 100)} % interval (fewer than 4 on a side, or fewer than "
                        f"{statistics.MIN_REPETITIONS} repetitions on a side for the Mann-Whitney U test): untested "
                        f"(`{more}` or more)")
    unpaced = [row for row in rows if paced and row.pace is None]
    if unpaced:
        warnings.append(f"{len(unpaced)} of {len(rows)} matched entries have a repetition without its pace: their "
                        f"pace-aware verdict is {UNAVAILABLE} (the raw one counts for them)")
    return warnings


def compare_pair(baseline: RunFile, contender: RunFile, time_kind: str = "real", alpha: float = 0.05,
                 noise_percent: float = DEFAULT_NOISE_PERCENT) -> Comparison:
    """B (contender) against A (baseline): every matched entry's row, the combinations and the calibrations
    apart, each family Benjamini-Hochberg adjusted on its own; the entries only one file has; the warnings.
    Each side as one file: replicated.compare_sides gives sides of two or more runs their intervals from the
    runs."""
    keys_a, keys_b = set(baseline.runs), set(contender.runs)
    pace = _Pace.of(baseline, contender, time_kind)
    collapsed = baseline.collapsed | contender.collapsed
    rows, calibration_rows, errored = [], [], []
    for key in sorted(keys_a & keys_b, key=BenchmarkKey.sort_key):
        row = _row(key, baseline, contender, time_kind, pace, collapsed)
        if isinstance(row, tuple):
            errored.append((key, *row))
        else:
            (calibration_rows if is_calibration(key) else rows).append(row)
    untested = sum(row.interval is None and not row.collapsed for row in rows)
    drift, pooled_entries = _pool(rows, baseline, contender, time_kind, pace)
    for family in (rows, calibration_rows):
        for row, adjusted in zip(family, statistics.benjamini_hochberg([row.p_raw for row in family])):
            row.p_adjusted = adjusted
    errored += _errored_alone(baseline, keys_a - keys_b) + _errored_alone(contender, keys_b - keys_a)
    errored.sort(key=lambda item: item[0].sort_key())
    comparison = Comparison(baseline, contender, rows,
                            added=sorted(keys_b - keys_a, key=BenchmarkKey.sort_key),
                            removed=sorted(keys_a - keys_b, key=BenchmarkKey.sort_key),
                            errored=errored, warnings=_warnings(baseline, contender, time_kind, rows, untested,
                                                              pace.different_modes is not None),
                            time_kind=time_kind, alpha=alpha, noise_percent=noise_percent,
                            calibrations=calibration_rows,
                            different_modes=pace.different_modes, drift=drift, pooled_entries=pooled_entries)
    return comparison
