"""The one module that maps lockstep's names to the words and the order a page shows them in.

Nothing else in reports/ names a primitive, a layout or a placement, and nothing branches on one: the facts the
tools act on come from the result file (what `lockstep run` planned and measured, the layouts' traits, the
delay causes' order). What is here is presentation, and the facts of files written before the writer gave
them: each such fallback says which field of the file replaces it.
"""
from __future__ import annotations

# ---------------------------------------------------------------- layouts and placements

# The layouts of the registry (layouts/registry.hpp) in its order, with their kind and writer isolation in bytes
# (docs/design.md, Layouts): the fallback for a run file without lockstep_layouts (run_analysis.layout_facts),
# which states them itself. The order is the heat maps' columns; the traits decide which layout shares lines and
# which isolates writers, never the names.
LAYOUTS = (("packed", "shared", 0), ("padded64", "shared", 64), ("padded128", "shared", 128),
           ("per_thread", "private_copy", 64))
# The order of the placements' groups, and each one's marker in the CPU figure.
PIN_ORDER = ("compact", "compact_smt", "scatter", "none", "migrate")
PIN_MARKERS = {"compact": "o", "compact_smt": "v", "scatter": "^", "none": "s", "migrate": "D"}
# A migration's comparison in a file without lockstep_planned_pairs (matrix.penalty_rows): the placements that
# move the threads against the one that pins them, and what each move is called.
PINNED_PLACEMENT = "compact"
MOVED_PLACEMENTS = ("migrate", "none")
PLACEMENT_MOVES = {"none": "left to the OS (pin:none)", "migrate": "moved on purpose (pin:migrate)"}


def placement_move(pin: str) -> str:
    """What a placement does to the threads, in the penalties' words."""
    return PLACEMENT_MOVES.get(pin, f"placed at pin:{pin}")


# ---------------------------------------------------------------- delay causes (`lockstep delay --out`, causes)

# The causes of a late step, in the order of bench/delay/attribution.hpp's delay_cause, with their words: only for
# a delay file written before lockstep delay wrote cause_kinds (delay_reader.read_causes reads a file's own list).
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
