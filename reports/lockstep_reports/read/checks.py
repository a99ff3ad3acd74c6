"""What every reader checks beyond its kind's schema, and how it says what is wrong.

read_document (inputs.py) checks a file against its kind's schema (schemas.py) before any reader sees it; what a
schema cannot express (a range that depends on the unit, NaN in a benchmark entry, a distribution's order) is
checked by the reader of its kind with these. A problem raises InputError, one line: '<file>: <place>: <problem>'.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..common import fields
from . import schemas
from .schemas import shown


class InputError(Exception):
    """A file the tools cannot use. str() is one line: '<file>: <problem>'."""

    def __init__(self, path: str, problem: str):
        super().__init__(f"{path}: {' '.join(problem.split())}")
        self.path = path
        self.problem = problem


class CheckedObject:
    """One JSON object of a file that its kind's schema has checked (read_document): what is left to check is
    what a schema cannot express (a range that depends on the unit, NaN in a benchmark entry). `where` names
    it in an error ("benchmark entry 3 ('rk4/serial')")."""

    def __init__(self, path: str, value: dict, where: str):
        self.path, self.value, self.where = path, value, where

    def fail(self, key: str, problem: str):
        raise InputError(self.path, f"{self.where}: {key} {problem}" if self.where else f"{key} {problem}")

    def get(self, key: str, required: bool, nullable: bool = False):
        if key not in self.value:
            if required:
                self.fail(key, "is missing")
            return None
        value = self.value[key]
        if value is None and not nullable:
            self.fail(key, "is null")
        return value

    def number(self, key: str, low: float, high: float, required: bool = True, nullable: bool = False,
               unit: str = "", non_finite: bool = False) -> float | None:
        """A number in [low, high]; NaN or an infinity is returned as it is when `non_finite` (the caller
        counts it as unavailable), else it is an error."""
        value = self.get(key, required, nullable)
        if value is None:
            return None
        return checked_number(self, key, value, low, high, unit, non_finite)


def checked_number(owner: CheckedObject, key: str, value, low: float, high: float, unit: str = "",
                   non_finite: bool = False, scale: float = 1.0) -> float:
    """value * scale, checked to lie in [low, high] (given in the unit of the product)."""
    if isinstance(value, int) and abs(value) > high / scale:  # before float(): an int may exceed the floats
        owner.fail(key, f"is {shown(value)}, beyond any measured value (above {high:g}{unit})")
    if not math.isfinite(value):
        if non_finite:
            return float(value)
        owner.fail(key, f"is {shown(value)}, not a finite number")
    number = float(value) * scale
    if number < low:
        why = (": a time is positive" if low > 0 else ": it cannot be negative" if low == 0
               else ", beyond any measured value")
        owner.fail(key, f"is {shown(number)}{unit}, below {low:g}{unit}{why}")
    if number > high:
        owner.fail(key, f"is {shown(number)}{unit}, beyond any measured value (above {high:g}{unit})")
    return number


def fail(path: str, place: tuple, problem: str):
    """A problem the schema cannot express, at a place given as JSON path parts."""
    raise InputError(path, f"{schemas.json_path(place)}: {problem}")


@dataclass(frozen=True)
class Distribution:
    count: int | None
    statistics: dict[str, float | None]  # fields.DISTRIBUTION_STATISTICS -> ns, None when unavailable


def read_distribution(path: str, place: tuple, summary: dict, statistics=fields.DISTRIBUTION_STATISTICS,
                      time: bool = True) -> Distribution:
    """{min, p50, ..., count}: every statistic a number, or all null with count 0 (a file without count has
    samples). `time`: the statistics are durations, within fields.LONGEST_NS."""
    count = summary.get("count")
    values = {}
    for name in statistics:
        value = summary.get(name)
        if value is not None and count == 0:
            fail(path, place + (name,), "is a number though count is 0")
        if value is None and count != 0:
            fail(path, place + (name,), "is missing or null" + (f" though count is {count}" if count else ""))
        if value is not None and time and not 0.0 <= value <= fields.LONGEST_NS:
            fail(path, place + (name,), f"is {shown(value)} ns, not a measured time")
        values[name] = value
    known = [(name, values[name]) for name in statistics if values[name] is not None]
    for (low_name, low), (high_name, high) in zip(known, known[1:]):
        if low > high:
            fail(path, place + (high_name,), f"is {high:g} ns, below {low_name} {low:g} ns: the statistics are out "
                                             "of order")
    return Distribution(None if count is None else int(count), values)
