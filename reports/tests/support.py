"""Shared helpers of the report tools' tests: fixture paths and running the tool as a user would."""
import io
import json
import os
import pathlib
import sys
import tempfile
import unittest
from contextlib import redirect_stderr, redirect_stdout

REPORTS_DIR = pathlib.Path(__file__).resolve().parent.parent
FIXTURES = REPORTS_DIR / "tests" / "fixtures"
if str(REPORTS_DIR) not in sys.path:
    sys.path.insert(0, str(REPORTS_DIR))

from lockstep_reports.main import main  # noqa: E402


def fixture(name: str) -> str:
    return os.fspath(FIXTURES / name)


def run_tool(*argv: str):
    """(exit status, stdout, stderr) of `lockstep <argv...>` run in this process."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        status = main(list(argv))
    return status, out.getvalue(), err.getvalue()


def logical_line(text: str, start: str) -> str:
    """The first line of `text` that starts with `start`, with the lines compare wrapped it onto (indented two more
    than it: lockstep_reports.text_layout.wrap) joined back by single spaces."""
    lines = text.splitlines()
    index = next(index for index, line in enumerate(lines) if line.startswith(start))
    indent = " " * (len(lines[index]) - len(lines[index].lstrip()) + 2)
    parts = [lines[index]]
    for line in lines[index + 1:]:
        if not line.startswith(indent) or line[len(indent):len(indent) + 1] in ("", " "):
            break
        parts.append(line.strip())
    return " ".join(parts)


# A `lockstep run` file with the run's answer (lockstep_headline): reports/tests/fixtures/make_fixtures.py.
HEADLINE = "headline.json"


def typed_document(document: dict, rename=None) -> dict:
    """A `lockstep run` document as the writer writes it since the typed entry: each benchmark entry with its spec
    as values (lockstep_entry, the spec its name implies: names.spec_of) and the answer under lockstep_answer.
    rename: a function of an entry's name giving the name the copy writes everywhere in its place (the entries'
    names and run_names, and every section that names an entry): a reader that reads the spec cannot tell."""
    from lockstep_reports.common.names import parse_name, spec_of
    from lockstep_reports.read.run_checks import base_name

    typed = json.loads(json.dumps(document))
    for raw in typed["benchmarks"]:
        spec = spec_of(parse_name(base_name(raw)))
        raw["lockstep_entry"] = {"kind": spec.kind, "sync": spec.sync, "layout": spec.layout, "pin": spec.pin,
                                 "threads": spec.threads, "model": spec.model, "masses": spec.masses,
                                 "accounting": spec.accounting, "unit": spec.unit}
    if "lockstep_headline" in typed:
        typed["lockstep_answer"] = typed.pop("lockstep_headline")
    if rename is None:
        return typed
    names = {base_name(raw) for raw in typed["benchmarks"]}

    def renamed(node):
        if isinstance(node, dict):
            return {key: renamed(value) for key, value in node.items()}
        if isinstance(node, list):
            return [renamed(value) for value in node]
        if isinstance(node, str):
            if node in names:
                return rename(node)
            stem, _, aggregate = node.rpartition("_")
            return f"{rename(stem)}_{aggregate}" if stem in names else node
        return node

    return {key: value if key == "context" else renamed(value) for key, value in typed.items()}


def headline_document() -> dict:
    with open(fixture(HEADLINE), encoding="utf-8") as stream:
        return json.load(stream)


class Scratch(unittest.TestCase):
    """A test with a scratch directory: write() puts a file there, report() makes a report of files and returns
    its two pages (HTML, Markdown)."""

    def setUp(self):
        self.directory = tempfile.TemporaryDirectory()
        self.addCleanup(self.directory.cleanup)

    def write(self, name, document):
        path = os.path.join(self.directory.name, name)
        with open(path, "w", encoding="utf-8") as stream:
            stream.write(document if isinstance(document, str) else json.dumps(document))
        return path

    def report(self, *paths):
        out = os.path.join(self.directory.name, "report")
        status, _, err = run_tool("report", *paths, "--out", out)
        self.assertEqual(status, 0, err)
        pages = []
        for page in ("report.html", "report.md"):
            with open(os.path.join(out, page), encoding="utf-8") as stream:
                pages.append(stream.read())
        return pages
