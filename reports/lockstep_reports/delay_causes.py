"""Why a `lockstep delay` run's late steps were late: the tail's causes as stacked bars.

Reads the `causes` object of a delay result file (docs/result-files.md, delay;
docs/schemas/delay.schema.json, $defs/causes), as `lockstep delay` writes it
(bench/delay/delay_report.cpp, causes_json). `causes_figure(document)`
returns an SVG string (or None when the file has no causes), which the
report's delay section places (report.py, delay_section), and `causes_rows`
the table behind it.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from .figures import to_svg  # noqa: E402

# The order and the words of bench/delay/delay_report.hpp's delay_cause.
CAUSES = (
    ("compute", "compute"),
    ("run_queue_wait", "run-queue wait"),
    ("migration", "migration"),
    ("page_faults", "page faults"),
    ("interrupts", "interrupts"),
    ("wake_up_latency", "wake-up latency"),
    ("machine_stall", "machine stall"),
    ("unexplained", "unexplained"),
)


def causes_rows(document: dict) -> list[tuple[str, dict[str, float]]]:
    """(label, {cause key: share of the excess}) per bar: each tail row, then each CPU above p99."""
    causes = document.get("causes")
    if not causes or causes.get("unavailable"):
        return []
    rows = []

    def shares(split: dict) -> dict[str, float]:
        total = sum(split.get(key, 0.0) for key, _ in CAUSES)
        return {key: (split.get(key, 0.0) / total if total > 0 else 0.0) for key, _ in CAUSES}

    for row in causes.get("tail", []):
        rows.append((f"{row['label']} ({row['steps']} steps)", shares(row["cause_ns"])))
    for entry in causes.get("per_cpu", []):
        rows.append((f"CPU {entry['cpu']}, above p99", shares(entry["cause_ns"])))
    return rows


def causes_figure(document: dict) -> str | None:
    """Stacked horizontal bars: for each percentile of the tail and each CPU, the share of the excess per cause."""
    rows = causes_rows(document)
    if not rows:
        return None
    figure, axes = plt.subplots(figsize=(8, 0.5 * len(rows) + 1.4))
    colours = plt.get_cmap("tab10").colors
    labels = [label for label, _ in rows]
    left = [0.0] * len(rows)
    for index, (key, words) in enumerate(CAUSES):
        widths = [100 * split[key] for _, split in rows]
        if not any(widths):
            continue
        axes.barh(labels, widths, left=left, color=colours[index % len(colours)], label=words)
        left = [a + b for a, b in zip(left, widths)]
    axes.invert_yaxis()
    axes.set_xlim(0, 100)
    axes.set_xlabel("share of the excess over the median completion (%)")
    axes.set_title("Why the late steps were late")
    axes.legend(loc="upper center", bbox_to_anchor=(0.5, -0.25), ncol=4, fontsize="small", frameon=False)
    figure.tight_layout()
    return to_svg(figure)
