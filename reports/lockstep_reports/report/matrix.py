"""A run file's sync x layout x placement x threads matrix as the report shows it: its groups (a placement and a
thread count), each group's primitives fastest first, the cells of a heat map, the bars with their spread, the
CPU per step, the split of a step, and the penalties of the entries' medians where the file has no pair for them.
figures.py draws what these give; nothing here draws."""
from __future__ import annotations

from dataclasses import dataclass

from ..analysis.run_analysis import layout_facts, median_ratio, run_median, sample
from ..common import statistics, words
from ..common.fields import TEAM_CPU_COUNTERS
from ..common.names import BenchmarkKey


def ordered(values, preferred):
    """The values in the preferred order, then the others sorted."""
    values = set(values)
    return [v for v in preferred if v in values] + sorted(values - set(preferred))


def rk4_groups(run_file) -> list[tuple[str, int]]:
    """(pin, threads) of every group of rk4 entries, placements in words.PIN_ORDER, then by thread count."""
    groups = {(key.get("pin"), key.threads) for key in run_file.runs
              if key.family == "rk4" and key.get("sync") and key.get("layout") and key.get("pin")}
    pins = ordered({pin for pin, _ in groups}, words.PIN_ORDER)
    return sorted(groups, key=lambda group: (pins.index(group[0]), group[1] or 0))


def model_at(run_file, threads) -> str | None:
    """The model segment of the run's rk4 entries at this thread count (a chain's "chain8"), or None: the
    paper's two-mass system, whose names carry no model."""
    for key in run_file.runs:
        if key.family == "rk4" and key.threads == threads and key.get("sync"):
            return key.get("model")
    return None


def rk4_key(run_file, sync, layout, pin, threads) -> BenchmarkKey:
    """The rk4 entry of a primitive, layout, placement and thread count (with the run's model there)."""
    segments = [("sync", sync), ("layout", layout), ("pin", pin), ("threads", str(threads))]
    model = model_at(run_file, threads)
    if model:
        segments.append(("model", model))
    return BenchmarkKey("rk4", tuple(sorted(segments)))


def syncs_layouts(run_file) -> tuple[list[str], list[str]]:
    """The primitives of the run's rk4 entries (sorted) and their layouts (in the registry's order:
    run_analysis.layout_facts)."""
    syncs = sorted({key.get("sync") for key in run_file.runs if key.family == "rk4" and key.get("sync")})
    layouts = ordered({key.get("layout") for key in run_file.runs if key.family == "rk4" and key.get("layout")},
                      [facts.name for facts in layout_facts(run_file)])
    return syncs, layouts


def ranked_syncs(run_file, pin: str, threads: int, layouts, collapsed=frozenset()) -> list[str]:
    """The primitives of one placement and thread count, fastest first: by the median of each one's fastest
    layout there; a primitive with nothing measured but collapsed or unavailable entries comes last."""
    syncs, _ = syncs_layouts(run_file)

    def best(sync):
        values = [run_median(run_file, key) for key in (rk4_key(run_file, sync, layout, pin, threads)
                                                         for layout in layouts) if key not in collapsed]
        values = [value for value in values if value is not None]
        return (0, min(values), sync) if values else (1, 0.0, sync)

    return sorted(syncs, key=best)


# ---------------------------------------------------------------- the heat map and the bars

@dataclass(frozen=True)
class HeatmapCells:
    """One heat map (figures.heatmap): the median step time of each primitive (rows, fastest first) with each
    layout (columns) at one placement and thread count. values[row][column]: None where the combination was not
    run or errored; errored: the (row, column) of those that errored (drawn "error", apart from the ones not run,
    "n/a"); collapsed: the (row, column) of cells whose entry collapsed (the answer's: grey, out of the
    colour scale); within_noise: the (sync, layout) cells whose false-sharing pair made no call (hatched, "≈");
    chosen: the (sync, layout) the run's answer chose there (outlined)."""

    pin: str
    threads: int
    syncs: tuple[str, ...]
    layouts: tuple[str, ...]
    values: tuple[tuple[float | None, ...], ...]
    collapsed: frozenset = frozenset()
    within_noise: frozenset = frozenset()
    chosen: tuple[str, str] | None = None
    errored: frozenset = frozenset()


def heatmap_cells(run_file, pin: str, threads: int, within_noise=frozenset(), collapsed=frozenset(),
                  chosen: tuple[str, str] | None = None) -> HeatmapCells:
    """The heat map of one placement and thread count (HeatmapCells); collapsed: the entries (keys) that
    collapsed."""
    _, layouts = syncs_layouts(run_file)
    syncs = ranked_syncs(run_file, pin, threads, layouts, collapsed)
    values, gone, errored = [], set(), set()
    for row, sync in enumerate(syncs):
        cells = []
        for column, layout in enumerate(layouts):
            key = rk4_key(run_file, sync, layout, pin, threads)
            value = run_median(run_file, key)
            cells.append(value)
            if value is not None and key in collapsed:
                gone.add((row, column))
            if key in run_file.runs and run_file.runs[key].errored:
                errored.add((row, column))
        values.append(tuple(cells))
    return HeatmapCells(pin, threads, tuple(syncs), tuple(layouts), tuple(values), frozenset(gone),
                        frozenset(within_noise), chosen, frozenset(errored))


@dataclass(frozen=True)
class SpreadBar:
    """One bar of figures.bars_with_spread: a primitive (row) at a layout (column), its repetitions' times, their
    median (the one every table shows: run_analysis.run_median) and interquartile range."""

    row: int
    column: int
    times: tuple[float, ...]
    median: float
    low: float
    high: float


@dataclass(frozen=True)
class SpreadBars:
    """Per primitive (fastest first) of one placement and thread count, one bar per layout; left_out: the
    primitives with a collapsed entry there (named under the title)."""

    pin: str
    threads: int
    syncs: tuple[str, ...]
    layouts: tuple[str, ...]
    bars: tuple[SpreadBar, ...]  # by layout, then by primitive
    left_out: tuple[str, ...]


def spread_bars(run_file, pin: str, threads: int, collapsed=frozenset()) -> SpreadBars:
    """The bars of one placement and thread count; collapsed entries (keys) are left out, and a primitive with
    nothing else there is not drawn."""
    _, layouts = syncs_layouts(run_file)
    syncs = ranked_syncs(run_file, pin, threads, layouts, collapsed)
    left_out = sorted({sync for sync in syncs for layout in layouts
                       if rk4_key(run_file, sync, layout, pin, threads) in collapsed})
    syncs = [sync for sync in syncs if any(rk4_key(run_file, sync, layout, pin, threads) not in collapsed
                                           for layout in layouts)]
    bars = []
    for column, layout in enumerate(layouts):
        for row, sync in enumerate(syncs):
            key = rk4_key(run_file, sync, layout, pin, threads)
            run = run_file.runs.get(key)
            if run is None or run.errored or key in collapsed:
                continue
            times, _ = sample(run)
            if not times:
                continue
            bars.append(SpreadBar(row, column, tuple(times), run_median(run_file, key),
                                  statistics.quantile(times, 0.25), statistics.quantile(times, 0.75)))
    return SpreadBars(pin, threads, tuple(syncs), tuple(layouts), tuple(bars), tuple(left_out))


# ---------------------------------------------------------------- CPU per step, and the step's split

@dataclass(frozen=True)
class CpuPoint:
    """One entry of an rk4/ or barrier/ family: its median time per unit (step or episode) and the median CPU
    time its whole team burned per unit (fields.TEAM_CPU_COUNTERS), both statistics.median over the
    repetitions (the unit's time as run_analysis.run_median takes it)."""

    key: BenchmarkKey
    unit_ns: float
    team_cpu_ns: float

    @property
    def cpus_busy(self) -> float:
        return self.team_cpu_ns / self.unit_ns


def cpu_points(run_file, family: str, collapsed=frozenset()) -> list[CpuPoint]:
    """The entries of one family (rk4: the sync/layout/pin/threads matrix; barrier: the bare barriers) with a
    time and a team CPU time per unit, collapsed entries (the answer's) left out; sorted by name. An entry
    without the counter (a file written before it) has no point."""
    points = []
    for key in sorted(run_file.runs, key=BenchmarkKey.sort_key):
        if key.family != family or not key.get("sync") or not key.get("pin") or key.threads is None:
            continue
        if key in collapsed or run_file.runs[key].errored:
            continue
        cpu = next((values for values in (run_file.runs[key].counter_values(name) for name in TEAM_CPU_COUNTERS)
                    if values), None)
        unit = run_median(run_file, key)
        if cpu and unit:
            team_cpu = statistics.median(cpu)
            if team_cpu > 0:
                points.append(CpuPoint(key, unit, team_cpu))
    return points


@dataclass(frozen=True)
class StepSplit:
    """Where an rk4 entry's step goes: the split (fields.STEP_SPLIT_COUNTERS, in their order: computing, waiting
    for the others, the release) of its median repetition, the one whose step is the median of those that carry
    the split (the lower middle one of an even count), as the writer wrote it, beside that repetition's step.

    The writer measures the two parts of the four stage syncs (waiting and release) on sampled steps and writes
    compute as the step less those syncs, clamped at 0 (docs/names-and-counters.md). So a repetition's three
    parts add up to its step exactly, unless the sampled syncs took more than the whole step: then compute reads
    0, which no measurement said, and the syncs' two parts add up to more than the step. Such a split is
    `clamped`; `clamped_repetitions` of the entry's `repetitions` were."""

    key: BenchmarkKey
    step_ns: float
    parts_ns: tuple[float, ...]
    clamped_repetitions: int = 0
    repetitions: int = 1

    @property
    def syncs_ns(self) -> float:
        """The four stage syncs as measured: waiting for the others and the release."""
        return sum(self.parts_ns[1:])

    @property
    def clamped(self) -> bool:
        """The sampled syncs took the whole step or more: compute was not measured (the writer's 0)."""
        return self.syncs_ns >= self.step_ns


def median_repetition(repetitions):
    """Of the repetitions that carry the split, the one whose step is the median (the lower middle one of an
    even count), None when none does."""
    split = sorted((repetition for repetition in repetitions if repetition.split is not None),
                   key=lambda repetition: repetition.real_ns)
    return split[(len(split) - 1) // 2] if split else None


def _entry_split(run, key) -> StepSplit | None:
    middle = median_repetition(run.repetitions)
    if middle is None:
        return None
    splits = [repetition.split for repetition in run.repetitions if repetition.split is not None]
    clamped = sum(1 for repetition in run.repetitions if repetition.split is not None
                  and sum(repetition.split[1:]) >= repetition.real_ns)
    return StepSplit(key, middle.real_ns, tuple(middle.split), clamped, len(splits))


def step_splits(run_file, pin: str, threads: int, collapsed=frozenset()) -> list[StepSplit]:
    """Per primitive of one placement and thread count (fastest first), the split of its fastest layout (by the
    entries' medians) there (StepSplit: its median repetition's); collapsed entries left out. Empty for a file
    written before the split."""
    _, layouts = syncs_layouts(run_file)
    splits = []
    for sync in ranked_syncs(run_file, pin, threads, layouts, collapsed):
        measured = []
        for layout in layouts:
            key = rk4_key(run_file, sync, layout, pin, threads)
            step = run_median(run_file, key) if key not in collapsed else None
            run = run_file.runs.get(key)
            split = _entry_split(run, key) if run is not None and step is not None else None
            if split is not None:
                measured.append((step, split))
        if measured:
            splits.append(min(measured, key=lambda item: item[0])[1])
    return splits


# ---------------------------------------------------------------- ratios drawn as bars

@dataclass(frozen=True)
class PenaltyRow:
    """One bar of a ratio figure (figures.penalties, figures.paired_ratios): kind ("false sharing: ..."),
    primitive, placement, thread count, time ratio; from a paired measurement (lockstep_pairs) also its interval
    and verdict. label: what the bar is, as its figure names it (default: primitive, placement, threads)."""

    kind: str
    sync: str
    threads: int
    ratio: float
    ci_low: float | None = None
    ci_high: float | None = None
    verdict: str | None = None
    pin: str = ""
    label: str = ""

    @property
    def shown_label(self) -> str:
        return self.label or f"{self.sync}, pin:{self.pin}, {self.threads} thread{'s' if self.threads != 1 else ''}"


PENALTY_KINDS = ("false_sharing", "migration")


def _layouts_compared(run_file, layouts) -> tuple[str | None, str | None]:
    """(the layout whose writers share lines, the one the medians' false sharing divides by) among the layouts
    present, by their traits: the shared layout with the widest writer isolation, else a private copy. This is
    the rule of the reports before lockstep_planned_pairs, kept for files without the run's plan; lockstep run
    plans the fastest isolating shared layout of each group (bench/run/paired_blocks.cpp)."""
    facts = [facts for facts in layout_facts(run_file) if facts.name in layouts]
    sharing = next((facts.name for facts in facts if facts.shares_lines), None)
    isolating = sorted((facts for facts in facts if not facts.shares_lines),
                       key=lambda facts: (facts.kind != "shared", -facts.writer_isolation))
    return sharing, (isolating[0].name if isolating else None)


def penalty_row(run_file, comparison: str, a: BenchmarkKey, b: BenchmarkKey, collapsed=frozenset()):
    """The ratio of two entries' medians as a penalty's bar (no interval, no verdict), None when either is missing
    or collapsed: false sharing (a's layout / b's) or migration (a's placement / b's, on their layout)."""
    ratio = median_ratio(run_file, a, b, collapsed=collapsed)
    if ratio is None or not a.get("sync") or a.threads is None:
        return None
    if comparison == "false_sharing":
        kind = f"false sharing: {a.get('layout')} / {b.get('layout')}"
    else:
        kind = f"migration: pin:{a.get('pin')} / pin:{b.get('pin')} ({a.get('layout')})"
    return PenaltyRow(kind, a.get("sync"), a.threads, ratio, pin=a.get("pin") or "")


def _replanned(run_file) -> list[tuple[str, BenchmarkKey, BenchmarkKey]]:
    """The false-sharing and migration comparisons of a file without the run's plan (lockstep_planned_pairs),
    planned again here by the layouts' traits (_layouts_compared): per primitive and thread count, the
    sharing layout against the isolating one pinned (words.PINNED_PLACEMENT), and each moving placement
    (words.MOVED_PLACEMENTS) against the pinned one on the isolating layout."""
    syncs, layouts = syncs_layouts(run_file)
    sharing, isolating = _layouts_compared(run_file, layouts)
    base = isolating or (layouts[0] if layouts else None)
    pinned = words.PINNED_PLACEMENT
    planned = []
    for sync in syncs:
        for threads in sorted({threads for _, threads in rk4_groups(run_file)}):
            if sharing and isolating:
                planned.append(("false_sharing", rk4_key(run_file, sync, sharing, pinned, threads),
                                rk4_key(run_file, sync, isolating, pinned, threads)))
            planned += [("migration", rk4_key(run_file, sync, base, moved, threads),
                         rk4_key(run_file, sync, base, pinned, threads)) for moved in words.MOVED_PLACEMENTS]
    return planned


def penalty_rows(run_file, collapsed=frozenset(), paired_kinds=frozenset()) -> list[PenaltyRow]:
    """The false-sharing and migration penalties that were not measured as pairs, from the entries' medians;
    collapsed entries left out. A file with the run's plan (lockstep_planned_pairs): the planned comparisons
    without a pair in lockstep_pairs. A file written before the plan: the kinds with no pair at all
    (paired_kinds: those with one), planned again here (_replanned)."""
    if run_file.planned is not None:
        measured = {(pair.comparison, pair.a_key, pair.b_key) for pair in run_file.pairs}
        planned = [(pair.comparison, pair.a_key, pair.b_key) for pair in run_file.planned
                   if pair.comparison in PENALTY_KINDS and (pair.comparison, pair.a_key, pair.b_key) not in measured]
    else:
        planned = [item for item in _replanned(run_file) if item[0] not in paired_kinds]
    rows = [penalty_row(run_file, comparison, a, b, collapsed) for comparison, a, b in planned]
    return [row for row in rows if row is not None]


def within_noise_cells(run_file) -> dict[tuple[str, int], frozenset]:
    """(pin, threads) -> the (sync, layout) cells of that heat map whose false-sharing pair made no call: within
    noise or unsure (statistics.verdict)."""
    cells: dict[tuple[str, int], set] = {}
    for pair in run_file.pairs:
        if pair.comparison == "false_sharing" and pair.verdict in (statistics.WITHIN_NOISE, statistics.UNSURE):
            key = pair.a_key
            cells.setdefault((key.get("pin"), key.threads), set()).add((key.get("sync"), key.get("layout")))
    return {group: frozenset(members) for group, members in cells.items()}
