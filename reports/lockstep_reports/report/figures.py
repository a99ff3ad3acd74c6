"""The report's figures, each drawn by matplotlib into SVG text with deterministic bytes.

Each figure draws what it is given: the cells, bars, points and rows that matrix.py, c2c_analysis.py, paper.py
and the readers derive; nothing here reads a run file's entries or computes a statistic of them.

Determinism: the SVG backend's ids come from a hash salted by svg.hashsalt
(fixed here instead of random), the Date metadata is removed, glyphs are
written as paths (no font lookup in the browser), and every loop runs over
sorted keys. The same input therefore gives the same SVG, byte for byte.
"""
from __future__ import annotations

import io
import math
import re

import matplotlib

matplotlib.use("svg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.lines  # noqa: E402
import matplotlib.patches  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

from ..common import words  # noqa: E402
from ..common.fields import STEP_SPLIT_COUNTERS  # noqa: E402
from ..common.formatting import format_ns  # noqa: E402
from .matrix import CpuPoint, PenaltyRow, StepSplit, ordered  # noqa: E402

matplotlib.rcParams.update({
    "svg.hashsalt": "lockstep-report",
    "svg.fonttype": "path",
    "font.size": 9,
    "axes.titlesize": 10,
    "figure.dpi": 100,
    "savefig.bbox": "tight",
})

# Digits of a value written inside a figure's cell.
CELL_DIGITS = 3


def to_svg(figure) -> str:
    stream = io.StringIO()
    figure.savefig(stream, format="svg", metadata={"Date": None, "Creator": "lockstep report (matplotlib)"})
    plt.close(figure)
    return stream.getvalue()


def inline_svg(svg: str, prefix: str) -> str:
    """SVG text ready to sit inside HTML: no XML prolog, and ids made unique per figure."""
    svg = re.sub(r"^.*?(<svg\b)", r"\1", svg, count=1, flags=re.S)
    svg = re.sub(r'\bid="([^"]+)"', lambda m: f'id="{prefix}-{m.group(1)}"', svg)
    svg = re.sub(r'(xlink:href|href)="#([^"]+)"', lambda m: f'{m.group(1)}="#{prefix}-{m.group(2)}"', svg)
    svg = re.sub(r"url\(#([^)]+)\)", lambda m: f"url(#{prefix}-{m.group(1)})", svg)
    return svg.strip()


def heatmap(cells) -> str:
    """Median step time, primitive (rows, fastest first) x layout (columns), for one placement and thread
    count (matrix.HeatmapCells); the colour scale is in the cells' unit (a time, on a log scale) and spans the
    entries that count. A cell within noise (its false-sharing pair made no call) is hatched, its value marked
    with "≈"; a collapsed one is grey and out of the colour scale; the chosen one is outlined."""
    pin, threads, within_noise, chosen = cells.pin, cells.threads, cells.within_noise, cells.chosen
    syncs, layouts = list(cells.syncs), list(cells.layouts)
    grid = np.full((len(syncs), len(layouts)), np.nan)
    gone = np.zeros((len(syncs), len(layouts)), dtype=bool)
    for row, values in enumerate(cells.values):
        for column, value in enumerate(values):
            if value is not None:
                grid[row, column] = value
                gone[row, column] = (row, column) in cells.collapsed
    figure, axes = plt.subplots(figsize=(1.0 * len(layouts) + 2.4, 0.36 * len(syncs) + 1.5))
    counted = grid[np.isfinite(grid) & ~gone]
    norm = (LogNorm(vmin=float(counted.min()), vmax=float(max(counted.max(), counted.min() * 1.0001)))
            if counted.size else None)
    shown = np.where(gone, np.nan, grid)
    image = axes.imshow(np.ma.masked_invalid(shown), cmap="viridis_r", norm=norm, aspect="auto")
    axes.set_xticks(range(len(layouts)), layouts)
    axes.set_yticks(range(len(syncs)), syncs)
    axes.set_xlabel("layout")
    axes.set_ylabel("primitive (fastest first)")
    for row in range(len(syncs)):
        for column in range(len(layouts)):
            value = grid[row, column]
            text = format_ns(value, CELL_DIGITS) if math.isfinite(value) else "n/a"
            if (row, column) in cells.errored:
                _error_cell(axes, row, column)
                continue
            if gone[row, column]:
                axes.add_patch(matplotlib.patches.Rectangle((column - 0.5, row - 0.5), 1.0, 1.0, facecolor="#eeeeee",
                                                            hatch="xx", edgecolor="#bbbbbb", lw=0.0))
                axes.text(column, row, f"collapsed\n{text}", ha="center", va="center", fontsize=7, color="#555555",
                          linespacing=1.0)
                continue
            dark = math.isfinite(value) and norm is not None and norm(value) > 0.55
            noisy = (syncs[row], layouts[column]) in within_noise
            if noisy:
                axes.add_patch(matplotlib.patches.Rectangle((column - 0.5, row - 0.5), 1.0, 1.0, fill=False,
                                                            hatch="///", edgecolor="white" if dark else "#444444",
                                                            lw=0.5))
                text = "≈ " + text
            axes.text(column, row, text, ha="center", va="center", fontsize=8, color="white" if dark else "black",
                      bbox=dict(boxstyle="round,pad=0.2", fc="black" if dark else "white", ec="none", alpha=0.75)
                      if noisy else None)
    if chosen and chosen[0] in syncs and chosen[1] in layouts:
        row, column = syncs.index(chosen[0]), layouts.index(chosen[1])
        axes.add_patch(matplotlib.patches.Rectangle((column - 0.47, row - 0.47), 0.94, 0.94, fill=False,
                                                    edgecolor="#d62728", lw=2.2))
    axes.set_title(f"median step time, pin:{pin}, {threads} thread{'s' if threads != 1 else ''}"
                   + ("\n(red outline: the combination the run's answer chose)" if chosen else ""), fontsize=9)
    if norm is not None:
        colorbar = figure.colorbar(image, ax=axes, label="median step time (log)")
        duration_axis(colorbar.ax.yaxis)
    _missing_legend(axes, cells)
    return to_svg(figure)


# An entry that errored, drawn apart from a combination not run (n/a): its colours and hatch.
ERROR_FACE, ERROR_EDGE, ERROR_TEXT = "#f6d5d5", "#c44e52", "#8b1a1a"


def _error_cell(axes, row: int, column: int) -> None:
    axes.add_patch(matplotlib.patches.Rectangle((column - 0.5, row - 0.5), 1.0, 1.0, facecolor=ERROR_FACE,
                                                hatch="\\\\", edgecolor=ERROR_EDGE, lw=0.0))
    axes.text(column, row, "error", ha="center", va="center", fontsize=8, color=ERROR_TEXT, fontweight="bold")


def _missing_legend(axes, cells) -> None:
    """Under a heat map, what its cells without a time are: an entry that errored ("error") and a combination
    not run ("n/a"), each when the map has one."""
    missing = {(row, column) for row, values in enumerate(cells.values) for column, value in enumerate(values)
               if value is None}
    handles = []
    if cells.errored:
        handles.append(matplotlib.patches.Patch(facecolor=ERROR_FACE, edgecolor=ERROR_EDGE, hatch="\\\\",
                                                label="error: the entry ran and failed (no time)"))
    if missing - set(cells.errored):
        handles.append(matplotlib.patches.Patch(facecolor="white", edgecolor="#999999",
                                                label="n/a: not run (not applicable)"))
    if handles:
        # below the layouts' names and the axis's label: an offset in the legend's font size, whatever the map's height
        axes.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(0.0, 0.0), borderaxespad=4.2,
                    frameon=False)


def log_floor(value: float) -> float:
    """The power of ten at or below a positive value: where a log axis starts so that its smallest bar shows."""
    return 10.0 ** math.floor(math.log10(value))


def log_ceiling(value: float) -> float:
    return 10.0 ** math.ceil(math.log10(value))


def duration_axis(axis, unit_ns: float = 1.0) -> None:
    """A logarithmic axis of durations (its values in units of unit_ns) labelled as people write them
    ("100 ns", "1 us", "10 ms"): at the powers of ten, and at 2 and 5 times them too when the axis spans
    less than two decades (call it after the limits are set)."""
    low, high = sorted(axis.get_view_interval())
    subs = (1.0,)
    if low > 0 and high / low < 100.0:
        subs = (1.0, 2.0, 5.0)
        # Within a factor of a few, 1-2-5 may leave one tick or none: every digit then.
        decades = range(math.floor(math.log10(low)), math.ceil(math.log10(high)) + 1)
        if sum(low <= sub * 10.0 ** decade <= high for decade in decades for sub in subs) < 2:
            subs = tuple(float(digit) for digit in range(1, 10))
    axis.set_major_locator(matplotlib.ticker.LogLocator(base=10.0, subs=subs))
    axis.set_major_formatter(matplotlib.ticker.FuncFormatter(
        lambda value, _: format_ns(value * unit_ns, 1) if value > 0 else ""))
    axis.set_minor_formatter(matplotlib.ticker.NullFormatter())


def bars_with_spread(bars) -> str:
    """Per primitive (fastest first), one bar per layout at the median (matrix.SpreadBars); the whisker spans
    the interquartile range and each dot is one repetition. The time axis is logarithmic: the primitives' step
    times span decades (a spinning barrier's hundreds of ns beside a sleeping one's 100 us). The primitives with
    a collapsed entry are named under the title."""
    pin, threads, left_out = bars.pin, bars.threads, bars.left_out
    syncs, layouts = list(bars.syncs), list(bars.layouts)
    figure, axes = plt.subplots(figsize=(min(10.0, max(6.0, 0.62 * len(syncs) + 1.6)), 3.8))
    axes.set_yscale("log")
    width = 0.8 / max(1, len(layouts))
    colors = plt.get_cmap("tab10")
    drawn = []
    for bar in bars.bars:
        column, layout, times, center = bar.column, layouts[bar.column], bar.times, bar.median
        x = bar.row + (column - (len(layouts) - 1) / 2) * width
        drawn += list(times)
        axes.bar(x, center, width * 0.9, color=colors(column), label=layout if not any(
            label == layout for label in axes.get_legend_handles_labels()[1]) else None)
        axes.errorbar(x, center, yerr=[[center - bar.low], [bar.high - center]], color="black", capsize=2, lw=0.8)
        offsets = np.linspace(-width * 0.3, width * 0.3, len(times)) if len(times) > 1 else [0.0]
        axes.scatter(np.asarray(offsets) + x, sorted(times), s=3, color="black", zorder=3)
    if drawn:
        axes.set_ylim(log_floor(min(drawn) * 0.9), log_ceiling(max(drawn) * 1.1))
    duration_axis(axes.yaxis)
    axes.set_xticks(range(len(syncs)), syncs, rotation=35, ha="right", rotation_mode="anchor")
    axes.set_xlim(-0.6, max(len(syncs), 1) - 0.4)
    axes.set_xlabel("primitive (fastest first)")
    axes.set_ylabel("step time (log)")
    axes.grid(axis="y", which="major", color="#dddddd", lw=0.6)
    axes.set_axisbelow(True)
    title = f"step time per primitive and layout, pin:{pin}, {threads} thread{'s' if threads != 1 else ''}"
    if left_out:
        title += f"\ncollapsed, not drawn: {', '.join(left_out)}"
    axes.set_title(title, fontsize=9)
    handles, labels = axes.get_legend_handles_labels()
    if handles:
        axes.legend(title="layout", fontsize=7, title_fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                    frameon=False)
    return to_svg(figure)


# ---------------------------------------------------------------- CPU per step, and the step's split

# Panels of one CPU figure side by side (one per thread count); more wrap to the next row.
CPU_PANELS_PER_ROW = 3
# Up to this many CPUs a panel draws every line k CPUs busy; beyond, the powers of two (the lines of 15 and 16
# would lie on each other).
EVERY_BUSY_LINE = 8


def busy_lines(threads: int, cpus: int | None = None) -> list[int]:
    """The k of the lines "k CPUs busy" a panel of this thread count draws: 1 .. threads, or 1 .. the machine's
    `cpus` and the thread count itself when the threads outnumber them (a team cannot keep more CPUs busy than
    there are: the last line says where it would sit if each thread had one); past EVERY_BUSY_LINE, the powers
    of two below that and the count."""
    reach = threads if cpus is None else min(threads, cpus)
    lines = list(range(1, reach + 1)) if reach <= EVERY_BUSY_LINE else \
        [2 ** power for power in range(reach.bit_length()) if 2 ** power < reach] + [reach]
    return lines + ([threads] if threads > reach else [])


# How many points of a panel are named: the fastest entry of each of the fastest primitives (and the entry that
# keeps the fewest CPUs busy).
NAMED_FASTEST = 3


def _named_points(points: list[CpuPoint]) -> list[CpuPoint]:
    """The points a panel names by primitive: the fastest entry of each of its NAMED_FASTEST fastest
    primitives, and the entry that keeps the fewest CPUs busy (team CPU / time: a sleeping primitive) unless
    its primitive is named already."""
    named, primitives = [], set()
    for point in sorted(points, key=lambda point: (point.unit_ns, point.key.sort_key())):
        if point.key.get("sync") not in primitives and len(primitives) < NAMED_FASTEST:
            primitives.add(point.key.get("sync"))
            named.append(point)
    frugal = min(points, key=lambda point: (point.cpus_busy, point.key.sort_key()), default=None)
    if frugal is not None and frugal.key.get("sync") not in primitives:  # a primitive is named once
        named.append(frugal)
    return named


# The room a name of a point takes in pixels at figure.dpi 100 and font size 7: a character's width (generous)
# and a line's height.
NAME_CHARACTER_PX = 5.6
NAME_LINE_PX = 11.0


def _point_name(point: CpuPoint) -> str:
    """A named point's words: its primitive, and its layout where it has one ("<primitive> (<layout>)")."""
    return point.key.get("sync") + (f" ({point.key.get('layout')})" if point.key.get("layout") else "")


def _place_names(axes, named: list[CpuPoint], members: list[CpuPoint]) -> None:
    """Each named point's primitive written below and to the right of it, where a panel is mostly empty (no
    team burns less than a CPU's worth of the fast steps, and a sleeping team's points lie right of the
    spinners'; near the panel's right edge, under them): the names of points near each other start in one
    column, and each name moves down until it covers no point of the panel and no other name; a thin line
    leads to its point. Call it once the panel's limits and place are final (positions are taken in pixels)."""
    to_pixels = axes.transData.transform
    spots = sorted(((tuple(to_pixels((point.unit_ns, point.team_cpu_ns))), point) for point in named),
                   key=lambda spot: spot[0])
    clusters = []  # named points less than 8 lines apart across share a column of names
    for spot in spots:
        if clusters and spot[0][0] - clusters[-1][-1][0][0] < 8.0 * NAME_LINE_PX:
            clusters[-1].append(spot)
        else:
            clusters.append([spot])
    half = NAME_LINE_PX / 2.0
    taken = [(x - 4.0, y - 4.0, x + 4.0, y + 4.0)  # every point's marker: (left, bottom, right, top)
             for x, y in (to_pixels((point.unit_ns, point.team_cpu_ns)) for point in members)]
    scale = 72.0 / axes.figure.dpi  # pixels to points
    edge = axes.get_window_extent().x1
    for cluster in clusters:
        widest = NAME_CHARACTER_PX * max(len(_point_name(point)) for _, point in cluster)
        left = max(x for (x, _), _ in cluster) + 2.0 * NAME_LINE_PX
        left = min(left, edge - widest - 4.0)  # near the right edge: the column moves left, under the points
        for (x, y), point in sorted(cluster, key=lambda spot: (-spot[0][1], spot[0][0])):
            text = _point_name(point)
            right = left + NAME_CHARACTER_PX * len(text)
            height = y - 2.0 * NAME_LINE_PX
            for _ in range(200):  # down a little at a time until the name's box is free
                if not any(left < box[2] and box[0] < right and height - half < box[3] and box[1] < height + half
                           for box in taken):
                    break
                height -= 2.0
            taken.append((left, height - half, right, height + half))
            axes.annotate(text, (point.unit_ns, point.team_cpu_ns), xytext=((left - x) * scale, (height - y) * scale),
                          textcoords="offset points", ha="left", va="center", fontsize=7, color="#222222",
                          arrowprops=dict(arrowstyle="-", color="#777777", lw=0.5, shrinkA=1, shrinkB=3))


def cpu_against_time(points: list[CpuPoint], unit: str, cpus: int | None = None, chosen=frozenset(),
                     layout_order=()) -> str:
    """Median time per unit (x) against the median CPU time the team burned per unit (y), log-log, one panel
    per thread count (CPU_PANELS_PER_ROW to a row), one point per entry: marker by placement, colour by layout
    (rk4). The lines y = k x for k = 1 .. threads (busy_lines: up to the machine's `cpus`, and the thread count
    dotted beyond them) are "k CPUs busy", named at the panel's right edge: a spinning team sits on k = its
    threads (or the CPUs it has), a sleeping one below. The fastest primitives and the entry that keeps the
    fewest CPUs busy are named; the `chosen` entries (keys: the answer's choices) are ringed in red, as
    the heat maps outline them. layout_order: the layouts in the order of their colours (matrix.syncs_layouts)."""
    thread_counts = sorted({point.key.threads for point in points})
    layouts = ordered({point.key.get("layout") for point in points if point.key.get("layout")}, layout_order)
    pins = ordered({point.key.get("pin") for point in points}, words.PIN_ORDER)
    palette = plt.get_cmap("tab10")
    colors = {layout: palette(index) for index, layout in enumerate(layouts)}
    columns = min(len(thread_counts), CPU_PANELS_PER_ROW)
    rows = math.ceil(len(thread_counts) / columns)
    figure, grid = plt.subplots(rows, columns, figsize=(5.2 * columns, 4.4 * rows + 0.4), squeeze=False)
    panels = list(grid.flat)
    for axes in panels[len(thread_counts):]:
        axes.set_visible(False)
    for axes, threads in zip(panels, thread_counts):
        members = [point for point in points if point.key.threads == threads]
        x_low = log_floor(min(point.unit_ns for point in members) / 1.5)
        x_high = log_ceiling(max(point.unit_ns for point in members) * 1.5)
        # Every line leaves the panel through its right edge, where it is named; below the lowest point there
        # is room for the names (half a decade: _place_names writes them below and right of their points).
        y_low = min([x_low] + [point.team_cpu_ns for point in members]) / 3.0
        y_high = max(x_high * threads * 1.5, max(point.team_cpu_ns for point in members) * 1.5)
        axes.set_xscale("log")
        axes.set_yscale("log")
        axes.set_xlim(x_low, x_high)
        axes.set_ylim(y_low, y_high)
        for busy in busy_lines(threads, cpus):
            beyond = cpus is not None and busy > cpus
            color = "#aaaaaa" if beyond else "#555555"
            axes.plot([y_low / busy, x_high], [y_low, busy * x_high], color=color, lw=0.7, ls=":" if beyond else "--",
                      zorder=1)
            axes.annotate(f"{busy} CPU{'s' if busy != 1 else ''} busy", (1.0, busy * x_high),
                          xycoords=("axes fraction", "data"), xytext=(3, 0), textcoords="offset points",
                          ha="left", va="center", fontsize=7, color=color, annotation_clip=False)
        for point in members:
            axes.scatter([point.unit_ns], [point.team_cpu_ns], s=22, zorder=3,
                         marker=words.PIN_MARKERS.get(point.key.get("pin"), "P"),
                         color=colors.get(point.key.get("layout"), "#4c72b0"), edgecolors="black", linewidths=0.3,
                         alpha=0.85)
        for point in members:
            if point.key in chosen:
                axes.plot([point.unit_ns], [point.team_cpu_ns], marker="o", ms=11, mfc="none", mec="#d62728",
                          mew=1.6, ls="none", zorder=4)
        duration_axis(axes.xaxis)
        duration_axis(axes.yaxis)
        axes.grid(which="major", color="#eeeeee", lw=0.6)
        axes.set_axisbelow(True)
        axes.set_xlabel(f"median time per {unit} (log)")
        axes.set_ylabel(f"median team CPU per {unit} (log)")
        over = f" on {cpus} CPUs" if cpus is not None and threads > cpus else ""
        axes.set_title(f"{threads} thread{'s' if threads != 1 else ''}{over}", fontsize=9)
    handles = [matplotlib.lines.Line2D([], [], ls="none", marker=words.PIN_MARKERS.get(pin, "P"), color="white",
                                       markeredgecolor="black", label=f"pin:{pin}") for pin in pins]
    handles += [matplotlib.patches.Patch(color=colors[layout], label=layout) for layout in layouts]
    handles.append(matplotlib.lines.Line2D([], [], ls="--", color="#555555", lw=0.7, label="k CPUs busy: y = k x"))
    if cpus is not None and max(thread_counts) > cpus:
        handles.append(matplotlib.lines.Line2D([], [], ls=":", color="#aaaaaa", lw=0.7,
                                               label=f"more than the machine's {cpus} CPUs"))
    if any(point.key in chosen for point in points):
        handles.append(matplotlib.lines.Line2D([], [], ls="none", marker="o", ms=9, mfc="none", mec="#d62728",
                                               mew=1.6, label="the run's answer chose it"))
    figure.legend(handles=handles, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, 0.0), frameon=False,
                  ncol=min(len(handles), 2 + 2 * columns))  # about as wide as the panels
    figure.suptitle(f"time per {unit} against the CPU the team burns per {unit} (one point per entry)", fontsize=9)
    figure.tight_layout(w_pad=4.0, h_pad=2.0)
    for axes, threads in zip(panels, thread_counts):  # the panels' places are final
        members = [point for point in points if point.key.threads == threads]
        _place_names(axes, _named_points(members), members)
    return to_svg(figure)


SPLIT_COLORS = ("#4c72b0", "#dd8452", "#c44e52")


def step_split_bars(splits: list[StepSplit], title: str) -> str:
    """One horizontal bar per entry (top: the fastest), its parts as shares of its step (a part below 0, a
    clock's noise, drawn as 0), the step time written at the bar's end. A clamped split (StepSplit.clamped: the
    sampled syncs took the whole step or more) has no compute: its two sync parts are drawn as measured, hatched,
    past the step's line at 100 %."""
    figure, axes = plt.subplots(figsize=(7.6, 0.28 * len(splits) + 1.6))
    right = 100.0
    for row, split in enumerate(splits):
        parts = [max(0.0, part) for part in split.parts_ns]
        if split.clamped:
            parts[0] = 0.0
        left = 0.0
        for index, part in enumerate(parts):
            share = 100.0 * part / split.step_ns
            axes.barh(row, share, 0.7, left=left, color=SPLIT_COLORS[index], lw=0,
                      hatch="////" if split.clamped else None, edgecolor="white" if split.clamped else None,
                      label=STEP_SPLIT_COUNTERS[index][1] if row == 0 else None)
            if share >= 12.0 and not split.clamped:
                axes.text(left + share / 2, row, f"{share:.0f} %", ha="center", va="center", fontsize=6,
                          color="white")
            left += share
        right = max(right, left)
        end = format_ns(split.step_ns, CELL_DIGITS) + (f", syncs {left:.0f} %" if split.clamped else "")
        axes.text(left + 1.0, row, end, ha="left", va="center", fontsize=7)
    axes.axvline(100.0, color="black", lw=0.8, ls="--")
    labels = [f"{split.key.get('sync')} ({split.key.get('layout')})" for split in splits]
    axes.set_yticks(range(len(splits)), labels, fontsize=7)
    axes.set_ylim(len(splits) - 0.5, -0.5)
    clamped = any(split.clamped for split in splits)
    axes.set_xlim(0.0, right + (24.0 if clamped else 12.0))
    ticks = [tick for tick in range(0, int(right) + 1, 25)]
    axes.set_xticks(ticks, [f"{tick} %" for tick in ticks])
    axes.set_xlabel("share of the step (the median repetition's; its step at the bar's end; dashed: the step)")
    axes.set_title(title, fontsize=9)
    handles, names = axes.get_legend_handles_labels()
    if clamped:
        handles.append(matplotlib.patches.Patch(facecolor="#999999", hatch="////", edgecolor="white"))
        names.append("hatched: compute not measured")
    axes.legend(handles, names, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return to_svg(figure)


# Where a verdict of a paired ratio is drawn (statistics.VERDICTS): the bar's colour, hatched and pale when the
# interval reaches into the noise band (within noise: inside it; unsure: across its edge). A ratio of two
# medians, with no interval and no verdict, is drawn in MEDIANS_COLOR.
VERDICT_STYLE = {"penalty": {"hatch": None, "alpha": 1.0}, "gain": {"hatch": None, "alpha": 1.0},
                 "within noise": {"hatch": "////", "alpha": 0.35}, "unsure": {"hatch": "xxxx", "alpha": 0.35}}
VERDICT_COLOR = {"penalty": "#c44e52", "gain": "#55a868", "within noise": "#8c8c8c", "unsure": "#dd8452"}
MEDIANS_COLOR = "#4c72b0"


def ratio_ticks(low: float, high: float) -> list[float]:
    """Ticks of a logarithmic ratio axis from low to high that do not crowd each other: fine steps around 1 on a
    narrow axis, 1-2-5 over a few decades, powers of ten beyond (every other one past six decades)."""
    decades = math.log10(high / low)
    powers = range(math.floor(math.log10(low)), math.ceil(math.log10(high)) + 1)
    if decades <= 0.15:
        candidates = [0.9, 0.95, 0.98, 1.0, 1.02, 1.05, 1.1]
    elif decades <= 0.35:
        candidates = [0.67, 0.8, 0.9, 1.0, 1.1, 1.25, 1.5]
    elif decades <= 0.7:
        candidates = [0.5, 0.67, 0.8, 1.0, 1.25, 1.5, 2.0]
    elif decades <= 2.2:
        candidates = [digit * 10.0 ** power for power in powers for digit in (1.0, 2.0, 5.0)]
    else:
        step = 1 if decades <= 6 else 2
        candidates = [10.0 ** power for power in powers if power % step == 0]
    return [tick for tick in candidates if low <= tick <= high]


def ratio_text(value: float) -> str:
    """A tick of a ratio axis: "0.5x", "1x", "20x", "1,000x", "1e-06x"."""
    if value >= 10:
        return f"{value:,.0f}x"
    return f"{value:g}x"


# How far an interval's whisker may reach beyond the span of the medians (with 1 and the noise band) before the
# axis clips it: a factor on each side. One degenerate interval (3 pairs, [0.0005, 1.01]) would otherwise stretch
# the axis over decades and leave every other bar a sliver; a clipped whisker ends in an arrow at the bound.
WHISKER_ROOM = 2.0


def finite_positive(values) -> list[float]:
    return [v for v in values if v is not None and v > 0 and math.isfinite(v)]


def ratio_axis_range(ratios, intervals, noise: float | None) -> tuple[float, float]:
    """(low, high) of a ratio axis: every ratio, 1 and the noise band (±25 % when there is none), and the
    intervals' ends, each clipped to WHISKER_ROOM beyond the span of the rest. intervals: (low, high) pairs
    (None where a ratio has none)."""
    band = 1.0 + (noise or 0.25)
    medians = finite_positive(ratios)
    low, high = min(medians + [1.0 / band]), max(medians + [band])
    ends = [(lo, hi) for lo, hi in intervals if lo is not None and hi is not None]
    lows, highs = finite_positive(lo for lo, _ in ends), finite_positive(hi for _, hi in ends)
    return (max(low / WHISKER_ROOM, min(lows + [low])), min(high * WHISKER_ROOM, max(highs + [high])))


def _ratio_axis(axes, span: tuple[float, float], noise: float | None, margin: float = 0.06) -> None:
    """A logarithmic ratio axis over span (ratio_axis_range) and a margin on each side (a share of the span),
    showing 1 and the noise band, shaded; its ticks never crowd (ratio_ticks)."""
    axes.set_xscale("log")
    low, high = span
    room = (high / low) ** margin
    low, high = low / room, high * room
    axes.set_xlim(low, high)
    axes.axvline(1.0, color="black", lw=0.8)
    if noise:
        axes.axvspan(1.0 / (1.0 + noise), 1.0 + noise, color="#bbbbbb", alpha=0.35, lw=0)
    ticks = ratio_ticks(low, high)
    axes.xaxis.set_major_locator(matplotlib.ticker.FixedLocator(ticks))
    axes.xaxis.set_major_formatter(matplotlib.ticker.FixedFormatter([ratio_text(t) for t in ticks]))
    axes.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
    axes.grid(axis="x", which="major", color="#dddddd", lw=0.6)
    axes.set_axisbelow(True)


def _ratio_bars(axes, rows: list[PenaltyRow], noise: float | None) -> int:
    """One horizontal bar per row from 1 to its ratio, top to bottom in the order given, named on the y axis,
    coloured by its verdict (hatched when within noise or unsure), its interval as a whisker; a whisker that
    reaches past the axis's span (ratio_axis_range) ends there in an arrow. Returns how many were clipped."""
    span = ratio_axis_range([row.ratio for row in rows], [(row.ci_low, row.ci_high) for row in rows], noise)
    _ratio_axis(axes, span, noise, margin=0.16)
    clipped = 0
    for y, row in enumerate(rows):
        style = VERDICT_STYLE.get(row.verdict, VERDICT_STYLE["penalty"])
        color = VERDICT_COLOR.get(row.verdict, MEDIANS_COLOR)
        axes.barh(y, row.ratio - 1.0, 0.7, left=1.0, color=color, alpha=style["alpha"], hatch=style["hatch"],
                  edgecolor=color if style["hatch"] else None, lw=0.0)
        reach = [row.ratio]
        low_clipped = False
        if row.ci_low is not None and row.ci_high is not None:
            low, high = max(row.ci_low, span[0]), min(row.ci_high, span[1])
            axes.errorbar(row.ratio, y, xerr=[[max(row.ratio - low, 0.0)], [max(high - row.ratio, 0.0)]],
                          color="black", capsize=2, lw=0.8)
            for end, bound, marker in ((row.ci_low, span[0], "<"), (row.ci_high, span[1], ">")):
                if (end < bound) if marker == "<" else (end > bound):
                    axes.plot([bound], [y], marker=marker, color="black", ms=5, ls="none")
                    clipped += 1
                    low_clipped = low_clipped or marker == "<"
            reach += [low, high]
        # The ratio written beyond the bar's end (and its whisker's), on the side it points to; on the right
        # when its whisker was clipped on the left, where the names are.
        if row.ratio >= 1.0 or low_clipped:
            axes.annotate(f"{row.ratio:.2f}x", (max(reach), y), xytext=(5, 0), textcoords="offset points",
                          ha="left", va="center", fontsize=6, color="#333333")
        else:
            axes.annotate(f"{row.ratio:.2f}x", (min(reach), y), xytext=(-5, 0), textcoords="offset points",
                          ha="right", va="center", fontsize=6, color="#333333")
    axes.set_yticks(range(len(rows)), [row.shown_label for row in rows], fontsize=7)
    axes.set_ylim(len(rows) - 0.5, -0.5)
    return clipped


CLIPPED_NOTE = "interval past the axis (its ends: the table)"


def _verdict_legend(axes, rows: list[PenaltyRow], noise: float | None, note: str = "", clipped: int = 0) -> None:
    handles = [matplotlib.patches.Patch(facecolor=color, alpha=VERDICT_STYLE[verdict]["alpha"],
                                        hatch=VERDICT_STYLE[verdict]["hatch"], edgecolor=color, label=verdict)
               for verdict, color in VERDICT_COLOR.items() if any(row.verdict == verdict for row in rows)]
    if clipped:
        handles.append(matplotlib.lines.Line2D([], [], marker=">", color="black", ls="none", ms=5,
                                               label=CLIPPED_NOTE))
    if any(row.verdict not in VERDICT_COLOR for row in rows):
        handles.append(matplotlib.patches.Patch(color=MEDIANS_COLOR, label="ratio of medians (no interval)"))
    if noise:
        handles.append(matplotlib.patches.Patch(color="#bbbbbb", alpha=0.35, label=f"noise band ±{100 * noise:g} %"))
    if note:
        handles.append(matplotlib.patches.Patch(color="none", label=note))
    axes.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)


def _bars_height(count: int) -> float:
    return 0.24 * count + 0.9


def penalties(rows: list[PenaltyRow], noise: float | None = None) -> str:
    """The penalties as horizontal bars from 1, one panel per kind (false sharing, migration), one bar per
    primitive, placement and thread count, each named on its own line (never two bars on one line), on a
    logarithmic ratio axis that covers them all; a paired row carries its interval as a whisker and is
    coloured by its verdict."""
    kinds = sorted({row.kind for row in rows})
    by_kind = [sorted((row for row in rows if row.kind == kind), key=lambda row: (row.threads, row.pin, row.sync))
               for kind in kinds]
    heights = [_bars_height(len(members)) for members in by_kind]
    figure, axes_list = plt.subplots(len(kinds), 1, figsize=(9.0, sum(heights) + 0.5), squeeze=False,
                                     gridspec_kw={"height_ratios": heights})
    clipped = 0
    for axes, kind, members in zip(axes_list[:, 0], kinds, by_kind):
        clipped += _ratio_bars(axes, members, noise)
        axes.set_title(kind, fontsize=9)
    axes_list[-1, 0].set_xlabel("time ratio (log; > 1: penalty, < 1: gain)")
    _verdict_legend(axes_list[0, 0], rows, noise, clipped=clipped)
    figure.tight_layout()
    return to_svg(figure)


def paired_ratios(rows: list[PenaltyRow], title: str, noise: float | None = None, note: str = "") -> str:
    """Paired ratios (lockstep_pairs) as horizontal bars from 1 on a logarithmic ratio axis, one named line per
    bar in the order given: the median per adjacent pair, the whisker its confidence interval, the noise band
    shaded, a bar within noise or unsure hatched and pale. note: a line added to the legend."""
    figure, axes = plt.subplots(figsize=(7.6, _bars_height(len(rows)) + 0.4))
    clipped = _ratio_bars(axes, rows, noise)
    axes.set_xlabel("paired time ratio a / b (log; median per adjacent pair, whisker: confidence interval)")
    _verdict_legend(axes, rows, noise, note, clipped)
    axes.set_title(title, fontsize=9)
    return to_svg(figure)


def c2c_heatmap(latencies) -> str:
    """The p50 one-way latency of every pair of one method, CPUs in topology order (c2c_analysis.LatencyGrid)."""
    order, method = list(latencies.cpus), latencies.method
    grid = np.array([[np.nan if value is None else value for value in row] for row in latencies.p50_ns],
                    dtype=float).reshape(len(order), len(order))
    size = max(3.2, 0.38 * len(order) + 1.8)
    figure, axes = plt.subplots(figsize=(size + 1.0, size))
    image = axes.imshow(np.ma.masked_invalid(grid), cmap="magma_r", aspect="equal")
    axes.set_xticks(range(len(order)), [str(cpu) for cpu in order], fontsize=7)
    axes.set_yticks(range(len(order)), [str(cpu) for cpu in order], fontsize=7)
    if len(order) <= 16:
        for i in range(len(order)):
            for j in range(len(order)):
                if math.isfinite(grid[i, j]):
                    axes.text(j, i, f"{grid[i, j]:.0f}", ha="center", va="center", fontsize=6,
                              color="white" if grid[i, j] > np.nanmean(grid) else "black")
    axes.set_xlabel("CPU (ordered by topology)")
    axes.set_ylabel("CPU")
    axes.set_title(f"core-to-core one-way latency, p50 ({latencies.label}{', ' + method if method else ''})")
    figure.colorbar(image, ax=axes, label="ns")
    return to_svg(figure)


def delay_histogram(delay) -> str:
    """The wake-up latency histogram of a paced run (delay_reader.DelayFile), its p50, p99 and p99.9 marked."""
    histogram = delay.histogram
    counts = np.asarray(histogram.counts, dtype=float)
    edges_us = (histogram.first_ns + histogram.bucket_ns * np.arange(counts.size + 1)) / 1e3
    figure, axes = plt.subplots(figsize=(6.4, 3.2))
    axes.stairs(counts, edges_us, fill=True, color="#4c72b0")
    axes.set_yscale("log")
    axes.set_ylim(bottom=0.8)
    for name, style in (("p50", "-"), ("p99", "--"), ("p999", ":")):
        value = delay.pinned.wakeup.statistics.get(name)
        if value is not None:  # the axis is in us
            axes.axvline(value / 1e3, color="black", ls=style, lw=0.9, label=f"{name} {format_ns(value)}")
    axes.set_xlabel("wake-up latency (us)")
    axes.set_ylabel("periods")
    axes.set_title(f"paced wake-up latency ({delay.label}; period {format_ns(delay.settings.get('period_ns'))})")
    if axes.get_legend_handles_labels()[0]:
        axes.legend(fontsize=7)
    return to_svg(figure)


def delay_causes(rows: list[tuple[str, dict[str, float]]], names) -> str:
    """Why a delay run's late steps were late: one stacked horizontal bar per row (label, {cause key: ns of
    excess}), each cause's share of the row's excess, the causes in the order of names ((key, words)); a cause no
    row has is left out of the legend."""
    figure, axes = plt.subplots(figsize=(8, 0.5 * len(rows) + 1.4))
    colours = plt.get_cmap("tab10").colors
    labels = [label for label, _ in rows]
    shares = []
    for _, split in rows:
        total = sum(split.get(key, 0.0) for key, _ in names)
        shares.append({key: (split.get(key, 0.0) / total if total > 0 else 0.0) for key, _ in names})
    left = [0.0] * len(rows)
    for index, (key, name) in enumerate(names):
        widths = [100 * split[key] for split in shares]
        if not any(widths):
            continue
        axes.barh(labels, widths, left=left, color=colours[index % len(colours)], label=name)
        left = [a + b for a, b in zip(left, widths)]
    axes.invert_yaxis()
    axes.set_xlim(0, 100)
    axes.set_xlabel("share of the excess over the median completion (%)")
    axes.set_title("Why the late steps were late")
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.25), ncol=4, fontsize="small", frameon=False)
    figure.tight_layout()
    return to_svg(figure)


def trajectory(verify, reference, deviation: float) -> str:
    """The paper's Figure 2: x1 and x2 of a verify trajectory against time, with the analytic solution
    (reference: its x1 and x2 at the trajectory's times) dashed."""
    t = np.asarray(verify.t)
    x1, x2 = np.asarray(verify.x1), np.asarray(verify.x2)
    reference_x1, reference_x2 = reference
    label = verify.label
    figure, axes = plt.subplots(figsize=(6.8, 3.2))
    axes.plot(t, x1, lw=1.0, label="x1 (lockstep)")
    axes.plot(t, x2, lw=1.0, label="x2 (lockstep)")
    axes.plot(t, reference_x1, lw=0.6, ls="--", color="black", label="analytic")
    axes.plot(t, reference_x2, lw=0.6, ls="--", color="black")
    axes.set_xlabel("t (s)")
    axes.set_ylabel("displacement")
    axes.set_title(f"trajectory (the paper's Figure 2), {label}; max |lockstep - analytic| = {deviation:.2e}")
    axes.legend(fontsize=7, ncol=3, loc="upper center", bbox_to_anchor=(0.5, -0.18))
    return to_svg(figure)


def wakeup_histograms(histograms, panels, title: str, marks=None) -> str:
    """Wake-up latency histograms in 1 us buckets (delay_reader.LatencyHistograms) on a logarithmic latency axis
    and a logarithmic count axis: the body (a few us) and the tail (hundreds of us) both show, and the tail
    is the point. panels: (title, counts, overflow, highlighted) each; side by side, sharing both axes.
    The wake-ups beyond the bound stand as one hatched overflow bar at its right. marks: {name: ns} drawn
    as vertical lines (p50, p99, p99.9) on a single panel."""
    per_row = min(len(panels), 4)
    rows = math.ceil(len(panels) / per_row)
    width = 6.4 if len(panels) == 1 else 2.9 * per_row + 0.6
    figure, axes_grid = plt.subplots(rows, per_row, figsize=(width, 2.6 * rows + 0.6), squeeze=False,
                                     sharex=True, sharey=True)
    bucket = histograms.bucket_us
    bound = histograms.bound_us
    used = [i for _, counts, _, _ in panels for i, c in enumerate(counts) if c]
    first = max(min(used) * bucket, bucket / 2) if used else bucket / 2
    last = (max(used) + 1) * bucket if used else bound
    overflowing = any(overflow for _, _, overflow, _ in panels)
    right = bound if overflowing else last
    overflow_edges = (right, right * 1.5)
    highest = max([max(list(counts) + [overflow]) for _, counts, overflow, _ in panels] + [1])
    for index, axes in enumerate(axes_grid.flat):
        if index >= len(panels):
            axes.set_visible(False)
            continue
        name, counts, overflow, highlighted = panels[index]
        counts = np.asarray(counts, dtype=float)
        edges = bucket * np.arange(counts.size + 1)
        edges[0] = min(first, edges[1] / 2)  # a log axis has no 0: the first bucket starts half way to its end
        axes.set_xscale("log")
        axes.set_yscale("log")
        axes.stairs(counts, edges, fill=True, color="#4c72b0")
        if overflow:
            axes.stairs([overflow], overflow_edges, fill=True, color="#c44e52", hatch="////", lw=0,
                        label=f"later than {format_ns(bound * 1e3, 3)}: {overflow}")
        for (label, value), style in zip(sorted((marks or {}).items(), key=lambda item: item[1]), ("-", "--", ":")):
            axes.axvline(value / 1e3, color="black", ls=style, lw=0.9, label=f"{label} {format_ns(value, 3)}")
        if axes.get_legend_handles_labels()[0]:
            if len(panels) == 1:
                axes.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
            else:
                axes.legend(fontsize=6, loc="upper right", frameon=False)
        axes.set_ylim(0.8, highest * 3.0)
        if len(panels) > 1:
            axes.set_title(name + (" (noisiest)" if highlighted else ""), fontsize=8,
                           color="#c44e52" if highlighted else "black")
        if index % per_row == 0:
            axes.set_ylabel("wake-ups (log)")
        if index >= len(panels) - per_row:
            axes.set_xlabel("wake-up latency (log)")
    axes_grid.flat[0].set_xlim(first / 1.5, (overflow_edges[1] if overflowing else last) * 1.1)
    for axes in axes_grid.flat:
        duration_axis(axes.xaxis, unit_ns=1e3)
    figure.suptitle(title, fontsize=9)
    return to_svg(figure)


def period_search(search) -> str:
    """The find-period search (delay_reader.PeriodSearch): each trial's period against its observed miss rate
    (whisker up to the upper bound that decided it), the target rate and the answer marked, the trials
    numbered in the order they ran. A trial without a miss sits on the axis's floor, marked as zero."""
    trials = list(search.trials)
    figure, axes = plt.subplots(figsize=(6.4, 3.4))
    axes.set_xscale("log")
    axes.set_yscale("log")
    rates = [t.miss_rate for t in trials + ([search.confirm] if search.confirm else []) if t.miss_rate > 0]
    bounds = [t.upper_bound for t in trials if t.upper_bound]
    low = min(rates + bounds + [search.miss_rate]) / 10.0 if (rates or bounds or search.miss_rate) else 1e-6
    low = log_floor(low) if low > 0 else 1e-6
    high = log_ceiling(max(rates + bounds + [search.miss_rate]) * 1.5) if (rates or bounds) else 1.0
    floor = low * 1.6  # where a trial without a miss is drawn
    for number, trial in enumerate(trials, start=1):
        x = trial.period_ns
        y = trial.miss_rate if trial.miss_rate > 0 else floor
        color = "#55a868" if trial.holds else "#c44e52"
        if trial.upper_bound and trial.upper_bound > y:
            axes.plot([x, x], [y, trial.upper_bound], color=color, lw=0.9)
            axes.plot([x], [trial.upper_bound], marker="_", color=color, ms=7)
        axes.plot([x], [y], marker="o" if trial.holds else "X", color=color, ms=6 if trial.holds else 7,
                  mfc=color if trial.miss_rate > 0 else "white", ls="none")
        axes.annotate(str(number), (x, y), textcoords="offset points", xytext=(5, -9), fontsize=7)
    if search.confirm is not None:
        y = search.confirm.miss_rate if search.confirm.miss_rate > 0 else floor
        axes.plot([search.confirm.period_ns], [y], marker="*", color="black", ms=10, ls="none",
                  label="confirming run")
    axes.axhline(search.miss_rate, color="black", ls="--", lw=0.9, label=f"target rate {search.miss_rate:g}")
    if search.found_period_ns:
        axes.axvline(search.found_period_ns, color="#55a868", lw=1.2,
                     label=f"answer {format_ns(search.found_period_ns, 3)}")
    if search.failed_period_ns:
        axes.axvline(search.failed_period_ns, color="#c44e52", lw=0.9, ls=":",
                     label=f"failed {format_ns(search.failed_period_ns, 3)}")
    axes.axhspan(low, floor * 1.5, color="#eeeeee", lw=0)
    axes.text(0.01, floor, " no miss", transform=axes.get_yaxis_transform(), fontsize=7, va="center", color="#555555")
    axes.set_ylim(low, high)
    periods = [t.period_ns for t in trials] + ([search.confirm.period_ns] if search.confirm else [])
    if periods:
        axes.set_xlim(min(periods) / 1.6, max(periods) * 1.6)
    duration_axis(axes.xaxis)
    axes.set_xlabel("period (log)")
    axes.set_ylabel("observed miss rate (log)")
    axes.plot([], [], marker="o", color="#55a868", ls="none", label="holds")
    axes.plot([], [], marker="X", color="#c44e52", ls="none", label="fails")
    axes.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    axes.set_title("find-period: periods tried against their miss rate"
                   + (" (cut by the search budget)" if search.budget_cut else ""), fontsize=9)
    return to_svg(figure)


def mode_colors(count: int):
    """One colour per pace mode, fastest first; outliers (mode -1) are grey."""
    palette = plt.get_cmap("tab10")
    return {mode: palette(mode % 10) for mode in range(count)} | {-1: (0.6, 0.6, 0.6, 1.0)}


def pace_trace(readings, modes, title: str) -> str:
    """The pace trace as a time line: each reference reading's core-to-core latency (and serial step, in a
    second panel) against the time since the run started, coloured by the pace mode it was put in, each
    mode's median as a line. readings: objects with t_s, c2c_ns (None on one CPU), serial_ns, mode; modes:
    objects with mode, c2c_ns, serial_ns, share."""
    colors = mode_colors(len(modes))
    has_c2c = any(r.c2c_ns is not None for r in readings)
    panels = [("c2c_ns", "core-to-core one-way")] if has_c2c else []
    panels.append(("serial_ns", "serial RK4 step"))
    figure, axes_list = plt.subplots(len(panels), 1, figsize=(7.2, 1.9 * len(panels) + 0.7), squeeze=False,
                                     sharex=True)
    for (key, name), axes in zip(panels, axes_list[:, 0]):
        values = [getattr(r, key) for r in readings if getattr(r, key) is not None]
        for mode in sorted({r.mode for r in readings}):
            points = [(r.t_s, getattr(r, key)) for r in readings if r.mode == mode and getattr(r, key) is not None]
            if points:
                xs, ys = zip(*points)
                label = "outlier" if mode < 0 else f"mode {mode}"
                axes.scatter(xs, ys, s=7, color=colors.get(mode, colors[-1]), label=label, zorder=3, lw=0)
        for mode in modes:
            value = getattr(mode, key, None)
            if value is not None:
                axes.axhline(value, color=colors.get(mode.mode, colors[-1]), lw=0.8, ls="--")
        if values and max(values) / min(values) > 3.0:
            axes.set_yscale("log")
            axes.set_ylim(log_floor(min(values) * 0.9), log_ceiling(max(values) * 1.1))
            duration_axis(axes.yaxis)
        else:
            axes.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda value, _: format_ns(value, 2)))
        axes.set_ylabel(name, fontsize=8)
        axes.grid(axis="y", color="#eeeeee", lw=0.6)
    axes_list[-1, 0].set_xlabel("time since the run started (s)")
    handles, labels = axes_list[0, 0].get_legend_handles_labels()
    if handles:
        axes_list[0, 0].legend(handles, labels, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                               frameon=False, markerscale=1.6)
    axes_list[0, 0].set_title(title, fontsize=9)
    return to_svg(figure)


def _log_log_axes(axes, ticks, values) -> None:
    """A time against a doubling count: x on a log2 scale with the given ticks written plainly, y on a log scale
    spanning the values as durations (none: y left as it is)."""
    axes.set_xscale("log", base=2)
    axes.set_xticks(ticks)
    axes.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda value, _: f"{value:g}"))
    axes.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    if values:
        axes.set_yscale("log")
        axes.set_ylim(log_floor(min(values) * 0.9), log_ceiling(max(values) * 1.1))
        duration_axis(axes.yaxis)


def scaling_curve(curve) -> str:
    """`lockstep run --scaling`: the curve's counter against threads on log-log axes, one line per primitive on
    its best layout at each count (a bar: the min..max over repetitions), hollow markers where the threads
    outnumbered the CPUs, and the run's
    core-to-core one-way latency as a reference line. curve: run_file.ScalingCurve."""
    figure, axes = plt.subplots(figsize=(7.2, 4.2))
    lines = {}
    for point in curve.points:
        if point.value_ns > 0:
            lines.setdefault(point.sync, []).append(point)
    palette = plt.get_cmap("tab20")
    values = []
    for index, (sync, points) in enumerate(sorted(lines.items())):
        points.sort(key=lambda point: point.threads)
        color = palette(index % 20)
        width = 2.2 if sync == curve.best else 1.0
        axes.plot([p.threads for p in points], [p.value_ns for p in points], color=color, lw=width,
                  label=sync + (" (scales best)" if sync == curve.best else ""), zorder=3)
        for point in points:
            axes.scatter([point.threads], [point.value_ns], s=18, zorder=4, color=color if not point.oversubscribed
                         else "white", edgecolors=color, linewidths=1.0)
            if point.range_ns and point.range_ns[0] > 0:
                axes.vlines(point.threads, *point.range_ns, color=color, lw=0.7, alpha=0.6, zorder=3)
                values += list(point.range_ns)
        values += [p.value_ns for p in points]
    if curve.c2c_one_way_ns:
        axes.axhline(curve.c2c_one_way_ns, color="#555555", lw=0.8, ls="--",
                     label=f"c2c one-way {format_ns(curve.c2c_one_way_ns)}")
        values.append(curve.c2c_one_way_ns)
    _log_log_axes(axes, list(curve.threads), values)
    axes.set_xlabel("threads (hollow: more threads than CPUs)")
    axes.set_ylabel("sync time per stage" if curve.counter == "sync_ns_per_stage" else "step time")
    axes.grid(color="#eeeeee", lw=0.6)
    axes.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    axes.set_title(f"Scaling at pin:{curve.pin}, each primitive on its best layout", fontsize=9)
    return to_svg(figure)


def _crossover_span(axes, crossover, color, edges: tuple[float, float]) -> None:
    """A series' crossover S* as a dotted vertical line, its interval shaded (an open end, null in the file, runs
    to the edge of the sizes drawn, shaded lighter)."""
    if crossover.masses is None:
        return
    low = crossover.ci_low if crossover.ci_low is not None else edges[0]
    high = crossover.ci_high if crossover.ci_high is not None else edges[1]
    closed = crossover.ci_low is not None and crossover.ci_high is not None
    if high > low:
        axes.axvspan(low, high, color=color, alpha=0.12 if closed else 0.06, lw=0, zorder=1)
    axes.axvline(crossover.masses, color=color, lw=1.2, ls=":", zorder=2)


def crossover_curves(series, labels, title: str, ceiling=None) -> str:
    """`lockstep run --crossover` at one thread count: step time against the chain's size S (masses) on log-log
    axes, per series (answer_reader.Crossover: a primitive on its layout) its measured points as the file holds
    them: the parallel step (solid, filled markers), the serial step it was paired with (black, the series'
    marker hollow), the model's step (dashed, the series' colour), and the crossover S* (dotted) with its
    interval (shaded); with the machine's ceiling at this thread count (answer_reader.Ceiling), the chain's blocks
    stepped at once with no sync (grey, dash-dot). A size that measured nothing (CrossoverPoint.measured false)
    is not drawn. labels: one legend text per series."""
    figure, axes = plt.subplots(figsize=(7.2, 4.2))
    palette = plt.get_cmap("tab10")
    markers = ("o", "s", "^", "D", "v", "P")
    sizes, values = [], []
    for index, crossover in enumerate(series):
        color, marker = palette(index % 10), markers[index % len(markers)]
        points = sorted((p for p in crossover.points if p.measured), key=lambda p: p.masses)
        masses = [p.masses for p in points]
        axes.plot(masses, [p.parallel_ns for p in points], color=color, lw=1.6, marker=marker, ms=4,
                  label=labels[index], zorder=4)
        axes.plot(masses, [p.serial_ns for p in points], color="black", lw=0.8, marker=marker, ms=4,
                  markerfacecolor="white", label=f"serial step, paired with {crossover.sync}", zorder=3)
        modelled = [p for p in points if p.model_ns is not None and p.model_ns > 0]
        axes.plot([p.masses for p in modelled], [p.model_ns for p in modelled], color=color, lw=1.0, ls="--",
                  marker="x", ms=4, label=f"model beside {crossover.sync}", zorder=3)
        sizes += [p.masses for p in crossover.points]
        values += [p.parallel_ns for p in points] + [p.serial_ns for p in points] + [p.model_ns for p in modelled]
    if ceiling is not None:
        blocks = sorted((p for p in ceiling.points if p.measured), key=lambda p: p.masses)
        axes.plot([p.masses for p in blocks], [p.blocks_ns for p in blocks], color="grey", lw=1.2, ls="-.",
                  marker=".", ms=4, label="the blocks at once, no sync (the ceiling)", zorder=3)
        values += [p.blocks_ns for p in blocks]
    edges = (min(sizes), max(sizes)) if sizes else (1.0, 2.0)
    for index, crossover in enumerate(series):
        _crossover_span(axes, crossover, palette(index % 10), edges)
    axes.set_xlim(edges[0] / 1.3, edges[1] * 1.3)
    grid = sorted(set(sizes))
    _log_log_axes(axes, grid if len(grid) <= 12 else grid[::2], values)
    axes.set_xlabel("S, the chain's masses (2S equations)")
    axes.set_ylabel("step time")
    axes.grid(color="#eeeeee", lw=0.6)
    axes.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    axes.set_title(title, fontsize=9)
    return to_svg(figure)


def mpi_distributions(exchanges, field: str, keys, title: str, reference_ns: float | None = None,
                      reference_label: str = "", ylabel: str = "") -> str:
    """Grouped bars on a log axis: one group per exchange of a `lockstep mpi` file (mpi_reader.MpiExchange),
    one bar per statistic of its `field` distribution (stage, skew); a dashed line at reference_ns."""
    labels = [exchange.label for exchange in exchanges]
    width = 0.8 / len(keys)
    figure, axes = plt.subplots(figsize=(max(6.0, 1.4 * len(labels) + 2.0), 3.8))
    positive = []
    for index, key in enumerate(keys):
        values = [getattr(exchange, field).get(key) for exchange in exchanges]
        shown = [value if value and value > 0 else np.nan for value in values]
        positive += [value for value in shown if math.isfinite(value)]
        axes.bar(np.arange(len(labels)) + (index - (len(keys) - 1) / 2) * width, shown, width,
                 label=key.replace("p999", "p99.9"))
    if reference_ns:
        axes.axhline(reference_ns, linestyle="--", color="black", linewidth=1.0, label=reference_label)
        positive.append(reference_ns)
    axes.set_yscale("log")
    if positive:
        axes.set_ylim(log_floor(min(positive)), log_ceiling(max(positive)) * 1.5)
    duration_axis(axes.yaxis)
    axes.set_xticks(range(len(labels)), labels, fontsize=8, rotation=15, ha="right")
    axes.set_xlabel("exchange")
    if ylabel:
        axes.set_ylabel(ylabel)
    axes.set_title(title, fontsize=10)
    axes.legend(fontsize=7, ncol=len(keys) + 1)
    figure.tight_layout()
    return to_svg(figure)
