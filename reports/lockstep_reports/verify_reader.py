"""The reader of `lockstep verify --csv` trajectories: t, x1, x2 per line, time running forward."""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass

from . import fields
from .checks import InputError
from .schemas import shown


@dataclass
class VerifyFile:
    path: str
    label: str
    t: list[float]
    x1: list[float]
    x2: list[float]


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
    t, x1, x2 = [], [], []
    for line_number, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        if len(row) < 3:
            raise InputError(path, f"line {line_number} has {len(row)} values, not 3 (truncated?)")
        try:
            values = [float(cell) for cell in row[:3]]
        except ValueError:
            raise InputError(path, f"line {line_number} is not three numbers: {shown(','.join(row))}") from None
        if not all(math.isfinite(value) for value in values):
            raise InputError(path, f"line {line_number} holds a value that is not a finite number: "
                                   f"{shown(','.join(row))}")
        if not 0.0 <= values[0] <= fields.LONGEST_NS / 1e9 or (t and values[0] <= t[-1]):
            raise InputError(path, f"line {line_number}: t = {values[0]:g} s does not follow the t before it "
                                   "(time runs forward from 0)")
        if max(abs(values[1]), abs(values[2])) > fields.LARGEST_DISPLACEMENT:
            raise InputError(path, f"line {line_number}: a displacement beyond {fields.LARGEST_DISPLACEMENT:g} "
                                   "is not this model's")
        t.append(values[0])
        x1.append(values[1])
        x2.append(values[2])
    if len(t) < 2:
        raise InputError(path, "a trajectory with fewer than two rows")
    return VerifyFile(path=path, label=label, t=t, x1=x1, x2=x2)
