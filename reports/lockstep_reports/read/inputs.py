"""Reading lockstep's result files: every JSON file through read_document, once.

The kinds of file that reach the tools:
  run      Google Benchmark JSON (1.7 and later) written by `lockstep run`
  mpi      `lockstep mpi --out`   {"kind": "mpi", ...}: benchmark entries in the same shape
  c2c      `lockstep c2c --out`   {"kind": "c2c", ...}
  delay    `lockstep delay --out` {"kind": "delay", ...}
  verify   `lockstep verify --csv` (header t,x1,x2)
and, for compare's machine fingerprint only, the context of `lockstep falseshare`, `migrate` and `verify --out`.

read_document checks a JSON file against its kind's schema (docs/schemas/<kind>.schema.json, through
schemas.py) before anything reads it: the types, what is required, the ranges that need no other field. Then the
reader of its kind turns it into what the tools use and checks what a schema cannot express (checks.py):

  run, mpi   run_reader.py (run_file.py: the entries, pace, pairs, scaling; run_answer.py: the answer; mpi_reader.py: an mpi
             file's settings and exchanges)
  c2c        c2c_reader.py
  delay      delay_reader.py
  verify     verify_reader.py (the CSV, which is not JSON)
  the rest   context_reader.py (the machine context, for compare's fingerprint)

No other module parses a result file: compare and report take what these readers give (the split of a step
and a delay run's causes included). A key no schema names is ignored, whatever it holds; NaN and Infinity make one
value of a benchmark entry unavailable, and anywhere else a damaged file.

A file that is unreadable, truncated, of another kind, or holds a value that
cannot be right raises InputError, whose text is one line naming the file,
the place in it and the problem; the command line turns it into exit status 2.
"""
from __future__ import annotations

import functools
import json
import os

from ..common import fields
from . import context_reader, schemas
from .c2c_reader import read_c2c
from .checks import InputError
from .context_reader import CONTEXT_ONLY_KINDS, read_context_file
from .delay_reader import read_delay
from .run_file import RunFile
from .run_reader import run_file_from_document
from .schemas import json_kind, shown
from .verify_reader import load_verify_csv

# The prefix of every key lockstep adds to Google Benchmark's JSON (the context's lockstep_schema, lockstep_mode,
# ...; the top level's lockstep_pace, lockstep_answer, ...).
LOCKSTEP_PREFIX = schemas.SECTION_PREFIX


# ---------------------------------------------------------------- files as text

def read_text(path: str) -> str:
    if os.path.isdir(path):
        raise InputError(path, "is a directory, not a result file")
    try:
        with open(path, "rb") as stream:
            raw = stream.read()
    except OSError as error:
        raise InputError(path, f"cannot read: {error.strerror or error}") from None
    if not raw.strip():
        raise InputError(path, "is empty (an interrupted run?)")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as error:
        raise InputError(path, f"is not text (byte {error.start} is not UTF-8): not a lockstep result "
                               "file") from None


def parse_json(path: str, text: str):
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        if error.pos >= len(text.rstrip()) - 1:
            raise InputError(path, f"truncated: the JSON ends at byte {len(text)} before it closes "
                                   "(an interrupted or still-running run?)") from None
        raise InputError(path, f"not valid JSON at line {error.lineno} column {error.colno} "
                               f"({error.msg})") from None
    except RecursionError:
        raise InputError(path, "not a lockstep result file: its JSON nests too deeply to read") from None
    except ValueError as error:  # e.g. an integer longer than Python converts
        raise InputError(path, f"not a lockstep result file: {error}") from None


# ---------------------------------------------------------------- one reading function for every kind

def read_document(path: str, text: str | None = None) -> tuple[str, object]:
    """(kind, document) of a lockstep JSON result file, checked against its kind's schema
    (docs/schemas/<kind>.schema.json, schemas.py) before anything reads it. A file without "kind" is a
    `lockstep run` file (Google Benchmark JSON). Every tool reads JSON results through this."""
    text = read_text(path) if text is None else text
    document = parse_json(path, text)
    if not isinstance(document, dict):
        raise InputError(path, f"not Google Benchmark JSON: the top level is {json_kind(document)}, "
                               "not an object with \"context\" and \"benchmarks\"")
    if "kind" in document and document["kind"] is None:
        raise InputError(path, "kind is null: a lockstep result names its kind (a `lockstep run` file, Google "
                               "Benchmark's JSON, has no kind at all)")
    kind = "run" if document.get("kind") is None else document["kind"]
    if kind not in schemas.KINDS or kind == "run" and document.get("kind") is not None:
        raise InputError(path, f"unknown lockstep file kind {shown(kind)}")
    if kind in ("run", "mpi"):
        benchmarks, context = document.get("benchmarks"), document.get("context")
        if not isinstance(benchmarks, list) or not isinstance(context, dict):
            missing = "\"benchmarks\" list" if not isinstance(benchmarks, list) else "\"context\" object"
            raise InputError(path, f"not Google Benchmark JSON (no {missing}): not a `lockstep {kind}` result file")
        if not benchmarks:
            raise InputError(path, "holds no benchmark entries (did the filter match nothing?)")
        if kind == "run" and not written_by_lockstep(document):
            raise InputError(path, "is Google Benchmark JSON that lockstep did not write (no lockstep_ key in it): "
                                   "compare and report read the files of `lockstep run`")
    problem = _schema_problem(kind, text)
    if problem is not None:
        raise InputError(path, problem)
    return kind, document


@functools.lru_cache(maxsize=16)
def _schema_problem(kind: str, text: str) -> str | None:
    """schemas.problem of the document this text holds, once per text in a process: compare reads a side
    again for each pairing and a test reads the same fixture many times, and the check walks every value."""
    return schemas.problem(json.loads(text), kind)


def written_by_lockstep(document: dict) -> bool:
    """A Google Benchmark document that `lockstep run` wrote: its context names lockstep's keys (lockstep_schema,
    lockstep_mode, ...: bench/results/machine_context.hpp) or it carries a lockstep section (lockstep_pace,
    lockstep_headline, ...). A plain Google Benchmark file has neither: the tools would read its times but none of
    what they show beside them (the machine, the calibrations, the answer), so it is refused, not half read."""
    return any(str(key).startswith(LOCKSTEP_PREFIX) for key in list(document["context"]) + list(document))


def load_run_file(path: str, label: str | None = None) -> RunFile:
    label = label or os.path.basename(path)
    return run_file_from_document(path, label, read_document(path)[1])


def load_for_compare(path: str, label: str | None = None) -> "RunFile | context_reader.ContextFile":
    """A `lockstep run` or `lockstep mpi` file, or the context of another kind of lockstep result."""
    label = label or os.path.basename(path)
    kind, document = read_document(path)
    if kind in CONTEXT_ONLY_KINDS:
        return read_context_file(path, label, kind, document)
    if kind not in ("run", "mpi"):
        raise InputError(path, f"is `lockstep {kind}` output: neither results nor a machine context to compare")
    return run_file_from_document(path, label, document)


# ---------------------------------------------------------------- any file

def load_any(path: str, label: str | None = None):
    """Any of the five kinds (run and mpi results, c2c, delay, a verify trajectory), recognised by content
    (never by the file name)."""
    label = label or os.path.basename(path)
    text = read_text(path)
    if text.lstrip()[:1] not in ("{", "["):
        if text.lstrip().startswith("t,"):
            return load_verify_csv(path, text, label)
        raise InputError(path, "neither JSON nor a `lockstep verify --csv` trajectory")
    kind, document = read_document(path, text)
    if kind == "c2c":
        return read_c2c(path, label, document)
    if kind == "delay":
        return read_delay(path, label, document)
    if kind in ("run", "mpi"):
        return run_file_from_document(path, label, document)
    raise InputError(path, f"is `lockstep {kind}` output, which the report does not show (it takes run, mpi, c2c "
                           "and delay results, and verify --csv trajectories)")


def run_number(name: str) -> int | None:
    """I of a group's run-I.json, None for any other name."""
    stem = name[len("run-"):-len(".json")] if name.startswith("run-") and name.endswith(".json") else ""
    return int(stem) if stem.isdigit() else None


def in_run_order(files: list[RunFile]) -> list[RunFile]:
    """A group's runs in the order they ran: by each run's index in its context (fields.RUN_INDEX_CONTEXT, which
    `lockstep run --runs K` sets), else by the number in its file name (run-I.json), else as given."""
    def place(item):
        position, run_file = item
        index = run_file.context.get(fields.RUN_INDEX_CONTEXT)
        number = run_number(os.path.basename(run_file.path))
        return (0, index, position) if index is not None else (1, number, position) if number is not None \
            else (2, position, position)
    return [run_file for _, run_file in sorted(enumerate(files), key=place)]


def side_paths(argument: str) -> list[str]:
    """The files of one side of a comparison: a file; a directory, its run files (run-1.json ... run-K.json of
    `lockstep run --runs K`) in their order; or files joined by commas (A1.json,A2.json), each a run of the side."""
    if os.path.isdir(argument):
        names = sorted((name for name in os.listdir(argument) if run_number(name) is not None), key=run_number)
        if not names:
            raise InputError(argument, "is a directory without run files (run-1.json ... run-K.json, as "
                                       "`lockstep run --runs K --out DIR` writes them)")
        return [os.path.join(argument, name) for name in names]
    if "," in argument and not os.path.exists(argument):
        paths = [path for path in argument.split(",") if path]
        if not paths:
            raise InputError(argument, "names no file")
        return paths
    return [argument]


def unique_labels(paths: list[str]) -> list[str]:
    """Short names for files: the base name, or more of the path where base names collide."""
    labels = [os.path.basename(p) for p in paths]
    if len(set(labels)) == len(labels):
        return labels
    return [os.path.normpath(p) for p in paths]
