"""What each lockstep command writes against its kind's schema (docs/schemas/<kind>.schema.json).

Runs one kind's commands with the smallest settings that still write every shape of the file (delay: plain,
--compare-pinning, --per-cpu, --find-period with and without an answer; run: plain, --scaling and --crossover; verify:
two masses and a chain; topology: this machine and a synthetic one; mpi: two ranks, and two ranks that must share
a CPU), and checks each file as a writer's test does: strictly, so a key
a writer adds or misspells without its schema fails here (reports/lockstep_reports/read/schemas.py, strict=True), a
top-level lockstep_* section as well. The shapes of a kind together must write every section its schema names
(a section with an older name a reader still accepts under either name: EARLIER_NAMES), so that no section goes
unchecked. A run file's entries that carry their spec (lockstep_entry) must each name the benchmark their spec
is: the key reports/lockstep_reports/common/names.py makes from the spec equals the one it parses from the name, the
one place where the reader and the writer's name are held together (the reader never parses a typed file's names).
The reader checks the same schemas when it reads a file (reports/lockstep_reports/read/inputs.py, read_document).

    check_result_schemas.py --lockstep BIN KIND [--keep DIR]

Exit 0: every file fits; 1: a command failed or a file does not fit (one line each on stdout).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "reports"))
from lockstep_reports.common.names import entry_spec, parse_name  # noqa: E402
from lockstep_reports.read import schemas  # noqa: E402
from lockstep_reports.read.run_checks import base_name  # noqa: E402

# kind -> [(shape, arguments before --out, arguments after it, extra environment)]
SHAPES = {
    "run": [
        ("quick", ["run", "--quick", "--repetitions", "1", "--threads", "2", "--pin", "compact", "--pairs", "2"],
         ["--", "--benchmark_min_time=0.01"], {}),
        ("scaling", ["run", "--quick", "--scaling", "--repetitions", "1", "--sync", "std_barrier",
                     "--layout", "padded64", "--pairs", "0"], ["--", "--benchmark_min_time=0.01"], {}),
        ("crossover", ["run", "--quick", "--repetitions", "1", "--threads", "2", "--pin", "compact",
                       "--sync", "mailbox,std_barrier", "--layout", "per_thread", "--pairs", "2", "--crossover",
                       "--crossover-max-masses", "16", "--crossover-budget", "5s", "--crossover-pairs", "4"],
         ["--", "--benchmark_min_time=0.01"], {}),
    ],
    "c2c": [("plain", ["c2c", "--samples", "20", "--rounds", "5", "--max-pairs", "4"], [], {})],
    "delay": [
        ("plain", ["delay", "--period", "1ms", "--duration", "50ms"], [], {}),
        ("compare-pinning", ["delay", "--period", "1ms", "--duration", "50ms", "--compare-pinning"], [], {}),
        ("per-cpu", ["delay", "--period", "1ms", "--duration", "50ms", "--per-cpu"], [], {}),
        ("find-period", ["delay", "--period", "1ms", "--find-period", "--miss-rate", "0.1",
                         "--search-budget", "2s"], [], {}),
        # A search whose budget cannot show the rate: no answer, no confirming run (figure5 empty).
        ("find-period, no answer", ["delay", "--period", "30us", "--find-period", "--miss-rate", "0.0001",
                                    "--search-budget", "1s"], [], {}),
    ],
    "falseshare": [("plain", ["falseshare", "--strides", "8,64", "--window", "5ms", "--repeats", "2"], [], {})],
    "migrate": [("plain", ["migrate", "--repeats", "5", "--bytes", "4096"], [], {})],
    "mpi": [("two ranks", ["mpi", "--ranks", "2", "--steps", "50", "--warmup", "5", "--rounds", "1",
                           "--pingpong", "100"], [], {}),
            # Both ranks given CPU 0 only: the placement's crowded machine and its remedy.
            ("two ranks on one CPU", ["mpi", "--ranks", "2", "--steps", "50", "--warmup", "5", "--rounds", "1",
                                      "--pingpong", "100"], [], {})],
    "verify": [("two masses", ["verify"], [], {}), ("chain", ["verify", "--masses", "3"], [], {})],
    "topology": [
        ("this machine", ["topology"], [], {}),
        ("synthetic", ["topology"], [], {"HWLOC_SYNTHETIC": "pack:2 l3:2 l2:1 core:2 pu:2"}),
    ],
}


# A section's earlier name, which its schema still names for the files written before it -> its name now: either
# name written counts as the section written.
EARLIER_NAMES = {"run": {"lockstep_headline": "lockstep_answer"}}

# (kind, shape) -> the command lockstep runs under (taskset -c 0: the process may run on CPU 0 only).
WRAPPERS = {("mpi", "two ranks on one CPU"): ["taskset", "-c", "0"]}


def name_problem(document) -> str | None:
    """The first benchmark entry whose lockstep_entry is not the benchmark its name names; None when all agree."""
    for index, raw in enumerate(document.get("benchmarks", []) if isinstance(document, dict) else []):
        if "lockstep_entry" in raw and entry_spec(raw["lockstep_entry"]).key != parse_name(base_name(raw)):
            return (f"benchmarks[{index}].lockstep_entry: is not the entry its name {raw['name']!r} names "
                    f"({entry_spec(raw['lockstep_entry']).key.display})")
    return None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lockstep", required=True)
    parser.add_argument("kind", choices=sorted(SHAPES))
    parser.add_argument("--keep", help="keep the written files in this directory")
    options = parser.parse_args()

    failures = 0
    written = set()
    with tempfile.TemporaryDirectory(prefix="lockstep-schema-") as scratch:
        directory = options.keep or scratch
        for index, (shape, before, after, environment) in enumerate(SHAPES[options.kind]):
            out = os.path.join(directory, f"{options.kind}-{index}.json")
            command = WRAPPERS.get((options.kind, shape), []) + [options.lockstep] + before + ["--out", out] + after
            done = subprocess.run(command, env={**os.environ, **environment}, stdout=subprocess.DEVNULL,
                                  stderr=subprocess.PIPE, text=True, timeout=300)
            if done.returncode != 0:
                last = (done.stderr.strip().splitlines() or ["(nothing on stderr)"])[-1]
                print(f"FAIL {options.kind} ({shape}): `{' '.join(command[1:])}` exited {done.returncode}: {last}")
                failures += 1
                continue
            with open(out, encoding="utf-8") as stream:
                document = json.load(stream)
            written |= {key for key in document if key.startswith(schemas.SECTION_PREFIX)}
            problem = schemas.problem(document, options.kind, strict=True) or name_problem(document)
            if problem is None:
                print(f"ok   {options.kind} ({shape}): fits {schemas.schema_path(options.kind).name}")
            else:
                print(f"FAIL {options.kind} ({shape}): {out}: {problem} "
                      f"(docs/schemas/{options.kind}.schema.json)")
                failures += 1
    now = EARLIER_NAMES.get(options.kind, {})
    named = {now.get(key, key) for key in json.loads(schemas.schema_path(options.kind).read_text(encoding="utf-8"))[
        "properties"] if key.startswith(schemas.SECTION_PREFIX)}
    unwritten = sorted(named - {now.get(key, key) for key in written})
    if unwritten and not failures:
        print(f"FAIL {options.kind}: no shape writes {', '.join(unwritten)}, which "
              f"docs/schemas/{options.kind}.schema.json names: add a shape that does")
        failures += 1
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
