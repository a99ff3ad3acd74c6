"""How the tools write numbers: one formatter for durations and one for plain numbers.

A value that is missing or not a finite number is never written as a number:
it is written as fields.UNAVAILABLE (or the caller's own word for a table cell).
"""
from __future__ import annotations

import math
import re

from .fields import UNAVAILABLE

# The units a duration is written in, largest first, with their size in ns.
DURATION_UNITS = (("s", 1e9), ("ms", 1e6), ("us", 1e3), ("ns", 1.0))
# Decimals in a table: one in ns, three in the larger units.
TABLE_DECIMALS = {"ns": 1, "us": 3, "ms": 3, "s": 3}


def is_number(value) -> bool:
    """A finite int or float (never a bool; an int of any size is finite, and math.isfinite would
    overflow on one beyond the floats)."""
    if isinstance(value, bool):
        return False
    return isinstance(value, int) or (isinstance(value, float) and math.isfinite(value))


def format_ns(value, significant: int | None = None) -> str:
    """A duration given in ns, in the largest unit that keeps it at 1 or more: "61.5 ns", "1.234 us".

    Tables take the default (TABLE_DECIMALS); a figure's cells give `significant` digits
    ("950 ns", "1.23 us", "12.3 us")."""
    if not is_number(value):
        return UNAVAILABLE
    unit, size = next(((unit, size) for unit, size in DURATION_UNITS if abs(value) >= size), DURATION_UNITS[-1])
    scaled = value / size
    if significant is None:
        decimals = TABLE_DECIMALS[unit]
    else:
        magnitude = math.floor(math.log10(abs(scaled))) if scaled else 0
        decimals = max(0, significant - 1 - magnitude)
    return f"{scaled:.{decimals}f} {unit}"


def format_number(value, digits: int = 2, suffix: str = "", missing: str = UNAVAILABLE) -> str:
    """A plain number with `digits` decimals (an int as it is) and a suffix ("x", " %"); `missing` when it
    is None or not a finite number."""
    if not is_number(value):
        return missing
    if isinstance(value, int):
        return f"{value}{suffix}"
    return f"{value:.{digits}f}{suffix}"


def format_duration(value) -> str:
    """A duration given in ns, as a person writes a setting: the largest unit that keeps it at 1 or
    more, without trailing zeros ("1 ms", "250 us", "1.5 ms", "10 s")."""
    if not is_number(value):
        return UNAVAILABLE
    unit, size = next(((unit, size) for unit, size in DURATION_UNITS if abs(value) >= size), DURATION_UNITS[-1])
    text = f"{value / size:.3f}".rstrip("0").rstrip(".")
    return f"{text} {unit}"


def format_count(value, missing: str = UNAVAILABLE) -> str:
    """A whole count with thousands separators ("10,000"); `missing` when it is not a number."""
    if not is_number(value):
        return missing
    if isinstance(value, float) and not value.is_integer():
        return f"{value:,.1f}"
    return f"{int(value):,}"


def format_rate(value, missing: str = UNAVAILABLE) -> str:
    """A small rate (a miss rate), three significant digits: "0", "0.001", "0.00025", "3e-6"."""
    if not is_number(value):
        return missing
    return re.sub(r"e([+-])0*(\d)", r"e\1\2", f"{value:.3g}")


def format_crossover(crossover) -> str:
    """A crossover S* in masses with its interval, as the run found it (answer_reader.Crossover): "25 [21, 60]"; an
    open end (null in the file: beyond the sizes measured) as the run's line says it, "[below 4, 60]", "[25,
    beyond 4096]", or no interval where the file has no measured point to name; "none" without a crossover."""
    if crossover.masses is None:
        return "none"
    return f"{crossover.masses:.0f}" + crossover_interval(crossover)


def crossover_interval(crossover) -> str:
    """format_crossover's interval alone, with its leading space: " [21, 60]", "" where the file gives none."""
    measured = [point.masses for point in crossover.points if point.measured]
    low = f"{crossover.ci_low:.0f}" if crossover.ci_low is not None else f"below {min(measured)}" if measured else ""
    high = (f"{crossover.ci_high:.0f}" if crossover.ci_high is not None else f"beyond {max(measured)}" if measured
            else "")
    return f" [{low}, {high}]" if low and high else ""
