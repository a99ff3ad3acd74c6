"""What makes two run files incomparable as they stand, said first by compare: the build (a Debug build's times are
the unoptimised code's, not its machine's), the mode (`--quick` against the default run), the lockstep revision
(another commit, or a tree with uncommitted changes), and the matrix or the models each file ran.

Each finding is one sentence for a person, naming the files by their letters ([A], [B], ...). The rules that act
on them live here too: a comparison with an unoptimised file gives no aggregate verdict (Comparison.withheld), and
the calibrations' move is blamed on the build, not the machine, when the builds differ (build_difference).
"""
from __future__ import annotations

from ..analysis.run_analysis import calibration
from ..common import statistics
from ..common.fields import (BUILD_TYPE_CONTEXT, CXX_FLAGS_CONTEXT, DIRTY_SUFFIX, MODE_CONTEXT, QUICK_MODE,
                             REVISION_CONTEXT, SERIAL_CONTEXT)
from ..common.formatting import format_ns
from ..read.run_file import RunFile

# The build types whose code is built without optimisation (CMake's Debug: -g alone, GCC's -O0).
UNOPTIMISED_BUILD_TYPES = ("debug",)
# Compiler flags that make a build's times the instrumentation's: a sanitizer, or no optimisation at all.
UNOPTIMISED_FLAGS = ("-fsanitize", "-O0")
# The model of an entry without a model segment, in words.
PAPER_MODEL = "the paper's two masses"


def letter(index: int) -> str:
    return f"[{chr(ord('A') + index)}]"


def _context(run_file: RunFile, key: str) -> str:
    value = run_file.context.get(key)
    return "" if value is None else str(value)


def unoptimised(run_file: RunFile) -> str | None:
    """Why this file's times are not its machine's ("a Debug build", "built with -fsanitize=thread"), None when
    nothing in its context says so (a file without build_type is taken as it is)."""
    build_type = _context(run_file, BUILD_TYPE_CONTEXT)
    if build_type.lower() in UNOPTIMISED_BUILD_TYPES:
        return f"a {build_type} build"
    flags = _context(run_file, CXX_FLAGS_CONTEXT).split()
    flag = next((flag for flag in flags for marker in UNOPTIMISED_FLAGS if flag.startswith(marker)), None)
    return f"built with {flag}" if flag else None


def _build(run_file: RunFile) -> str:
    """A file's build in a few words: "Debug, GNU 12.2.0, -g"."""
    parts = [_context(run_file, key) for key in (BUILD_TYPE_CONTEXT, "compiler", CXX_FLAGS_CONTEXT)]
    return ", ".join(part for part in parts if part) or "unknown"


def build_difference(files: list[RunFile], names: list[str] | None = None) -> str | None:
    """How the builds differ ("[A] Debug, GNU 12.2.0, -g; [B] Release, GNU 12.2.0, -O3 -DNDEBUG"; `names` in place
    of the letters), None when they are the same or some file does not say."""
    builds = [_build(run_file) for run_file in files]
    if len(set(builds)) < 2 or "unknown" in builds:
        return None
    names = names or [letter(index) for index in range(len(files))]
    return "; ".join(f"{name} {build}" for name, build in zip(names, builds))


def withheld_text(sides: list[tuple[str, str]]) -> str:
    """Why a comparison gives no aggregate verdict, from its unoptimised sides as (name, reason): "A is a Debug
    build: its times are the build's, not its machine's"."""
    return " and ".join(f"{name} is {reason}" for name, reason in sides) + ": its times are the build's, not its " \
        "machine's"


def _build_lines(files: list[RunFile]) -> list[str]:
    out = []
    for index, run_file in enumerate(files):
        reason = unoptimised(run_file)
        if reason is None:
            continue
        serial = calibration(run_file, SERIAL_CONTEXT)
        others = [(letter(other), calibration(f, SERIAL_CONTEXT)) for other, f in enumerate(files)
                  if other != index and unoptimised(f) is None]
        evidence = ""
        if serial and any(value for _, value in others):
            evidence = (f" (serial RK4 step {format_ns(serial)} against "
                        + ", ".join(f"{name}'s {format_ns(value)}" for name, value in others if value) + ")")
        flags = _context(run_file, CXX_FLAGS_CONTEXT) or "flags unknown"
        out.append(f"{letter(index)} {run_file.label} is {reason} ({flags}): its times are the unoptimised code's, "
                   f"not its machine's{evidence}; no aggregate verdict uses them.")
    difference = build_difference(files)
    if difference and not out:
        out.append(f"the builds differ ({difference}): a difference below may be the compiler's, not the "
                   f"machine's.")
    return out


def _repetitions(run_file: RunFile) -> int | None:
    """The median count of repetitions of the file's entries (what its mode gave each)."""
    counts = [len(run.repetitions) for run in run_file.runs.values() if run.repetitions]
    return int(statistics.median(counts)) if counts else None


def _mode_lines(files: list[RunFile]) -> list[str]:
    modes = [_context(run_file, MODE_CONTEXT) for run_file in files]
    if len(set(modes)) < 2:
        return []
    groups: dict[str, list[str]] = {}  # the mode in words -> the files' letters, in order
    for index, (run_file, mode) in enumerate(zip(files, modes)):
        what = ("--quick" if mode == QUICK_MODE else mode if mode
                else "unknown (written before lockstep_mode)")
        count = _repetitions(run_file)
        groups.setdefault(what + (f" ({count} repetitions an entry)" if count else ""), []).append(letter(index))
    parts = [f"{', '.join(letters)} {what}" for what, letters in groups.items()]
    meaning = ""
    if QUICK_MODE in modes:
        meaning = ": a quick run measures less, over shorter batches, so a time can differ by the mode alone"
    return [f"the modes differ: {'; '.join(parts)}{meaning}."]


def _revision_lines(files: list[RunFile]) -> list[str]:
    """Different lockstep revisions, and builds from a tree with uncommitted changes (DIRTY_SUFFIX)."""
    revisions = [_context(run_file, REVISION_CONTEXT) for run_file in files]
    dirty = [letter(index) for index, revision in enumerate(revisions) if revision.endswith(DIRTY_SUFFIX)]
    dirt = f"{DIRTY_SUFFIX}: built with uncommitted changes, so not that commit's code"
    if len({revision for revision in revisions if revision}) > 1:
        schemas = [_context(run_file, "lockstep_schema") for run_file in files]
        schema = ("result schemas " + ", ".join(f"{letter(index)} {value or 'unknown'}"
                                                  for index, value in enumerate(schemas)) + ", read alike"
                  if len(set(schemas)) > 1 else "")
        notes = "; ".join(note for note in (dirt if dirty else "", schema) if note)
        listed = ", ".join(f"{letter(index)} {revision or 'unknown'}" for index, revision in enumerate(revisions))
        return [f"different lockstep revisions: {listed}: the code measured may differ"
                + (f" ({notes})." if notes else ".")]
    if dirty:
        return [f"{', '.join(dirty)} built from {revisions[0]} ({dirt}): the code measured may differ between them."]
    return []


def _matrix_lines(files: list[RunFile]) -> list[str]:
    """Per file after the first: the entries in common with [A] and only on either side, when they differ."""
    out = []
    base = set(files[0].runs)
    for index, run_file in enumerate(files[1:], start=1):
        other = set(run_file.runs)
        if other == base:
            continue
        syncs = [sorted({key.get("sync") for key in keys if key.get("sync")}) for keys in (base, other)]
        threads = [sorted({key.threads for key in keys if key.threads}) for keys in (base, other)]
        detail = []
        if syncs[0] != syncs[1]:
            detail.append(f"primitives: {letter(0)} {len(syncs[0])}, {letter(index)} {len(syncs[1])}")
        if threads[0] != threads[1]:
            detail.append("thread counts: " + ", ".join(f"{letter(side)} {' and '.join(map(str, counts)) or 'none'}"
                                                        for side, counts in ((0, threads[0]), (index, threads[1]))))
        out.append(f"the matrices differ: {len(base & other)} entries in common, {len(base - other)} only on "
                   f"{letter(0)}, {len(other - base)} only on {letter(index)}" + (f" ({'; '.join(detail)})" if detail
                                                                                  else "")
                   + ": only those in common are compared.")
    return out


def _models(run_file: RunFile) -> tuple[str, ...]:
    models = {key.get("model") or "" for key in run_file.runs if key.family == "rk4" and key.get("sync")}
    return tuple(sorted(models))


def _model_lines(files: list[RunFile]) -> list[str]:
    models = [_models(run_file) for run_file in files]
    if len(set(models)) < 2:
        return []
    return ["different models: " + "; ".join(f"{letter(index)} " + (", ".join(m or PAPER_MODEL for m in ran) or "none")
                                             for index, ran in enumerate(models))
            + ": an entry of one model never matches another's."]


def findings(files: list[RunFile]) -> list[str]:
    """Everything that makes the files incomparable as they stand, most serious first: the build, the mode, the
    revision, the matrix, the models. Empty when nothing does."""
    if len(files) < 2:
        return []
    return (_build_lines(files) + _mode_lines(files) + _revision_lines(files) + _matrix_lines(files)
            + _model_lines(files))
