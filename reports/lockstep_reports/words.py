"""The one module that maps lockstep's names to the words and the order a page shows them in.

Nothing else in reports/ names a primitive, a layout or a placement, and nothing branches on one: the facts the
tools act on come from the result file (what `lockstep run` planned and measured, the layouts' traits, the
delay causes' order). What is here is presentation, and the facts of files written before the writer gave
them: each such fallback says which field of the file replaces it.
"""
from __future__ import annotations

# ---------------------------------------------------------------- layouts and placements

# The order of the layouts' columns (a heat map's, the CPU figure's colours).
LAYOUT_ORDER = ("packed", "padded64", "padded128", "per_thread")
# The order of the placements' groups, and each one's marker in the CPU figure.
PIN_ORDER = ("compact", "scatter", "none", "migrate")
PIN_MARKERS = {"compact": "o", "scatter": "^", "none": "s", "migrate": "D"}

# ---------------------------------------------------------------- delay causes (`lockstep delay --out`, causes)

# The causes of a late step, in the order of bench/delay/delay_report.hpp's delay_cause, with their words: the
# fallback for a delay file without causes.names (delay_reader.read_causes), which a writer that writes the
# enum's keys and words beside the rows replaces.
DELAY_CAUSES = (
    ("compute", "compute"),
    ("run_queue_wait", "run-queue wait"),
    ("migration", "migration"),
    ("page_faults", "page faults"),
    ("interrupts", "interrupts"),
    ("wake_up_latency", "wake-up latency"),
    ("machine_stall", "machine stall"),
    ("unexplained", "unexplained"),
)
