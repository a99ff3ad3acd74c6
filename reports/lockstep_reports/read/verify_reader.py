"""The reader of `lockstep verify --csv` trajectories: t, x1, x2 per line, time running forward."""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass

from ..common import fields
from .checks import InputError
from .schemas import shown


# The analytic solution at each row's t, in columns a later `lockstep verify --csv` may add beside the trajectory;
# read when the header names both (paper.trajectory_reference prefers them), ignored otherwise.
EXACT_COLUMNS = ("exact_x1", "exact_x2")


@dataclass
class VerifyFile:
    path: str
    label: str
    t: list[float]
    x1: list[float]
    x2: list[float]
    exact: tuple[list[float], list[float]] | None = None  # the file's EXACT_COLUMNS; None: a file without them


def _row_values(path: str, line_number: int, row: list[str], columns: list[int]) -> list[float]:
    """The numbers of one line in the columns read (t, x1, x2, and the exact solution where the file has it),
    each a finite number."""
    if len(row) <= max(columns):
        raise InputError(path, f"line {line_number} has {len(row)} values, not {max(columns) + 1} (truncated?)")
    try:
        values = [float(row[column]) for column in columns]
    except ValueError:
        raise InputError(path, f"line {line_number} is not {'three' if len(columns) == 3 else len(columns)} numbers: "
                               f"{shown(','.join(row))}") from None
    if not all(math.isfinite(value) for value in values):
        raise InputError(path, f"line {line_number} holds a value that is not a finite number: "
                               f"{shown(','.join(row))}")
    return values


def load_verify_csv(path: str, text: str, label: str) -> VerifyFile:
    if not text.endswith("\n"):
        raise InputError(path, "the last line is cut (no newline at the end): an interrupted `lockstep verify`?")
    try:
        rows = list(csv.reader(io.StringIO(text)))
    except csv.Error as error:
        raise InputError(path, f"not a CSV trajectory: {error}") from None
    header = [cell.strip() for cell in rows[0]] if rows else []
    if tuple(header[:3]) != fields.VERIFY_HEADER:
        raise InputError(path, f"a CSV whose header is {','.join(header)!r}, not 't,x1,x2' "
                               "(`lockstep verify --csv` writes that)")
    exact = all(name in header for name in EXACT_COLUMNS)
    columns = [0, 1, 2] + ([header.index(name) for name in EXACT_COLUMNS] if exact else [])
    series = [[] for _ in columns]
    for line_number, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        values = _row_values(path, line_number, row, columns)
        if not 0.0 <= values[0] <= fields.LONGEST_NS / 1e9 or (series[0] and values[0] <= series[0][-1]):
            raise InputError(path, f"line {line_number}: t = {values[0]:g} s does not follow the t before it "
                                   "(time runs forward from 0)")
        if max(abs(value) for value in values[1:]) > fields.LARGEST_DISPLACEMENT:
            raise InputError(path, f"line {line_number}: a displacement beyond {fields.LARGEST_DISPLACEMENT:g} "
                                   "is not this model's")
        for values_of_column, value in zip(series, values):
            values_of_column.append(value)
    if len(series[0]) < 2:
        raise InputError(path, "a trajectory with fewer than two rows")
    return VerifyFile(path=path, label=label, t=series[0], x1=series[1], x2=series[2],
                      exact=(series[3], series[4]) if exact else None)
