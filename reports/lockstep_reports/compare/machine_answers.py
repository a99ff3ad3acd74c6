"""Each machine's answer side by side, one column per file (compare across machines opens with it): per thread
count and placement the combination its run chose with its step and the baseline set against it, the crossover
where the file has one, core-to-core latency, false sharing (the probe, and per access pattern where the file has
them), migration; then what differs between the machines.

Every figure is the file's own (its answer, lockstep_crossover and the context, read by run_reader.py and
answer_reader.py): nothing is recomputed here, so each machine's answer reads as its own run printed it.
"""
from __future__ import annotations

from ..analysis.run_analysis import calibration
from ..common import statistics
from ..common.fields import (BUILD_TYPE_CONTEXT, C2C_CONTEXT, MACHINE_KEYS, MODE_CONTEXT, QUICK_MODE, SERIAL_CONTEXT,
                             UNAVAILABLE)
from ..common.formatting import crossover_interval, format_ns
from ..common.text_layout import WIDTH, column_width, table
from ..common.words import PIN_ORDER
from ..read.run_answer import Answer, Ceiling, Choice, Crossover, CrossoverSweep, PairedRatio, Rival
from ..read.run_file import RunFile
from .comparability import letter, unoptimised

# The files side by side in one table; more go into a second table below.
COLUMNS = 4
# What is not in a file (its run did not measure it, or it predates the field).
ABSENT = "-"
# What the machines' differences show beside the CPU model (which the answers' first row shows).
MACHINE_DETAIL = tuple(key for key in MACHINE_KEYS if key != "cpu_model") + ("mhz_per_cpu",)
# A paired verdict (statistics.VERDICTS) in the words of each ratio: the baseline's step over the chosen
# one's, and an access's time on one shared cache line over its time on lines apart.
BASELINE_WORDS = {statistics.GAIN: "faster", statistics.WITHIN_NOISE: "a tie", statistics.UNSURE: "unsure"}
FALSE_SHARING_WORDS = {statistics.GAIN: "one line faster",
                       statistics.WITHIN_NOISE: "no penalty", statistics.UNSURE: "unsure"}


def _figure(value: float) -> str:
    """Three significant digits, trailing zeros kept ("1.90", "25.3", "0.846"); whole from 100 on."""
    return f"{value:#.3g}" if value < 100 else f"{value:.0f}"


def paired_text(ratio: PairedRatio | Rival | None, words: dict[str, str]) -> str:
    """"11.4x [5.98, 25.3]": the median and its interval, and the verdict in words where it is not the penalty
    the ratio's own words say ("1.03x [0.91, 1.09], a tie"); "-" for none."""
    if ratio is None:
        return ABSENT
    if ratio.median is None:
        return UNAVAILABLE
    text = _figure(ratio.median) + "x"
    if ratio.ci_low is not None and ratio.ci_high is not None:
        text += f" [{_figure(ratio.ci_low)}, {_figure(ratio.ci_high)}]"
    shown = ratio.verdict and ratio.verdict != statistics.PENALTY
    return text + (f", {words.get(ratio.verdict, ratio.verdict)}" if shown else "")


def _answer(run_file: RunFile) -> Answer:
    """The file's answer; Answer() (nothing in it) for a file written before it."""
    return run_file.answer or Answer()


def _crossovers_of(run_file: RunFile) -> tuple[Crossover, ...]:
    return run_file.crossover.crossovers if run_file.crossover else ()


def _choices(run_file: RunFile) -> dict[tuple, Choice]:
    """{(model, threads, pin): the choice} of a file's answer."""
    return {(choice.model, choice.threads, choice.pin): choice for choice in _answer(run_file).choices}


def _group_order(group: tuple) -> tuple:
    model, threads, pin = group
    return (model, threads, PIN_ORDER.index(pin) if pin in PIN_ORDER else len(PIN_ORDER), pin)


def _group_label(group: tuple) -> str:
    model, threads, pin = group
    return (f"{model}, " if model else "") + f"{threads} thread{'' if threads == 1 else 's'}" + (
        f", pin:{pin}" if pin else "")


def _build(run_file: RunFile) -> str:
    build = run_file.context.get(BUILD_TYPE_CONTEXT) or f"build {UNAVAILABLE}"
    mode = run_file.context.get(MODE_CONTEXT)
    run = "--quick" if mode == QUICK_MODE else "default run" if mode == "default" else mode or f"mode {UNAVAILABLE}"
    return f"{build}, {run}" + (" (not the machine's times)" if unoptimised(run_file) else "")


def _combination(choice: Choice) -> str:
    return f"{choice.sync} + {choice.layout}" if choice.layout else choice.sync


def _crowded(run_file: RunFile, group: tuple) -> str:
    """" (4 threads on 2 CPUs)": a choice that ran with more threads than its machine's CPUs."""
    cpus = run_file.context.get("num_cpus")
    return f" ({group[1]} on {cpus} CPUs)" if cpus else " (more threads than CPUs)"


def crossover_words(crossover: Crossover) -> str:
    """A crossover as the file states it, without its primitive: "from 25 masses [21, 60]", ", unconfirmed" when
    no size above it confirmed it, "at every size measured, from 512 masses", "none within the sweep (up to 4096
    masses)", "nothing measured" (every size's pairs set aside)."""
    if crossover.masses is None:
        measured = [point.masses for point in crossover.points if point.measured]
        if crossover.points and not measured:
            return "nothing measured"
        return "none within the sweep" + (f" (up to {max(measured)} masses)" if measured else "")
    if crossover.status == "always":
        return f"at every size measured, from {crossover.masses:.0f} masses"
    return (f"from {crossover.masses:.0f} masses{crossover_interval(crossover)}"
            + (", unconfirmed" if crossover.status == "crossed_unconfirmed" else ""))


def _crossover_text(crossover: Crossover) -> str:
    words = crossover_words(crossover)
    return f"{crossover.sync}{':' if crossover.masses is None else ''} {words}"


def _crossovers(run_file: RunFile) -> dict[tuple, str]:
    """{(model, threads, pin): the file's crossovers there, in words}; the crossover's model is the paper's."""
    found: dict[tuple, list[str]] = {}
    for crossover in _crossovers_of(run_file):
        found.setdefault(("", crossover.threads, crossover.pin), []).append(_crossover_text(crossover))
    return {group: "; ".join(texts) for group, texts in found.items()}


def ceiling_words(sweep: CrossoverSweep, ceiling: Ceiling) -> str | None:
    """A file's ceiling as its ceiling line quotes it: "1.82x [1.74, 1.91] at 32 masses, LEADER 0.87 of it" (the
    leader: the run's choice there); None where it measured nothing."""
    point = ceiling.quoted()
    if point is None:
        return None
    words = f"{point.speedup:.2f}x [{point.ci_low:.2f}, {point.ci_high:.2f}] at {point.masses} masses"
    for crossover in sweep.crossovers:
        if crossover.threads == ceiling.threads and crossover.pin == ceiling.pin and crossover.leader:
            reached = next((p for p in crossover.points if p.masses == point.masses and p.of_ceiling is not None), None)
            if reached:
                words += f", {crossover.sync} {reached.of_ceiling:.2f} of it"
    return words


def _ceilings(run_file: RunFile) -> dict[tuple, str]:
    """{(model, threads, pin): the file's ceiling there, in words} (ceiling_words)."""
    sweep = run_file.crossover
    found = {}
    for ceiling in sweep.ceilings if sweep else ():
        words = ceiling_words(sweep, ceiling)
        if words:
            found[("", ceiling.threads, ceiling.pin)] = words
    return found


def crossover_lines(files: list[RunFile]) -> list[str]:
    """Two or more files that each swept the crossover (lockstep_crossover): per thread count, placement and
    primitive each file's crossover as it wrote it, side by side (one column per file, its letter); none
    otherwise. Compare between runs of one machine shows it (across machines the answers' table has the
    crossover rows)."""
    found = [{(c.threads, c.pin, c.sync): crossover_words(c) for c in _crossovers_of(run_file)}
             for run_file in files]
    if sum(1 for each in found if each) < 2:
        return []
    rows = [[_group_label(("", threads, pin)) + f", {sync}"] + [each.get((threads, pin, sync), ABSENT)
                                                                 for each in found]
            for threads, pin, sync in sorted({key for each in found for key in each},
                                             key=lambda key: (_group_order(("", key[0], key[1])), key[2]))]
    room = column_width(max(len(row[0]) for row in rows), len(files))
    headings = [""] + [_heading(letter(index), run_file.label, room) for index, run_file in enumerate(files)]
    ceilings = [_ceilings(run_file) for run_file in files]
    rows += [[_group_label(group) + ", the ceiling"] + [each.get(group, ABSENT) for each in ceilings]
             for group in sorted({group for each in ceilings for group in each}, key=_group_order)]
    return (["Crossovers (S* in masses [interval], as each run wrote it; -: not swept there, or written before it):"]
            + table(headings, rows, width=WIDTH))


def _choice_rows(files: list[RunFile]) -> list[list[str]]:
    """Per model, thread count and placement any file answers for: the combination it chose, its step, the
    baseline set against it, and the crossover where the file has one."""
    choices = [_choices(run_file) for run_file in files]
    crossovers = [_crossovers(run_file) for run_file in files]
    ceilings = [_ceilings(run_file) for run_file in files]
    rows = []
    for group in sorted({group for found in choices + crossovers for group in found}, key=_group_order):
        picked = [found.get(group) for found in choices]  # a choice or None
        # A group only a crossover names keeps its title (rows of nothing but ABSENT are left out).
        rows.append([_group_label(group)] + [_combination(p) if p else ABSENT if any(picked) else ""
                                             for p in picked])
        rows.append(["  a step"] + [format_ns(p.ns_per_step, 3) + (_crowded(run_file, group) if p.oversubscribed
                                                                   else "")
                                    if p else ABSENT for p, run_file in zip(picked, files)])
        names = {p.baseline.sync for p in picked if p and p.baseline}
        if names:
            one = len(names) == 1
            rows.append([f"  {next(iter(names))} takes" if one else "  the baseline takes"]
                        + [ABSENT if not (p and p.baseline) else paired_text(p.baseline, BASELINE_WORDS) if one
                           else f"{p.baseline.sync} {paired_text(p.baseline, BASELINE_WORDS)}" for p in picked])
        rows.append(["  crossover"] + [found.get(group, ABSENT) for found in crossovers])
        if any(found.get(group) for found in ceilings):
            rows.append(["  the ceiling"] + [found.get(group, ABSENT) for found in ceilings])
    return rows


def _probe_rows(files: list[RunFile]) -> list[list[str]]:
    """False sharing (the probe, then each access pattern any file measured) and migration."""
    answers = [_answer(run_file) for run_file in files]
    rows = [["false sharing"] + [
        paired_text(answer.false_sharing, FALSE_SHARING_WORDS) if answer.false_sharing
        else f"{UNAVAILABLE}: {answer.false_sharing_unavailable}" if answer.false_sharing_unavailable else ABSENT
        for answer in answers]]
    patterns = list(dict.fromkeys(pattern.name for answer in answers for pattern in answer.patterns))
    for name in patterns:
        rows.append([f"  {name}"] + [paired_text(next((p for p in answer.patterns if p.name == name), None),
                                                 FALSE_SHARING_WORDS) for answer in answers])
    rows.append(["migration"] + [
        f"move {format_ns(answer.migration.move_ns, 3)}, refill {format_ns(answer.migration.refill_ns, 3)}"
        if answer.migration else f"{UNAVAILABLE}: {answer.migration_unavailable}" if answer.migration_unavailable
        else ABSENT for answer in answers])
    return rows


def _calibration_cell(run_file: RunFile, key: str) -> str:
    value = calibration(run_file, key)
    return format_ns(value) if value else UNAVAILABLE


def _rows(files: list[RunFile]) -> list[list[str]]:
    rows = [["CPU"] + [f"{f.context.get('cpu_model') or UNAVAILABLE}, {f.context.get('num_cpus') or '?'} CPUs"
                       for f in files],
            ["build, run"] + [_build(f) for f in files]]
    if any(f.answer is None for f in files):
        rows.append(["the run's answer"] + ["in the file" if f.answer else "none: the file predates it"
                                            for f in files])
    rows += [["core-to-core, one way"] + [_calibration_cell(f, C2C_CONTEXT) for f in files],
             ["serial RK4 step"] + [_calibration_cell(f, SERIAL_CONTEXT) for f in files]]
    rows += _choice_rows(files) + _probe_rows(files)
    return [row for row in rows if any(cell != ABSENT for cell in row[1:])]


def _legend(rows: list[list[str]]) -> list[str]:
    """What the rows shown mean, each said once below the table: none when nothing needs saying."""
    labels = {row[0].strip() for row in rows}
    parts = []
    if "a step" in labels:
        parts.append("a step: the chosen combination's median time per RK4 step")
    if "false sharing" in labels or any(label.endswith(" takes") for label in labels):
        parts.append("2.50x [2.10, 3.00]: a ratio and its 95 % interval, measured side by side in that run")
    if any(label.endswith(" takes") for label in labels):
        parts.append("<primitive> takes: its step over the chosen one's (its verdict named unless slower)")
    if "crossover" in labels:
        parts.append("crossover: the model size from which the parallel step beats the serial one")
    if "false sharing" in labels:
        parts.append("false sharing: an access's time on one shared cache line over lines apart")
    if "migration" in labels:
        parts.append("migration: medians of a forced move between CPUs and of the cache refill after it")
    if any(ABSENT in row[1:] for row in rows):
        parts.append(f"{ABSENT}: not in that file")
    return ["; ".join(parts) + "."] if parts else []


def _heading(name: str, label: str, room: int) -> str:
    """A column's heading: the file's letter and name, or its letter alone where the name would not fit (the
    first line of compare's text names every file beside its letter)."""
    heading = f"{name} {label}"
    return heading if len(heading) <= room else name


def answer_lines(files: list[RunFile], first: int = 0) -> list[str]:
    """The answers side by side (COLUMNS files a table), each column headed by its file's letter and name, then
    the legend; `first`: the index (letter) of files[0]."""
    out = ["Each machine's answer, as its own run gave it (the answer in its file; nothing recomputed here):"]
    shown = []
    for start in range(0, len(files), COLUMNS):
        chunk = files[start:start + COLUMNS]
        rows = _rows(chunk)
        room = column_width(max(len(row[0]) for row in rows), len(chunk))
        headings = [""] + [_heading(letter(first + start + i), f.label, room) for i, f in enumerate(chunk)]
        out += table(headings, rows, width=WIDTH)
        shown += rows
    return out + _legend(shown)


def difference_lines(files) -> list[str]:
    """What differs between the machines beside the CPU model: topology, hypervisor, kernel, CPUs, clock (a line
    for one or two keys, a table for more); and what is the same."""
    values = {key: [str(f.context.get(key) if f.context.get(key) is not None else UNAVAILABLE) for f in files]
              for key in MACHINE_DETAIL}
    differ = [key for key in MACHINE_DETAIL if len(set(values[key])) > 1]
    same = f"the same {', '.join(key for key in MACHINE_DETAIL if key not in differ)}" if len(differ) < len(
        MACHINE_DETAIL) else ""
    if len(differ) <= 2:
        listed = [f"{key} (" + ", ".join(f"{letter(i)} {value}" for i, value in enumerate(values[key])) + ")"
                  for key in differ]
        return ["What differs between the machines: the CPU" + "".join(f", {item}" for item in listed)
                + (f"; {same}." if same else ".")]
    room = column_width(max(len(key) for key in differ), len(files))
    headings = [""] + [_heading(letter(i), f.label, room) for i, f in enumerate(files)]
    return (["What differs between the machines besides the CPU" + (f" ({same}):" if same else ":")]
            + table(headings, [[key] + values[key] for key in differ], width=WIDTH))
