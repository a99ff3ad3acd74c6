"""The machine context every lockstep result carries (docs/schemas/context.schema.json): the fingerprint keys the
tools read (fields.FINGERPRINT_KEYS), checked; and the reader of the kinds compare takes for their context only."""
from __future__ import annotations

from dataclasses import dataclass

from ..common import fields
from .checks import InputError
from .schemas import shown


def read_context(path: str, label: str, raw: dict) -> tuple[dict, list[str]]:
    """The fingerprint keys of a context the schema has checked. A key of another kind's context (date in a
    c2c file) is read when it holds what it holds in its own kind, else ignored as any unknown key."""
    values = {}
    for key in fields.FINGERPRINT_KEYS + fields.RUN_CONTEXT_KEYS:
        value = raw.get(key)
        if key in fields.CONTEXT_COUNTS:
            if isinstance(value, int) and not isinstance(value, bool) or isinstance(value, str) and value.isdigit():
                values[key] = int(value)  # the schema holds it to a whole number from 1, or its digits
        elif key in fields.CONTEXT_INTEGERS and isinstance(value, (int, float)) and not isinstance(value, bool):
            values[key] = int(value)
        elif key not in fields.CONTEXT_INTEGERS and isinstance(value, str):
            values[key] = value
    for key in fields.CALIBRATION_CONTEXT:
        if key in values and values[key] != fields.UNAVAILABLE:
            try:
                number = float(values[key])
            except ValueError:
                raise InputError(path, f"context.{key}: is {shown(values[key])}: neither a number of ns nor "
                                       f"{fields.UNAVAILABLE!r}") from None
            if not fields.SHORTEST_NS <= number <= fields.LONGEST_NS:  # NaN fails this too
                raise InputError(path, f"context.{key}: is {shown(values[key])}: not a measured time in ns")

    warnings = []
    schema = raw.get("json_schema_version")
    if isinstance(schema, int) and schema > fields.KNOWN_GB_JSON_SCHEMA:
        warnings.append(f"{label}: Google Benchmark JSON schema {schema} is newer than this tool knows "
                        f"({fields.KNOWN_GB_JSON_SCHEMA}); reading the fields it knows")
    lockstep_schema = values.get("lockstep_schema")
    if lockstep_schema is None:
        warnings.append(f"{label}: no lockstep keys in the context (not written by `lockstep run`?): "
                        "no machine fingerprint or normalisation for it")
    elif int(lockstep_schema) > fields.KNOWN_LOCKSTEP_SCHEMA:
        warnings.append(f"{label}: lockstep result schema {lockstep_schema} is newer than this tool knows "
                        f"({fields.KNOWN_LOCKSTEP_SCHEMA}); reading the fields it knows")
    return values, warnings


# The kinds of lockstep result that carry the machine context but no benchmark entries.
CONTEXT_ONLY_KINDS = ("c2c", "delay", "falseshare", "migrate", "verify")


@dataclass
class ContextFile:
    """A `lockstep c2c`, `delay`, `falseshare`, `migrate` or `verify` result as compare reads it: only its
    machine context (the same fingerprint every lockstep command writes), so that compare can say whether
    files of different kinds come from one machine."""
    path: str
    label: str
    kind: str
    context: dict
    warnings: list[str]


def read_context_file(path: str, label: str, kind: str, document: dict) -> ContextFile:
    """A result of one of CONTEXT_ONLY_KINDS as compare reads it: its context alone."""
    context, warnings = read_context(path, label, document["context"])
    return ContextFile(path=path, label=label, kind=kind, context=context, warnings=warnings)
