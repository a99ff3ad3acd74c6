"""What compare and report both derive from one run file: an entry's sample and median, the ratio of two
entries' medians, its repetitions per pace mode, the in-run calibrations, which entries are calibrations, and
each primitive's line against the best other. Nothing here compares two files (compare.py) or draws."""
from __future__ import annotations

from ..common import statistics, words
from ..common.fields import C2C_COUNTER, SERIAL_CONTEXT
from ..common.names import BenchmarkKey, parse_name
from ..read.run_file import LayoutFacts, PacePair, Run, RunFile

# Families that measure the machine or the instrumentation, not a combination.
CALIBRATION_FAMILIES = ("c2c", "overhead")
# The in-run calibration entries: compared apart, and read when the context lacks the value.
SERIAL_ENTRY = "rk4/serial"
C2C_ENTRY = "c2c/pin:compact/threads:2"


def is_calibration(key: BenchmarkKey) -> bool:
    # The serial step of every model the run integrates: rk4/serial, and rk4/model:chainS/serial for a chain;
    # and `lockstep mpi`'s ping-pong (mpi/pingpong/...), the MPI counterpart of c2c.
    return (key.family in CALIBRATION_FAMILIES or key.without("model").display == SERIAL_ENTRY
            or (key.family == "mpi" and key.get("pingpong") == ""))


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


def run_median(run_file: RunFile, key: BenchmarkKey, time_kind: str = "real") -> float | None:
    run = run_file.runs.get(key)
    if run is None or run.errored:
        return None
    times, _ = sample(run, time_kind)
    return statistics.median(times) if times else None


def median_ratio(run_file: RunFile, numerator: BenchmarkKey, denominator: BenchmarkKey, time_kind: str = "real",
                 collapsed=frozenset()) -> float | None:
    """median(numerator) / median(denominator) of one file's entries (run_median): the one ratio of two medians
    every table and figure shows. None when either entry is missing, errored, has a zero median or is in
    `collapsed`."""
    if numerator in collapsed or denominator in collapsed:
        return None
    top, bottom = run_median(run_file, numerator, time_kind), run_median(run_file, denominator, time_kind)
    return top / bottom if (top and bottom) else None


def per_mode_medians(run: Run) -> tuple[dict[int, tuple[float, int]], float | None, int]:
    """An entry's repetitions split by the pace mode they ran in (real time): {mode: (median, repetitions)},
    the slowest mode's median over the fastest's (the trace lists its modes fastest first: the highest mode's
    over the lowest's; None with fewer than two modes), and how many repetitions straddled a change of mode."""
    paced = [(r.pace.mode, r.real_ns) for r in run.repetitions if r.pace is not None and r.pace.mode is not None]
    by_mode: dict[int, list[float]] = {}
    for mode, value in paced:
        if mode >= 0:
            by_mode.setdefault(mode, []).append(value)
    medians = {mode: (statistics.median(values), len(values)) for mode, values in by_mode.items()}
    spread = medians[max(medians)][0] / medians[min(medians)][0] if len(medians) >= 2 else None
    return medians, spread, sum(1 for mode, _ in paced if mode < 0)


def mode_medians(run_file: RunFile, key: BenchmarkKey) -> tuple[dict[int, tuple[float, int]], float | None, int]:
    """per_mode_medians of an entry as the run grouped them where its file says (lockstep_pace's entry_medians:
    an entry it does not list ran in one mode and straddled no change); a file written before them gets them
    grouped here from each repetition's pace_mode."""
    if run_file.mode_medians is None:
        return per_mode_medians(run_file.runs[key])
    found = run_file.mode_medians.get(key)
    if found is None:
        return {}, None, 0
    medians = found.medians
    spread = medians[max(medians)][0] / medians[min(medians)][0] if len(medians) >= 2 else None
    return medians, spread, found.straddling


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


def layout_facts(run_file: RunFile) -> tuple[LayoutFacts, ...]:
    """The layouts' traits in the registry's order: the file's lockstep_layouts; a file written before it gets
    words.LAYOUTS, the registry as it stood when the writer did not state it."""
    if run_file.layouts is not None:
        return run_file.layouts
    return tuple(LayoutFacts(name, kind, isolation) for name, kind, isolation in words.LAYOUTS)


def sharing_layout(run_file: RunFile) -> str | None:
    """The layout whose writers share cache lines on purpose (the false-sharing case), by its traits."""
    return next((facts.name for facts in layout_facts(run_file) if facts.shares_lines), None)
