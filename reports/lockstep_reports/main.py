"""Command lines of the two tools. Exit status: 0 ok, 1 a regression beyond
--fail-above (compare), 2 bad input (one line on stderr naming the file and the
problem): an unusable result file, a bad option, or an output location that
cannot be written, which is checked before any work."""
from __future__ import annotations

import argparse
import dataclasses
import difflib
import json
import math
import os
import sys

from .common.output import OutputError, check_directory_target, check_file_target, write_file
from .compare import compare_text, planner
from .compare.comparability import withheld_text
from .compare.comparison import DEFAULT_NOISE_PERCENT, NOISE_RATIONALE
from .compare.replicated import compare_sides, merged_side
from .read.inputs import InputError, in_run_order, load_for_compare, side_paths, unique_labels
from .read.run_file import RunFile

EXIT_OK, EXIT_REGRESSION, EXIT_USAGE = 0, 1, 2


class UsageError(Exception):
    pass


class ParagraphFormatter(argparse.HelpFormatter):
    """argparse's help in the style of every other lockstep command's (CLI11's): options in a column at 30, an
    option's spellings joined by a comma; the description's and the epilog's paragraphs (split at blank lines)
    each filled to the width, and lines that start with two spaces (examples) kept as they are."""

    def __init__(self, prog, **keywords):
        keywords.setdefault("max_help_position", 30)
        super().__init__(prog, **keywords)

    def _format_action_invocation(self, action):
        if not action.option_strings or action.nargs == 0:
            return ",".join(action.option_strings) or super()._format_action_invocation(action)
        metavar = self._format_args(action, self._get_default_metavar_for_optional(action))
        return ",".join(action.option_strings) + " " + metavar

    def _fill_text(self, text, width, indent):
        paragraphs = []
        for paragraph in text.split("\n\n"):
            lines = paragraph.split("\n")
            if any(line.startswith("  ") for line in lines):
                paragraphs.append("\n".join(indent + line for line in lines))
            else:
                paragraphs.append(super()._fill_text(" ".join(lines), width, indent))
        return "\n\n".join(paragraphs)


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a bad command line is one line on stderr (and exit 2), like every lockstep command; an
    option is written whole (no abbreviations), and a mistyped one gets the closest option named."""

    def __init__(self, **keywords):
        super().__init__(allow_abbrev=False, formatter_class=ParagraphFormatter, add_help=False, **keywords)
        self._positionals.title = "Positionals"
        self._optionals.title = "Options"
        self.add_argument("-h", "--help", action="help", help="Print this help message and exit")

    def format_help(self):
        """As the other commands print theirs: the description's first paragraph, the usage, the positionals and
        the options, then the rest of the description and the epilog."""
        formatter = self._get_formatter()
        first, _, rest = (self.description or "").partition("\n\n")
        formatter.add_text(first)
        formatter.add_usage(self.usage, self._actions, self._mutually_exclusive_groups, prefix="Usage: ")
        for group in self._action_groups:
            formatter.start_section(group.title)
            formatter.add_text(group.description)
            formatter.add_arguments(group._group_actions)
            formatter.end_section()
        formatter.add_text(rest)
        formatter.add_text(self.epilog)
        return formatter.format_help()

    def error(self, message):
        # "--time: unknown value ..." as the other commands word it, not argparse's "argument --time: ..."
        message = message.removeprefix("argument ")
        if "did you mean" in message or "(valid: " in message:  # it says what to give already
            raise UsageError(message)
        raise UsageError(f"{message} (`lockstep {self.prog.split()[-1]} --help` lists the options)")

    def parse_args(self, args=None, namespace=None):
        self.check_options(args or [])
        return super().parse_args(args, namespace)

    def check_options(self, argv: list[str]) -> None:
        """Every word that looks like an option names one of this tool's: else one line, the closest option
        suggested ("unknown option --nosie; did you mean --noise?")."""
        takes_value = {name for action in self._actions if action.option_strings and action.nargs != 0
                       for name in action.option_strings}
        known = sorted(self._option_string_actions)
        expecting_value = False
        for word in argv:
            if expecting_value:
                expecting_value = False
                continue
            if word == "--":
                return
            if not word.startswith("-") or word == "-" or _is_number(word):
                continue
            name = word.split("=", 1)[0]
            if name in self._option_string_actions:
                expecting_value = name in takes_value and "=" not in word
                continue
            close = difflib.get_close_matches(name, [option for option in known if option.startswith("--")], n=1,
                                              cutoff=0.6)
            hint = f"; did you mean {close[0]}?" if close else f" (`{self.prog} --help` lists the options)"
            raise UsageError(f"unknown option {name}{hint}")


def _is_number(word: str) -> bool:
    try:
        float(word.rstrip("%"))
    except ValueError:
        return False
    return True


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


def one_of(*names: str):
    """A value from a list of names; anything else is a one-line usage error that suggests the closest name, as
    every other lockstep command's lists do ("unknown value 'rael' (did you mean real?)")."""
    def check(text: str) -> str:
        if text in names:
            return text
        close = difflib.get_close_matches(text, names, n=1, cutoff=0.6)
        hint = f"did you mean {close[0]}?" if close else "valid: " + ", ".join(names)
        raise argparse.ArgumentTypeError(f"unknown value {text!r} ({hint})")
    return check


BAD_INPUT = ("2 bad input: an unusable file, a bad option, or an output that cannot be written (one line on stderr "
             "naming it, nothing written)")


def tool_parser(tool: str, description: str, files_metavar: str, files_help: str, epilog: str) -> OneLineParser:
    parser = OneLineParser(prog=f"lockstep {tool}", description=description, epilog=epilog,
                           usage=f"%(prog)s [OPTIONS] {files_metavar} [{files_metavar} ...]")
    parser.add_argument("files", nargs="+", metavar=files_metavar, help=files_help)
    return parser


def compare_parser() -> argparse.ArgumentParser:
    parser = tool_parser(
        "compare",
        "Compare the results of `lockstep run` (or of `lockstep mpi --out`) across runs and machines.\n\n"
        "The first file is the baseline A; every other file is compared with it, entry by entry (matched by "
        "name). An entry is slower or faster only when the whole exact 95% interval of its ratio B/A lies beyond "
        "the noise band, 'within noise' when it lies inside, 'unsure' across an edge; the Mann-Whitney p-values "
        "are Benjamini-Hochberg adjusted (false discovery rate). When both files carry the pace trace, every "
        "entry also gets a pace-aware verdict (within matching pace modes, or on the time divided by the pace's "
        "c2c reading), and the summary counts what changed beyond the pace. rk4/serial, c2c (by its one_way_ns "
        "counter), the MPI ping-pong and the overhead pair are compared apart, as calibrations, and the "
        "context's calibrations say how far the machine itself moved between the runs. Files of `lockstep c2c`, "
        "`delay`, `falseshare`, `migrate` and `verify --out` join the machine fingerprint only.\n\n"
        "By default it prints about 40 lines: the machines' differences, then per comparison the answer first "
        "(the geometric mean of B/A over every matched combination with its 95% interval and verdict, and the "
        "groups - per primitive, thread count, placement - that are slower or faster), the calibrations' "
        "move, the pace, the verdict counts, the smallest change the unsure entries could have shown, and the "
        "entries that changed beyond the pace (slower and faster, largest first), what was added, removed or "
        "errored. --all prints every entry with its counters, the "
        "calibrations, the whole context and the across-machines tables. The same file twice (or two files "
        "with the same bytes) is one line saying so.",
        "RESULT.json", "two or more sides, the baseline first: each a result file, a directory of runs (`lockstep "
                       "run --runs K --out DIR`: its runs are the side's replicates, and the intervals come from the "
                       "variance between them; with 4 or more a side each side's halves are also compared, A against "
                       "A) or files joined by commas (A1.json,A2.json); with --plan, the pilot",
        "examples:\n  lockstep compare results/a.json results/b.json\n"
        "  lockstep compare a.json b.json --noise 2% --fail-above 10 --out comparison.json\n"
        "  lockstep compare results/before/ results/after/\n"
        "  lockstep compare --plan results/pilot/ --detect 15%\n\n"
        "exit status: 0 done; 1 with --fail-above, a combination or a group slower beyond the limit; " + BAD_INPUT)
    parser.add_argument("--noise", type=percentage, default=DEFAULT_NOISE_PERCENT, metavar="PCT",
                        help=f"noise band in percent, the %% sign optional (5 or 5%%; default "
                             f"{DEFAULT_NOISE_PERCENT:g}): an entry is slower only when its whole interval of B/A "
                             f"lies above 1 + PCT/100, faster only when below 1 / (1 + PCT/100), within noise when "
                             f"inside, unsure across an edge. Why {DEFAULT_NOISE_PERCENT:g}: "
                             + NOISE_RATIONALE.replace("%", "%%"))
    parser.add_argument("--fail-above", type=percentage, metavar="PCT",
                        help="exit 1 when a matched combination is slower than A beyond the pace (its whole "
                             "interval above the noise band; pace-aware where both files carry the pace) by more "
                             "than PCT percent (5 or 5%%), or a group is (the geometric mean of B/A over every "
                             "combination, or per primitive, thread count or placement: its whole interval above "
                             "the band, the mean above PCT); each such entry and group is named on stderr")
    parser.add_argument("--alpha", type=float, default=0.05, metavar="LEVEL",
                        help="false discovery rate of the Benjamini-Hochberg q-values shown and counted beside "
                             "the verdicts, between 0 and 1 (default 0.05)")
    parser.add_argument("--time", type=one_of("real", "cpu"), default="real", metavar="{real,cpu}",
                        help="which time to compare: real, the wall-clock step time (default), or cpu, participant "
                             "0's CPU time per step")
    parser.add_argument("--all", action="store_true", dest="everything",
                        help="print everything: every matched entry with its interval, q, verdicts and counters, "
                             "the calibrations, the whole context of every file and the across-machines tables "
                             "(the default is the summary, about 40 lines)")
    parser.add_argument("--plan", action="store_true",
                        help="plan instead of compare: the files (or directories of runs) are a pilot; print, per "
                             "thread count and overall, the smallest uniform change a plan of runs x repetitions "
                             "sees in 80%% of the entries and on their geometric mean (at --noise and 95%% "
                             "intervals), from the pilot's variance between and within runs")
    parser.add_argument("--detect", type=percentage, metavar="PCT",
                        help="with --plan: the cheapest plan (runs a side x repetitions, Kalibera and Jones's "
                             "allocation) that sees a uniform change of PCT in 80%% of the entries, and its time on "
                             "the pilot's machine; with --pilot: the change the plan was made for")
    parser.add_argument("--pilot", metavar="PILOT",
                        help="sides of several runs only: the pilot their plan came from (a directory of runs, or "
                             "files joined by commas); compare says whether the sides' runs differed more than the "
                             "plan assumed, and if so what plan would see the change (--detect, else what the pilot's "
                             "plan said these sides would see) with their spread")
    # --out, as in every lockstep command that writes a result; --json, its earlier name, still works.
    parser.add_argument("--out", "--json", dest="json", metavar="FILE",
                        help="also write the whole comparison as JSON to FILE (atomically; its directory must "
                             "exist; not one of the inputs)")
    return parser


def report_parser() -> argparse.ArgumentParser:
    parser = tool_parser(
        "report",
        "Write a self-contained HTML page (report.html), the same as Markdown (report.md) and every figure as "
        "SVG (figures/) from lockstep's result files, recognised by their content: the JSON of `lockstep run` "
        "(results/<host>-<time>.json by default) and of `lockstep mpi --out`, `lockstep c2c --out`, "
        "`lockstep delay --out`, and the trajectory of `lockstep verify --csv`.\n\n"
        "The page leads with each run's answer (the lines `lockstep run` printed last, verbatim) and where the "
        "rest is; then one section per result, each opened by a click (the first ones open): step time per "
        "primitive and layout, each primitive against the best other, false-sharing and migration penalties, "
        "the pace, every paired ratio, the fastest combinations, core-to-core latency, the paced delay, the "
        "trajectory, the paper's values; the machines' context last.",
        "RESULT", "result files of any of the five kinds",
        "example:\n  lockstep report results/host-20260101T120000Z.json --out host-report\n\n"
        "exit status: 0 done; " + BAD_INPUT)
    parser.add_argument("--out", default="lockstep-report", metavar="DIR",
                        help="directory for report.html, report.md and figures/ (default: lockstep-report); its "
                             "parent must exist; an earlier report there is replaced whole, any other content "
                             "is refused")
    parser.add_argument("--title", default="lockstep report", help="the page's title (default: lockstep report)")
    return parser


def run_compare(argv: list[str]) -> int:
    options = compare_parser().parse_args(argv)
    if options.detect is not None and not (options.plan or options.pilot):
        raise UsageError("--detect goes with --plan (the change a plan should see) or --pilot")
    if options.pilot and options.plan:
        raise UsageError("--pilot goes with a comparison of runs, not with --plan (whose files are the pilot)")
    if options.plan:
        return run_planner(options)
    if len(options.files) < 2:
        raise UsageError("compare needs at least two result files (the first is the baseline)")
    if not 0.0 < options.alpha < 1.0:
        raise UsageError(f"--alpha {options.alpha:g}: give a level between 0 and 1")
    if options.json:
        check_file_target(options.json)
        if os.path.exists(options.json) and any(os.path.exists(path) and os.path.samefile(path, options.json)
                                                for path in options.files):
            raise UsageError(f"{typed_option(argv, ('--out', '--json'))} {options.json} is one of the result "
                             f"files: give another file")
    files = load_sides(options.files)
    # `lockstep run` files are compared, the first against each later one; the other kinds (c2c, delay, ...)
    # only join the machine fingerprint.
    run_files = [f for f in files if isinstance(f, RunFile)]
    context_files = [f for f in files if not isinstance(f, RunFile)]
    singles = [side_paths(argument) for argument in options.files]
    identical = same_bytes([paths[0] for paths in singles]) if all(len(p) == 1 for p in singles) else ""
    if identical and not options.json:
        sys.stdout.write(identical)
        return EXIT_OK
    comparisons = [compare_sides(run_files[0], other, options.time, options.alpha, options.noise)
                   for other in run_files[1:]]
    if options.pilot:
        check_plans(comparisons, options)
    if options.json:
        write_file(options.json, comparison_json(comparisons))
    if identical:
        sys.stdout.write(identical)
        return EXIT_OK
    sys.stdout.write(compare_text.render_text(run_files, comparisons, options.time, context_files, options.everything))
    if options.fail_above is not None:
        failures = [(c, row) for c in comparisons for row in c.regressions_beyond(options.fail_above)]
        groups = [(c, aggregate) for c in comparisons for aggregate in c.failed_groups(options.fail_above)]
        for comparison, aggregate in groups:
            what = "every matched combination" if aggregate.group == "all" else f"the group {aggregate.group}"
            sys.stderr.write(f"lockstep compare: regression beyond {options.fail_above:g}%: {what} "
                             f"({aggregate.entries} entries) is {(aggregate.ratio - 1) * 100:.1f}% slower in "
                             f"{comparison.contender.label} (geometric mean of B/A "
                             f"{compare_text.aggregate_text(comparison, aggregate)}, beyond the {options.noise:g}% "
                             f"noise band)\n")
        if groups and not failures:
            return EXIT_REGRESSION
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


def load_sides(arguments: list[str]) -> list:
    """Each argument one side: a file (load_for_compare), or several runs (a directory of `lockstep run --runs K`,
    or files joined by commas) merged into one side (replicated.merged_side) in the order they ran (in_run_order:
    by the run index in each context, else by file name)."""
    sides = []
    for argument, label in zip(arguments, unique_labels([os.path.normpath(a) for a in arguments])):
        paths = side_paths(argument)
        if len(paths) == 1:
            sides.append(load_for_compare(paths[0], label))
            continue
        runs = [load_for_compare(path, f"{label}/{os.path.basename(path)}") for path in paths]
        if not all(isinstance(run, RunFile) for run in runs):
            raise UsageError(f"{argument}: a side of several runs takes `lockstep run` files only")
        sides.append(merged_side(in_run_order(runs), label, argument))
    return sides


def pilot_runs(arguments: list[str]) -> list[RunFile]:
    """A pilot's runs, in the order they ran: each argument a file, a directory of runs or files joined by commas."""
    runs = []
    for argument in arguments:
        for path in side_paths(argument):
            found = load_for_compare(path, path)
            if not isinstance(found, RunFile):
                raise UsageError(f"{path}: a pilot is a `lockstep run` file (or a directory of them)")
            runs.append(found)
    return in_run_order(runs)


def check_plans(comparisons: list, options) -> None:
    """--pilot: each comparison of runs gets the plan checked after the fact (planner.check_plan)."""
    files = pilot_runs([options.pilot])
    if not any(comparison.replicated for comparison in comparisons):
        raise UsageError("--pilot: the sides hold one run each; a plan is checked on sides of several runs")
    for comparison in comparisons:
        if comparison.replicated is not None:
            comparison.replicated.plan_check = planner.check_plan(comparison, files, options.pilot, options.time,
                                                                  options.detect)


def run_planner(options) -> int:
    """--plan: the pilot's components, what its plan sees, and with --detect the cheapest plan that sees it."""
    sys.stdout.write(planner.plan_text(pilot_runs(options.files), options.time, options.noise, options.detect,
                                       " ".join(options.files)))
    return EXIT_OK


def typed_option(argv: list[str], spellings: tuple[str, ...]) -> str:
    """Which of an option's spellings the user typed (the last given wins, as in argparse): messages name the
    option as it was typed. The first spelling when none is in argv."""
    typed = spellings[0]
    for word in argv:
        if word == "--":
            break
        name = word.split("=", 1)[0]
        if name in spellings:
            typed = name
    return typed


def same_bytes(paths: list[str]) -> str:
    """One line when every file holds the same bytes (the same file given twice, or a copy): nothing can have
    changed, so nothing is compared. "" otherwise."""
    contents = set()
    for path in paths:
        with open(path, "rb") as stream:  # each was read whole a moment ago
            contents.add(stream.read())
        if len(contents) > 1:
            return ""
    names = " and ".join(dict.fromkeys(paths))
    what = "is the same file given twice" if len(set(paths)) == 1 else "are identical (the same bytes)"
    return f"lockstep compare: {names} {what}: nothing changed, nothing to compare\n"


def row_json(comparison, row) -> dict:
    return {"name": row.key.display, "measure": row.measure, "median_a_ns": row.median_a,
            "median_b_ns": row.median_b, "ratio": row.ratio,
            "interval": list(row.interval) if row.interval else None,
            "p": row.p_raw, "q_bh": row.p_adjusted, "verdict": comparison.verdict(row),
            "collapsed": row.collapsed, "detectable_pct": row.detectable(comparison.noise_percent),
            "pace": None if row.pace is None else {
                "method": row.pace.method, "detail": row.pace.detail, "ratio": row.pace.ratio,
                "interval": list(row.pace.interval) if row.pace.interval else None,
                "repetitions": [row.pace.repetitions_a, row.pace.repetitions_b],
                "interval_rule": "pooled" if row.pace.pooled else "exact",
                "verdict": comparison.pace_verdict(row)},
            "verdict_beyond_pace": comparison.beyond_pace(row),
            "counters": {k: list(v) for k, v in sorted(row.counters.items())}}


def replicates_json(replicated) -> dict | None:
    """What the runs of both sides gave (comparison.Replicated): the runs a side, the power, A against A per split;
    None with one run a side."""
    if replicated is None:
        return None
    splits = {}
    for split in dict.fromkeys(check.split for check in replicated.against_itself):
        changed, compared = replicated.total(split)
        splits[split] = {"changed": changed, "compared": compared,
                         "sides": [{"changed": c.changed, "compared": c.compared, "runs": list(c.runs)}
                                   for c in replicated.split(split)]}
    return {"runs": [replicated.runs_a, replicated.runs_b], "entries_power_pct": replicated.entries_power,
            "aggregate_power_pct": replicated.aggregate_power, "against_itself": splits,
            "pace": pace_json(replicated.pace),
            "plan_check": None if replicated.plan_check is None else dataclasses.asdict(replicated.plan_check)}


def pace_json(pace) -> dict | None:
    """The pace sides of several runs were compared in (comparison.PaceAcrossRuns); None without a pace trace."""
    if pace is None:
        return None
    return {"reading": pace.reading, "reference_ns": pace.reference_ns,
            "sides": [{"runs": side.runs, "runs_in_pace": side.runs_in_pace, "share": side.share,
                       "spread_every_pace": side.every_pace, "spread_one_pace": side.one_pace,
                       "between": side.between, "within": side.within, "explained": side.explained}
                      for side in pace.sides],
            "entries_one_pace": pace.entries_one_pace, "entries_every_pace": pace.entries_every_pace,
            "missing": [{"pace_ns": value, "lacking": side, "runs_holding": holding}
                        for value, side, holding in pace.missing]}


def comparison_json(comparisons) -> str:
    document = {"kind": "compare", "comparisons": []}
    for comparison in comparisons:
        document["comparisons"].append({
            "baseline": comparison.baseline.label, "contender": comparison.contender.label,
            "time": comparison.time_kind, "alpha": comparison.alpha, "correction": "benjamini-hochberg",
            "interval": "exact distribution-free shift interval (Mann-Whitney U inverted on log time)",
            "noise_pct": comparison.noise_percent,
            "geometric_mean": comparison.geometric_mean, "matched": len(comparison.rows),
            "aggregates": [{"group": a.group, "entries": a.entries, "geometric_mean": a.ratio,
                            "interval": list(a.interval) if a.interval else None, "verdict": a.verdict,
                            "detectable_pct": a.detectable(comparison.noise_percent)}
                           for a in comparison.aggregates()],
            "drift": comparison.drift, "pooled_entries": comparison.pooled_entries,
            "replicates": replicates_json(comparison.replicated),
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
            "warnings": comparison.warnings + (["no aggregate verdict: " + withheld_text(
                [(run_file.label, reason) for run_file, reason in comparison.unoptimised_sides()])]
                if comparison.withheld else []),
        })
    # allow_nan=False: the readers let no NaN or infinity through to a figure; one here is a bug, not JSON.
    return json.dumps(document, indent=2, sort_keys=True, allow_nan=False) + "\n"


def run_report(argv: list[str]) -> int:
    options = report_parser().parse_args(argv)
    check_directory_target(options.out)
    from .report import report  # matplotlib and jinja2: a second or more, so only once the output can be written

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
