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

Entries are named as the file names them; key_of gives each its key (the file's lockstep_entry where it has
them, else the name parsed: run_reader.typed_keys). docs/schemas/run.schema.json holds their shapes, checked with the rest of the file before they are read
(inputs.read_document); what a schema cannot say (a layout or a comparison listed once, a mode of the trace) is
checked in run_checks.py. This module only builds them.
"""
from __future__ import annotations

from ..common import fields
from ..common.names import BenchmarkKey, parse_name
from .run_file import LayoutFacts, ModeMedians, ModelConstants, PlannedPair, Ranking


def read_layouts(document: dict) -> tuple[LayoutFacts, ...] | None:
    """lockstep_layouts: the layouts of the registry in its order, each once, with its kind and writer isolation."""
    if fields.LAYOUTS_KEY not in document:
        return None
    return tuple(LayoutFacts(raw["name"], raw["kind"], raw["writer_isolation"]) for raw in document[fields.LAYOUTS_KEY])


def read_planned(document: dict, key_of=parse_name) -> tuple[PlannedPair, ...] | None:
    """lockstep_planned_pairs: every comparison the run planned, each once."""
    if fields.PLANNED_KEY not in document:
        return None
    return tuple(PlannedPair(raw["comparison"], raw["group"], raw["a"], raw["b"], key_of(raw["a"]),
                             key_of(raw["b"])) for raw in document[fields.PLANNED_KEY])


def read_mode_medians(document: dict, key_of=parse_name) -> dict[BenchmarkKey, ModeMedians] | None:
    """lockstep_pace.entry_medians: per entry, its median per pace mode (a mode of the trace) and how many of its
    repetitions straddled a change."""
    block = document.get(fields.PACE_KEY)
    if block is None or fields.MODE_MEDIANS_KEY not in block:
        return None
    result = {}
    for raw in block[fields.MODE_MEDIANS_KEY]:
        key = key_of(raw["entry"])
        result[key] = ModeMedians(key, {mode["mode"]: (float(mode["median_ns"]), mode["repetitions"])
                                        for mode in raw["modes"]}, raw["straddling"])
    return result


def read_rankings(document: dict, key_of=parse_name) -> tuple[Ranking, ...] | None:
    """lockstep_rankings: per placement and thread count, the rk4 entries fastest first."""
    if fields.RANKINGS_KEY not in document:
        return None
    return tuple(Ranking(raw["pin"], raw["threads"], tuple(
        (key_of(item["entry"]), float(item["ns_per_step"]),
         None if item["vs_serial"] is None else float(item["vs_serial"])) for item in raw["entries"]))
        for raw in document[fields.RANKINGS_KEY])


def read_model(document: dict) -> ModelConstants | None:
    """lockstep_model: the model's constants and normal modes as the run's kernel holds it."""
    if fields.MODEL_KEY not in document:
        return None
    block = document[fields.MODEL_KEY]
    roots = block["roots"]

    def fast_slow(key: str) -> tuple[float, float]:
        return float(roots[key]["fast"]), float(roots[key]["slow"])

    return ModelConstants(float(block["c_over_m"]), tuple(float(value) for value in block["positions_0"]),
                          fast_slow("computed_rad_s"), fast_slow("paper_rad_s"),
                          float(roots["paper_implied_c_over_m"]), block["evaluations_per_step"])
