"""Bad result files by the thousand: seeded mutations of the fixtures and samples, fed to `lockstep compare`
and `lockstep report` through their real entry point (lockstep_reports.main.main, what reports/cli.py runs
for the lockstep binary), in this process, so that 1200 cases take about two minutes of one CPU.

Each case is one mutation of one base document (a fixture or a sample, run files trimmed to a few
benchmarks so that a comparison is quick): truncated at a random byte, bytes that are not UTF-8, another
tool's file, a value of the wrong type, a key missing, an extra key, an unknown context key, NaN or an
infinity, a huge or a negative number, an empty list, an entry duplicated, entries reordered. The mutated
file goes to `compare` beside an unmutated file of the same kind, in both orders (with --json), and to
`report` alone; the report of every case is built with the figures' drawing replaced by a stand-in (the
reading, checking, tables, pages and writing are the real ones), and for a seeded subset with the real
figures.

Every run must end in one of:
  rejected     exit 2, exactly one line on stderr naming the mutated file and what is wrong, nothing
               written (no --json file, no report directory, no temporary left beside them);
  same         the result of the unmutated file, byte for byte (the file's path aside);
  reported     exit 0 or 1 with more "unavailable" / "left out" in the output than the unmutated file
               gives (a NaN the format allows, an optional field missing);
  other value  only where the mutation makes another valid file: a negative value of a field that may be
               negative (fields.SIGNED_COUNTERS, a displacement), a trajectory cut at a row's end, a list of
               the run's headline (lockstep_headline) emptied or with an entry twice.
A mutation the format allows (an extra key, an unknown context key, reordered benchmarks or c2c pairs)
must give "same"; a cut, non-UTF-8 bytes and another tool's file must give "rejected". Never a traceback,
a hang (each run has a 20 s alarm), a warning from numpy or matplotlib, or NaN / Infinity / None / an
absurd run of digits in an output.

LOCKSTEP_FUZZ_CASES sets the number of cases (default 1200), LOCKSTEP_FUZZ_SEED the seed,
LOCKSTEP_FUZZ_RENDER_EVERY how often the figures are drawn, LOCKSTEP_FUZZ_KEEP=DIR keeps the files of
failing cases there, LOCKSTEP_FUZZ_LOG=FILE writes one line per run (case, mutation, place, outcome).
"""
import contextlib
import copy
import functools
import io
import json
import math
import os
import random
import re
import shutil
import signal
import tempfile
import time
import traceback
import unittest
import warnings
from collections import Counter

from support import FIXTURES, REPORTS_DIR

from lockstep_reports.common import fields
from lockstep_reports.common.names import parse_name
from lockstep_reports.main import main
from lockstep_reports.read.schemas import json_kind
from lockstep_reports.report import figures

SEED = int(os.environ.get("LOCKSTEP_FUZZ_SEED", "20260310"))
CASES = int(os.environ.get("LOCKSTEP_FUZZ_CASES", "1200"))
# One case in this many also gets its report with the real figures.
RENDER_EVERY = int(os.environ.get("LOCKSTEP_FUZZ_RENDER_EVERY", "50"))
ALARM_SECONDS = 20
SAMPLES = REPORTS_DIR / "samples"

# ---------------------------------------------------------------- the base documents

RUN_BASES = (  # (base, partner): the partner is the unmutated file of the comparison
    (FIXTURES / "machine_a.json", FIXTURES / "machine_a_rerun.json"),
    (FIXTURES / "machine_b.json", FIXTURES / "aggregates_only.json"),
    (FIXTURES / "later_schema.json", FIXTURES / "machine_a.json"),
    (FIXTURES / "errored.json", FIXTURES / "machine_a.json"),
    (FIXTURES / "few_repetitions.json", FIXTURES / "machine_a.json"),
    (FIXTURES / "aggregates_only.json", FIXTURES / "machine_b.json"),
    (SAMPLES / "pair-a.json", SAMPLES / "pair-b.json"),
    (SAMPLES / "run.json", SAMPLES / "pair-a.json"),
    (FIXTURES / "paced_a.json", FIXTURES / "paced_b.json"),  # the pace trace and pairs
    (FIXTURES / "headline.json", FIXTURES / "paced_b.json"),  # the run's answer (lockstep_headline)
    (FIXTURES / "mpi-a.json", FIXTURES / "mpi-b.json"),  # `lockstep mpi` files: the contract by hand
    (FIXTURES / "mpi.json", FIXTURES / "mpi-b.json"),  # and as lockstep mpi writes it
)
OTHER_BASES = (FIXTURES / "c2c_a.json", FIXTURES / "c2c_b.json", SAMPLES / "c2c.json",
               FIXTURES / "delay_a.json", SAMPLES / "delay.json")
CSV_BASES = (FIXTURES / "verify_a.csv", SAMPLES / "verify.csv")
CSV_ROWS = 200  # a trajectory's first rows: enough to read, quick to draw
REPETITIONS = 5  # repetitions kept per benchmark: enough for the Mann-Whitney test (statistics.MIN_REPETITIONS)
# rk4 combinations kept per run file, beside the calibrations, one barrier and one overhead pair: the first
# two primitives x the first two layouts x pin:compact and one other placement, at one thread count (two
# heat maps, two bar charts and the penalties when drawn).
RK4_SYNCS, RK4_LAYOUTS = 2, 2
C2C_CPUS = {0, 1, 4, 8, 9, 12}  # c2c_b's pairs among these CPUs: siblings, L3 neighbours, the other L3


def run_name(entry):
    """The benchmark an entry belongs to (Google Benchmark names an aggregate <run_name>_<aggregate>)."""
    if "run_name" in entry or "aggregate_name" not in entry:
        return entry.get("run_name") or entry["name"]
    return entry["name"][: -(len(entry["aggregate_name"]) + 1)]


def kept_runs(document):
    """The benchmarks of a trimmed run file: rk4/serial, c2c, the first overhead pair and barrier entry,
    the first RK4_RUNS rk4 combinations, every errored benchmark; every entry of a `lockstep mpi` file."""
    names = list(dict.fromkeys(run_name(entry) for entry in document["benchmarks"]))
    errored = {run_name(entry) for entry in document["benchmarks"] if entry.get("error_occurred")}
    kept = [n for n in names if n.startswith(("rk4/serial", "c2c/", "mpi/"))]  # a lockstep mpi file: all of it
    kept += [n for n in names if n.startswith("barrier/")][:1]
    overhead = [n for n in names if n.startswith("overhead/")]
    if overhead:
        first = overhead[0].replace("accounting:on", "accounting:off")
        kept += [n for n in overhead if n.replace("accounting:on", "accounting:off") == first]
    combinations = [(n, parse_name(n)) for n in names if parse_name(n).family == "rk4" and parse_name(n).get("sync")]
    if combinations:
        syncs = list(dict.fromkeys(key.get("sync") for _, key in combinations))[:RK4_SYNCS]
        layouts = list(dict.fromkeys(key.get("layout") for _, key in combinations))[:RK4_LAYOUTS]
        pins = ["compact"] + [p for p in dict.fromkeys(key.get("pin") for _, key in combinations) if p != "compact"][:1]
        threads = combinations[0][1].get("threads")
        kept += [n for n, key in combinations if key.get("sync") in syncs and key.get("layout") in layouts
                 and key.get("pin") in pins and key.get("threads") == threads]
    return set(kept) | errored


def trimmed_run(document, names):
    trimmed = copy.deepcopy(document)
    trimmed["benchmarks"] = [entry for entry in trimmed["benchmarks"] if run_name(entry) in names
                             and entry.get("repetition_index", 0) < REPETITIONS]
    return trimmed


def load_bases():
    """[(name, kind, text or document, partner document or None)], kind "json" or "csv"."""
    bases = []
    for base, partner in RUN_BASES:
        document = json.loads(base.read_text(encoding="utf-8"))
        names = kept_runs(document)
        partner_document = trimmed_run(json.loads(partner.read_text(encoding="utf-8")), names)
        bases.append((base.name, "json", trimmed_run(document, names), partner_document))
    for base in OTHER_BASES:
        document = json.loads(base.read_text(encoding="utf-8"))
        if base.name == "c2c_b.json":
            document["pairs"] = [p for p in document["pairs"] if p["a"] in C2C_CPUS and p["b"] in C2C_CPUS]
        bases.append((f"{base.parent.name}-{base.name}", "json", document, None))
    for base in CSV_BASES:
        lines = base.read_text(encoding="utf-8").splitlines(keepends=True)
        bases.append((f"{base.parent.name}-{base.name}", "csv", "".join(lines[: CSV_ROWS + 1]), None))
    return bases


# ---------------------------------------------------------------- mutations

# Mutations the format allows: the result must be the unmutated file's.
MUST_BE_SAME = {"extra key", "unknown context key", "reordered entries", "extra column"}
# Mutations no reader may accept.
MUST_BE_REJECTED = {"truncated", "not UTF-8", "another tool's file"}
JSON_KINDS = ("truncated", "not UTF-8", "another tool's file", "wrong type", "missing key", "extra key",
              "unknown context key", "NaN or infinity", "huge number", "negative number", "empty list",
              "duplicated entry", "reordered entries")
CSV_KINDS = ("truncated", "not UTF-8", "another tool's file", "wrong type", "missing key", "extra column",
             "NaN or infinity", "huge number", "negative number", "empty list", "duplicated entry",
             "rows swapped")

OTHER_TOOLS_JSON = (
    {"file_version": 1, "cmdline": "cyclictest -m -p95 -i200 -h400 -q", "rt_test_version": "2.5",
     "start_time": "Tue Mar 10 09:00:00 2026", "end_time": "Tue Mar 10 09:01:00 2026", "return_code": 0,
     "sysinfo": {"sysname": "Linux"}, "num_threads": 2, "resolution_in_ns": 1,
     "thread": {"0": {"histogram": {"12": 7, "13": 40}, "cycles": 300000, "min": 3, "max": 47, "avg": 12,
                      "cpu": 0, "node": 0}}},
    {"results": [{"command": "sleep 0.1", "mean": 0.1012, "stddev": 0.0003, "median": 0.1011, "user": 0.0009,
                  "system": 0.001, "min": 0.1008, "max": 0.1019, "times": [0.1008, 0.1011, 0.1019],
                  "exit_codes": [0, 0, 0]}]},
    {"name": "left-pad", "version": "1.3.0", "dependencies": {}, "scripts": {"test": "node test.js"}},
    {"context": {"date": "2026-03-10"}, "benchmarks": {"BM_x": 3}},
    {"kind": "compare", "comparisons": []},
    {"kind": "c2c", "lockstep_schema": 1},
    [1, 2, 3], "lockstep", 42, None, {}, [[[[[[]]]]]],
)
OTHER_TOOLS_TEXT = (
    "command,mean,stddev,median,user,system,min,max\nsleep 0.1,0.1012,0.0003,0.1011,0.0009,0.001,0.1008,0.1019\n",
    "# /dev/cpu_dma_latency set to 0us\nT: 0 ( 1234) P:95 I:200 C: 300000 Min: 3 Act: 5 Avg: 12 Max: 47\n",
    "<?xml version=\"1.0\"?><testsuites tests=\"1\"/>\n",
    "\x7fELF\x02\x01\x01",
    "t;x1;x2\n0;2;-3\n0.001;1.9;-2.9\n",
)
NOT_UTF8 = (b"\xff", b"\xc3\x28", b"\xed\xa0\x80", b"\x80\x80", b"\xfe\xff")
WRONG_VALUES = ("text", 17, 2.5, True, None, [], {}, [1, "a"], {"a": 1})
HUGE_TOKENS = ("1e300", "-1e300", "1.7976931348623157e308", "1e999", "-1e999", "1" + "0" * 30,
               "1" + "0" * 400, "9" * 5000)
NON_FINITE = (math.nan, math.inf, -math.inf)
MARKER = "\u2603fuzz\u2603"  # a text the mutator puts in a document and swaps for a raw JSON token


def sites(node, path=()):
    """(path, value) of every node below the root, depth first."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        yield path + (key,), value
        yield from sites(value, path + (key,))


def parent_of(document, path):
    node = document
    for key in path[:-1]:
        node = node[key]
    return node


def context_of(document):
    if isinstance(document, dict) and isinstance(document.get("context"), dict):
        return document["context"]
    return None


class Mutation:
    """One mutated file: its text or bytes, what was done, and where (a JSON path or a CSV line)."""

    def __init__(self, kind, data, where="", other_value_allowed=False):
        self.kind, self.data, self.where = kind, data, where
        self.other_value_allowed = other_value_allowed  # the mutation may make another valid file


def not_utf8(rng, text):
    raw = text.encode("utf-8")
    at = rng.randrange(0, len(raw))
    return Mutation("not UTF-8", raw[:at] + rng.choice(NOT_UTF8) + raw[at:], f"byte {at}")


def dumped(document):
    """A document as a file holds it (on one line: json's C encoder, several times quicker than indent=2)."""
    return json.dumps(document) + "\n"


# Objects whose keys are data, not field names: a key added there is a new entry (an exchange said not
# applicable, with its reason), read and checked as the others, not an unknown field ignored.
OPEN_MAPS = {("not_applicable",)}


class Sites:
    """The places of a base document a mutation can touch, listed once (paths stay valid in a copy)."""

    def __init__(self, document):
        self.text = dumped(document)
        every = list(sites(document))
        self.every = [path for path, _ in every]
        self.numbers = [path for path, value in every if json_kind(value) == "a number"]
        self.objects = [path for path, value in every if isinstance(value, dict) and path not in OPEN_MAPS] + [()]
        self.filled_objects = [path for path, value in every if isinstance(value, dict) and value] + [()]
        self.lists = [path for path, value in every if isinstance(value, list) and value]

    def copy(self):
        return json.loads(self.text)


def pick(rng, paths):
    """A place chosen region by region: first a top-level key (context, benchmarks, histogram, ...), then a
    place under it, so that the context's few fields are hit as often as the benchmarks' thousands."""
    regions = {}
    for path in paths:
        regions.setdefault(path[0] if path else "", []).append(path)
    return rng.choice(regions[rng.choice(sorted(regions))])


def node_at(document, path):
    node = document
    for key in path:
        node = node[key]
    return node


def mutate_json(rng, kind, base):
    text = base.text
    document = json.loads(text)
    if kind == "truncated":
        cut = rng.randrange(0, len(text) - 1)
        return Mutation(kind, text[:cut], f"byte {cut} of {len(text)}")  # never the whole: "}\n" ends it
    if kind == "not UTF-8":
        return not_utf8(rng, text)
    if kind == "another tool's file":
        if rng.random() < 0.75:
            return Mutation(kind, dumped(rng.choice(OTHER_TOOLS_JSON)), "json")
        return Mutation(kind, rng.choice(OTHER_TOOLS_TEXT), "text")

    mutated = document
    raw_token = None
    if kind == "wrong type":
        path = pick(rng, base.every)
        value = node_at(mutated, path)
        choices = [v for v in WRONG_VALUES if json_kind(v) != json_kind(value)
                   and not (value is None and json_kind(v) == "a number")]  # null -> a number may be valid
        parent_of(mutated, path)[path[-1]] = copy.deepcopy(rng.choice(choices))
    elif kind == "missing key":
        path = pick(rng, base.filled_objects)
        value = node_at(mutated, path)
        key = rng.choice(sorted(value))
        del value[key]
        path = path + (key,)
    elif kind == "extra key":
        path = pick(rng, base.objects)
        value = node_at(mutated, path)
        key = f"fuzz_extra_{rng.randrange(1000)}"
        value[key] = copy.deepcopy(rng.choice(WRONG_VALUES + (math.nan, 1e300, -5)))
        path = path + (key,)
    elif kind == "unknown context key":
        context = context_of(mutated)
        if context is None:
            return mutate_json(rng, "extra key", base)
        key = f"fuzz_context_{rng.randrange(1000)}"
        context[key] = copy.deepcopy(rng.choice(WRONG_VALUES + (math.nan, "4.5")))
        path = ("context", key)
    elif kind in ("NaN or infinity", "huge number", "negative number"):
        path = pick(rng, base.numbers)
        value = node_at(mutated, path)
        parent = parent_of(mutated, path)
        if kind == "NaN or infinity":
            parent[path[-1]] = rng.choice(NON_FINITE)
        elif kind == "huge number":
            raw_token = rng.choice(HUGE_TOKENS)
            parent[path[-1]] = MARKER
        else:
            parent[path[-1]] = -abs(value) - rng.choice((1, 0.5, 1000))
    elif kind == "empty list":
        path = pick(rng, base.lists)
        node_at(mutated, path).clear()
    elif kind == "duplicated entry":
        path = pick(rng, base.lists)
        value = node_at(mutated, path)
        index = rng.randrange(len(value))
        value.insert(rng.randrange(len(value) + 1), copy.deepcopy(value[index]))
    elif kind == "reordered entries":
        # Entries of an order-free list (benchmarks, c2c pairs), or the keys of an object.
        key = next((key for key in ("benchmarks", "pairs") if len(mutated.get(key, [])) > 1), None)
        if key is not None and rng.random() < 0.75:
            entries = mutated[key]
            original = list(entries)
            while entries == original:
                rng.shuffle(entries)
            path = (key,)
        else:
            path = pick(rng, [p for p in base.filled_objects if len(node_at(mutated, p)) > 1])
            value = node_at(mutated, path)
            items = list(value.items())
            rng.shuffle(items)
            value.clear()
            value.update(items)
    else:
        raise AssertionError(kind)
    text = dumped(mutated)
    if raw_token is not None:
        text = text.replace(json.dumps(MARKER), raw_token)
    # A negative value a field may hold: a signed counter's, or a mode's -1 (outlier, straddling, unknown).
    signed = kind == "negative number" and (path[-1] in fields.SIGNED_COUNTERS or path[-1] in fields.MODE_KEYS
                                            or (len(path) > 1 and path[-2] in fields.MODE_KEYS))
    # The run's answer with a list emptied or an entry twice (a line, a choice) is another answer a run may give:
    # its lines are shown as they are.
    answer = kind in ("empty list", "duplicated entry") and bool(path) and path[0] in fields.ANSWER_KEYS
    return Mutation(kind, text, "/".join(str(p) for p in path), other_value_allowed=signed or answer)


def mutate_csv(rng, kind, text):
    lines = text.splitlines(keepends=True)
    row = rng.randrange(1, len(lines))
    cells = lines[row].rstrip("\n").split(",")
    column = rng.randrange(len(cells))
    where = f"line {row + 1} column {column + 1}"

    def with_cell(value):
        changed = list(cells)
        changed[column] = value
        return "".join(lines[:row] + [",".join(changed) + "\n"] + lines[row + 1:])

    if kind == "truncated":
        cut = rng.randrange(0, len(text) - 1)
        # A cut right after a newline leaves a shorter trajectory: the CSV carries no row count.
        return Mutation(kind, text[:cut], f"byte {cut}", other_value_allowed=cut > 0 and text[cut - 1] == "\n")
    if kind == "not UTF-8":
        return not_utf8(rng, text)
    if kind == "another tool's file":
        return Mutation(kind, rng.choice(OTHER_TOOLS_TEXT + (dumped(OTHER_TOOLS_JSON[1]),)))
    if kind == "wrong type":
        return Mutation(kind, with_cell(rng.choice(("abc", "", "true", "0x10", "[1]"))), where)
    if kind == "missing key":
        del cells[column]
        return Mutation(kind, "".join(lines[:row] + [",".join(cells) + "\n"] + lines[row + 1:]), where)
    if kind == "extra column":
        if rng.random() < 0.5:
            return Mutation(kind, "".join(line.rstrip("\n") + ",0.5\n" for line in lines), "every line")
        return Mutation(kind, "".join(lines[:row] + [lines[row].rstrip("\n") + ",7\n"] + lines[row + 1:]), where)
    if kind == "NaN or infinity":
        return Mutation(kind, with_cell(rng.choice(("nan", "NaN", "inf", "-inf", "Infinity", "1e999"))), where)
    if kind == "huge number":
        return Mutation(kind, with_cell(rng.choice(("1e300", "-1e300", "1e30", "9" * 400))), where)
    if kind == "negative number":
        value = float(cells[column])
        return Mutation(kind, with_cell(repr(-abs(value) - 1.0)), where, other_value_allowed=column > 0)
    if kind == "empty list":
        return Mutation(kind, lines[0], "rows")
    if kind == "duplicated entry":
        return Mutation(kind, "".join(lines[:row] + [lines[row]] + lines[row:]), f"line {row + 1}")
    if kind == "rows swapped":  # time runs backwards: not a trajectory
        other = row + 1 if row + 1 < len(lines) else row - 1
        if other < 1:
            other = row
        swapped = list(lines)
        swapped[row], swapped[other] = swapped[other], swapped[row]
        return Mutation(kind, "".join(swapped), f"lines {row + 1} and {other + 1}")
    raise AssertionError(kind)


# ---------------------------------------------------------------- running the tools

class Hang(Exception):
    pass


def _alarm(signum, frame):
    raise Hang()


@contextlib.contextmanager
def drawing_replaced():
    """Every figure's drawing replaced by a stand-in SVG: the report's data, tables, pages and writing run,
    matplotlib does not."""
    names = ("heatmap", "bars_with_spread", "penalties", "paired_ratios", "c2c_heatmap", "delay_histogram",
             "trajectory")
    saved = {name: getattr(figures, name) for name in names}
    for name in names:
        setattr(figures, name, lambda *args, _name=name, **kwargs: f'<svg id="{_name}"><path d="M0 0"/></svg>')
    try:
        yield
    finally:
        for name, function in saved.items():
            setattr(figures, name, function)


def run_tool(argv):
    """(status, stdout, stderr, failure): main() in this process; failure is a traceback or "hang"."""
    out, err = io.StringIO(), io.StringIO()
    signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(ALARM_SECONDS)
    failure = None
    status = None
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
            warnings.simplefilter("error")  # a numpy or matplotlib warning: a value that was not a number
            try:
                status = main(list(argv))
            except SystemExit as done:
                status = done.code
    except Hang:
        failure = f"hang: no end within {ALARM_SECONDS} s"
    except BaseException:  # noqa: B902 - anything at all is a failure of the tool
        failure = "traceback:\n" + traceback.format_exc()
    finally:
        signal.alarm(0)
    return status, out.getvalue(), err.getvalue(), failure


UNSAFE = re.compile(r"\b(nan|NaN|inf|Inf|Infinity|None)\b|\d{16,}")
MARKERS = re.compile(r"unavailable|left out")
LEFT_OUT = re.compile(r".*left out as unavailable.*")  # the warning that names what was NaN or infinite


# A line compare's summary wrapped (lockstep_reports.text_layout.wrap: the next lines indented two more), joined
# back here so that the warning that names what was NaN reads as one line.
WRAPPED = re.compile(r"\n  (?=\S)")


def unsafe_numbers(text):
    """What in an accepted file's output is not a number where a number belongs (the warning that says a
    value was NaN and left out aside)."""
    return sorted({match.group(0) for match in UNSAFE.finditer(LEFT_OUT.sub("", WRAPPED.sub(" ", text)))})


class Result:
    """What one run of a tool gave, with its path-free form for comparing with the unmutated file's."""

    def __init__(self, status, out, err, files, failure):
        self.status, self.out, self.err, self.files, self.failure = status, out, err, files, failure

    def key(self, path):
        def plain(text):
            return text.replace(path, "<FILE>")
        return (self.status, plain(self.out), plain(self.err),
                tuple(sorted((name, plain(text)) for name, text in self.files.items())))

    @functools.cached_property
    def shown_text(self):
        """What a reader sees: stdout, stderr and report.md (report.html holds the same sections around the
        figures' SVG; compare's JSON is checked on its own)."""
        return "\n".join([self.out, self.err] + [text for name, text in sorted(self.files.items())
                                                 if name.endswith(".md")])

    def json_problem(self):
        """compare's JSON must be JSON: no NaN or Infinity, which Python writes and JSON has not."""
        for name, text in self.files.items():
            if name.endswith(".json"):
                try:
                    json.loads(text, parse_constant=lambda constant: 1 / 0)
                except (ValueError, ZeroDivisionError) as error:
                    return f"{name} is not JSON: {error}"
        return None


def read_tree(directory):
    files = {}
    for root, _, names in os.walk(directory):
        for name in names:
            path = os.path.join(root, name)
            with open(path, encoding="utf-8") as stream:
                files[os.path.relpath(path, directory)] = stream.read()
    return files


class Bench:
    """The scratch directory of the cases: the mutated file, the unmutated one and the partner, and the
    places the tools write to."""

    def __init__(self, root):
        self.root = root
        for name in ("mutated", "unmutated", "partner", "json", "report"):
            os.makedirs(os.path.join(root, name))

    def write(self, where, name, data):
        path = os.path.join(self.root, where, name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as stream:
            stream.write(data if isinstance(data, bytes) else data.encode("utf-8"))
        return path

    def compare(self, first, second):
        target = os.path.join(self.root, "json", "compare.json")
        status, out, err, failure = run_tool(["compare", first, second, "--json", target])
        files = {}
        left = os.listdir(os.path.join(self.root, "json"))
        if os.path.exists(target):
            with open(target, encoding="utf-8") as stream:
                files["compare.json"] = stream.read()
            os.unlink(target)
        leftovers = [name for name in left if name != "compare.json"]
        return Result(status, out, err, files, failure), leftovers, "compare.json" in left

    def report(self, path):
        target = os.path.join(self.root, "report", "out")
        status, out, err, failure = run_tool(["report", path, "--out", target])
        files = read_tree(target) if os.path.isdir(target) else {}
        left = os.listdir(os.path.join(self.root, "report"))
        shutil.rmtree(target, ignore_errors=True)
        leftovers = [name for name in left if name != "out"]
        return Result(status, out, err, files, failure), leftovers, "out" in left


# ---------------------------------------------------------------- judging one run

def first_difference(result, expected, path):
    """Where two results part, for a failure's message."""
    for part, ours, theirs in zip(("status", "stdout", "stderr", "files"), result.key(path), expected.key(path)):
        if ours != theirs:
            if part == "files":
                ours, theirs = "\n".join(f"{n}: {t}" for n, t in ours), "\n".join(f"{n}: {t}" for n, t in theirs)
            if not isinstance(ours, str):
                return f"{part}: {ours!r} against {theirs!r}"
            for line_ours, line_theirs in zip(ours.splitlines() + [""], theirs.splitlines() + [""]):
                if line_ours != line_theirs:
                    return f"{part}: {line_ours[:160]!r} against {line_theirs[:160]!r}"
    return "no difference"


def judge(result, leftovers, wrote, unmutated, mutation, path):
    """(outcome, problem): outcome one of rejected, same, reported, other value, or "failure".
    unmutated() gives the unmutated file's result, made when first needed (a drawn report is slow)."""
    if result.failure:
        return "failure", result.failure
    if leftovers:
        return "failure", f"left behind: {leftovers}"
    unsafe = unsafe_numbers(result.shown_text) if result.status != 2 else []  # a rejection quotes the value
    if unsafe:
        return "failure", f"not a number in the output: {unsafe}"
    if result.json_problem():
        return "failure", result.json_problem()
    if result.status == 2:
        lines = result.err.splitlines()
        if len(lines) != 1 or not result.err.endswith("\n"):
            return "failure", f"exit 2 with {len(lines)} lines on stderr: {result.err!r}"
        problem = lines[0].split(path + ": ", 1)[1] if path + ": " in lines[0] else ""
        if len(problem) < 8:
            return "failure", f"exit 2 without naming the file and what is wrong: {lines[0]!r}"
        if result.out or wrote:
            return "failure", f"exit 2 but something was written (stdout {len(result.out)} chars, files {wrote})"
        outcome = "rejected"
        if mutation.kind in MUST_BE_SAME and result.key(path) != unmutated().key(path):
            return "failure", (f"a mutation the format allows gave {outcome}, not the unmutated file's result: "
                               + first_difference(result, unmutated(), path))
    elif result.status in (0, 1):
        expected = unmutated()
        if result.key(path) == expected.key(path):
            outcome = "same"
        elif len(MARKERS.findall(WRAPPED.sub(" ", result.shown_text))) > len(
                MARKERS.findall(WRAPPED.sub(" ", expected.shown_text))):
            outcome = "reported"
        elif mutation.other_value_allowed:
            outcome = "other value"
        else:
            return "failure", ("accepted with another result that says nothing about it (silently different): "
                               + first_difference(result, expected, path))
        if mutation.kind in MUST_BE_REJECTED and not (mutation.other_value_allowed and outcome == "other value"):
            return "failure", f"a file {mutation.kind} was accepted ({outcome}), not rejected"
        if mutation.kind in MUST_BE_SAME and outcome != "same":
            return "failure", (f"a mutation the format allows gave {outcome}, not the unmutated file's result: "
                               + first_difference(result, expected, path))
    else:
        return "failure", f"exit status {result.status!r}"
    return outcome, None


class Fuzz(unittest.TestCase):
    def test_a_thousand_bad_files_each_end_in_one_line_or_the_unmutated_result(self):
        started = time.monotonic()
        rng = random.Random(SEED)
        bases = load_bases()
        scratch = tempfile.mkdtemp(prefix="lockstep-fuzz-", dir="/dev/shm" if os.path.isdir("/dev/shm") else None)
        self.addCleanup(shutil.rmtree, scratch, ignore_errors=True)
        bench = Bench(scratch)
        keep = os.environ.get("LOCKSTEP_FUZZ_KEEP")
        log = open(os.environ["LOCKSTEP_FUZZ_LOG"], "w", encoding="utf-8") if "LOCKSTEP_FUZZ_LOG" in os.environ else None
        if log:
            self.addCleanup(log.close)

        base_sites = {name: Sites(base) for name, kind, base, _ in bases if kind == "json"}
        expected = {}  # base name -> the unmutated file's results
        paths = {}
        for name, kind, base, partner in bases:
            suffix = ".csv" if kind == "csv" else ".json"
            data = base if kind == "csv" else dumped(base)
            unmutated = bench.write("unmutated", os.path.join(name, "case" + suffix), data)  # one per base
            partner_path = bench.write("partner", f"partner-{name}.json",
                                       dumped(partner if partner is not None else bases[0][3]))
            with drawing_replaced():
                results = {"compare a": bench.compare(partner_path, unmutated)[0],
                           "compare b": bench.compare(unmutated, partner_path)[0],
                           "report": bench.report(unmutated)[0]}
            expected[name] = (results, unmutated)
            paths[name] = partner_path

        def reference(name, label):
            """The unmutated file's result, checked once; the drawn report made when a case first needs it."""
            results, unmutated = expected[name]
            if label not in results:
                results[label] = bench.report(unmutated)[0]
            result = results[label]
            self.assertIsNone(result.failure, f"{name}, unmutated, {label}: {result.failure}")
            self.assertEqual(unsafe_numbers(result.shown_text), [], f"{name}, unmutated, {label}")
            return result

        outcomes = {tool: Counter() for tool in ("compare", "report", "report (figures drawn)")}
        kinds = Counter()
        failures = []
        for case in range(CASES):
            name, kind, base, _ = bases[rng.randrange(len(bases))]
            kinds_of_base = CSV_KINDS if kind == "csv" else JSON_KINDS
            mutation_kind = kinds_of_base[case % len(kinds_of_base)]
            mutation = (mutate_csv(rng, mutation_kind, base) if kind == "csv"
                        else mutate_json(rng, mutation_kind, base_sites[name]))
            kinds[mutation.kind] += 1
            results, unmutated = expected[name]
            path = bench.write("mutated", os.path.basename(unmutated), mutation.data)
            partner = paths[name]
            runs = []
            with drawing_replaced():
                runs.append(("compare", "compare a", bench.compare(partner, path)))
                runs.append(("compare", "compare b", bench.compare(path, partner)))
                runs.append(("report", "report", bench.report(path)))
            if case % RENDER_EVERY == 0:
                runs.append(("report (figures drawn)", "rendered", bench.report(path)))
            for tool, label, (result, leftovers, wrote) in runs:
                def unmutated_result(label=label):
                    found = reference(name, label)
                    # The unmutated file's path stands for the mutated one's in the expected result.
                    return Result(found.status, found.out.replace(unmutated, path), found.err.replace(unmutated, path),
                                  found.files, found.failure)
                outcome, problem = judge(result, leftovers, wrote, unmutated_result, mutation, path)
                outcomes[tool][outcome] += 1
                if log:
                    log.write(f"{case}\t{mutation.kind}\t{mutation.where}\t{name}\t{label}\t{outcome}\t"
                              f"{result.err.splitlines()[0] if result.status == 2 else ''}\n")
                if problem:
                    failures.append(f"case {case} ({mutation.kind} at {mutation.where} of {name}), {label}: {problem}")
                    if keep:
                        os.makedirs(keep, exist_ok=True)
                        shutil.copy(path, os.path.join(keep, f"case-{case}-{os.path.basename(path)}"))
        elapsed = time.monotonic() - started

        print(f"\nfuzz: {CASES} mutated files (seed {SEED}) from {len(bases)} fixtures and samples, "
              f"{sum(sum(c.values()) for c in outcomes.values())} runs in {elapsed:.1f} s")
        print("fuzz: mutations: " + ", ".join(f"{kind} {count}" for kind, count in sorted(kinds.items())))
        for tool, counts in outcomes.items():
            print(f"fuzz: {tool}: " + ", ".join(f"{outcome} {count}" for outcome, count in sorted(counts.items())))
        if failures:
            print(f"fuzz: {len(failures)} failures, the first ones:")
            for failure in failures[:15]:
                print("  " + failure.replace("\n", "\n    "))
        self.assertGreaterEqual(CASES, 1000 if "LOCKSTEP_FUZZ_CASES" not in os.environ else 1)
        self.assertEqual(failures, [], f"{len(failures)} of the runs failed (the first ones are printed above)")


if __name__ == "__main__":
    unittest.main()
