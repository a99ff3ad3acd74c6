"""Command lines of the two tools. Exit status: 0 ok, 1 a regression beyond
--fail-above (compare), 2 bad input (one line on stderr naming the file and the
problem)."""
from __future__ import annotations

import argparse
import json
import sys

from .inputs import InputError, load_run_file, unique_labels

EXIT_OK, EXIT_REGRESSION, EXIT_USAGE = 0, 1, 2


class UsageError(Exception):
    pass


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a bad command line is one line on stderr (and exit 2), like every lockstep command."""

    def error(self, message):
        raise UsageError(f"{message} (`lockstep {self.prog.split()[-1]} --help` lists the options)")


def compare_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="lockstep compare",
        description="Compare Google Benchmark JSON results of `lockstep run` across runs and machines. "
                    "The first file is the baseline A; every other file is compared with it.")
    parser.add_argument("files", nargs="+", metavar="RESULT.json", help="two or more result files")
    parser.add_argument("--fail-above", type=float, metavar="PCT",
                        help="exit 1 when a matched entry is significantly slower than A by more than PCT percent")
    parser.add_argument("--alpha", type=float, default=0.05,
                        help="family-wise significance level after Holm's correction (default 0.05)")
    parser.add_argument("--time", choices=("real", "cpu"), default="real",
                        help="which time to compare (default: real, the wall-clock step time)")
    parser.add_argument("--json", metavar="FILE", help="also write the comparison as JSON to FILE")
    return parser


def report_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="lockstep report",
        description="Write a self-contained HTML page and a Markdown file with figures from lockstep's "
                    "result files: `lockstep run` JSON, `lockstep c2c --json`, `lockstep delay --json`, "
                    "`lockstep verify --csv` (recognised by their content).")
    parser.add_argument("files", nargs="+", metavar="RESULT", help="result files of any of the four kinds")
    parser.add_argument("--out", default="lockstep-report", metavar="DIR",
                        help="directory for report.html, report.md and figures/ (default: lockstep-report)")
    parser.add_argument("--title", default="lockstep report", help="the page's title")
    return parser


def run_compare(argv: list[str]) -> int:
    from . import compare

    options = compare_parser().parse_args(argv)
    if len(options.files) < 2:
        raise UsageError("compare needs at least two result files (the first is the baseline)")
    if options.fail_above is not None and options.fail_above < 0:
        raise UsageError(f"--fail-above {options.fail_above:g}: give a percentage of 0 or more")
    if not 0.0 < options.alpha < 1.0:
        raise UsageError(f"--alpha {options.alpha:g}: give a level between 0 and 1")
    labels = unique_labels(options.files)
    run_files = [load_run_file(path, label) for path, label in zip(options.files, labels)]
    comparisons = [compare.compare_pair(run_files[0], other, options.time, options.alpha) for other in run_files[1:]]
    sys.stdout.write(compare.render_text(run_files, comparisons, options.time))
    if options.json:
        write_comparison_json(options.json, comparisons)
    if options.fail_above is not None:
        failures = [(c, row) for c in comparisons for row in c.regressions_beyond(options.fail_above)]
        if failures:
            for comparison, row in failures:
                sys.stderr.write(f"lockstep compare: regression beyond {options.fail_above:g}%: "
                                 f"{row.key.display} is {(row.ratio - 1) * 100:.1f}% slower in "
                                 f"{comparison.contender.label} (Holm p {row.p_adjusted:.2g})\n")
            return EXIT_REGRESSION
    return EXIT_OK


def write_comparison_json(path: str, comparisons) -> None:
    import os
    import tempfile

    document = {"kind": "compare", "comparisons": []}
    for comparison in comparisons:
        document["comparisons"].append({
            "baseline": comparison.baseline.label, "contender": comparison.contender.label,
            "time": comparison.time_kind, "alpha": comparison.alpha, "correction": "holm",
            "geometric_mean": comparison.geometric_mean, "matched": len(comparison.rows),
            "rows": [{"name": row.key.display, "median_a_ns": row.median_a, "median_b_ns": row.median_b,
                      "ratio": row.ratio, "interval": list(row.interval) if row.interval else None,
                      "p": row.p_raw, "p_holm": row.p_adjusted, "verdict": row.verdict(comparison.alpha),
                      "counters": {k: list(v) for k, v in sorted(row.counters.items())}}
                     for row in comparison.rows],
            "added": [key.display for key in comparison.added],
            "removed": [key.display for key in comparison.removed],
            "errored": [{"name": key.display, "in": where, "message": message}
                        for key, where, message in comparison.errored],
            "warnings": comparison.warnings,
        })
    directory = os.path.dirname(os.path.abspath(path))
    handle, temporary = tempfile.mkstemp(prefix=".compare-", dir=directory)
    with os.fdopen(handle, "w", encoding="utf-8") as stream:
        json.dump(document, stream, indent=2, sort_keys=True)
        stream.write("\n")
    os.replace(temporary, path)


def run_report(argv: list[str]) -> int:
    from . import report

    options = report_parser().parse_args(argv)
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
    except (InputError, UsageError) as error:
        sys.stderr.write(f"lockstep {tool}: {error}\n")
        return EXIT_USAGE
    except BrokenPipeError:
        return EXIT_OK
