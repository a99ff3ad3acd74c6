"""Runs compared within their pace: the pace modes of several runs matched across the runs, the reference pace, and
each run's figure for an entry taken from its repetitions in that pace only (docs/pace.md).

A machine that changes pace for whole runs (the AMD EPYC guest: the one-way core-to-core latency about 35 ns in most
runs and 105-116 ns through some, every primitive 2-3x slower there) puts that change into the spread between runs:
20 runs a side of `lockstep run --threads 2 --pin compact` spread a run's median by 34 % and 29 % (standard deviation
of log time, median over the 66 entries), and compare of A against B x1.15 called 8 of 66 entries slower. Every
repetition carries the mode of its run's pace trace (its pace_mode); a mode's c2c median is the machine's pace, and
the same pace reads alike in every run (30-38 ns in all of them). So the modes of all the runs of both sides are
grouped into the machine's paces (_mode_groups: modes within MODE_TOLERANCE of the group's fastest and no more than
CLASS_GAP from the next), the reference pace is the one that holds the most repetitions on the scarcer side of those
MIN_RUNS runs of each side hold (a run's figure from more repetitions is the surer), and
a run's figure for an entry is the median of its repetitions in that pace (matched_groups). On the trial above the
spread fell to 8.2 % and 5.0 % (the pace explained 94 % and 97 % of the between-run variance), and x1.15 was called
slower in 60 of 66 entries, the sides unscaled in 0. Carrying every repetition to the reference pace by the elasticity
its cluster shows within its runs (pace_statistics.pace_elasticities; a prototype, on the same files) called 64 of 66
and 0 there too, but it assumes
a step follows the c2c reading by one power law from pace to pace; the matched pace assumes nothing, as single-run
compare prefers matching modes to the normalised figure, and loses only the repetitions in other paces. Normalising
within the matched pace as well called 51 of 66: inside one pace the readings' spread is mostly the reading's own.

What the pace does not explain stays in the runs' spread (the intervals are on it). A run with no repetition of an
entry in the reference pace gives that entry no figure; an entry with fewer than MIN_RUNS runs a side in it is
compared on every repetition, as before, and counted. A pace one side's runs hold and the other's do not is named.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..common import statistics
from ..read.run_file import RunFile
from .pace_statistics import MODE_TOLERANCE

# Two modes of different runs are one pace of the machine when, sorted by their c2c medians, each is within CLASS_GAP
# of the one before and within MODE_TOLERANCE of the pace's fastest: this guest's paces sit 1.6x apart or more (c2c 17,
# 28-38, 97-117, 196-208 ns over 42 runs) while one pace's modes spread by 1.36x from run to run.
CLASS_GAP = 1.25
# An entry is compared within the reference pace when at least this many runs a side hold a repetition of it there.
MIN_RUNS = 2


@dataclass(frozen=True)
class PaceClass:
    """One pace of the machine across runs: its fastest and slowest mode's reading (c2c one-way in ns, or the serial
    step on a machine of one CPU), and per side the runs that hold a repetition in it and those repetitions."""

    index: int
    low_ns: float
    high_ns: float
    runs: tuple[int, ...]  # per side, the runs with a repetition in this pace
    repetitions: tuple[int, ...]  # per side
    cells: tuple[int, ...] = ()  # per side, the (run, entry) pairs with a repetition in this pace: the runs' figures

    @property
    def reading_ns(self) -> float:
        """The pace in words' figure: the geometric middle of its modes' readings."""
        return math.sqrt(self.low_ns * self.high_ns)


@dataclass(frozen=True)
class RunPace:
    """The paces of the runs of one or two sides (pace_classes) and the reference: the one the comparison is made in
    (None: no pace that every side holds in MIN_RUNS runs, or runs without a pace trace)."""

    classes: tuple[PaceClass, ...]
    reference: PaceClass | None
    reading: str  # "c2c_ns", or "serial_ns" on a machine of one CPU
    runs: tuple[int, ...]  # per side, its runs
    repetitions: tuple[int, ...]  # per side, its repetitions with a pace

    def share(self, side: int) -> float | None:
        """The part of a side's repetitions in the reference pace."""
        if self.reference is None or not self.repetitions[side]:
            return None
        return self.reference.repetitions[side] / self.repetitions[side]

    def missing(self) -> list[tuple[PaceClass, int, int]]:
        """(pace, the side whose runs hold none of it, a side that holds it) for every pace one side lacks."""
        return [(pace, side, other) for pace in self.classes for side in range(len(self.runs))
                for other in range(len(self.runs)) if not pace.runs[side] and pace.runs[other]]


def _reading(run_files: list[RunFile]) -> str | None:
    """The reading the paces are told apart by: c2c where every mode of every run has one, else the serial step;
    None when a run has no pace trace."""
    if any(f.pace is None for f in run_files):
        return None
    return "c2c_ns" if all(m.c2c_ns is not None for f in run_files for m in f.pace.modes) else "serial_ns"


def _mode_groups(readings: list[float]) -> list[tuple[float, float]]:
    """(low, high) of each group of sorted readings: a new group where the next reading is more than CLASS_GAP above
    the one before or MODE_TOLERANCE above the group's first."""
    groups: list[list[float]] = []
    for value in sorted(readings):
        if groups and value <= groups[-1][-1] * CLASS_GAP and value <= groups[-1][0] * MODE_TOLERANCE:
            groups[-1].append(value)
        else:
            groups.append([value])
    return [(group[0], group[-1]) for group in groups]


def class_of_modes(run_file: RunFile, bounds: list[tuple[float, float]], reading: str) -> dict[int, int]:
    """{a mode of the run: the index of its pace in bounds}."""
    found = {}
    for mode in run_file.pace.modes:
        value = getattr(mode, reading)
        found[mode.mode] = next(index for index, (low, high) in enumerate(bounds) if low <= value <= high)
    return found


def run_pace(sides: list[list[RunFile]], min_runs: int = MIN_RUNS) -> RunPace | None:
    """The paces of the sides' runs and the reference pace (held by min_runs runs of every side, or by every run of a
    side of fewer); None when a run has no pace trace (written before it)."""
    every = [f for side in sides for f in side]
    reading = _reading(every)
    if reading is None:
        return None
    bounds = _mode_groups([getattr(m, reading) for f in every for m in f.pace.modes])
    counts = {name: [[0] * len(bounds) for _ in sides] for name in ("runs", "repetitions", "cells")}
    totals = [0] * len(sides)
    for number, side in enumerate(sides):
        for run_file in side:
            classes = class_of_modes(run_file, bounds, reading)
            held = [0] * len(bounds)
            for run in run_file.runs.values():
                entry = [0] * len(bounds)
                for repetition in run.repetitions:
                    if repetition.pace is not None and repetition.pace.mode in classes:
                        entry[classes[repetition.pace.mode]] += 1
                for index, count in enumerate(entry):
                    held[index] += count
                    counts["cells"][number][index] += count > 0
                totals[number] += sum(entry)
            for index, count in enumerate(held):
                counts["runs"][number][index] += count > 0
                counts["repetitions"][number][index] += count
    classes = tuple(PaceClass(index, low, high, *(tuple(side[index] for side in counts[name])
                                                  for name in ("runs", "repetitions", "cells")))
                    for index, (low, high) in enumerate(bounds))
    held = [pace for pace in classes if all(runs >= min(min_runs, len(side)) for runs, side in zip(pace.runs, sides))]
    reference = max(held, key=lambda pace: (min(pace.repetitions), min(pace.cells)), default=None)
    return RunPace(classes, reference, reading, tuple(len(side) for side in sides), tuple(totals))


def matched_groups(run_files: list[RunFile], key, time_kind: str, pace: RunPace) -> list[list[float]]:
    """Each run's log times of the entry's repetitions in the reference pace (a run without one: left out)."""
    bounds = [(c.low_ns, c.high_ns) for c in pace.classes]
    groups = []
    for run_file in run_files:
        run = run_file.runs.get(key)
        if run is None or run.errored:
            continue
        classes = class_of_modes(run_file, bounds, pace.reading)
        logs = [math.log(r.real_ns if time_kind == "real" else r.cpu_ns) for r in run.repetitions
                if r.pace is not None and classes.get(r.pace.mode) == pace.reference.index]
        if logs:
            groups.append(logs)
    return groups


def every_group(run_files: list[RunFile], key, time_kind: str) -> list[list[float]]:
    """Each run's log times of all the entry's repetitions, whatever their pace."""
    return [[math.log(t) for t in f.runs[key].times_ns(time_kind) if t > 0] for f in run_files
            if key in f.runs and not f.runs[key].errored and f.runs[key].repetitions]


def reading_spread(run_files: list[RunFile], pace: RunPace) -> float | None:
    """How far the machine's pace moves while it stays in the reference pace: the standard deviation of the log of
    the pace trace's readings in it, within each run, the median over the runs (None: no run has three readings
    there)."""
    if pace is None or pace.reference is None:
        return None
    bounds = [(c.low_ns, c.high_ns) for c in pace.classes]
    spreads = []
    for run_file in run_files:
        classes = class_of_modes(run_file, bounds, pace.reading)
        logs = [math.log(getattr(r, pace.reading)) for r in run_file.pace.readings
                if classes.get(r.mode) == pace.reference.index and getattr(r, pace.reading)]
        if len(logs) >= 3:
            mean = sum(logs) / len(logs)
            spreads.append(math.sqrt(sum((v - mean) ** 2 for v in logs) / (len(logs) - 1)))
    return statistics.median(spreads) if spreads else None
