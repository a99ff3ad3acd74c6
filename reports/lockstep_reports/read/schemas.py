"""The result files' schemas, docs/schemas/<kind>.schema.json: one per kind lockstep writes, and the shapes
they share in context.schema.json. The reader checks every file against its kind's schema before it reads a
field (inputs.read_document), and the writers' tests check what each command writes against the same files
(tests/reports/check_result_schemas.py).

Two ways of checking:
  reader  (strict=False) what the tools accept: a key the schema does not name is ignored wherever it is, so
          a file of a later lockstep with a new key still reads;
  writer  (strict=True)  what lockstep writes: lockstep's own objects are closed ("additionalProperties" or
          "unevaluatedProperties" false), so a key misspelt by a writer fails its test.

A problem is one line naming the JSON path: "benchmarks[3].ns_per_step: expected a number, not text".
JSON Schema has no word for "finite": NaN and the infinities (which Python's json module reads) are numbers
to it. They belong only in a benchmark entry, where Google Benchmark writes them for a value it could not
compute; anywhere else the schema sees them as a value of no JSON type, which a field it names refuses.
"""
from __future__ import annotations

import functools
import json
import math
import re
from pathlib import Path

SCHEMA_DIR = Path(__file__).resolve().parents[3] / "docs" / "schemas"
# Every kind with a schema; a file without "kind" is a `lockstep run` file (Google Benchmark JSON).
KINDS = ("run", "c2c", "delay", "falseshare", "migrate", "mpi", "verify", "topology")
# The prefix of lockstep's own sections at a file's top level (lockstep_pace, lockstep_answer, ...).
SECTION_PREFIX = "lockstep_"
# The top-level lists whose entries are Google Benchmark's (NaN and infinities allowed in them).
ENTRY_LISTS = ("benchmarks",)

_TYPE_WORDS = {"number": "a number", "integer": "a whole number", "string": "text", "boolean": "true or false",
               "array": "a list", "object": "an object", "null": "null"}


def schema_path(kind: str) -> Path:
    return SCHEMA_DIR / f"{kind}.schema.json"


@functools.lru_cache(maxsize=None)
def _store() -> dict:
    """Every schema by its URI (the file's), so that "$ref": "context.schema.json#/..." resolves offline."""
    return {path.as_uri(): json.loads(path.read_text(encoding="utf-8"))
            for path in sorted(SCHEMA_DIR.glob("*.schema.json"))}


@functools.lru_cache(maxsize=None)
def _validator(kind: str, strict: bool):
    import jsonschema  # Debian's python3-jsonschema (scripts/setup.sh)

    uri = schema_path(kind).as_uri()
    schema = _store()[uri]
    base = jsonschema.Draft202012Validator
    if not strict:
        def open_object(keyword):
            check = base.VALIDATORS[keyword]

            def lenient(validator, value, instance, schema_here):
                if value is not False:  # a schema for the other keys still applies (a map's values)
                    yield from check(validator, value, instance, schema_here)
            return lenient

        base = jsonschema.validators.extend(base, {keyword: open_object(keyword) for keyword in
                                                   ("additionalProperties", "unevaluatedProperties")})
    return base(schema, resolver=jsonschema.RefResolver(uri, schema, store=_store()))


def json_path(parts) -> str:
    """A place in a document as the error names it: benchmarks[3].ns_per_step; "the top level" for the root."""
    text = ""
    for part in parts:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "the top level"


def shown(value) -> str:
    """A value as an error quotes it: short, one line, numbers as JSON spells them."""
    if isinstance(value, float):
        if math.isnan(value):
            return "NaN"
        if math.isinf(value):
            return "Infinity" if value > 0 else "-Infinity"
        return f"{value:g}"
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value) if abs(value) < 10 ** 30 else "a number of more than 30 digits"
    if isinstance(value, (dict, list)):
        return json_kind(value)
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def json_kind(value) -> str:
    """A JSON value's type, as an error message names it."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, str):
        return "text"
    if isinstance(value, list):
        return "a list"
    return "an object"


def _message(error) -> tuple[list, str]:
    """(path, problem) of one jsonschema error, in the reader's words."""
    path, keyword, expected, value = list(error.absolute_path), error.validator, error.validator_value, error.instance
    if keyword == "type":
        types = [expected] if isinstance(expected, str) else list(expected)
        return path, f"expected {' or '.join(_TYPE_WORDS.get(t, t) for t in types)}, not {json_kind(value)}"
    if keyword == "required":
        missing = next((key for key in expected if key not in value), expected[0])
        return path + [missing], "is missing"
    if keyword == "dependentRequired":
        for key, needs in expected.items():
            missing = [need for need in needs if key in value and need not in value]
            if missing:
                return path + [missing[0]], f"is missing beside {key}: the two come together"
    if keyword == "dependentSchemas":
        return path, error.message.split("\n")[0]
    if keyword in ("additionalProperties", "unevaluatedProperties"):
        extra = re.findall(r"'([^']*)'", str(error.message).split("(", 1)[-1])
        return path, f"has a key its schema does not name: {', '.join(map(repr, extra[:3]))}"
    if keyword in ("enum", "const"):
        choices = expected if keyword == "enum" else [expected]
        return path, f"is {shown(value)}, not {'one of ' if len(choices) > 1 else ''}{', '.join(map(str, choices))}"
    if keyword in ("minimum", "exclusiveMinimum"):
        return path, f"is {shown(value)}, below {'the least' if keyword == 'minimum' else 'or at'} {shown(expected)}"
    if keyword in ("maximum", "exclusiveMaximum"):
        return path, f"is {shown(value)}, above {'the most' if keyword == 'maximum' else 'or at'} {shown(expected)}"
    if keyword == "minItems":
        return path, "is an empty list" if not value else f"has {len(value)} items, fewer than {expected}"
    if keyword == "maxItems":
        return path, f"has {len(value)} items, more than {expected}"
    if keyword == "minLength":
        return path, "is empty"
    if keyword == "uniqueItems":
        return path, "holds an item twice"
    if keyword == "pattern" or error.schema.get("title") and keyword in ("anyOf", "oneOf"):
        return path, f"is {shown(value)}, not {error.schema.get('title') or 'text of the form ' + str(expected)}"
    return path, " ".join(str(error.message).split())[:160]


class _NonFinite:
    """A NaN or an infinity outside the benchmark entries, as the schema sees it: of no JSON type, so a field
    the schema types fails ("is NaN, not a finite number"), and a key it does not name is ignored as any other."""

    def __init__(self, text: str):
        self.text = text

    def __str__(self) -> str:
        return self.text


def _marked(node, top: bool = True):
    """The document with every non-finite number outside the benchmark entries replaced by a _NonFinite;
    the document itself when it has none (a copy is made only where one is)."""
    if isinstance(node, float) and not math.isfinite(node):
        return _NonFinite(shown(node))
    if isinstance(node, dict):
        changed = {key: value if top and key in ENTRY_LISTS else _marked(value, False) for key, value in node.items()}
        return node if all(changed[key] is node[key] for key in node) else changed
    if isinstance(node, list):
        changed = [_marked(value, False) for value in node]
        return node if all(a is b for a, b in zip(changed, node)) else changed
    return node


def unnamed_sections(document, kind: str) -> list[str]:
    """The top-level lockstep_* keys of a document that its kind's schema does not name (a run file's top level is
    Google Benchmark's, open to its later keys; lockstep's own sections are each named)."""
    if not isinstance(document, dict):
        return []
    named = _store()[schema_path(kind).as_uri()].get("properties", {})
    return [key for key in document if str(key).startswith(SECTION_PREFIX) and key not in named]


def problem(document, kind: str, strict: bool = False) -> str | None:
    """The first thing wrong with a document of the kind, as "<json path>: <problem>"; None when it fits. strict: also
    a top-level lockstep_* section the schema does not name (a writer's section without its schema)."""
    import jsonschema

    error = jsonschema.exceptions.best_match(_validator(kind, strict).iter_errors(_marked(document)))
    if error is None:
        unnamed = unnamed_sections(document, kind) if strict else []
        return f"{unnamed[0]}: a section {schema_path(kind).name} does not name" if unnamed else None
    if isinstance(error.instance, _NonFinite):
        return f"{json_path(error.absolute_path)}: is {error.instance}, not a finite number"
    path, text = _message(error)
    return f"{json_path(path)}: {text}"


def main(argv: list[str]) -> int:
    """python3 -m lockstep_reports.schemas [--reader] KIND FILE...: check files as the writers' tests do
    (strict), or as the reader does (--reader); one line per file that does not fit, exit 1 if any."""
    import sys

    strict = "--reader" not in argv
    argv = [argument for argument in argv if argument != "--reader"]
    if len(argv) < 2 or argv[0] not in KINDS:
        sys.stderr.write(f"usage: python3 -m lockstep_reports.schemas [--reader] {{{','.join(KINDS)}}} FILE...\n")
        return 2
    failed = 0
    for name in argv[1:]:
        try:
            with open(name, encoding="utf-8") as stream:
                document = json.load(stream)
        except (OSError, ValueError) as error:
            print(f"{name}: not readable JSON: {error}")
            failed += 1
            continue
        found = problem(document, argv[0], strict)
        if found is not None:
            print(f"{name}: {found}")
            failed += 1
    return 1 if failed else 0


if __name__ == "__main__":
    import sys
    sys.exit(main(sys.argv[1:]))
