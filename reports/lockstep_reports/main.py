"""Command lines of the two tools. Exit status: 0 ok, 1 a regression beyond
--fail-above (compare), 2 bad input (one line on stderr naming the file and the
problem): an unusable result file, a bad option, or an output location that
cannot be written, which is checked before any work."""
from __future__ import annotations

import argparse
import json
import math
import os
import sys

from .inputs import InputError, RunFile, load_for_compare, unique_labels
from .output import OutputError, check_directory_target, check_file_target, write_file

EXIT_OK, EXIT_REGRESSION, EXIT_USAGE = 0, 1, 2


class UsageError(Exception):
    pass


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a bad command line is one line on stderr (and exit 2), like every lockstep command."""

    def error(self, message):
        raise UsageError(f"{message} (`lockstep {self.prog.split()[-1]} --help` lists the options)")


def percentage(text: str) -> float:
    """A percentage of 0 or more ("5", "2.5", "5%"); anything else is a one-line usage error."""
    stripped = text.strip()
    if stripped.endswith("%"):
        stripped = stripped[:-1].strip()
    try:
        value = float(stripped)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a percentage (give a number such as 5)") from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: give a finite percentage of 0 or more")
    return value


def tool_parser(tool: str, description: str, files_metavar: str, files_help: str) -> OneLineParser:
    parser = OneLineParser(prog=f"lockstep {tool}", description=description)
    parser.add_argument("files", nargs="+", metavar=files_metavar, help=files_help)
    return parser


def compare_parser() -> argparse.ArgumentParser:
    from .compare import DEFAULT_NOISE_PERCENT, NOISE_RATIONALE

    parser = tool_parser(
        "compare",
        "Compare Google Benchmark JSON results of `lockstep run` (or of `lockstep mpi`) across runs "
        "and machines. "
                    "The first file is the baseline A; every other file is compared with it. An entry is "
                    "slower or faster only when the whole exact 95% interval of its ratio lies beyond the noise "
                    "band, 'within noise' when it lies inside, 'unsure' across an edge; the Mann-Whitney p-values "
                    "are Benjamini-Hochberg adjusted (false discovery rate). When both files carry the pace trace, "
                    "every entry also gets a pace-aware verdict (within matching pace modes, or on the time "
                    "divided by the pace's c2c reading), and the headline counts what changed beyond the pace. "
                    "rk4/serial, c2c (by its one_way_ns counter), the MPI ping-pong and the overhead "
                    "pair are compared apart, as calibrations, and the context's calibrations say how far the "
                    "machine itself moved between the runs.",
        "RESULT.json", "two or more result files")
    parser.add_argument("--noise", type=percentage, default=DEFAULT_NOISE_PERCENT, metavar="PCT",
                        help=f"noise band in percent (default {DEFAULT_NOISE_PERCENT:g}): an entry is slower "
                             f"only when its whole interval of B/A lies above 1 + PCT/100, faster only when below "
                             f"1 / (1 + PCT/100), within noise when inside, unsure across an edge. Why "
                             f"{DEFAULT_NOISE_PERCENT:g}: {NOISE_RATIONALE}".replace("%", "%%"))
    parser.add_argument("--fail-above", type=percentage, metavar="PCT",
                        help="exit 1 when a matched combination is slower than A beyond the pace (its whole "
                             "interval above the noise band; pace-aware where both files carry the pace) by more "
                             "than PCT percent")
    parser.add_argument("--alpha", type=float, default=0.05,
                        help="false discovery rate of the Benjamini-Hochberg q-values shown and counted beside "
                             "the verdicts (default 0.05)")
    parser.add_argument("--time", choices=("real", "cpu"), default="real",
                        help="which time to compare (default: real, the wall-clock step time)")
    # --out, as in every lockstep command that writes a result; --json, its earlier name, still works.
    parser.add_argument("--out", "--json", dest="json", metavar="FILE",
                        help="also write the comparison as JSON to FILE (atomically; its directory must exist)")
    return parser


def report_parser() -> argparse.ArgumentParser:
    parser = tool_parser(
        "report",
        "Write a self-contained HTML page and a Markdown file with figures from lockstep's "
        "result files: `lockstep run` JSON, `lockstep c2c --json`, `lockstep delay --json`, "
        "`lockstep mpi --out`, `lockstep verify --csv` (recognised by their content).",
        "RESULT", "result files of any of the five kinds")
    parser.add_argument("--out", default="lockstep-report", metavar="DIR",
                        help="directory for report.html, report.md and figures/ (default: lockstep-report); its "
                             "parent must exist; an earlier report there is replaced whole, any other content "
                             "is refused")
    parser.add_argument("--title", default="lockstep report", help="the page's title")
    return parser


def run_compare(argv: list[str]) -> int:
    from . import compare

    options = compare_parser().parse_args(argv)
    if len(options.files) < 2:
        raise UsageError("compare needs at least two result files (the first is the baseline)")
    if not 0.0 < options.alpha < 1.0:
        raise UsageError(f"--alpha {options.alpha:g}: give a level between 0 and 1")
    if options.json:
        check_file_target(options.json)
        if os.path.exists(options.json) and any(os.path.exists(path) and os.path.samefile(path, options.json)
                                                for path in options.files):
            raise UsageError(f"--json {options.json} is one of the result files: give another file")
    labels = unique_labels(options.files)
    files = [load_for_compare(path, label) for path, label in zip(options.files, labels)]
    # `lockstep run` files are compared, the first against each later one; the other kinds (c2c, delay, ...)
    # only join the machine fingerprint.
    run_files = [f for f in files if isinstance(f, RunFile)]
    context_files = [f for f in files if not isinstance(f, RunFile)]
    comparisons = [compare.compare_pair(run_files[0], other, options.time, options.alpha, options.noise)
                   for other in run_files[1:]]
    text = compare.render_text(run_files, comparisons, options.time, context_files)
    if options.json:
        write_file(options.json, comparison_json(comparisons))
    sys.stdout.write(text)
    if options.fail_above is not None:
        failures = [(c, row) for c in comparisons for row in c.regressions_beyond(options.fail_above)]
        if failures:
            for comparison, row in failures:
                shown = row.pace if row.pace else row
                how = f"pace-aware, {row.pace.method}" if row.pace else "raw"
                q = f", BH q {row.p_adjusted:.2g}" if row.p_adjusted is not None else ""
                sys.stderr.write(f"lockstep compare: regression beyond {options.fail_above:g}%: "
                                 f"{row.key.display} is {(shown.ratio - 1) * 100:.1f}% slower in "
                                 f"{comparison.contender.label} ({how}: interval [{shown.interval[0]:.3f}, "
                                 f"{shown.interval[1]:.3f}] beyond the {options.noise:g}% noise band{q})\n")
            return EXIT_REGRESSION
    return EXIT_OK


def row_json(comparison, row) -> dict:
    return {"name": row.key.display, "measure": row.measure, "median_a_ns": row.median_a,
            "median_b_ns": row.median_b, "ratio": row.ratio,
            "interval": list(row.interval) if row.interval else None,
            "p": row.p_raw, "q_bh": row.p_adjusted, "verdict": comparison.verdict(row),
            "pace": None if row.pace is None else {
                "method": row.pace.method, "detail": row.pace.detail, "ratio": row.pace.ratio,
                "interval": list(row.pace.interval) if row.pace.interval else None,
                "repetitions": [row.pace.repetitions_a, row.pace.repetitions_b],
                "verdict": comparison.pace_verdict(row)},
            "verdict_beyond_pace": comparison.beyond_pace(row),
            "counters": {k: list(v) for k, v in sorted(row.counters.items())}}


def comparison_json(comparisons) -> str:
    document = {"kind": "compare", "comparisons": []}
    for comparison in comparisons:
        document["comparisons"].append({
            "baseline": comparison.baseline.label, "contender": comparison.contender.label,
            "time": comparison.time_kind, "alpha": comparison.alpha, "correction": "benjamini-hochberg",
            "interval": "exact distribution-free shift interval (Mann-Whitney U inverted on log time)",
            "noise_pct": comparison.noise_percent,
            "geometric_mean": comparison.geometric_mean, "matched": len(comparison.rows),
            "verdicts": comparison.verdict_counts(),
            "verdicts_beyond_pace": comparison.pace_verdict_counts(),
            "pace": ("unavailable" if comparison.different_modes is None
                     else "different modes" if comparison.different_modes else "same modes"),
            "rows": [row_json(comparison, row) for row in comparison.rows],
            "calibrations": [row_json(comparison, row) for row in comparison.calibrations],
            "calibration_moves": [{"name": name, "unit": unit, "a": before, "b": after, "change_pct": change}
                                  for name, unit, before, after, change in comparison.calibration_moves()],
            "accounting_overheads": [{"name": key.display, "a": ratio_a, "b": ratio_b}
                                     for key, ratio_a, ratio_b in comparison.accounting_overheads()],
            "added": [key.display for key in comparison.added],
            "removed": [key.display for key in comparison.removed],
            "errored": [{"name": key.display, "in": where, "message": message}
                        for key, where, message in comparison.errored],
            "warnings": comparison.warnings,
        })
    # allow_nan=False: inputs.py lets no NaN or infinity through to a figure; one here is a bug, not JSON.
    return json.dumps(document, indent=2, sort_keys=True, allow_nan=False) + "\n"


def run_report(argv: list[str]) -> int:
    options = report_parser().parse_args(argv)
    check_directory_target(options.out)
    from . import report  # matplotlib and jinja2: a second or more, so only once the output can be written

    written = report.write_report(options.files, options.out, options.title)
    for path in written:
        sys.stderr.write(f"lockstep report: wrote {path}\n")
    return EXIT_OK


def main(argv: list[str]) -> int:
    tools = {"compare": run_compare, "report": run_report}
    if not argv or argv[0] not in tools:
        sys.stderr.write("lockstep reports: the first argument must be `compare` or `report`\n")
        return EXIT_USAGE
    tool = argv[0]
    try:
        return tools[tool](argv[1:])
    except (InputError, OutputError, UsageError) as error:
        sys.stderr.write(f"lockstep {tool}: {error}\n")
        return EXIT_USAGE
    except ModuleNotFoundError as error:
        sys.stderr.write(f"lockstep {tool}: needs the Python module {error.name} from Debian "
                         f"(`scripts/setup.sh` installs it; run by /usr/bin/python3, not a pyenv python3)\n")
        return EXIT_USAGE
    except BrokenPipeError:
        return EXIT_OK
