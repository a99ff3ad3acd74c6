"""compare's text: the summary (render_summary, about 40 lines within text_layout.WIDTH columns: what makes the
files incomparable first, and across machines each machine's answer side by side) and everything (render_text,
--all), from the comparisons compare.compare_pair made, the findings of comparability.py, the answers of
machine_answers.py and the tables across machines (normalisation.py)."""
from __future__ import annotations

import math

from ..analysis.normalisation import fingerprint, layout_effects, normalised, rank_tables, rk4_keys, same_machine
from ..analysis.run_analysis import sharing_layout
from ..common import statistics
from ..common.fields import C2C_COUNTER, COUNTERS_SHOWN, FINGERPRINT_KEYS, MACHINE_KEYS, UNAVAILABLE
from ..common.formatting import format_ns, format_number
from ..common.names import BenchmarkKey
from ..common.text_layout import WIDTH, table, wrapped
from ..read.run_file import RunFile
from .comparability import build_difference, findings, unoptimised, withheld_text
from .comparison import (ALTERNATE, COLLAPSED, DEFAULT_NOISE_PERCENT, DRIFT_SHOWN_ABOVE, IN_TIME_ORDER,
                         MIN_AGGREGATE_ENTRIES, NOISE_RATIONALE, VERDICTS, Aggregate, Comparison, PaceAware, Row)
from .machine_answers import answer_lines, crossover_lines, difference_lines
from .mpi_context import mpi_difference_lines
from .planner import plan_check_line
from .pace_statistics import (MIN_IN_MODE, MODE_TOLERANCE, PACE_MATCHING_MODES, PACE_NORMALISED, PACE_ONE_MODE,
                              PACE_ONE_STATE, matching_modes)
from .replicated import BETWEEN_RUNS, ONE_PACE, one_run_power
from .run_pace import MIN_RUNS

def mode_text(mode) -> str:
    value = f"c2c {mode.c2c_ns:.0f} ns" if mode.c2c_ns is not None else f"serial {mode.serial_ns:.1f} ns"
    return f"{value} ({mode.share * 100:.0f} %)"


def _pace_figure(reading: str, value: float) -> str:
    return f"c2c about {value:.0f} ns" if reading == "c2c_ns" else f"a serial step of about {value:.1f} ns"


def _spread_words(side) -> str:
    if side.every_pace is None or side.one_pace is None:
        return UNAVAILABLE
    return f"{side.every_pace * 100:.1f} % -> {side.one_pace * 100:.1f} %"


def runs_pace_lines(comparison: Comparison, letter: str) -> list[str]:
    """Sides of several runs (replicated.py, run_pace.py): the pace the entries were compared in, each side's runs and
    repetitions there, how much of the between-run variance the pace explained, the entries compared on every
    repetition, and a pace one side's runs hold and the other's do not."""
    pace = comparison.replicated.pace if comparison.replicated else None
    labels = " and ".join(f.label for f in (comparison.baseline, comparison.contender))
    if pace is None:
        return [f"pace: {labels} hold several runs, some without a pace trace (written before it): the verdicts are on "
                f"the runs' spread, which holds the pace's changes"]
    names = ("A", letter)
    if pace.reference_ns is None:
        lines = [f"pace across runs: no pace of the machine holds {MIN_RUNS} runs of each side: every entry is "
                 "compared on all its repetitions, the runs' spread holding the pace's changes"]
    else:
        held = "; ".join(f"{name}: {side.runs_in_pace} of {side.runs} runs, {side.share * 100:.0f} % of its "
                         f"repetitions" for name, side in zip(names, pace.sides))
        explained = [side.explained for side in pace.sides]
        lines = [f"pace across runs: the entries compared in the machine's pace at "
                 f"{_pace_figure(pace.reading, pace.reference_ns)}, the one that holds the most of their repetitions "
                 f"({held}); the pace "
                 + (f"explained {explained[0] * 100:.0f} % of A's between-run variance and {explained[1] * 100:.0f} "
                    f"% of {letter}'s" if None not in explained else "'s share of the variance is unavailable")
                 + f" (a run's figure spread {_spread_words(pace.sides[0])} and {_spread_words(pace.sides[1])}: "
                 "standard deviation of log time, median over the entries); the intervals keep the rest"]
        if pace.entries_every_pace:
            lines.append(f"  {pace.entries_every_pace} entr{'y' if pace.entries_every_pace == 1 else 'ies'} with "
                         f"fewer than {MIN_RUNS} runs a side in that pace compared on all their repetitions")
    for value, side, holding in pace.missing:
        lines.append(f"  {names[side]}'s runs hold no repetition at {_pace_figure(pace.reading, value)}, where "
                     f"{holding} of {names[1 - side]}'s do")
    return lines


def pace_note(baseline: RunFile, contender: RunFile, letter: str) -> list[str]:
    """Lines saying in which modes the two runs ran, and whether those differ (pace_statistics.modes_differ)."""
    missing = [f.label for f in (baseline, contender) if f.pace is None]
    if missing:
        return [f"pace: {UNAVAILABLE} in {' and '.join(missing)} (no lockstep_pace: written before the pace trace); "
                "raw verdicts only"]
    matches = matching_modes(baseline, contender)
    lines = [f"pace of {which}: {', '.join(mode_text(m) for m in f.pace.modes)}; {f.pace.changes} "
             f"change{'' if f.pace.changes == 1 else 's'} of mode (from its lockstep_pace: {f.pace.summary})"
             for which, f in (("A", baseline), (letter, contender))]
    unmatched_a = [m for m in baseline.pace.modes if all(m.mode != a for a, _ in matches)]
    unmatched_b = [m for m in contender.pace.modes if all(m.mode != b for _, b in matches)]
    different = bool(unmatched_a or unmatched_b)
    rule = f"modes match when their c2c medians are within {MODE_TOLERANCE:g}x"
    if not matches:
        lines.append(f"the runs ran in different pace modes: no mode in common ({rule}); every entry's pace-aware "
                     f"verdict is on the pace-normalised figure (time / the pace_c2c_ns read around each repetition)")
    elif different:
        only = ([f"only A: {', '.join(mode_text(m) for m in unmatched_a)}"] if unmatched_a else []) + \
               ([f"only {letter}: {', '.join(mode_text(m) for m in unmatched_b)}"] if unmatched_b else [])
        lines.append(f"the runs ran in different pace modes ({'; '.join(only)}; {rule})")
    else:
        lines.append(f"the runs ran in the same pace modes ({rule})")
    return lines


def _number(value: float | None, digits: int = 2) -> str:
    """A cell of a numeric column: "-" where there is nothing to show."""
    return format_number(value, digits, missing="-")


def file_letter(index: int) -> str:
    """The letter of the index-th file: A is the baseline."""
    return chr(ord("A") + index)


def _p(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.2g}" if value >= 1e-4 else "<1e-4"


def _table(headings: list[str], rows: list[list[str]], right: set[int] | None = None,
           width: int | None = None) -> list[str]:
    return table(headings, rows, right, width)


def fingerprint_lines(run_files: list[RunFile]) -> list[str]:
    labels = [f"[{file_letter(i)}] {f.label}" for i, f in enumerate(run_files)]
    prints = [fingerprint(f) for f in run_files]
    rows = []
    for key in FINGERPRINT_KEYS:
        values = [p[key] or UNAVAILABLE for p in prints]
        mark = "*" if len(set(values)) > 1 else ""
        rows.append([key + mark] + values)
    return _table(["context (* differs)"] + labels, rows)


def _percent(value: float) -> str:
    return f"{value:+.1f} %"


def calibration_move_line(comparison: Comparison, letter: str) -> str:
    """How far the machine itself moved between the two runs, by the context's in-run calibrations."""
    parts, moves = [], []
    for name, unit, before, after, move in comparison.calibration_moves():
        if move is not None:
            moves.append((name, after / before))
            digits = 2 if max(before, after) < 100 and name.startswith("serial") else 1
            parts.append(f"{name} {before:.{digits}f} -> {after:.{digits}f} {unit} ({_percent(move)})")
        else:
            parts.append(f"{name} {UNAVAILABLE}")
    line = (f"calibrations moved, {letter} against A (in-run medians from each file's context, else from its "
            f"calibration entries; the comparisons below are not rescaled by them): " + ", ".join(parts))
    noise = comparison.noise_percent
    beyond = [name for name, ratio in moves if statistics.beyond_noise(ratio, noise / 100.0)]
    if not moves:
        return line + ": the machine's movement between the runs is unknown."
    if beyond:
        return line + f". {' and '.join(beyond)} moved beyond the ±{noise:g} % noise threshold: " + _moved_why(
            comparison, letter)
    return line + f": inside the ±{noise:g} % noise threshold."


def _moved_why(comparison: Comparison, letter: str) -> str:
    """Why the calibrations moved, named where the files say: the builds differ (never "the machine changed"
    when the build did), or the files come from different machines; else the machine itself changed."""
    builds = build_difference([comparison.baseline, comparison.contender], ["[A]", f"[{letter}]"])
    if builds:
        return (f"the builds differ ({builds}), so these calibrations and the shifts below measure the build as "
                f"much as the machine.")
    if not same_machine(comparison.baseline, comparison.contender):
        return "these are different machines, so shifts of that size below may be the machine, not the code."
    return ("the machine itself changed between the runs (or they are different machines), so shifts of that size "
            "below may be the machine, not the code.")


def _interval(interval) -> str:
    return f"[{interval[0]:.3f}, {interval[1]:.3f}]" if interval else "-"


def _row_cells(comparison: Comparison, row: Row) -> list[str]:
    return [format_ns(row.median_a), format_ns(row.median_b), f"{row.ratio:.3f}", _interval(row.interval),
            f"{row.repetitions_a}/{row.repetitions_b}", _p(row.p_adjusted), comparison.verdict(row)]


PACE_HOW = {PACE_ONE_MODE: "one mode", PACE_MATCHING_MODES: "matching modes", PACE_ONE_STATE: "one c2c state",
            PACE_NORMALISED: "/ pace c2c", BETWEEN_RUNS: "runs", ONE_PACE: "runs, one pace"}


def pace_how(pace: PaceAware) -> str:
    """How a pace-aware figure was made, in a table's few characters: "/ pace c2c^0.35" for a time divided by
    its reading to its cluster's elasticity."""
    if "serial" in pace.detail:
        return "/ pace serial"
    if pace.method == PACE_NORMALISED and pace.power != 1.0:
        return f"/ pace c2c^{pace.power:.2f}"
    return PACE_HOW[pace.method]


def _pace_cells(comparison: Comparison, row: Row) -> list[str]:
    if row.pace is None:
        return [UNAVAILABLE, "-", "-", "-", "-"]
    return [pace_how(row.pace), f"{row.pace.ratio:.3f}", _interval(row.pace.interval), comparison.pace_verdict(row),
            _plus_minus(row.detectable(comparison.noise_percent))]


def _counts_text(counts: dict[str, int]) -> str:
    return (f"{counts['slower']} slower, {counts['faster']} faster, {counts['unsure']} unsure, "
            f"{counts['within noise']} within noise, {counts['untested']} untested"
            + (f", {counts[COLLAPSED]} {COLLAPSED}" if counts.get(COLLAPSED) else ""))


def _plus_minus(percent: float | None) -> str:
    return "-" if percent is None else f"±{percent:.0f} %"


def aggregate_line(comparison: Comparison, letter: str) -> str:
    """The answer: the geometric mean of B/A over every matched combination, its interval and verdict, and
    what it could not have seen when unsure. Printed the same way by the summary and --all."""
    overall = next((a for a in comparison.aggregates() if a.group == "all"), None)
    collapsed = len(comparison.rows) - len(comparison.combinations)
    apart = "calibrations" + (f" and {collapsed} collapsed" if collapsed else "") + " apart"
    head = (f"geometric mean of {letter}/A over the {len(comparison.combinations)} matched pairs (combinations "
            f"only, {apart}")
    if comparison.withheld:
        return head + "): withheld: " + withheld_text(
            [("A" if run_file is comparison.baseline else letter, reason)
             for run_file, reason in comparison.unoptimised_sides()])
    if overall is None:
        return head + f"): {UNAVAILABLE}"
    line = head + ("; beyond the pace" if comparison.paced else "") + "): " + aggregate_text(comparison, overall)
    if overall.verdict in ("slower", "faster") and comparison.replicated is None:
        # Its interval is drawn over the entries of one run a side: a drift of the whole machine between
        # the two runs (a host that wakes sleeping vCPUs slower for a minute) moves every entry alike and
        # reads as a change. Two default runs of one build, back to back on the development VM, gave
        # 1.003 once and 1.109 ("slower") once.
        line += ("\n  (one run a side: a drift of the whole machine between the runs reads as a change here; "
                 "to see its size, run A again and compare A with its rerun)")
    return line


def evidence_lines(comparison: Comparison, b: str) -> list[str]:
    """What the intervals stand on (the runs a side, or one run and the calibrated drift), the smallest uniform
    change the comparison sees at 80 % power (replicated.py), and, with four runs a side or more, the A against A
    check of each side's halves."""
    if comparison.withheld or not comparison.combinations:
        return []
    replicated = comparison.replicated
    if replicated is not None:
        basis = f"from {replicated.runs_a} and {replicated.runs_b} runs (the variance between runs)"
        entries, aggregate = replicated.entries_power, replicated.aggregate_power
    else:
        basis = ("one run a side, drift calibrated" if comparison.drift is not None else
                 "one run a side, no drift term") + " (--runs K measures it)"
        entries, aggregate = one_run_power(comparison)
    if entries is None and aggregate is None:
        out = [f"intervals: {basis}"]
    else:
        out = [f"power (80 %): {_power_percent(entries)} in 80 % of entries, {_power_percent(aggregate)} on the mean; "
               f"{basis}"]
    checks = replicated.split(ALTERNATE) if replicated is not None else []
    if checks:
        changed, compared = replicated.total(ALTERNATE)
        sides = ", ".join(f"{name} {c.changed} of {c.compared}" for name, c in zip(("A", b), checks))
        line = (f"A against A: {changed} of {compared} changed, {_rate(changed, compared)} false positives (each "
                f"side's odd runs against its even: {sides})")
        moved, seen = replicated.total(IN_TIME_ORDER)
        if seen and moved / seen > DRIFT_SHOWN_ABOVE:
            line += (f"; in time order, first half against second, {moved} of {seen}: the machine drifted while a side "
                     "ran, which reads as a change between sides measured one after the other (alternate their runs)")
        out.append(line)
    if replicated is not None and replicated.plan_check is not None:
        out.append(plan_check_line(replicated.plan_check, b))
    return out


def _power_percent(change: float | None) -> str:
    return UNAVAILABLE if change is None else f"{change:.1f} %"


def _rate(count: int, total: int) -> str:
    return f"{100.0 * count / total:.1f} %" if total else UNAVAILABLE


def aggregate_text(comparison: Comparison, aggregate: Aggregate) -> str:
    """"1.153, 95% interval [1.120, 1.184]: slower" (and, when unsure, the smallest change it could have
    shown); the one way an aggregate is written."""
    text = f"{aggregate.ratio:.3f}, 95% interval {_interval(aggregate.interval)}: {aggregate.verdict}"
    if aggregate.interval is None:
        return text + f" (fewer than {MIN_AGGREGATE_ENTRIES} entries)"
    if aggregate.verdict == "unsure":
        text += f" (could not have seen less than {_plus_minus(aggregate.detectable(comparison.noise_percent))})"
    return text


SHOWN_GROUPS = 5


def group_lines(comparison: Comparison) -> list[str]:
    """The groups whose geometric mean is slower or faster beyond the band (largest change first, at most
    SHOWN_GROUPS each way, each as aggregate_text writes it), and how many groups are within noise or unsure."""
    groups = [a for a in comparison.aggregates() if a.group != "all"]
    if not groups:
        return []
    out = []
    for verdict, largest in (("slower", True), ("faster", False)):
        called = sorted((a for a in groups if a.verdict == verdict), key=lambda a: (a.ratio, a.group),
                        reverse=largest)
        out += [f"  {a.group} ({a.entries} entries): {aggregate_text(comparison, a)}" for a in called[:SHOWN_GROUPS]]
        if len(called) > SHOWN_GROUPS:
            out.append(f"  ... and {len(called) - SHOWN_GROUPS} more {verdict} (--all lists every group)")
    rest = {name: sum(a.verdict == name for a in groups) for name in ("within noise", "unsure", "untested")}
    if any(rest.values()):
        out.append(("  the other groups: " if out else "  ") + ", ".join(f"{count} {name}" for name, count
                                                                      in rest.items() if count))
    return [f"by group (per primitive, thread count, placement; {len(groups)} groups):"] + out


def detectable_line(comparison: Comparison) -> str | None:
    """For the entries whose beyond-the-pace verdict is unsure: the smallest change they could have shown, and
    what would make it smaller. None when no entry is unsure."""
    unsure = [row for row in comparison.combinations if comparison.beyond_pace(row) == "unsure"]
    changes = sorted(change for change in (row.detectable(comparison.noise_percent) for row in unsure)
                     if change is not None)
    if not changes:
        return None
    median = statistics.median(changes)
    drift = comparison.drift
    line = (f"the {len(unsure)} unsure could not have seen less than {_plus_minus(median)} (median; "
            f"{_plus_minus(changes[0])} the best, {_plus_minus(changes[-1])} the worst). To see less: more ")
    if comparison.replicated is not None:
        return line + ("runs a side (lockstep compare --plan says how many, and how many repetitions each) or a "
                       f"wider band (--noise; now {comparison.noise_percent:g} %)")
    line += "repetitions (lockstep run --repetitions 10 narrows the within-run part by about 1/sqrt(2))"
    if drift is not None and drift * 100 < 0.05:
        line += (", a quieter machine (between these runs the entries spread no more than their own repetitions "
                 "do: no drift beyond them)")
    elif drift is not None:
        floor = ((1.0 + comparison.noise_percent / 100.0) * math.exp(1.96 * drift) - 1.0) * 100.0
        line += (f", a quieter machine (the drift between these runs, {drift * 100:.1f} % of log time, calibrated "
                 f"from every entry, sets a floor of {_plus_minus(floor)} that repetitions do not lower)")
    else:
        line += ", a quieter machine"
    return line + (f", or a wider band (--noise; now {comparison.noise_percent:g} %); the aggregate above "
                   f"sees a uniform change that single entries cannot")


def _tool(run_file: RunFile) -> str:
    return "lockstep mpi" if run_file.mpi else "lockstep run"


def _legend_lines(comparison: Comparison, b: str) -> list[str]:
    """What the columns of --all's table of entries mean: the time, the interval, q, the verdict, the pace."""
    noise = comparison.noise_percent
    limit = 1.0 + noise / 100.0
    kind = "real" if comparison.time_kind == "real" else "CPU"
    out = [f"time: {kind} time (the ns_per_step or ns_per_episode counter where an entry has it, else per "
           f"iteration), median of the repetitions; ratio {b}/A of the medians (> 1: {b} is slower); interval: the "
           f"exact distribution-free {int(statistics.CONFIDENCE * 100)}% interval of the shift {b}/A between the "
           f"repetitions (Mann-Whitney U inverted on log time); q: two-sided Mann-Whitney U p, Benjamini-Hochberg "
           f"adjusted (false discovery rate) over the {sum(r.p_raw is not None for r in comparison.rows)} tests of "
           f"this comparison's combinations; counters are medians, A -> {b}.",
           f"verdict: the interval against the noise band of {noise:g} % (--noise PCT): slower / faster = the "
           f"whole interval beyond it ({b}/A above {limit:.3f} or below {1.0 / limit:.3f}); within noise = the "
           f"whole interval inside it (a shift no larger than the machine's own run-to-run drift); unsure = the "
           f"interval reaches across an edge of the band (more repetitions would tell); untested = too few "
           f"repetitions for an interval."]
    if comparison.paced:
        need = MIN_IN_MODE if comparison.drift is not None else statistics.MIN_REPETITIONS
        out.append(f"pace-aware (pace columns): how = one mode (every repetition of both sides in one matching mode: "
                   f"the raw comparison), matching modes (only the repetitions in the best-filled pair of matching "
                   f"modes, when each side keeps {need}), or / pace c2c (each repetition's time "
                   f"divided by the c2c reading around it, pace_c2c_ns: the pace-normalised figure); its ratio, "
                   f"interval and verdict as above.")
    return out


def _entries_table(comparison: Comparison, b: str) -> list[str]:
    """Every matched combination: medians, ratio, interval, repetitions, q, verdict, the pace-aware figure (two
    paced files) and the counters either file has, A -> B."""
    counters_present = [(c, h) for c, h in COUNTERS_SHOWN if any(c in row.counters for row in comparison.rows)]
    pace_headings = (["pace: how", f"{b}/A paced", "paced interval", "paced verdict", "could see"]
                     if comparison.paced else [])
    headings = ["benchmark", "A median", f"{b} median", f"{b}/A", "95% interval", "reps", "q (BH)",
                "verdict"] + pace_headings + [h for _, h in counters_present]
    rows = []
    for row in comparison.rows:
        cells = [row.key.display] + _row_cells(comparison, row)
        if comparison.paced:
            cells += _pace_cells(comparison, row)
        for counter, _ in counters_present:
            before, after = row.counters.get(counter, (None, None))
            # Absent on both sides: the entry cannot have it (lockstep omits, e.g., the futex waits
            # of a primitive that hides them in a library), never a 0.
            cells.append(UNAVAILABLE if before is None and after is None
                         else f"{format_number(before)} -> {format_number(after)}")
        rows.append(cells)
    return _table(headings, rows, right={1, 2, 3, 6} | ({9} if comparison.paced else set()))


def _aggregate_lines(comparison: Comparison, b: str) -> list[str]:
    """The answer (aggregate_line), every group's aggregate as a table, and the file pair's pooling."""
    out = [aggregate_line(comparison, b)]
    groups = [aggregate for aggregate in comparison.aggregates() if aggregate.group != "all"]
    if groups:
        out += _table(["group", "entries", f"{b}/A geometric mean", "95% interval", "verdict", "could see"],
                      [[a.group, str(a.entries), f"{a.ratio:.3f}", _interval(a.interval), a.verdict,
                        _plus_minus(a.detectable(comparison.noise_percent))] for a in groups], right={1, 2})
    if comparison.drift is not None:
        out.append(f"pooled intervals ({comparison.pooled_entries} entries): each pace-aware interval from the "
                   f"entry's variance of log time moderated towards the file pair's, plus the drift between the "
                   f"runs calibrated from every entry's log ratio: {comparison.drift * 100:.1f} % (log time)")
    return out


def _counts_lines(comparison: Comparison) -> list[str]:
    """The verdicts counted: raw, pace-aware (with how each figure was made), and what changed beyond the pace."""
    raw_called, raw_discovered = comparison.discoveries(comparison.verdict)
    out = [f"raw verdicts at the {comparison.noise_percent:g} % noise band: "
           f"{_counts_text(comparison.verdict_counts())} ({raw_discovered} of the {raw_called} slower or faster also "
           f"have BH q < alpha {comparison.alpha:g})"]
    if comparison.paced:
        paced_rows = [row for row in comparison.rows if row.pace]
        pace_counts = {name: sum(comparison.pace_verdict(row) == name for row in paced_rows) for name in VERDICTS}
        methods = ", ".join(f"{sum(row.pace.method == method for row in paced_rows)} {method}"
                            for method in (PACE_ONE_MODE, PACE_MATCHING_MODES, PACE_ONE_STATE, PACE_NORMALISED))
        unpaced = len(comparison.rows) - len(paced_rows)
        out.append(f"pace-aware verdicts: {_counts_text(pace_counts)} ({methods}"
                   + (f"; {unpaced} {UNAVAILABLE}" if unpaced else "") + ")")
    beyond = comparison.pace_verdict_counts()
    _, discovered = comparison.discoveries(comparison.beyond_pace)
    what = ("beyond the pace (pace-aware verdicts; the raw one where an entry has no pace)" if comparison.paced
            else f"(raw verdicts: pace {UNAVAILABLE})")
    out.append(f"changed {what}: {beyond['slower'] + beyond['faster']} of {len(comparison.rows)} "
               f"({beyond['slower']} slower, {beyond['faster']} faster; {discovered} of them with BH q < alpha "
               f"{comparison.alpha:g})")
    return out


def _calibration_lines(comparison: Comparison, b: str) -> list[str]:
    """The calibrations, compared apart as their own family, and each overhead pair's accounting cost."""
    if not comparison.calibrations:
        return []
    out = ["", f"calibrations ({len(comparison.calibrations)}): the machine and the instrumentation, not a "
               f"combination; c2c compared by its {C2C_COUNTER} counter (its iteration time is thread start-up "
               f"plus the measurement), the overhead pair, rk4/serial and the MPI ping-pong (its OSU-style mean "
               f"one-way time) by their time (they measure the pace: raw only); q Benjamini-Hochberg over these "
               f"{sum(r.p_raw is not None for r in comparison.calibrations)} tests on their own; not in the "
               f"geometric mean, the counts above or --fail-above."]
    calibration_rows = [[row.key.display, row.measure] + _row_cells(comparison, row)
                        for row in comparison.calibrations]
    out += _table(["calibration", "measure", "A median", f"{b} median", f"{b}/A", "95% interval", "reps",
                   "q (BH)", "verdict"], calibration_rows, right={2, 3, 4, 7})
    for key, ratio_a, ratio_b in comparison.accounting_overheads():
        out.append(f"accounting overhead of {key.display} (time with accounting:on / off): "
                   f"A {_number(ratio_a, 3)}, {b} {_number(ratio_b, 3)}")
    return out


def _listing_lines(comparison: Comparison, b: str) -> list[str]:
    """Every entry only one file has, every errored one, and the comparison's warnings."""
    out = _only_lines(comparison, b, limit=None)
    out.append(f"errored (not compared): {len(comparison.errored)}")
    out += [f"  {key.display} in {where}: {message}" for key, where, message in comparison.errored]
    return out + [f"warning: {warning}" for warning in comparison.warnings]


def comparison_lines(comparison: Comparison, letter: str) -> list[str]:
    """One comparison as --all prints it: the machine's move, the pace, the legend, every entry, the aggregates,
    the counts, the calibrations and the listings."""
    b = letter
    out = [f"== {b} ({comparison.contender.label}) against A ({comparison.baseline.label})", ""]
    if not set(comparison.baseline.runs) & set(comparison.contender.runs):
        out += [f"no entries in common: A ({_tool(comparison.baseline)}) and {b} ({_tool(comparison.contender)}) "
                f"name different benchmarks, so nothing below is compared; each file's entries are listed at the "
                f"end", ""]
    out += [calibration_move_line(comparison, b), ""]
    out += (runs_pace_lines(comparison, b) if comparison.replicated else
            pace_note(comparison.baseline, comparison.contender, b)) + [""]
    out += _legend_lines(comparison, b) + [""]
    out += _entries_table(comparison, b) + [""]
    out += _aggregate_lines(comparison, b)
    out += evidence_lines(comparison, b)
    out += _counts_lines(comparison)
    out += _calibration_lines(comparison, b) + [""]
    return out + _listing_lines(comparison, b)


def across_machines_lines(run_files: list[RunFile], time_kind: str = "real") -> list[str]:
    letters = [file_letter(i) for i in range(len(run_files))]
    out = ["== Across machines: each file normalised by its own machine", ""]
    out.append("x serial: step time / that run's serial RK4 step of the entry's model (context serial_step_ns; "
               "a chain's: its rk4/model:chainS/serial entry); "
               "x c2c: stage sync time / that run's one-way core-to-core latency (context c2c_one_way_ns).")
    out += [f"[{letter}] {run_file.label} is {reason}: its x serial, x c2c and ranks are the unoptimised code's, not "
            f"its machine's." for letter, run_file in zip(letters, run_files)
            for reason in (unoptimised(run_file),) if reason]
    rows = []
    for key in rk4_keys(run_files):
        cells = [key.display]
        for run_file in run_files:
            vs_serial, vs_c2c = normalised(run_file, key, time_kind)
            cells += [_number(vs_serial), _number(vs_c2c)]
        rows.append(cells)
    headings = ["benchmark"]
    for letter in letters:
        headings += [f"{letter} x serial", f"{letter} x c2c"]
    out += _table(headings, rows, right=set(range(1, len(headings))))
    out.append("")
    reference = sharing_layout(run_files[0])
    out.append(f"Layouts against {reference} (speed-up = {reference} time / layout time, on each machine):")
    effect_rows = [[sync, pin, str(threads), layout] + [(_number(s) + "x") if s else "-" for s in speedups]
                   for sync, pin, threads, layout, speedups in layout_effects(run_files, reference, time_kind)]
    out += _table(["sync", "pin", "threads", "layout"] + [f"{letter} vs {reference}" for letter in letters],
                  effect_rows, right=set(range(4, 4 + len(letters))))
    out.append("")
    out.append("Rank per machine (fastest first; sync/layout, step time, x serial):")
    for (pin, threads), per_file in rank_tables(run_files, time_kind).items():
        out.append(f"-- pin:{pin} threads:{threads}")
        depth = max((len(entries) for entries in per_file), default=0)
        rank_rows = []
        for rank in range(depth):
            cells = [str(rank + 1)]
            for entries in per_file:
                if rank < len(entries):
                    name, step, vs_serial = entries[rank]
                    cells.append(f"{name} {format_ns(step)} ({_number(vs_serial)}x)")
                else:
                    cells.append("")
            rank_rows.append(cells)
        out += _table(["rank"] + [f"[{letter}] {f.label}" for letter, f in zip(letters, run_files)], rank_rows)
    return out


# The default output (render_text without everything) lists at most this many changed entries each way.
SHOWN_CHANGES = 6
ALL_HINT = ("(lockstep compare --all prints every entry with its interval and counters, the calibrations, the whole "
            "context and more)")


def differing_context_lines(files) -> list[str]:
    """The fingerprint's keys whose values differ between the files, as a table (A, B, ... side by side), or
    one line saying they are all the same."""
    labels = [f"[{file_letter(i)}] {f.label}" for i, f in enumerate(files)]
    prints = [fingerprint(f) for f in files]
    rows = []
    for key in FINGERPRINT_KEYS:
        values = [p[key] or UNAVAILABLE for p in prints]
        if len(set(values)) > 1:
            rows.append([key + "*"] + values)
    if not rows:
        return [f"context: the same {len(FINGERPRINT_KEYS)} fingerprint keys in every file"]
    return _table(["context (* differs)"] + labels, rows)


def _collapsed_mark(comparison: Comparison, key: BenchmarkKey) -> str:
    where = [letter for letter, run_file in (("A", comparison.baseline), ("B", comparison.contender))
             if key in run_file.collapsed]
    return f" (collapsed in {' and '.join(where)})" if where else ""


def _listed(keys, limit: int = 5) -> list[str]:
    shown = [f"  {key.display}" for key in keys[:limit]]
    return shown + ([f"  ... and {len(keys) - limit} more"] if len(keys) > limit else [])


# How a pace-aware figure was made, in the summary's words (--all gives pace_how's exact figure).
PACE_WORDS = {PACE_ONE_MODE: "one mode", PACE_MATCHING_MODES: "matching modes", PACE_ONE_STATE: "one c2c state",
              PACE_NORMALISED: "pace-scaled", BETWEEN_RUNS: "runs", ONE_PACE: "paced"}
PACE_WORD_MEANINGS = {
    "one mode": "every repetition of both runs in one pace mode",
    "matching modes": "only the repetitions in pace modes the two runs share",
    "one c2c state": "only the repetitions at one core-to-core latency",
    "pace-scaled": "each time divided by the core-to-core latency read around it (the serial step on a machine of "
                   "one CPU), as far as its primitive's times follow it (--all gives the power)",
    "raw": "the plain times (no pace read around them)",
    "runs": "the ratio of the geometric means of the runs, its interval from the variance between runs",
    "paced": "the ratio of the geometric means of the runs, each run's figure from its repetitions in the pace of the "
             "machine the runs share (above), its interval from the variance between runs",
}


def _pace_word(row: Row) -> str:
    return PACE_WORDS[row.pace.method] if row.pace else "raw"


def _changed_lines(comparison: Comparison, b: str, what: str) -> list[str]:
    """The entries that changed beyond the pace, slower (largest first) and faster (largest gain first), at most
    SHOWN_CHANGES each, and what the "how" words shown mean."""
    out, words = [], set()
    for verdict, order in (("slower", True), ("faster", False)):
        changed = sorted((row for row in comparison.rows if comparison.beyond_pace(row) == verdict),
                         key=lambda row: (row.beyond_pace_ratio(), row.key.sort_key()), reverse=order)
        if not changed:
            continue
        out.append(f"{verdict} {what if comparison.paced else ''}".rstrip()
                   + f" ({len(changed)}, {'largest first' if order else 'largest gain first'}):")
        rows = []
        for row in changed[:SHOWN_CHANGES]:
            shown = row.pace if row.pace else row
            words.add(_pace_word(row))
            rows.append([row.key.display + _collapsed_mark(comparison, row.key), format_ns(row.median_a),
                         format_ns(row.median_b), f"{shown.ratio:.3f}", _interval(shown.interval), _pace_word(row)])
        out += ["  " + line for line in _table(["benchmark", "A median", f"{b} median", f"{b}/A", "95% interval",
                                                "how"], rows, right={1, 2, 3}, width=WIDTH - 2)]
        if len(changed) > SHOWN_CHANGES:
            out.append(f"  ... and {len(changed) - SHOWN_CHANGES} more {verdict} (--all lists every entry)")
    if words:
        out.append("  how: " + "; ".join(f"{word} = {meaning}" for word, meaning in PACE_WORD_MEANINGS.items()
                                         if word in words))
    return out


def _only_lines(comparison: Comparison, b: str, limit: int | None = 5) -> list[str]:
    """The entries only one file has: "only on A" across machines, "removed" / "added" between runs of one."""
    across = not same_machine(comparison.baseline, comparison.contender)
    out = []
    for name, run_file, keys, change in (("A", comparison.baseline, comparison.removed, "removed"),
                                         (b, comparison.contender, comparison.added, "added")):
        out.append(f"only on {name} ({run_file.label}): {len(keys)}" if across
                   else f"only in {name} ({run_file.label}): {change}: {len(keys)}")
        out += _listed(keys, limit) if limit else [f"  {key.display}" for key in keys]
    return out


def summary_lines(comparison: Comparison, letter: str) -> list[str]:
    """One comparison in a few lines: how far the machine moved, the pace, the verdict counts, the geometric
    mean, the entries that changed beyond the pace (largest first), what was added, removed or errored."""
    b = letter
    noise = comparison.noise_percent
    out = [f"== {b} ({comparison.contender.label}) against A ({comparison.baseline.label})"]
    if not set(comparison.baseline.runs) & set(comparison.contender.runs):
        out.append(f"no entries in common: A ({_tool(comparison.baseline)}) and {b} ({_tool(comparison.contender)}) "
                   f"name different benchmarks, so nothing is compared")
    out.append(aggregate_line(comparison, b))
    out += evidence_lines(comparison, b)
    out += group_lines(comparison)
    out.append(calibration_move_line(comparison, b))
    out += (runs_pace_lines(comparison, b) if comparison.replicated else
            pace_note(comparison.baseline, comparison.contender, b))
    counts = comparison.pace_verdict_counts()
    what = ("between runs" if comparison.replicated is not None else "beyond the pace" if comparison.paced
            else f"(raw verdicts: pace {UNAVAILABLE})")
    out.append(f"changed {what}: {counts['slower'] + counts['faster']} of {len(comparison.rows)} "
               f"({counts['slower']} slower, {counts['faster']} faster); {counts['unsure']} unsure, "
               f"{counts['within noise']} within noise, {counts['untested']} untested"
               + (f", {counts[COLLAPSED]} {COLLAPSED} (in a file's answer: oversubscribed, one repetition)"
                  if counts[COLLAPSED] else "")
               + f" (verdict: the 95% interval of {b}/A against the {noise:g} % noise band)")
    unsure = detectable_line(comparison)
    if unsure:
        out.append(unsure)
    out += _changed_lines(comparison, b, what)
    if comparison.calibrations:
        verdicts = [comparison.verdict(row) for row in comparison.calibrations]
        moved = [row.key.display for row in comparison.calibrations if comparison.verdict(row) in ("slower", "faster")]
        out.append(f"calibrations, compared apart ({len(verdicts)}): "
                   + ", ".join(f"{verdicts.count(name)} {name}" for name in VERDICTS if verdicts.count(name))
                   + (f" (moved: {', '.join(moved)})" if moved else ""))
    out += _only_lines(comparison, b)
    out.append(f"errored (not compared): {len(comparison.errored)}")
    errored = [f"  {key.display} in {where}: {message}" for key, where, message in comparison.errored]
    out += errored[:5] + ([f"  ... and {len(errored) - 5} more"] if len(errored) > 5 else [])
    for warning in comparison.warnings:
        out.append(f"warning: {warning}")
    return out


def across_machines(run_files: list[RunFile]) -> bool:
    """The run files come from more than one machine (fingerprint's MACHINE_KEYS) and some of them are `lockstep
    run` files, whose answers can be set side by side: compare then opens with them."""
    machines = {tuple(fingerprint(f)[key] for key in MACHINE_KEYS) for f in run_files}
    return len(machines) > 1 and not all(run_file.mpi for run_file in run_files)


def findings_lines(run_files: list[RunFile]) -> list[str]:
    """What makes the files incomparable as they stand (comparability.findings), first and loud; none when
    nothing does."""
    found = findings(list(run_files))
    if not found:
        return []
    return ["Read first: what makes these files incomparable as they stand:"] + [f"- {line}" for line in found]


def _machines_line(all_files) -> str:
    machines = {tuple(fingerprint(f)[key] for key in MACHINE_KEYS) for f in all_files}
    return f"machines: {len(machines)} distinct (by {', '.join(MACHINE_KEYS)})"


def _answers_first(run_files: list[RunFile]) -> list[str]:
    """Across machines: each machine's answer side by side, then what differs between the machines."""
    return [""] + answer_lines(run_files) + [""] + difference_lines(run_files)


def _crossovers(run_files: list[RunFile], across: bool) -> list[str]:
    """The files' crossovers side by side, after a blank line, where two files swept it; across machines the
    answers' table has them already."""
    lines = [] if across else crossover_lines(run_files)
    return [""] + lines if lines else []


def render_text(run_files: list[RunFile], comparisons: list[Comparison], time_kind: str = "real",
                context_files=(), everything: bool = False) -> str:
    """The comparison as text: by default the summary (summary_lines per comparison, the context's differences),
    everything: every table. `context_files`: results of other kinds (context_reader.ContextFile), shown in the
    fingerprint only, after the run files (so a run file's letter is its place among the compared files)."""
    if not everything:
        return render_summary(run_files, comparisons, context_files)
    all_files = list(run_files) + list(context_files)
    out = ["lockstep compare: " + "  ".join(f"[{file_letter(i)}] {f.label}" for i, f in enumerate(all_files))]
    if comparisons:
        noise = comparisons[0].noise_percent
        if noise == DEFAULT_NOISE_PERCENT:
            out.append(f"noise threshold: {noise:g} % (the default, --noise PCT to change it: {NOISE_RATIONALE})")
        else:
            out.append(f"noise threshold: {noise:g} % (--noise; the default is {DEFAULT_NOISE_PERCENT:g} %)")
    out += wrapped(findings_lines(run_files))
    if across_machines(run_files):
        out += wrapped(_answers_first(run_files))
    out.append("")
    out += fingerprint_lines(all_files)
    out.append(_machines_line(all_files))
    if context_files:
        out.append("fingerprint only (not benchmark results): " +
                   ", ".join(f"{f.label} (lockstep {f.kind})" for f in context_files))
    out.append("")
    warnings = [w for f in all_files for w in f.warnings]
    for index, comparison in enumerate(comparisons, start=1):
        out += comparison_lines(comparison, file_letter(index))
        out.append("")
    if run_files and not all(run_file.mpi for run_file in run_files):  # MPI files hold no rk4 entries to normalise
        out += across_machines_lines(run_files, time_kind)
    out += wrapped(_crossovers(run_files, across_machines(run_files)))
    if warnings:
        out.append("")
        out += [f"warning: {w}" for w in warnings]
    return "\n".join(out) + "\n"


def across_lines(comparison: Comparison, letter: str) -> list[str]:
    """One comparison between two machines in a few lines: the geometric mean (or why there is none), what was
    compared and what only one machine ran; --all has every entry."""
    b = letter
    out = [f"== {b} ({comparison.contender.label}) against A ({comparison.baseline.label}), two machines",
           aggregate_line(comparison, b)]
    calibrations = f" and {len(comparison.calibrations)} calibrations" if comparison.calibrations else ""
    out.append(f"compared: {len(comparison.rows)} combinations{calibrations} both ran; only on A: "
               f"{len(comparison.removed)}, only on {b}: {len(comparison.added)}; errored: {len(comparison.errored)}")
    return out + [f"warning: {warning}" for warning in comparison.warnings]


ACROSS_HINT = "(lockstep compare --all adds every entry compared, the calibrations, the pace and the whole context)"


def _title(files) -> list[str]:
    """The files by letter: on the first line, or one a line where they do not fit on it."""
    named = [f"[{file_letter(i)}] {f.label}" for i, f in enumerate(files)]
    line = "lockstep compare: " + "  ".join(named)
    return [line] if len(line) <= WIDTH else ["lockstep compare:"] + [f"  {name}" for name in named]


def render_summary(run_files: list[RunFile], comparisons: list[Comparison], context_files=()) -> str:
    """The default text, at most text_layout.WIDTH columns: what makes the files incomparable first; across
    machines each machine's answer and what differs, then a few lines per comparison; between runs of one machine
    the differing context and each comparison's summary (summary_lines)."""
    all_files = list(run_files) + list(context_files)
    across = across_machines(run_files)
    out = _title(all_files)
    if comparisons:
        noise = comparisons[0].noise_percent
        out.append(f"noise band: {noise:g} % " + ("(the default; --noise PCT changes it, --help says why 5)"
                                                   if noise == DEFAULT_NOISE_PERCENT else
                                                   f"(--noise; the default is {DEFAULT_NOISE_PERCENT:g} %)"))
    out.append(_machines_line(all_files) + (": each machine's answer first" if across else ""))
    if across:
        out += findings_lines(run_files) + _answers_first(run_files)
    else:
        out += differing_context_lines(all_files) + findings_lines(run_files)
    out += mpi_difference_lines(all_files)
    if context_files:
        out.append("fingerprint only (not benchmark results): " +
                   ", ".join(f"{f.label} (lockstep {f.kind})" for f in context_files))
    for index, comparison in enumerate(comparisons, start=1):
        out.append("")
        same = same_machine(comparison.baseline, comparison.contender)
        out += (summary_lines if same or not across else across_lines)(comparison, file_letter(index))
    out += _crossovers(run_files, across)
    warnings = [w for f in all_files for w in f.warnings]
    if warnings:
        out.append("")
        out += [f"warning: {w}" for w in warnings]
    out += ["", ACROSS_HINT if across else ALL_HINT]
    return "\n".join(wrapped(out)) + "\n"
