"""The report's figures, each drawn by matplotlib into SVG text with deterministic bytes.

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
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

from . import paper, statistics  # noqa: E402
from .compare import run_median, sample  # noqa: E402
from .formatting import format_ns  # noqa: E402
from .names import BenchmarkKey  # noqa: E402

matplotlib.rcParams.update({
    "svg.hashsalt": "lockstep-report",
    "svg.fonttype": "path",
    "font.size": 9,
    "axes.titlesize": 10,
    "figure.dpi": 100,
    "savefig.bbox": "tight",
})

LAYOUT_ORDER = ("packed", "padded64", "padded128", "per_thread")
PIN_ORDER = ("compact", "scatter", "none", "migrate")
RELATION_RANK = {"same core": 0, "shared L2": 1, "shared L3": 2, "same package": 3, "same NUMA node": 4,
                 "cross package": 5, "other package": 5}
UNKNOWN_RELATION_RANK = 6
# Digits of a value written inside a figure's cell.
CELL_DIGITS = 3


def relation_rank(relation: str) -> int:
    return RELATION_RANK.get(relation, UNKNOWN_RELATION_RANK)


def relation_order(relation: str) -> tuple[int, str]:
    """Closest relation first, then by name."""
    return relation_rank(relation), relation


def ordered(values, preferred):
    values = set(values)
    return [v for v in preferred if v in values] + sorted(values - set(preferred))


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


def rk4_groups(run_file) -> list[tuple[str, int]]:
    groups = {(key.get("pin"), key.threads) for key in run_file.runs
              if key.family == "rk4" and key.get("sync") and key.get("layout") and key.get("pin")}
    pins = ordered({pin for pin, _ in groups}, PIN_ORDER)
    return sorted(groups, key=lambda group: (pins.index(group[0]), group[1] or 0))


def _rk4_key(sync, layout, pin, threads) -> BenchmarkKey:
    return BenchmarkKey("rk4", tuple(sorted((("sync", sync), ("layout", layout), ("pin", pin),
                                             ("threads", str(threads))))))


def _syncs_layouts(run_file):
    syncs = sorted({key.get("sync") for key in run_file.runs if key.family == "rk4" and key.get("sync")})
    layouts = ordered({key.get("layout") for key in run_file.runs if key.family == "rk4" and key.get("layout")},
                      LAYOUT_ORDER)
    return syncs, layouts


def heatmap(run_file, pin: str, threads: int) -> str:
    """Median step time, sync (rows) x layout (columns), for one placement and thread count."""
    syncs, layouts = _syncs_layouts(run_file)
    grid = np.full((len(syncs), len(layouts)), np.nan)
    for row, sync in enumerate(syncs):
        for column, layout in enumerate(layouts):
            value = run_median(run_file, _rk4_key(sync, layout, pin, threads))
            if value is not None:
                grid[row, column] = value
    figure, axes = plt.subplots(figsize=(1.3 * len(layouts) + 2.2, 0.42 * len(syncs) + 1.4))
    finite = grid[np.isfinite(grid)]
    norm = LogNorm(vmin=float(finite.min()), vmax=float(max(finite.max(), finite.min() * 1.0001))) if finite.size else None
    image = axes.imshow(np.ma.masked_invalid(grid), cmap="viridis_r", norm=norm, aspect="auto")
    axes.set_xticks(range(len(layouts)), layouts)
    axes.set_yticks(range(len(syncs)), syncs)
    for row in range(len(syncs)):
        for column in range(len(layouts)):
            value = grid[row, column]
            text = format_ns(value, CELL_DIGITS) if math.isfinite(value) else "n/a"
            axes.text(column, row, text, ha="center", va="center", fontsize=8,
                      color="white" if math.isfinite(value) and norm and norm(value) > 0.55 else "black")
    axes.set_title(f"step time (median), pin:{pin} threads:{threads}")
    figure.colorbar(image, ax=axes, label="ns per step (log)")
    return to_svg(figure)


def bars_with_spread(run_file, pin: str, threads: int) -> str:
    """Per primitive, one bar per layout at the median; the whisker spans the interquartile range
    and each dot is one repetition."""
    syncs, layouts = _syncs_layouts(run_file)
    figure, axes = plt.subplots(figsize=(max(5.0, 1.4 * len(syncs) + 1.5), 3.2))
    width = 0.8 / max(1, len(layouts))
    colors = plt.get_cmap("tab10")
    for column, layout in enumerate(layouts):
        for row, sync in enumerate(syncs):
            run = run_file.runs.get(_rk4_key(sync, layout, pin, threads))
            if run is None or run.errored:
                continue
            times, _ = sample(run)
            if not times:
                continue
            x = row + (column - (len(layouts) - 1) / 2) * width
            center = statistics.median(times)
            low, high = np.percentile(times, [25, 75])
            axes.bar(x, center, width * 0.9, color=colors(column), label=layout if row == 0 else None)
            axes.errorbar(x, center, yerr=[[center - low], [high - center]], color="black", capsize=2, lw=0.8)
            offsets = np.linspace(-width * 0.3, width * 0.3, len(times)) if len(times) > 1 else [0.0]
            axes.scatter(np.asarray(offsets) + x, sorted(times), s=4, color="black", zorder=3)
    axes.set_xticks(range(len(syncs)), syncs)
    axes.set_ylabel("ns per step")
    axes.set_title(f"step time per primitive, pin:{pin} threads:{threads} (bar median, whisker IQR, dot repetition)")
    handles, labels = axes.get_legend_handles_labels()
    if handles:
        axes.legend(title="layout", fontsize=7, ncol=min(4, len(labels)))
    return to_svg(figure)


def penalty_rows(run_file) -> list[tuple[str, str, int, float]]:
    """False sharing (packed / padded) and migration (migrate or none / compact), per primitive:
    (kind, sync, threads, time ratio)."""
    syncs, layouts = _syncs_layouts(run_file)
    padded = next((layout for layout in ("padded128", "padded64", "per_thread") if layout in layouts), None)
    groups = rk4_groups(run_file)
    threads_list = sorted({threads for _, threads in groups})
    rows = []
    for sync in syncs:
        for threads in threads_list:
            if padded and "packed" in layouts:
                packed_time = run_median(run_file, _rk4_key(sync, "packed", "compact", threads))
                padded_time = run_median(run_file, _rk4_key(sync, padded, "compact", threads))
                if packed_time and padded_time:
                    rows.append((f"false sharing: packed / {padded}", sync, threads, packed_time / padded_time))
            base_layout = padded or (layouts[0] if layouts else None)
            for moved in ("migrate", "none"):
                compact = run_median(run_file, _rk4_key(sync, base_layout, "compact", threads))
                other = run_median(run_file, _rk4_key(sync, base_layout, moved, threads))
                if compact and other:
                    rows.append((f"migration: pin:{moved} / pin:compact ({base_layout})", sync, threads,
                                 other / compact))
    return rows


def penalties(rows: list[tuple[str, str, int, float]]) -> str:
    """The penalty_rows as bars: one panel per kind, one bar per primitive and thread count."""
    syncs = sorted({row[1] for row in rows})
    threads_list = sorted({row[2] for row in rows})
    kinds = sorted({row[0] for row in rows})
    figure, axes_list = plt.subplots(1, len(kinds), figsize=(4.2 * len(kinds), 3.2), squeeze=False)
    colors = plt.get_cmap("tab10")
    for axes, kind in zip(axes_list[0], kinds):
        width = 0.8 / max(1, len(threads_list))
        for index, threads in enumerate(threads_list):
            xs, ys = [], []
            for position, sync in enumerate(syncs):
                for row in rows:
                    if row[0] == kind and row[1] == sync and row[2] == threads:
                        xs.append(position + (index - (len(threads_list) - 1) / 2) * width)
                        ys.append(row[3])
            axes.bar(xs, ys, width * 0.9, color=colors(index), label=f"threads:{threads}")
        axes.axhline(1.0, color="black", lw=0.8)
        axes.set_xticks(range(len(syncs)), syncs, rotation=20)
        axes.set_ylabel("time ratio (> 1: penalty)")
        axes.set_title(kind, fontsize=9)
        axes.legend(fontsize=7, loc="lower right")
    return to_svg(figure)


def topology_order(pairs) -> list[int]:
    """CPUs ordered so that those sharing closer caches sit together: group by each relation level,
    farthest first, keyed by the smallest CPU id of each group (inputs.C2cPair)."""
    cpus = sorted({pair.a for pair in pairs} | {pair.b for pair in pairs})
    ranks = sorted({relation_rank(pair.relation) for pair in pairs}, reverse=True)
    keys = {cpu: [] for cpu in cpus}
    for level in ranks:
        parent = {cpu: cpu for cpu in cpus}

        def find(cpu):
            while parent[cpu] != cpu:
                parent[cpu] = parent[parent[cpu]]
                cpu = parent[cpu]
            return cpu

        for pair in pairs:
            if relation_rank(pair.relation) < level:
                first, second = find(pair.a), find(pair.b)
                if first != second:
                    parent[max(first, second)] = min(first, second)
        for cpu in cpus:
            keys[cpu].append(find(cpu))
    return sorted(cpus, key=lambda cpu: (keys[cpu], cpu))


def c2c_heatmap(c2c_file, method: str | None = None) -> str:
    """The p50 one-way latency of every pair of one method (inputs.C2cFile), CPUs in topology order."""
    order = topology_order(c2c_file.pairs)
    index = {cpu: i for i, cpu in enumerate(order)}
    grid = np.full((len(order), len(order)), np.nan)
    for pair in c2c_file.pairs:
        if (method is None or pair.method == method) and pair.p50_ns is not None:
            grid[index[pair.a], index[pair.b]] = pair.p50_ns
            grid[index[pair.b], index[pair.a]] = pair.p50_ns
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
    axes.set_title(f"core-to-core one-way latency, p50 ({c2c_file.label}{', ' + method if method else ''})")
    figure.colorbar(image, ax=axes, label="ns")
    return to_svg(figure)


def delay_histogram(delay) -> str:
    """The wake-up latency histogram of a paced run (inputs.DelayFile), its p50, p99 and p99.9 marked."""
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


def trajectory_deviation(verify) -> float:
    """The largest deviation of a trajectory (inputs.VerifyFile) from the analytic solution."""
    reference_x1, reference_x2 = paper.analytic_trajectory(verify.t)
    return float(max(np.max(np.abs(np.asarray(verify.x1) - reference_x1)),
                     np.max(np.abs(np.asarray(verify.x2) - reference_x2))))


def trajectory(verify, deviation: float) -> str:
    """The paper's Figure 2: x1 and x2 against time, with the analytic solution dashed."""
    t = np.asarray(verify.t)
    x1, x2 = np.asarray(verify.x1), np.asarray(verify.x2)
    reference_x1, reference_x2 = paper.analytic_trajectory(t)
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
