"""The run's answer and its crossover sweep, as the run's file states them (nothing here is recomputed): the
answer's lines, choices (each with its runner-up and baseline, paired), collapsed entries, the answer first, the
crossover's lines and the known-answer probes (false sharing, per access pattern, migration); the sweep's series,
points and ceilings, which the report draws (report.crossover_section). run_answer.py holds what they read into.

The answer is the file's lockstep_answer; a file written before that name holds it as lockstep_headline and reads
the same (ANSWER_KEYS). Their shapes are docs/schemas/run.schema.json's, checked with the rest of the file before
they are read (inputs.read_document), and what a schema cannot say (an interval in order, a measured speedup within
its interval) in run_checks.py: this module only builds them. A file without a part reads without it:
false sharing per access pattern is written by `lockstep run` since the probe measures each pattern (answer_json
in bench/run/answer.cpp; tests/fixtures/run/quick-pairs.headline.json is its output), the top-level
`lockstep_crossover` by `lockstep run --crossover` (crossover_json in bench/run/crossover.cpp;
reports/tests/fixtures/crossover_a.json is its output). A crossover in the shape this reader was written ahead of the
writer for, {threads, pin, sync, masses, ci_low, ci_high}, still reads (its status, layout and points empty).
"""
from __future__ import annotations

from ..common import fields
from ..common.names import parse_name
from .run_answer import (Answer, BestChoice, Ceiling, CeilingPoint, Choice, Crossover, CrossoverPoint, CrossoverSweep,
                         Migration, PairedRatio, Rival)

# In the answer: [{pattern, median, ci_low, ci_high, verdict}, with `words`, the pattern as the answer names it
# ("atomic read-modify-writes"), where lockstep run wrote them].
PATTERNS_KEY = "false_sharing_patterns"
PATTERN_WORDS = "words"
# What a crossover's status may say (docs/schemas/run.schema.json; bench/run/crossover.cpp, to_string): "" where
# the file has no status (written ahead of the writer, in the shape above).
CROSSOVER_STATUSES = ("crossed", "crossed_unconfirmed", "none_within_sweep", "always")


def _float(value) -> float | None:
    """A number the schema has checked, as the tools hold it (a float); None for null or missing."""
    return None if value is None else float(value)


def _paired(block: dict, name_key: str) -> PairedRatio:
    """{<name_key>, median, ci_low, ci_high, verdict}; a median of null: the file says it could not be measured."""
    return PairedRatio(block[name_key] if name_key else "", _float(block.get("median")), _float(block.get("ci_low")),
                       _float(block.get("ci_high")), block.get("verdict"))


def _pattern(block: dict) -> PairedRatio:
    """One access pattern's false sharing, named by its words where the file has them ("plain stores"), else by
    its `pattern`."""
    ratio = _paired(block, "pattern")
    words = block.get(PATTERN_WORDS)
    return PairedRatio(words, ratio.median, ratio.ci_low, ratio.ci_high, ratio.verdict) if words else ratio


def _migration(block: dict) -> Migration | None:
    raw = block.get("migration_probe")
    if raw is None:
        return None
    # refill_p50_ns: a difference of two medians (a move with the refill against one without), below 0 when the
    # refill added nothing measurable, as lockstep run then writes it.
    return Migration(float(raw["move_p50_ns"]), float(raw["refill_p50_ns"]), raw.get("cpus") or "")


def _point(raw: dict) -> CrossoverPoint:
    return CrossoverPoint(raw["masses"], float(raw["serial_ns"]), float(raw["parallel_ns"]), float(raw["speedup"]),
                          float(raw["ci_low"]), float(raw["ci_high"]), raw.get("verdict"), raw["pairs"],
                          raw["pairs_set_aside"], _float(raw.get("model_ns")), _float(raw.get("measured_over_model")),
                          raw.get("failure", ""), _float(raw.get("of_ceiling")))


def _ceiling(raw: dict) -> Ceiling:
    points = tuple(CeilingPoint(point["masses"], float(point["serial_ns"]), float(point["blocks_ns"]),
                                float(point["speedup"]), float(point["ci_low"]), float(point["ci_high"]),
                                point["pairs"], point["pairs_set_aside"], point["failure"])
                   for point in raw.get("points", []))
    return Ceiling(raw["threads"], raw["pin"], points, raw.get("quoted_masses"))


def _crossover(raw: dict) -> Crossover:
    return Crossover(raw["threads"], raw.get("pin") or "", raw["sync"], *(_float(raw.get(key)) for key in
                                                                         ("masses", "ci_low", "ci_high")),
                     layout=raw.get("layout") or "", leader=bool(raw.get("leader", False)),
                     status=raw.get("status") or "", confirmed_at=_float(raw.get("confirmed_at")),
                     contradicted_at=_float(raw.get("contradicted_at")), stop_reason=raw.get("stop_reason") or "",
                     stage_sync_ns=_float(raw.get("stage_sync_ns")),
                     points=tuple(_point(point) for point in raw.get("points", [])))


def _rival(raw: dict | None, key_of) -> Rival | None:
    """A choice's runner_up or baseline: null (none), or its entry and its paired ratio to the choice."""
    if raw is None:
        return None
    return Rival(raw["entry"], key_of(raw["entry"]), raw["sync"], float(raw["median"]), float(raw["ci_low"]),
                 float(raw["ci_high"]), raw["verdict"])


def _choice(raw: dict, key_of) -> Choice:
    """One of the answer's choices (the file's recommendations); the keys written after the first answers (spread,
    paces, runner-up, baseline, tied, ...) optional."""
    return Choice(
        raw["threads"], raw["pin"], raw["model"], raw["entry"], key_of(raw["entry"]), raw["sync"], raw["layout"],
        float(raw["ns_per_step"]), raw["basis"], spread_pct=_float(raw.get("spread_pct")), paces=raw.get("paces"),
        straddles_pace_change=bool(raw.get("straddles_pace_change")), vs_c2c=_float(raw.get("vs_c2c")),
        cpus_busy=_float(raw.get("cpus_busy")), oversubscribed=bool(raw.get("oversubscribed")),
        median_leader=raw.get("median_leader") or "", runner_up=_rival(raw.get("runner_up"), key_of),
        baseline=_rival(raw.get("baseline"), key_of), tied=bool(raw.get("tied")))


def _best(raw: dict | None, key_of) -> BestChoice | None:
    """The answer first (None: a file written before it)."""
    if raw is None:
        return None
    level = tuple((other["threads"], other["pin"], float(other["ns_per_step"])) for other in raw.get("level") or [])
    return BestChoice(raw["threads"], raw["pin"], raw["entry"], key_of(raw["entry"]), float(raw["ns_per_step"]),
                      _float(raw.get("serial_ns_per_step")), _float(raw.get("vs_serial")), level)


def answer_block(document: dict) -> tuple[str, dict] | None:
    """(its key, the run's answer as the file holds it): lockstep_answer, or in a file written before that name
    lockstep_headline; None for a file with neither."""
    return next(((key, document[key]) for key in fields.ANSWER_KEYS if key in document), None)


def read_answer(document: dict, key_of=parse_name) -> Answer | None:
    """The run's answer; None for a file written before it. key_of: an entry's key from its name (the file's
    lockstep_entry where it has them: run_reader.typed_keys)."""
    found = answer_block(document)
    if found is None:
        return None
    block = found[1]
    collapsed, keys = [], set()
    for name in block["collapsed"]:
        key = key_of(name)
        if key not in keys:
            collapsed.append(name)
            keys.add(key)
    probe = block.get("false_sharing_probe")
    return Answer(tuple(block["lines"]), tuple(_choice(raw, key_of) for raw in block["recommendations"]), tuple(collapsed),
                  frozenset(keys), _best(block.get("answer"), key_of), tuple(block.get("crossover", [])),
                  None if probe is None else _paired(probe, ""), block.get("false_sharing_probe_unavailable") or None,
                  tuple(_pattern(raw) for raw in block.get(PATTERNS_KEY, [])), _migration(block),
                  block.get("migration_probe_unavailable") or None)


def read_crossover(document: dict) -> CrossoverSweep | None:
    """The file's lockstep_crossover; None for a file without it (no --crossover)."""
    if fields.CROSSOVER_KEY not in document:
        return None
    block = document[fields.CROSSOVER_KEY]
    return CrossoverSweep(_float(block.get("budget_s")), _float(block.get("spent_s")), block.get("pairs_per_point"),
                          block.get("stop_reason") or "", tuple(block.get("lines", [])),
                          tuple(_ceiling(raw) for raw in block.get("ceilings", [])),
                          tuple(_crossover(raw) for raw in block.get("crossovers", [])))
