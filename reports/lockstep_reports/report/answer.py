"""The answer a report shows first for one `lockstep run` file (report.answer_of): a table a person reads, built
from the file's answer (its choices and, where the file has it, the answer first; nothing recomputed), the answer's
other lines whole, the entries that errored, and the words they use.

The answer's lines are the terminal's: the choices (a line per thread count and placement, its details
indented under it), then the rest, each fact a line at column 0 with its details indented (false sharing,
migration, pace, what was left out), then the terminal's pointers to the result file and the next commands
(bench/run/answer.cpp, make_headline). The table replaces the choices' lines; the rest is shown whole,
wrapped by the page; the pointers are the terminal's, and the report's own "where the rest is" replaces them.
A run with `--crossover` writes its crossover lines (the answer's crossover) between the answer first and
the choices: they are shown as written, under the answer first, and kept out of the grouping of the others.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..common.fields import UNAVAILABLE
from ..common.formatting import format_ns, format_number
from ..read.run_answer import BestChoice, Choice, Rival
from ..read.run_file import RunFile

# The words of a rival's verdict (its step over the choice's, paired: statistics.VERDICTS): above the noise
# band the rival is slower, below it faster.
RIVAL_VERDICTS = {"penalty": "slower", "gain": "faster", "within noise": "within noise", "unsure": "unsure"}
# The terminal's pointers among the answer's lines (bench/run/answer.cpp): where its result file is, and
# the commands that make this report and a comparison.
TERMINAL_POINTERS = ("Results: ", "Report: ")
# How a lockstep run before whole lines marked a line it cut at its 120 characters.
CUT_MARK = " ..."
CUT_NOTE = " [cut here in the file, by the lockstep run that wrote it]"


@dataclass
class AnswerBox:
    """What the page shows first for one `lockstep run` file. A file without an answer: lines empty, and `note`
    says so in one line. Otherwise: `first`, the answer first ("" for a file without it); `crossover`, the
    crossover lines as the run wrote them (empty without the sweep); the table of choices
    (`headings`, `rows`, `caption`); `findings`, the answer's other facts, each a line and the lines under it,
    whole; `errored`, the entries that errored ("" when none did); `glossary`,
    (word, what it means) for the words the answer uses."""
    label: str
    lines: list[str]
    note: str = ""
    first: str = ""
    crossover: list[str] = field(default_factory=list)  # the answer's crossover lines, as written
    headings: list[str] = field(default_factory=list)
    rows: list[list[str]] = field(default_factory=list)
    caption: str = ""
    findings: list[tuple[str, list[str]]] = field(default_factory=list)
    errored: str = ""
    glossary: list[tuple[str, str]] = field(default_factory=list)


def whole(line: str) -> str:
    """An answer's line as the report shows it: as written, but for a line its writer cut at its width (ending
    " ..."), which is said to be cut in words instead of ending in dots."""
    stripped = line.strip()
    return stripped[:-len(CUT_MARK)].rstrip() + CUT_NOTE if line.endswith(CUT_MARK) else stripped


def line_groups(lines) -> list[list[str]]:
    """The answer's lines by fact: a line at column 0 starts one, the indented lines under it belong to it."""
    groups: list[list[str]] = []
    for line in lines:
        if groups and line[:1].isspace():
            groups[-1].append(line)
        else:
            groups.append([line])
    return groups


def _choices_group(groups) -> int | None:
    """The index of the choices' lines: the first fact with lines under it (the choices come before every
    other fact that has details), None when no fact has any."""
    return next((index for index, group in enumerate(groups) if len(group) > 1), None)


def findings(lines, has_table: bool, has_first: bool) -> tuple[str, list[tuple[str, list[str]]]]:
    """(the choices' title, the other facts): the choices' lines are left out where the table shows them (their
    title becomes its caption), the lines before them where the answer-first object says them, the
    terminal's pointers always."""
    groups = line_groups(lines)
    choices = _choices_group(groups)
    title = ""
    kept = []
    for index, group in enumerate(groups):
        if choices is not None and has_table and index == choices:
            title = whole(group[0]).rstrip(":")
            continue
        if choices is not None and has_first and index < choices:
            continue
        if group[0].startswith(TERMINAL_POINTERS):
            continue
        kept.append((whole(group[0]), [whole(line) for line in group[1:]]))
    return title, kept


def _entry_words(key) -> str:
    """An rk4 entry as the table names it: "<primitive> + <layout>" (its name whole when it has neither)."""
    sync, layout = key.get("sync"), key.get("layout")
    return f"{sync} + {layout}" if sync and layout else (sync or key.display)


def _ratio_words(rival: Rival) -> str:
    return (f"{format_number(rival.median, 2, 'x')} [{format_number(rival.ci_low, 2)}, "
            f"{format_number(rival.ci_high, 2)}], {RIVAL_VERDICTS.get(rival.verdict, rival.verdict)}")


def _where(item: Choice, cpus: int | None) -> str:
    threads = f"{item.threads} thread{'s' if item.threads != 1 else ''}"
    if item.oversubscribed and cpus:
        threads += f" on {cpus} CPUs"
    model = f"model:{item.model}, " if item.model else ""
    return f"{model}{threads}, pin:{item.pin}"


def _step_words(item: Choice) -> str:
    """The choice's median step, its spread, and where the spread comes from when the machine changed pace."""
    words = format_ns(item.ns_per_step)
    if item.spread_pct is not None:
        words += f" ±{format_number(item.spread_pct, 1)} %"
    if item.paces is not None and item.paces >= 2:
        words += f" over {item.paces} paces: uncertain"
    elif item.straddles_pace_change:
        words += ", a repetition straddled a change of pace"
    return words


def _use_words(item: Choice) -> str:
    chosen = _entry_words(item.entry_key)
    if item.tied and item.runner_up is not None:
        return f"{chosen} or {_entry_words(item.runner_up.entry_key)}: tied"
    return chosen


def _runner_up_words(item: Choice) -> str:
    rival = item.runner_up
    if rival is None:
        return ("none: no paired comparison (ranked by the medians only)" if item.basis == "medians"
                else "none measured")
    words = _entry_words(rival.entry_key)
    if item.median_leader and item.median_leader == rival.entry and item.median_leader != item.entry:
        words += " (first by median)"
    return f"{'tied: ' if item.tied else ''}{words}: {_ratio_words(rival)}"


def _baseline_column(choices) -> tuple[str, bool]:
    """The baseline column's heading, and whether each cell names its primitive (when the baselines differ)."""
    syncs = {item.baseline.sync for item in choices if item.baseline is not None}
    if len(syncs) == 1:
        return f"{next(iter(syncs))}: its step / the choice's", False
    return "the baseline: its step / the choice's", True


def _baseline_words(item: Choice, named: bool, baseline_sync: str | None) -> str:
    rival = item.baseline
    if rival is None:
        return "the choice itself" if baseline_sync and item.sync == baseline_sync else "none measured"
    return (f"{_entry_words(rival.entry_key)}: " if named else "") + _ratio_words(rival)


def choices_table(choices, cpus: int | None) -> tuple[list[str], list[list[str]]]:
    """The choices as a table: per thread count and placement, the choice, its step with its spread,
    a stage's sync in c2c transfers, its runner-up (or the tie) and the baseline against it."""
    if not choices:
        return [], []
    baseline_heading, named = _baseline_column(choices)
    syncs = {item.baseline.sync for item in choices if item.baseline is not None}
    baseline_sync = next(iter(syncs)) if len(syncs) == 1 else None
    headings = ["threads, placement", "use", "step (median ± spread)", "a stage's sync, in c2c transfers",
                "runner-up: its step / the choice's", baseline_heading]
    rows = [[_where(item, cpus), _use_words(item), _step_words(item),
             format_number(item.vs_c2c, 2, missing=UNAVAILABLE), _runner_up_words(item),
             _baseline_words(item, named, baseline_sync)] for item in choices]
    return headings, rows


def first_words(best: BestChoice) -> str:
    """The answer first: the run's best combination, and its step against the serial step of its model."""
    words = (f"Best of the run: {best.threads} thread{'s' if best.threads != 1 else ''}, pin:{best.pin}, "
             f"{_entry_words(best.entry_key)}, {format_ns(best.ns_per_step)} a step")
    if best.level:
        others = " and ".join(f"{threads} thread{'s' if threads != 1 else ''}, pin:{pin} ({format_ns(step)})"
                              for threads, pin, step in best.level)
        words += f", tied with {others}: their repetitions overlap and no pair compared them"
    if best.vs_serial is None:
        return words + "."
    serial = f" ({format_ns(best.serial_ns_per_step)})" if best.serial_ns_per_step is not None else ""
    meaning = ("one thread alone computes it faster: the synchronisation costs more than sharing the work saves"
               if best.vs_serial > 1.0 else "sharing the work pays for its synchronisation")
    return f"{words}: {format_number(best.vs_serial, 1, 'x')} the serial step{serial}; {meaning}."


def errored_keys(run_file: RunFile) -> list:
    """The entries of the file that errored (lockstep run marked their repetitions errored: no time), by name."""
    return sorted((key for key, run in run_file.runs.items() if run.errored), key=lambda key: key.sort_key())


def errored_words(run_file: RunFile) -> str:
    """The entries that errored, counted and named; "" when none did."""
    names = errored_keys(run_file)
    if not names:
        return ""
    return (f"Errored: {len(names)} entr{'y' if len(names) == 1 else 'ies'} with failed repetitions, so no "
            f"time: {', '.join(f'{key.display} ({failed_words(run_file.runs[key])})' for key in names)}. Drawn "
            "\"error\" in the heat maps, apart from the cells marked n/a (not run: not applicable); the messages "
            "are in the section \"Errored entries\".")


def failed_words(run) -> str:
    """How many of an errored entry's repetitions failed: "3 of 5 repetitions failed"."""
    return f"{run.failed} of {run.failed + len(run.repetitions)} repetitions failed"


# The words the answer uses, and what each means: said in the answer box, where they first appear.
GLOSSARY = (
    ("step", "one RK4 step of the model by the whole team of threads: the median over the repetitions; ± half "
             "the repetitions' range, as a share of the median."),
    ("pace", "how fast the machine ran at the time: a virtual machine's core-to-core latency and serial step "
             "change for seconds at a time. lockstep run reads both between its blocks of measurement and groups "
             "the readings into pace modes (the section \"Pace of the machine\"). \"Over 2 paces\": the "
             "repetitions ran at two paces, so their spread mixes the two and the step is uncertain."),
    ("c2c transfers a stage", "a stage's synchronisation time in units of this run's core-to-core one-way latency "
                              "(the time one cache line takes to pass from one CPU to another): 1 is one "
                              "transfer, about the least a handoff between two CPUs can cost."),
    ("Nx [low, high]", "a ratio measured as pairs: both entries run side by side in alternating short blocks; "
                       "Nx is the median of the per-pair ratios of their times (in the table: the other's step "
                       "over the choice's, so above 1 the other is slower), [low, high] its 95 % interval."),
    ("slower, faster, within noise, unsure, tied", "a ratio's verdict against the noise band: slower (penalty) "
                                                   "when the whole interval lies above the band, faster (gain) "
                                                   "below it, within noise inside it, unsure across its edge. "
                                                   "Tied: the pair cannot tell the two apart (within noise or "
                                                   "unsure), so both are named."),
    ("one line against apart (false sharing)", "the false-sharing probe: the time of one access with the two "
                                               "threads' words on one cache line over its time with them apart "
                                               "(the distances are in the line), per access pattern: plain "
                                               "stores, atomic read-modify-writes, seq_cst stores, a writer beside "
                                               "a reader (files written before the patterns measured plain stores "
                                               "only: \"a write\"). Penalty: sharing the line made that access "
                                               "slower; gain or within noise: this machine hid false sharing for "
                                               "that pattern."),
    ("collapsed", "an entry that ran with more threads than CPUs at 100 times the best of its kind or more: left "
                  "out of the rankings, ratios and colour scales."),
)


# Said in the glossary of an answer that has crossover lines.
CROSSOVER_WORDS = ("crossover, S*", "from what model size a parallel step beats the serial one (`lockstep run "
                                    "--crossover`): the chain of S masses (2S equations) stepped by the team "
                                    "against the serial step of the same chain, paired side by side; S* is where "
                                    "the speedup serial / parallel crosses 1, [low, high] where its 95 % interval "
                                    "does, confirmed by a size above it whose whole interval clears 1. The section "
                                    "\"Crossover\" draws every point and the model beside it.")


def answer_of(run_file: RunFile, cpus: int | None) -> AnswerBox:
    """The answer box of a run file with an answer (report.answer_of says it when the file has none)."""
    answer = run_file.answer
    headings, rows = choices_table(answer.choices, cpus)
    first = first_words(answer.best) if answer.best is not None else ""
    crossover = set(answer.crossover)
    title, facts = findings([line for line in answer.lines if line not in crossover], bool(rows), bool(first))
    caption = ""
    if rows:
        caption = ((title + ". ") if title else "") + ("Each ratio is the other's step over the choice's, measured "
                                                       "side by side (above 1: the other is slower).")
    return AnswerBox(run_file.label, list(answer.lines), first=first,
                     crossover=[whole(line) for line in answer.crossover], headings=headings, rows=rows,
                     caption=caption, findings=facts, errored=errored_words(run_file),
                     glossary=list(GLOSSARY) + ([CROSSOVER_WORDS] if answer.crossover else []))
