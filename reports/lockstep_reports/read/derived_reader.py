"""What `lockstep run` derived and writes into its file for the tools to read rather than derive again: the
layouts' traits, the comparisons it planned, each entry's medians per pace mode, the rankings, and the model's
constants. Each is read where the file has it; a file written before it reads with None, and the tools fall back
to what they did before (each fallback says so where it is).

    lockstep_layouts          [{name, kind, writer_isolation}] in the registry's order
    lockstep_planned_pairs    [{comparison, group, a, b}]: every comparison planned, measured or not
    lockstep_pace.entry_medians
                              [{entry, modes: [{mode, median_ns, repetitions}], straddling}]: the entries whose
                              repetitions ran in more than one mode
    lockstep_rankings         [{pin, threads, entries: [{entry, ns_per_step, vs_serial}]}] fastest first
    lockstep_model            {c_over_m, positions_0, roots: {computed_rad_s: {fast, slow}, paper_rad_s: {fast,
                              slow}, paper_implied_c_over_m}, evaluations_per_step}

docs/schemas/run.schema.json does not name these yet, so what is read is checked here, whole: a value of the
wrong type or range is exit 2 with one line naming its JSON path, as for any other field.
"""
from __future__ import annotations

import math

from ..common import fields
from ..common.names import BenchmarkKey, parse_name
from .checks import fail
from .run_file import LayoutFacts, ModeMedians, ModelConstants, PaceTrace, PlannedPair, Ranking
from .schemas import json_kind, shown

LAYOUTS_KEY = "lockstep_layouts"
PLANNED_KEY = "lockstep_planned_pairs"
MODE_MEDIANS_KEY = "entry_medians"  # inside fields.PACE_KEY
RANKINGS_KEY = "lockstep_rankings"
MODEL_KEY = "lockstep_model"
# The layouts' kinds (layouts/concepts.hpp, layout_kind).
LAYOUT_KINDS = ("shared", "private_copy")


# ---------------------------------------------------------------- typed values, checked

def _object(path: str, place: tuple, value) -> dict:
    if not isinstance(value, dict):
        fail(path, place, f"is {json_kind(value)}, not an object")
    return value


def _list(path: str, place: tuple, value) -> list:
    if not isinstance(value, list):
        fail(path, place, f"is {json_kind(value)}, not a list")
    return value


def _field(path: str, place: tuple, block: dict, key: str):
    if key not in block:
        fail(path, place + (key,), "is missing")
    return block[key]


def _text(path: str, place: tuple, block: dict, key: str) -> str:
    value = _field(path, place, block, key)
    if not isinstance(value, str) or not value:
        fail(path, place + (key,), f"is {json_kind(value)}, not a text")
    return value


def _number(path: str, place: tuple, block: dict, key: str, low: float, high: float) -> float:
    value = _field(path, place, block, key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        fail(path, place + (key,), f"is {shown(value)}, not a finite number")
    if not low <= value <= high:
        fail(path, place + (key,), f"is {shown(value)}, outside {low:g}..{high:g}")
    return float(value)


def _whole(path: str, place: tuple, block: dict, key: str, low: int, high: float = fields.LARGEST_AMOUNT) -> int:
    value = _field(path, place, block, key)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        fail(path, place + (key,), f"is {shown(value)}, not a whole number from {low}")
    return value


def _entry(path: str, place: tuple, block: dict, key: str) -> tuple[str, BenchmarkKey]:
    name = _text(path, place, block, key)
    parsed = parse_name(name)
    if not parsed.family:
        fail(path, place + (key,), f"is {shown(name)}: no benchmark family")
    return name, parsed


def _fast_slow(path: str, place: tuple, block: dict, key: str) -> tuple[float, float]:
    pair = _object(path, place + (key,), _field(path, place, block, key))
    return tuple(_number(path, place + (key,), pair, name, 0.0, fields.LARGEST_AMOUNT) for name in ("fast", "slow"))


# ---------------------------------------------------------------- the sections

def read_layouts(path: str, document: dict) -> tuple[LayoutFacts, ...] | None:
    """lockstep_layouts: the layouts of the registry in its order, each once, with its kind and writer isolation."""
    if LAYOUTS_KEY not in document:
        return None
    layouts = []
    for index, raw in enumerate(_list(path, (LAYOUTS_KEY,), document[LAYOUTS_KEY])):
        here = (LAYOUTS_KEY, index)
        raw = _object(path, here, raw)
        name, kind = _text(path, here, raw, "name"), _text(path, here, raw, "kind")
        if kind not in LAYOUT_KINDS:
            fail(path, here + ("kind",), f"is {shown(kind)}, not one of {', '.join(LAYOUT_KINDS)}")
        if any(layout.name == name for layout in layouts):
            fail(path, here + ("name",), f"repeats {shown(name)}: a layout is listed once")
        layouts.append(LayoutFacts(name, kind, _whole(path, here, raw, "writer_isolation", 0)))
    return tuple(layouts)


def read_planned(path: str, document: dict) -> tuple[PlannedPair, ...] | None:
    """lockstep_planned_pairs: every comparison the run planned, each once."""
    if PLANNED_KEY not in document:
        return None
    planned = []
    for index, raw in enumerate(_list(path, (PLANNED_KEY,), document[PLANNED_KEY])):
        here = (PLANNED_KEY, index)
        raw = _object(path, here, raw)
        comparison = _text(path, here, raw, "comparison")
        if comparison not in fields.PAIR_COMPARISONS:
            fail(path, here + ("comparison",),
                 f"is {shown(comparison)}, not one of {', '.join(fields.PAIR_COMPARISONS)}")
        (a, a_key), (b, b_key) = _entry(path, here, raw, "a"), _entry(path, here, raw, "b")
        pair = PlannedPair(comparison, _text(path, here, raw, "group"), a, b, a_key, b_key)
        if any((p.comparison, p.a_key, p.b_key) == (comparison, a_key, b_key) for p in planned):
            fail(path, here, f"repeats the {comparison} comparison of {a} and {b}: a comparison is planned once")
        planned.append(pair)
    return tuple(planned)


def read_mode_medians(path: str, document: dict, trace: PaceTrace | None) -> dict[BenchmarkKey, ModeMedians] | None:
    """lockstep_pace.entry_medians: per entry, its median per pace mode (a mode of the trace) and how many of its
    repetitions straddled a change."""
    block = document.get(fields.PACE_KEY)
    if trace is None or not isinstance(block, dict) or MODE_MEDIANS_KEY not in block:
        return None
    at = (fields.PACE_KEY, MODE_MEDIANS_KEY)
    result = {}
    for index, raw in enumerate(_list(path, at, block[MODE_MEDIANS_KEY])):
        here = at + (index,)
        raw = _object(path, here, raw)
        _, key = _entry(path, here, raw, "entry")
        if key in result:
            fail(path, here + ("entry",), f"repeats {shown(key.display)}: an entry is listed once")
        medians = {}
        for place, mode in enumerate(_list(path, here + ("modes",), _field(path, here, raw, "modes"))):
            there = here + ("modes", place)
            mode = _object(path, there, mode)
            number = _whole(path, there, mode, "mode", 0, len(trace.modes) - 1)
            medians[number] = (_number(path, there, mode, "median_ns", fields.SHORTEST_NS, fields.LONGEST_NS),
                               _whole(path, there, mode, "repetitions", 1))
        result[key] = ModeMedians(key, medians, _whole(path, here, raw, "straddling", 0))
    return result


def read_rankings(path: str, document: dict) -> tuple[Ranking, ...] | None:
    """lockstep_rankings: per placement and thread count, the rk4 entries fastest first."""
    if RANKINGS_KEY not in document:
        return None
    rankings = []
    for index, raw in enumerate(_list(path, (RANKINGS_KEY,), document[RANKINGS_KEY])):
        here = (RANKINGS_KEY, index)
        raw = _object(path, here, raw)
        entries = []
        for place, item in enumerate(_list(path, here + ("entries",), _field(path, here, raw, "entries"))):
            there = here + ("entries", place)
            item = _object(path, there, item)
            vs_serial = _field(path, there, item, "vs_serial")
            entries.append((_entry(path, there, item, "entry")[1],
                            _number(path, there, item, "ns_per_step", fields.SHORTEST_NS, fields.LONGEST_NS),
                            None if vs_serial is None else _number(path, there, item, "vs_serial", 0.0,
                                                                   fields.LARGEST_AMOUNT)))
        rankings.append(Ranking(_text(path, here, raw, "pin"), _whole(path, here, raw, "threads", 1), tuple(entries)))
    return tuple(rankings)


def read_model(path: str, document: dict) -> ModelConstants | None:
    """lockstep_model: the model's constants and normal modes as the run's kernel holds them."""
    if MODEL_KEY not in document:
        return None
    at = (MODEL_KEY,)
    block = _object(path, at, document[MODEL_KEY])
    positions = _list(path, at + ("positions_0",), _field(path, at, block, "positions_0"))
    if not positions or any(isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value)
                            for value in positions):
        fail(path, at + ("positions_0",), "is not a list of finite numbers, one per mass")
    roots = _object(path, at + ("roots",), _field(path, at, block, "roots"))
    return ModelConstants(
        _number(path, at, block, "c_over_m", 0.0, fields.LARGEST_AMOUNT), tuple(float(value) for value in positions),
        _fast_slow(path, at + ("roots",), roots, "computed_rad_s"),
        _fast_slow(path, at + ("roots",), roots, "paper_rad_s"),
        _number(path, at + ("roots",), roots, "paper_implied_c_over_m", 0.0, fields.LARGEST_AMOUNT),
        _whole(path, at, block, "evaluations_per_step", 1))
