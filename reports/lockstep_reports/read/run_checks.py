"""What a run file's schema cannot say about its lockstep_* sections, in one place: cross-references (a mode a reading
or a pair names is one of the trace's, a scaling point holds its curve's counter; in a file whose entries carry their
spec, lockstep_entry, every entry carries it and every entry a section names is one of the file's), sums (the modes' shares add up to
the run at most), order (the modes fastest first and at their own index, the readings in time order, an interval's
low end at or below its high end and a measured speedup within its interval) and what appears once (a pair, a
layout, a planned comparison, an entry's medians per mode).

docs/schemas/run.schema.json says everything else (types, what is required, ranges, enumerations, an entry's name
with its family), and read_document (inputs.py) has checked it before check_sections runs: the readers
(run_reader.py, answer_reader.py, derived_reader.py) then only build what the tools hold. A problem is one line
naming its JSON path (checks.fail), as a schema's is. The benchmark entries' values, whose ranges depend on their
time unit and whose NaN reads as unavailable, are checked as run_reader reads them.
"""
from __future__ import annotations

from ..common import fields
from .checks import fail
from .schemas import shown


def _once(path: str, place: tuple, index: int, seen: dict, identity, problem: str) -> None:
    """Fail when `identity` was seen before in the list (seen: identity -> its index): "repeats entry N PROBLEM"."""
    if identity in seen:
        fail(path, place, f"repeats entry {seen[identity]} {problem}")
    seen[identity] = index


def _ordered(path: str, place: tuple, low: float | None, high: float | None, low_key: str = "ci_low",
             high_key: str = "ci_high") -> None:
    if low is not None and high is not None and low > high:
        fail(path, place + (low_key,), f"is {low:g}, above {high_key} {high:g}")


def _pace(path: str, trace: dict) -> None:
    """The modes at their own index, fastest first, alike in whether they have a c2c reading, their shares within
    the run; the readings in time order naming a mode; the changes within what the readings can change; each entry's
    medians per mode naming the trace's modes, an entry once."""
    at = (fields.PACE_KEY,)
    modes = trace["modes"]
    for index, mode in enumerate(modes):
        here = at + ("modes", index)
        if mode["mode"] != index:
            fail(path, here + ("mode",), f"is {shown(mode['mode'])}, not {index}: the modes are listed in the order of "
                                         "their index")
        if index and (mode["c2c_ns"] is None) != (modes[0]["c2c_ns"] is None):
            fail(path, here + ("c2c_ns",), "is null in some modes and a number in others: either the machine has a "
                                           "pair of CPUs to measure or it has not")
        before = modes[index - 1]["c2c_ns"] if index else None
        if before is not None and mode["c2c_ns"] < before:
            fail(path, here + ("c2c_ns",), f"is {mode['c2c_ns']:g} ns, below the {before:g} ns of the mode before: "
                                           "the modes are sorted fastest first")
    total = sum(mode["share"] for mode in modes)
    if total > 1.0 + fields.SHARE_SLACK:
        fail(path, at + ("modes",), f"have shares adding up to {total:g}, more than the whole run")
    readings = trace["readings"]
    for index, reading in enumerate(readings):
        here = at + ("readings", index)
        if index and reading["t_s"] < readings[index - 1]["t_s"]:
            fail(path, here + ("t_s",), f"is {reading['t_s']:g} s, before the {readings[index - 1]['t_s']:g} s of the "
                                        "reading before: the readings are in time order")
        if reading["mode"] >= len(modes):
            fail(path, here + ("mode",), f"is {shown(reading['mode'])}, not one of the {len(modes)} modes (0.."
                                         f"{len(modes) - 1}) or -1")
    if trace["changes"] > len(readings) - 1:
        fail(path, at + ("changes",), f"is {shown(trace['changes'])}, more than the {len(readings)} readings can "
                                      "change")
    seen: dict = {}
    for index, medians in enumerate(trace.get(fields.MODE_MEDIANS_KEY, [])):
        here = at + (fields.MODE_MEDIANS_KEY, index)
        _once(path, here + ("entry",), index, seen, medians["entry"],
              f"({shown(medians['entry'])}): an entry is listed once")
        for place, mode in enumerate(medians["modes"]):
            if mode["mode"] >= len(modes):
                fail(path, here + ("modes", place, "mode"), f"is {shown(mode['mode'])}, not one of the {len(modes)} "
                                                            f"modes of {fields.PACE_KEY} (0..{len(modes) - 1})")


def _pairs(path: str, document: dict) -> None:
    """Each pair once, one mode per ratio naming a mode of the trace (-1 without one), its interval in order."""
    trace = document.get(fields.PACE_KEY)
    highest = len(trace["modes"]) - 1 if trace else fields.OUTLIER_MODE
    seen: dict = {}
    for index, pair in enumerate(document.get(fields.PAIRS_KEY, [])):
        at = (fields.PAIRS_KEY, index)
        _once(path, at, index, seen, (pair["comparison"], pair["a"], pair["b"]),
              f"(the same {pair['comparison']} pair of {pair['a']} and {pair['b']}): a damaged or concatenated file")
        if len(pair["modes"]) != len(pair["ratios"]):
            fail(path, at + ("modes",), f"has {len(pair['modes'])} values for {len(pair['ratios'])} ratios: one mode "
                                        "per pair")
        for place, mode in enumerate(pair["modes"]):
            if mode > highest:
                where = (f"one of the {highest + 1} modes of {fields.PACE_KEY} or -1" if trace
                         else f"-1: the file has no {fields.PACE_KEY}")
                fail(path, at + ("modes", place), f"is {shown(mode)}, not {where}")
        _ordered(path, at, pair["ci_low"], pair["ci_high"])


def _scaling(path: str, curve: dict) -> None:
    for index, point in enumerate(curve["points"]):
        if curve["counter"] not in point:
            fail(path, (fields.SCALING_KEY, "points", index, curve["counter"]), "is missing: the curve's counter")


def _answer(path: str, key: str, block: dict) -> None:
    """The intervals of the choices' rivals, the false-sharing probe and its patterns in order."""
    for index, choice in enumerate(block["recommendations"]):
        for rival in ("runner_up", "baseline"):
            if choice.get(rival):
                _ordered(path, (key, "recommendations", index, rival), choice[rival]["ci_low"],
                         choice[rival]["ci_high"])
    if block.get("false_sharing_probe"):
        _ordered(path, (key, "false_sharing_probe"), block["false_sharing_probe"]["ci_low"],
                 block["false_sharing_probe"]["ci_high"])
    for index, pattern in enumerate(block.get("false_sharing_patterns", [])):
        _ordered(path, (key, "false_sharing_patterns", index), pattern["ci_low"], pattern["ci_high"])


def _measured_within(path: str, place: tuple, point: dict) -> None:
    """A point measured (no failure, pairs kept) has its speedup within its interval."""
    if not point.get("failure") and point["pairs"] > 0 and not point["ci_low"] <= point["speedup"] <= point["ci_high"]:
        fail(path, place + ("speedup",), f"is {point['speedup']:g}, outside its interval "
                                         f"[{point['ci_low']:g}, {point['ci_high']:g}]")


def _crossover(path: str, block: dict) -> None:
    for index, series in enumerate(block["crossovers"]):
        here = (fields.CROSSOVER_KEY, "crossovers", index)
        for place, point in enumerate(series.get("points", [])):
            _measured_within(path, here + ("points", place), point)
    for index, ceiling in enumerate(block.get("ceilings", [])):
        for place, point in enumerate(ceiling["points"]):
            _measured_within(path, (fields.CROSSOVER_KEY, "ceilings", index, "points", place), point)


def _derived(path: str, document: dict) -> None:
    """A layout listed once, a comparison planned once."""
    seen: dict = {}
    for index, layout in enumerate(document.get(fields.LAYOUTS_KEY, [])):
        if layout["name"] in seen:
            fail(path, (fields.LAYOUTS_KEY, index, "name"), f"repeats {shown(layout['name'])}: a layout is listed once")
        seen[layout["name"]] = index
    seen = {}
    for index, pair in enumerate(document.get(fields.PLANNED_KEY, [])):
        _once(path, (fields.PLANNED_KEY, index), index, seen, (pair["comparison"], pair["a"], pair["b"]),
              f"(the {pair['comparison']} comparison of {pair['a']} and {pair['b']}): a comparison is planned once")


def base_name(raw: dict) -> str:
    """A benchmark entry's name without Google Benchmark's aggregate suffix ("_median"): its run_name where it has
    one."""
    name, aggregate = raw["name"], raw.get("aggregate_name") if raw.get("run_type") == "aggregate" else None
    return raw.get("run_name") or (name[: -(len(aggregate) + 1)] if aggregate and name.endswith("_" + aggregate)
                                   else name)


def _named_entries(document: dict):
    """(JSON path, name) of every entry a section names."""
    for index, pair in enumerate(document.get(fields.PAIRS_KEY, [])):
        yield from (((fields.PAIRS_KEY, index, side), pair[side]) for side in ("a", "b"))
    for index, pair in enumerate(document.get(fields.PLANNED_KEY, [])):
        yield from (((fields.PLANNED_KEY, index, side), pair[side]) for side in ("a", "b"))
    for index, ranking in enumerate(document.get(fields.RANKINGS_KEY, [])):
        for place, item in enumerate(ranking["entries"]):
            yield (fields.RANKINGS_KEY, index, "entries", place, "entry"), item["entry"]
    for index, medians in enumerate(document.get(fields.PACE_KEY, {}).get(fields.MODE_MEDIANS_KEY, [])):
        yield (fields.PACE_KEY, fields.MODE_MEDIANS_KEY, index, "entry"), medians["entry"]
    for key in fields.ANSWER_KEYS:
        block = document.get(key, {})
        for index, name in enumerate(block.get("collapsed", [])):
            yield (key, "collapsed", index), name
        for index, choice in enumerate(block.get("recommendations", [])):
            yield (key, "recommendations", index, "entry"), choice["entry"]
            for rival in ("runner_up", "baseline"):
                if choice.get(rival):
                    yield (key, "recommendations", index, rival, "entry"), choice[rival]["entry"]
        best = block.get("answer")
        if best:
            yield (key, "answer", "entry"), best["entry"]
            for index, other in enumerate(best.get("level") or []):
                yield (key, "answer", "level", index, "entry"), other["entry"]


def _typed_entries(path: str, document: dict) -> None:
    """A file whose entries carry their spec (lockstep_entry): every entry carries it, and every entry a section
    names is one of the file's (its sections are read by the specs, never by parsing a name)."""
    benchmarks = document["benchmarks"]
    typed = [fields.ENTRY_KEY in raw for raw in benchmarks]
    if not any(typed):
        return
    if not all(typed):
        index = typed.index(False)
        fail(path, ("benchmarks", index, fields.ENTRY_KEY), f"is missing, though entry {typed.index(True)} carries "
                                                            "its own: every entry of a file carries its spec or none")
    names = {base_name(raw) for raw in benchmarks}
    for place, name in _named_entries(document):
        if name not in names:
            fail(path, place, f"is {shown(name)}, which names no entry of the file")


def check_sections(path: str, document: dict) -> None:
    """Every lockstep_* section of a run document read_document has checked against its schema, for what the schema
    cannot say; the first problem raises InputError (one line naming its JSON path)."""
    if fields.PACE_KEY in document:
        _pace(path, document[fields.PACE_KEY])
    _pairs(path, document)
    if fields.SCALING_KEY in document:
        _scaling(path, document[fields.SCALING_KEY])
    for key in fields.ANSWER_KEYS:
        if key in document:
            _answer(path, key, document[key])
    if fields.CROSSOVER_KEY in document:
        _crossover(path, document[fields.CROSSOVER_KEY])
    _derived(path, document)
    _typed_entries(path, document)
