"""`lockstep report RESULT... [--out DIR]`: one self-contained HTML page and one Markdown file.

The results become Sections (title, paragraphs, tables, figures); two jinja2
templates (templates/) render them: report.html.j2, autoescaped, carries its
figures as inline SVG and its style inline and loads nothing from anywhere (a
few lines of script record, on the <body> element, how many figures the
browser laid out and whether any error occurred: the browser test reads them
back); report.md.j2 shows the same tables and links the same figures, written
as SVG files under figures/. The whole directory is written at once
(output.write_directory).

Deterministic: the same inputs give the same bytes (figures.py fixes
matplotlib's hash salt and drops its date; nothing here reads the clock).
"""
from __future__ import annotations

import functools
import os
import re
from dataclasses import dataclass, field

import jinja2
import markupsafe

from ..analysis.normalisation import fingerprint, layout_effects, rank_tables
from ..analysis.run_analysis import against_best_other_views, calibration, mode_medians, run_median, sharing_layout
from ..common import statistics, words
from ..common.fields import (DELAY_SETTINGS, DISTRIBUTION_STATISTICS, FINGERPRINT_KEYS, PINGPONG_P50_COUNTER,
                             SERIAL_CONTEXT, STEP_SPLIT_COUNTERS, UNAVAILABLE)
from ..common.formatting import format_count, format_crossover, format_duration, format_ns, format_number, format_rate
from ..common.names import parse_name
from ..common.output import FIGURES_DIRECTORY, HTML_PAGE, MARKDOWN_PAGE, PAGES, write_directory
from ..read.c2c_reader import C2cFile
from ..read.delay_reader import DelayExtras, DelayFile
from ..read.inputs import load_any, unique_labels
from ..read.run_file import RunFile
from ..read.verify_reader import VerifyFile
from . import answer, c2c_analysis, figures, matrix, paper
from .answer import AnswerBox
TEMPLATES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "templates")


@dataclass
class Table:
    headings: list[str]
    rows: list[list[str]]
    caption: str = ""


@dataclass
class Figure:
    slug: str
    title: str
    svg: str
    caption: str = ""


@dataclass
class Section:
    title: str
    paragraphs: list[str] = field(default_factory=list)
    tables: list[Table] = field(default_factory=list)
    figures: list[Figure] = field(default_factory=list)
    open: bool = False  # shown open in the HTML page (the first sections); the others open on a click


# ---------------------------------------------------------------- sections

def inputs_table(loaded) -> Table:
    kinds = {RunFile: "benchmark results (`lockstep run`)", C2cFile: "core-to-core latency (`lockstep c2c`)",
             DelayFile: "paced delay run (`lockstep delay`)", VerifyFile: "trajectory (`lockstep verify --csv`)"}
    rows = [[item.label, "the step across MPI ranks (`lockstep mpi`)" if getattr(item, "mpi", None) else
             kinds[type(item)]] for item in loaded]
    return Table(["file", "kind"], rows, caption="The inputs of this report")


def machines_section(loaded, run_files: list[RunFile]) -> Section:
    """The inputs and each result file's context (the raw fingerprint table): what a comparison across machines
    needs, kept at the end of the page."""
    tables = [inputs_table(loaded)]
    paragraphs = ["The inputs of this report, and each result file's context: what a comparison across machines "
                  "needs. `lockstep compare` tests the differences."]
    if run_files:
        prints = [fingerprint(f) for f in run_files]
        rows = [[key] + [p[key] or UNAVAILABLE for p in prints] for key in FINGERPRINT_KEYS]
        tables.append(Table(["context"] + [f.label for f in run_files], rows))
    if len(run_files) > 1:
        reference = sharing_layout(run_files[0])
        effects = [[sync, pin, str(threads), layout] + [format_number(s, 2, "x") for s in speedups]
                   for sync, pin, threads, layout, speedups in layout_effects(run_files, reference)]
        tables.append(Table(["sync", "pin", "threads", "layout"] + [f"{f.label}: vs {reference}" for f in run_files],
                            effects, caption=f"Each layout's speed-up over {reference} ({reference} time / layout "
                                             "time), on each machine: the false-sharing effect read side by side."))
    return Section("Machines and inputs", paragraphs=paragraphs, tables=tables)


# Where the rest is, said under the answers: on the page, and in the Markdown file.
WHERE_THE_RESULTS_ARE = {
    "html": "The full results: the sections below, each opened by a click on its title (the first ones are open); "
            "the inputs, the machines' context and the raw tables in the last sections. report.md beside this page "
            "holds the same in Markdown, figures/ each figure as SVG, and the result files every number "
            "(`lockstep run --verbose` prints every table).",
    "markdown": "The full results: the sections below; the inputs, the machines' context and the raw tables in the "
                "last sections. report.html beside this file holds the same as one page, figures/ each figure as "
                "SVG, and the result files every number (`lockstep run --verbose` prints every table).",
}


def answer_of(run_file: RunFile) -> AnswerBox:
    """The run's answer (answer.py: the table of its choices, its other facts whole, what errored, the words
    it uses), or one line saying the file has none."""
    if run_file.answer is None:
        return AnswerBox(run_file.label, [], f"{run_file.label} has no answer (lockstep_answer, or lockstep_headline "
                                             f"before that name, is {UNAVAILABLE}: its `lockstep run` is older than the "
                                             "saved answer); its results are in the sections below.")
    return answer.answer_of(run_file, _machine_cpus(run_file))


def collapsed_line(run_file: RunFile) -> str:
    """One line naming the entries the run found collapsed (its answer's), with the range of their medians;
    "" when none did."""
    keys = sorted(run_file.collapsed, key=lambda key: key.sort_key())
    if not keys:
        return ""
    syncs = sorted({key.get("sync") or key.display for key in keys})
    threads = sorted({key.threads for key in keys if key.threads is not None})
    medians = [value for value in (run_median(run_file, key) for key in keys) if value is not None]
    units = sorted({"an episode" if key.family == "barrier" else "a step" for key in keys})
    spread = (f"{format_ns(min(medians), 3)}-{format_ns(max(medians), 3)} {' or '.join(units)}" if medians
              else f"their times {UNAVAILABLE} in this file")
    at = f" (at {', '.join(f'{count} threads' for count in threads)})" if threads else ""
    return (f"Collapse when threads outnumber CPUs: {', '.join(syncs)}{at}, {spread}; left out of the rankings, "
            "ratios and colour scales below (the run's answer lists them).")


def errored_section(run_file: RunFile, errored: list) -> Section:
    """The entries that errored, each with its messages as the file holds them (whole)."""
    rows = [[key.display, answer.failed_words(run_file.runs[key]), "; ".join(run_file.runs[key].errors)]
            for key in errored]
    return Section(f"Errored entries: {run_file.label}", paragraphs=[
        f"Errored: {len(errored)} entr{'y' if len(errored) == 1 else 'ies'} whose repetitions failed (lockstep run "
        "marked them errored: their times are not a measurement). An entry with a failed repetition gets no time "
        "here: it is left out of every figure, ranking and ratio (the repetitions that finished stay in the file) "
        "and drawn \"error\" in the heat maps. The messages are lockstep run's, as the file holds them."],
        tables=[Table(["entry", "repetitions", "what failed"], rows)])


def chosen_cell(run_file: RunFile, pin: str, threads: int) -> tuple[str, str] | None:
    """(sync, layout) the run's answer chose at this placement and thread count, if it has one."""
    if run_file.answer is None:
        return None
    return next(((item.sync, item.layout) for item in run_file.answer.choices
                 if item.pin == pin and item.threads == threads), None)


def run_sections(run_file: RunFile, counter: list[int]) -> list[Section]:
    sections = []
    groups = matrix.rk4_groups(run_file)
    if not groups:
        return [Section(f"Results: {run_file.label}",
                        paragraphs=["No `rk4/sync:.../layout:.../pin:.../threads:...` entries in this file."])]
    collapsed = run_file.collapsed
    errored = answer.errored_keys(run_file)
    heat = Section(f"Step time, sync x layout: {run_file.label}",
                   paragraphs=["Median step time of each synchronisation primitive (rows, fastest first) with each "
                               "data layout (columns), one map per placement (pin) and thread count. Darker is "
                               "slower; n/a: the combination was not run (not applicable)."
                               + (f" error, hatched red: the entry ran and failed, so it has no time ({len(errored)} "
                                  "in this file: the section \"Errored entries\")."
                                  if errored else "")])
    if any(chosen_cell(run_file, pin, threads) for pin, threads in groups):
        heat.paragraphs.append("Outlined in red: the combination the run's answer chose there.")
    bars = Section(f"Spread per primitive: {run_file.label}",
                   paragraphs=["Per primitive (fastest first), one bar per layout at the median over repetitions, "
                               "whiskers over the interquartile range, one dot per repetition."])
    left_out = collapsed_line(run_file)
    if left_out:
        heat.paragraphs.append(left_out + " Their cells are grey.")
        bars.paragraphs.append(left_out)
    noisy_cells = matrix.within_noise_cells(run_file)
    if noisy_cells:
        heat.paragraphs.append(f"Hatched, marked ≈: the {sharing_layout(run_file)} cell whose paired false-sharing "
                               "ratio against its padded layout was within noise or unsure (its confidence interval "
                               "lies inside the noise band, or straddles its edge): the two cells do not differ "
                               "measurably.")
    for pin, threads in groups:
        heat.figures.append(Figure(f"heatmap-{counter[0]}-{pin}-{threads}", f"pin:{pin}, {threads} threads",
                                   figures.heatmap(matrix.heatmap_cells(
                                       run_file, pin, threads, noisy_cells.get((pin, threads), frozenset()),
                                       collapsed, chosen_cell(run_file, pin, threads)))))
        bars.figures.append(Figure(f"bars-{counter[0]}-{pin}-{threads}", f"pin:{pin}, {threads} threads",
                                   figures.bars_with_spread(matrix.spread_bars(run_file, pin, threads, collapsed))))
    sections += [heat, bars, cpu_section(run_file, counter)]
    if errored:
        sections.append(errored_section(run_file, errored))
    split = split_section(run_file, counter)
    if split:
        sections.append(split)
    if run_file.pairs:
        best_other = best_other_section(run_file, counter)
        if best_other:
            sections.append(best_other)
    penalty = penalty_section(run_file, counter)
    if penalty:
        sections.append(penalty)
    if run_file.scaling is not None and len(run_file.scaling.threads) >= 2:
        sections.append(scaling_section(run_file, counter))
    crossover = crossover_section(run_file, counter)
    if crossover:
        sections.append(crossover)
    if run_file.pace is not None:
        sections.append(pace_section(run_file, counter))
    if run_file.pairs:
        sections.append(pairs_section(run_file, counter))
    rank_rows = []
    for (pin, threads), per_file in rank_tables([run_file], top=5).items():
        for rank, (name, step, vs_serial) in enumerate(per_file[0], start=1):
            rank_rows.append([f"pin:{pin} threads:{threads}", str(rank), name, format_ns(step),
                              format_number(vs_serial, 2, "x")])
    paragraphs = ["The five fastest sync/layout pairs per placement and thread count; x serial is the step time over "
                  "this run's serial RK4 step."]
    if left_out:
        paragraphs.append("Collapsed entries are not ranked.")
    sections.append(Section(f"Fastest combinations: {run_file.label}", paragraphs=paragraphs,
                            tables=[Table(["group", "rank", "sync/layout", "step (median)", "x serial"], rank_rows)]))
    counter[0] += 1
    return sections


def _machine_cpus(run_file: RunFile) -> int | None:
    """The CPUs of the machine the run measured on (its context's num_cpus), None when the file lacks it."""
    cpus = run_file.context.get("num_cpus")
    return cpus if isinstance(cpus, int) and not isinstance(cpus, bool) and cpus > 0 else None


# What the CPU figure tells a user who shares the machine, said under its title.
CPU_FIGURE_READING = (
    "One point per entry: its median time per step (x) against the median CPU time its whole team burned per step "
    "(y: every participant's thread CPU clock, summed; team_cpu_ns_per_step), marker by placement, colour by "
    "layout, one panel per thread count. On the dashed line k the team kept k CPUs busy the whole step. A "
    "spinning primitive sits on k = its threads (or on the CPUs there are, when the threads outnumber them): it "
    "burns threads x its step whether or not the others have arrived, and takes those CPUs from anything else "
    "on the machine. A primitive that sleeps while it waits sits below: it leaves the rest of the step's CPU "
    "to other programs, at the price of the wake-up in its step time. Sharing the machine, read the fastest "
    "point that sits low enough; alone on it, read x only. Named: the fastest primitives (each at its fastest "
    "entry) and the entry that keeps the fewest CPUs busy.")


def cpu_section(run_file: RunFile, counter: list[int]) -> Section:
    """Step time against the team's CPU per step, one figure for the rk4 entries and one for the bare
    barriers; a file without team_cpu_* (written before it) gets one line saying why there is no figure."""
    title = f"Step time against CPU per step: {run_file.label}"
    collapsed = run_file.collapsed
    families = [(family, unit, matrix.cpu_points(run_file, family, collapsed))
                for family, unit in (("rk4", "step"), ("barrier", "episode"))]
    if not any(points for _, _, points in families):
        return Section(title, paragraphs=[
            f"No figure: {run_file.label} has no team CPU time per step (the counter team_cpu_ns_per_step, "
            f"{UNAVAILABLE} in this file: its `lockstep run` is older than the counter)."])
    section = Section(title, paragraphs=[CPU_FIGURE_READING])
    left_out = sum(1 for key in collapsed if key.family in ("rk4", "barrier"))
    if left_out:
        section.paragraphs.append(f"Not drawn: the {left_out} collapsed entries (the run's answer lists them).")
    cpus = _machine_cpus(run_file)
    chosen = frozenset(item.entry_key for item in run_file.answer.choices) if run_file.answer else frozenset()
    if any(point.key in chosen for _, _, points in families for point in points):
        section.paragraphs.append("Ringed in red: the combination the run's answer chose at each placement and "
                                  "thread count.")
    for family, unit, points in families:
        if points:
            what = "the RK4 step (rk4/ entries)" if family == "rk4" else "the bare barrier (barrier/ entries)"
            section.figures.append(Figure(f"cpu-{counter[0]}-{family}", f"{what}, {len(points)} entries",
                                          figures.cpu_against_time(points, unit, cpus, chosen,
                                                                    matrix.syncs_layouts(run_file)[1])))
    if any(family == "barrier" and points for family, _, points in families):
        section.paragraphs.append("The barrier/ entries time the bare barrier, without the RK4 stages: per episode "
                                  "(one arrive_and_wait by every participant), read the same way.")
    return section


# What "Where a step's time goes" shows, and why (reports/README.md says the same).
SPLIT_READING = (
    "Each primitive at its fastest layout, its step split in three: computing the stages, waiting for the others "
    "to arrive, and the release (from the latest awaited arrival to the departure: the synchronisation itself). "
    "A step late for waiting is late because another participant was; a long release is the primitive's own "
    "cost. Each split is one repetition's, the entry's median one (the repetition whose step is the median), "
    "as lockstep run wrote it: the writer times the two parts of the four stage syncs on sampled steps and "
    "writes compute as the step less those syncs, so the three parts add up to that repetition's step exactly. "
    "A split of medians would not: each part's median comes from another repetition, and on a machine that "
    "changes pace they can differ severalfold. The bars are shares of the step, the step at each bar's end.")
CLAMPED_READING = (
    "Hatched, compute \"not measured\": the sampled syncs took the whole step or more (the writer then clamps "
    "compute at 0, a value no measurement gave), so the split does not add up: the two sync parts are shown as "
    "measured, past the step's line, and no compute is made up for them. The syncs are timed on sampled steps "
    "and carry their own error, which can exceed a participant's compute when that is small beside the syncs")


def _split_row(where: str, split: matrix.StepSplit) -> list[str]:
    compute = "not measured (clamped)" if split.clamped else format_ns(split.parts_ns[0])
    share = split.syncs_ns / split.step_ns
    syncs = f"{format_number(100 * share, 0, ' %')}" + (": more than the step" if share > 1.0 else "")
    return ([where, f"{split.key.get('sync')} + {split.key.get('layout')}", format_ns(split.step_ns), compute]
            + [format_ns(part) for part in split.parts_ns[1:]]
            + [syncs, f"{split.clamped_repetitions} of {split.repetitions}"])


def split_section(run_file: RunFile, counter: list[int]) -> Section | None:
    """Where an rk4 step's time goes (compute, waiting for the others, release), per primitive at its fastest
    layout (its median repetition: matrix.StepSplit), one figure per placement and thread count and a table;
    a split whose syncs took the step or more marked, not made to add up. None for a file without the split
    (written before it)."""
    groups = [(pin, threads, matrix.step_splits(run_file, pin, threads, run_file.collapsed))
              for pin, threads in matrix.rk4_groups(run_file)]
    if not any(splits for _, _, splits in groups):
        return None
    names = [word for _, word in STEP_SPLIT_COUNTERS]
    section = Section(f"Where a step's time goes: {run_file.label}", paragraphs=[SPLIT_READING])
    rows = []
    for pin, threads, splits in groups:
        if not splits:
            continue
        where = f"pin:{pin}, {threads} thread{'s' if threads != 1 else ''}"
        section.figures.append(Figure(f"split-{counter[0]}-{pin}-{threads}", where, figures.step_split_bars(
            splits, f"where the step goes, each primitive at its fastest layout, {where}")))
        rows += [_split_row(where, split) for split in splits]
    clamped = sum(1 for _, _, splits in groups for split in splits if split.clamped)
    if clamped:
        serial = calibration(run_file, SERIAL_CONTEXT)
        scale = (f": the serial step, all of a step's work on one thread, is {format_ns(serial)} here, and a "
                 "participant computes its share of it" if serial else "")
        section.paragraphs.append(f"{CLAMPED_READING}{scale}. {clamped} of the {len(rows)} splits shown are so.")
    section.tables.append(Table(
        ["group", "sync + layout", "step (the median repetition)"] + names
        + ["the syncs: share of the step", "repetitions with compute clamped"], rows,
        caption="The split of each entry's median repetition, as written (docs/names-and-counters.md). Compute "
                "is the step less the syncs (waiting + release): where it was measured the three add up to the "
                "step; \"not measured (clamped)\": the syncs took the whole step or more. The last column counts "
                "the entry's repetitions so clamped."))
    return section


def _pingpong_one_way(run_file: RunFile) -> tuple[float | None, str]:
    """The ping-pong's one-way time, median over the rounds, and what it is: the p50 of the round trips / 2
    where every round has it (one_way_p50_ns), else their mean (the entry's time, OSU style)."""
    pingpongs = [run for key, run in run_file.runs.items() if key.family == "mpi" and key.get("pingpong") == ""]
    if not pingpongs or pingpongs[0].errored:
        return None, "p50"
    run = pingpongs[0]
    values = run.counter_values(PINGPONG_P50_COUNTER)
    if values and len(values) == len(run.repetitions):
        return statistics.median(values), "p50"
    return run_median(run_file, run.key), "mean"


def mpi_section(run_file: RunFile, counter: list[int]) -> Section:
    """A `lockstep mpi` file: per-stage exchange latency and arrival skew per exchange (its last round's
    details), beside the ping-pong; the step time per exchange over the rounds."""
    mpi = run_file.mpi
    pingpong, pingpong_what = _pingpong_one_way(run_file)
    title = (f"{mpi.ranks} ranks on {mpi.hosts} host{'s' if mpi.hosts != 1 else ''}, {mpi.transport} transport, "
             f"model {mpi.model}")
    latency = Figure(f"mpi-latency-{counter[0]}", f"per-stage exchange latency, {run_file.label}",
                     figures.mpi_distributions(mpi.exchanges, "stage", ("p50", "p99", "p999", "max"),
                                               f"per-stage exchange latency ({title})", pingpong,
                                               f"ping-pong one-way {pingpong_what}", "latency of a stage (log)"))
    skew = Figure(f"mpi-skew-{counter[0]}", f"per-stage arrival skew, {run_file.label}",
                  figures.mpi_distributions(mpi.exchanges, "skew", ("p50", "p99", "max"),
                                            f"arrival skew per stage: latest minus earliest rank ({title})",
                                            ylabel="arrival skew (log)"))
    rows = []
    for exchange in mpi.exchanges:
        run = run_file.runs.get(parse_name(exchange.name))
        step = run_median(run_file, run.key) if run else None
        counts = exchange.slowest_counts
        total = sum(counts)
        slowest = max(range(len(counts)), key=counts.__getitem__) if counts else None
        rows.append([exchange.label, format_ns(step)] +
                    [format_ns(exchange.stage.get(key)) for key in ("p50", "p99", "p999", "max")] +
                    [format_ns(exchange.skew.get(key)) for key in ("p50", "p99", "max")] +
                    [f"{slowest} ({100.0 * counts[slowest] / total:.0f} %)" if total else UNAVAILABLE])
    paragraphs = [f"{title}. Per exchange: the step time (median over the rounds), each stage's exchange "
                  "latency at each rank (the last round, every rank and stage pooled), and the arrival skew per "
                  "stage (the latest rank's arrival minus the earliest's) with the rank that arrived last most "
                  "often. The dashed line is the 2-rank ping-pong's one-way time, timed as osu_latency times it "
                  f"({pingpong_what}, median over the rounds)" + (f": {format_ns(pingpong)}." if pingpong else ".")]
    for label, reason in mpi.not_applicable:
        paragraphs.append(f"Not applicable: {label}: {reason}")
    counter[0] += 1
    return Section(f"The step across MPI ranks: {run_file.label}", paragraphs=paragraphs, figures=[latency, skew],
                   tables=[Table(["exchange", "step (median)", "stage p50", "p99", "p99.9", "max", "skew p50",
                                  "skew p99", "skew max", "slowest rank"], rows)])


def _separation(curve, by_sync) -> str:
    """Whether the best at the largest count is apart from the primitives next to it: those whose min..max over
    repetitions overlaps the best's are named, as the run does not separate them."""
    last = curve.threads[-1]
    best = by_sync[curve.best].get(last)
    if best is None or best.range_ns is None:
        return ""
    tied = sorted(sync for sync, points in by_sync.items()
                  if sync != curve.best and len(points) == len(curve.threads) and last in points
                  and points[last].range_ns is not None and points[last].range_ns[0] <= best.range_ns[1])
    if not tied:
        return "; its repetitions' range is clear of every other primitive's"
    return f"; not separated from {', '.join(tied)}: their repetitions' ranges overlap its"


def scaling_section(run_file: RunFile, counter: list[int]) -> Section:
    curve = run_file.scaling
    what = "sync time per stage" if curve.counter == "sync_ns_per_stage" else "step time"
    paragraphs = [f"`lockstep run --scaling`: the {what} of each primitive against the thread count, at "
                  f"pin:{curve.pin}, each on the layout that was fastest at that count. Beyond four threads the "
                  "model is an s-mass chain with one equation per thread, whose consumers wait for their two "
                  "neighbours while a barrier waits for every thread. Hollow markers: more threads than CPUs."]
    by_sync = {}
    for point in curve.points:
        by_sync.setdefault(point.sync, {})[point.threads] = point
    if curve.best:
        paragraphs.append(f"Scales best: {curve.best} (the lowest {what} at {curve.threads[-1]} threads among the "
                          f"primitives measured at every count){_separation(curve, by_sync)}.")
    rows = []
    for sync in sorted(by_sync):
        rows.append([sync] + [format_ns(by_sync[sync][t].value_ns) + ("*" if by_sync[sync][t].oversubscribed else "")
                              if t in by_sync[sync] else "n/a" for t in curve.threads])
    return Section(f"Scaling: {run_file.label}", paragraphs=paragraphs,
                   figures=[Figure(f"scaling-{counter[0]}", f"{what} against threads",
                                   figures.scaling_curve(curve))],
                   tables=[Table(["primitive"] + [f"{t} threads" for t in curve.threads], rows)])


# Why a crossover series or the sweep stopped (lockstep_crossover's stop_reason: bench/run/crossover.cpp), in words.
CROSSOVER_STOPS = {"confirmed": "two sizes in a row clear of 1", "budget": "the sweep's budget ran out",
                   "largest_size": "the largest size"}
# A crossover's status (answer_reader.CROSSOVER_STATUSES) in words.
CROSSOVER_STATUS_WORDS = {"crossed": "crossed", "crossed_unconfirmed": "crossed, unconfirmed",
                          "none_within_sweep": "none within the sweep", "always": "pays off at every size measured"}
# A point's verdict (fields.PAIR_VERDICTS) is its speedup's, serial / parallel, against the noise band: above it
# ("penalty": the serial step is the slower) the parallel step is faster.
SPEEDUP_VERDICTS = {"penalty": "parallel faster", "gain": "parallel slower", "within noise": "within noise",
                    "unsure": "unsure"}


def _masses(value: float | None) -> str:
    return f"{value:.0f}" if value is not None else ""


def _series_name(crossover) -> str:
    return f"{crossover.sync} + {crossover.layout}" if crossover.layout else crossover.sync


def _pairs_text(point) -> str:
    """A point's pairs kept, and those set aside where there were any."""
    return f"{point.pairs} ({point.pairs_set_aside} set aside)" if point.pairs_set_aside else str(point.pairs)


def _speedup_text(point) -> str:
    """A point's paired speedup with its interval: "1.93x [1.78, 2.06]"."""
    return (f"{format_number(point.speedup, 2, 'x')} [{format_number(point.ci_low, 2)}, "
            f"{format_number(point.ci_high, 2)}]")


def _ceiling_rows(sweep) -> list[list[str]]:
    """One row per size of each ceiling the sweep measured (none in a file without them)."""
    rows = []
    for ceiling in sweep.ceilings if sweep else ():
        where = f"{ceiling.threads}, pin:{ceiling.pin}"
        for point in ceiling.points:
            rows.append([where, str(point.masses), format_ns(point.serial_ns), format_ns(point.blocks_ns),
                         _speedup_text(point), _pairs_text(point)] if point.measured else
                        [where, str(point.masses), "", "", point.failure or "not measured", _pairs_text(point)])
    return rows


def _crossover_rows(series) -> tuple[list[list[str]], list[list[str]]]:
    """(one row per series, one row per point) for the crossover section's tables. A thread count's first
    leading series is the run's choice, a later one the rival tied with it (lockstep run plans them so)."""
    rows, points = [], []
    led = set()
    for crossover in series:
        where = f"{crossover.threads} threads" + (f", pin:{crossover.pin}" if crossover.pin else "")
        role = ""
        if crossover.leader:
            role = " (tied with the run's choice)" if (crossover.threads, crossover.pin) in led else " (the run's leader)"
            led.add((crossover.threads, crossover.pin))
        checked = (f"confirmed at {_masses(crossover.confirmed_at)}" if crossover.confirmed_at is not None else
                   f"contradicted at {_masses(crossover.contradicted_at)}" if crossover.contradicted_at is not None
                   else "")
        rows.append([where, _series_name(crossover) + role,
                     format_crossover(crossover), CROSSOVER_STATUS_WORDS.get(crossover.status, crossover.status),
                     checked,
                     format_ns(crossover.stage_sync_ns) if crossover.stage_sync_ns is not None else UNAVAILABLE,
                     CROSSOVER_STOPS.get(crossover.stop_reason, crossover.stop_reason)])
        for point in crossover.points:
            head = [f"{crossover.threads}, {crossover.sync}", str(point.masses)]
            pairs = _pairs_text(point)
            if not point.measured:
                points.append(head + ["", "", point.failure or "not measured", "", pairs, "", "", ""])
                continue
            points.append(head + [format_ns(point.serial_ns), format_ns(point.parallel_ns),
                                  _speedup_text(point),
                                  SPEEDUP_VERDICTS.get(point.verdict, point.verdict or ""), pairs,
                                  format_ns(point.model_ns) if point.model_ns is not None else UNAVAILABLE,
                                  format_number(point.measured_over_model, 2, "x", missing=UNAVAILABLE),
                                  format_number(point.of_ceiling, 2, missing=UNAVAILABLE)])
    return rows, points


def crossover_section(run_file: RunFile, counter: list[int]) -> Section | None:
    """`lockstep run --crossover`: the run's crossover lines as written, one figure per thread count (step time
    against S, the crossover marked, the model beside), the series and their points as the file holds them; None
    for a file without the sweep."""
    sweep = run_file.crossover
    found = sweep.crossovers if sweep else ()
    if not found:
        return None
    lines = run_file.answer.crossover if run_file.answer and run_file.answer.crossover else sweep.lines
    paragraphs = [f"The run's answer: {line}" for line in lines]
    paragraphs.append(
        "`lockstep run --crossover`: from what model size a parallel step pays off. Per thread count, the step time "
        "of the chain of S masses (2S equations) against S, log-log: each primitive on its layout (solid), the "
        "serial step of the same S it was paired with side by side (black, hollow markers), and beside each series "
        "the model's step (dashed: the serial step / T plus the measured sync of each RK4 stage); grey, dash-dot: "
        "the machine's ceiling, the chain's blocks stepped at once with no exchange and no sync. Dotted: the "
        "crossover S*, where the speedup serial / parallel crosses 1; shaded: its interval, where the speedup's 95 % "
        "interval crosses 1 (an open end, beyond the sizes measured, runs to the edge, lighter). A size whose pairs "
        "were all set aside (another process took a CPU) has no point.")
    if sweep and sweep.spent_s is not None:
        budget = f" of its {sweep.budget_s:g} s budget" if sweep.budget_s is not None else ""
        per_point = f", {sweep.pairs_per_point} pairs a size" if sweep.pairs_per_point is not None else ""
        stop = CROSSOVER_STOPS.get(sweep.stop_reason, sweep.stop_reason)
        paragraphs.append(f"The sweep took {sweep.spent_s:.1f} s{budget}{per_point}"
                          + (f"; stopped: {stop}." if stop else "."))
    section = Section(f"Crossover: {run_file.label}", paragraphs=paragraphs)
    for threads in sorted({crossover.threads for crossover in found}):
        series = [crossover for crossover in found if crossover.threads == threads]
        pins = sorted({crossover.pin for crossover in series if crossover.pin})
        title = f"step time against S, {threads} threads" + (f", pin:{', '.join(pins)}" if pins else "")
        labels = [f"{_series_name(crossover)}: S* {format_crossover(crossover)}" for crossover in series]
        ceiling = next((each for each in (sweep.ceilings if sweep else ()) if each.threads == threads), None)
        section.figures.append(Figure(f"crossover-{counter[0]}-{threads}", title,
                                      figures.crossover_curves(series, labels, title, ceiling)))
    rows, points = _crossover_rows(found)
    section.tables += [
        Table(["threads, placement", "primitive + layout", "S* (masses) [interval]", "status", "checked",
               "a stage's sync (model)", "stopped"], rows, caption="Each series' crossover as the run found it."),
        Table(["threads, primitive", "S", "serial step", "parallel step", "speedup [95 % interval]", "verdict",
               "pairs", "model", "measured / model", "of the ceiling"], points,
              caption="Every size swept, as the file holds it: the medians of the pairs and the paired speedup; "
                      "of the ceiling: the speedup over the ceiling's at that size (medians).")]
    ceiling_rows = _ceiling_rows(sweep)
    if ceiling_rows:
        section.tables.append(Table(
            ["threads, placement", "S", "serial step", "the blocks at once", "speedup [95 % interval]", "pairs"],
            ceiling_rows, caption="The machine's ceiling: the chain's blocks (those the partition gives the threads) "
                                  "stepped at once with no exchange and no sync, paired with the serial step: what the "
                                  "machine gives an even split with no sync to pay (a reference, not a bound)."))
    return section


def penalty_table(rows: list[matrix.PenaltyRow]) -> Table:
    """One line per bar of the penalties figure: what it compares, for which primitive, placement and thread
    count, its ratio and (a paired one) its interval and verdict."""
    lines = []
    for row in sorted(rows, key=lambda row: (row.kind, row.threads, row.pin, row.sync)):
        paired = row.ci_low is not None and row.ci_high is not None
        lines.append([row.kind, row.sync, row.pin, str(row.threads), format_number(row.ratio, 2, "x"),
                      f"[{format_number(row.ci_low, 2)}, {format_number(row.ci_high, 2)}]" if paired else "",
                      row.verdict or ("" if paired else "ratio of medians")])
    return Table(["comparison", "primitive", "placement", "threads", "ratio", "interval", "verdict"], lines)


PAIRED_PENALTIES = {"false_sharing": "false sharing (paired): shared lines / isolated",
                    "migration": "migration (paired): pin:{pin} / pin:{pinned}"}


def _threads_words(threads) -> str:
    return f"{threads} thread{'s' if threads != 1 else ''}"


def pair_label(pair) -> str:
    """What a paired bar compares, in a few words: the primitive(s) first, then what differs and where
    ("<a's primitive> vs <b's> (step, pin:compact, 4 threads)", "<primitive>, pin:none, 2 threads: <a's layout> vs
    <b's layout>")."""
    a, b = pair.a_key, pair.b_key
    threads = _threads_words(a.threads) if a.threads is not None else ""
    if pair.comparison == "against_best_other":
        what = "episode" if a.family == "barrier" else "step"
        where = ", ".join(part for part in (what, f"pin:{a.get('pin')}" if a.get("pin") else "", threads) if part)
        return f"{a.get('sync') or a.display} vs {b.get('sync') or b.display} ({where})"
    if pair.comparison == "false_sharing":
        return (f"{a.get('sync')}, pin:{a.get('pin')}, {threads}: {a.get('layout')} vs {b.get('layout')}")
    if pair.comparison == "migration":
        return f"{a.get('sync')}, {threads} ({a.get('layout')}): pin:{a.get('pin')} vs pin:{b.get('pin')}"
    return _difference(a, b).replace(" / ", " vs ")


def _drawn_as_penalty(pair) -> bool:
    """A pair the penalties draw: false sharing or migration, of a primitive at a thread count."""
    return pair.comparison in PAIRED_PENALTIES and bool(pair.a_key.get("sync")) and pair.a_key.threads is not None


def paired_penalty_rows(run_file: RunFile) -> list[matrix.PenaltyRow]:
    """The false-sharing and migration penalties measured as pairs (lockstep_pairs), with their intervals."""
    rows = []
    for pair in run_file.pairs:
        if _drawn_as_penalty(pair):
            kind = PAIRED_PENALTIES[pair.comparison].format(pin=pair.a_key.get("pin"), pinned=pair.b_key.get("pin"))
            rows.append(matrix.PenaltyRow(kind, pair.a_key.get("sync"), pair.a_key.threads, pair.median,
                                           pair.ci_low, pair.ci_high, pair.verdict, pin=pair.a_key.get("pin") or "",
                                           label=pair_label(pair)))
    return rows


def _pins_words(pins) -> str:
    return ", ".join(f"pin:{pin}" for pin in matrix.ordered(pins, words.PIN_ORDER))


def penalty_section(run_file: RunFile, counter: list[int]) -> Section | None:
    paired = paired_penalty_rows(run_file)
    # What the file measured as pairs is drawn from its pairs; the rest from the medians (matrix.penalty_rows).
    paired_kinds = {pair.comparison for pair in run_file.pairs if _drawn_as_penalty(pair)}
    rows = paired + matrix.penalty_rows(run_file, run_file.collapsed, paired_kinds)
    if not rows:
        return None
    sharing = [row for row in rows if row.kind.startswith("false sharing")]
    moving = [row for row in rows if row.kind.startswith("migration")]
    paragraphs = []
    if sharing:
        paragraphs.append("False sharing: the step time of the layout whose writers share cache lines "
                          f"({sharing_layout(run_file) or UNAVAILABLE}) over the layout that keeps them apart, per "
                          f"primitive at each placement measured: {_pins_words({row.pin for row in sharing})}.")
    if moving:
        paragraphs.append("Migration: the step time with the threads "
                          + " or ".join(sorted({words.placement_move(row.pin) for row in moving}))
                          + " over the same entry pinned compactly (pin:compact).")
    paragraphs.append("One bar per primitive, placement and thread count, named on its line. 1.0x is no penalty; "
                      "the ratio axis is logarithmic (a 2x penalty and a 2x gain lie equally far from 1) and covers "
                      "every bar.")
    noise = None
    if run_file.pace is not None and not paired:
        paragraphs.append(f"Paired ratios {UNAVAILABLE}: this file has a pace trace but no false-sharing or "
                          "migration pairs (lockstep_pairs); the ratios below are of the entries' medians, which "
                          "a change of pace can move.")
    if paired:
        noise = max(pair.noise for pair in run_file.pairs)
        confidence = max(pair.confidence for pair in run_file.pairs)
        paragraphs.append(f"Measured as pairs: both sides in alternating short blocks, one ratio per adjacent pair; "
                          f"the bar is the median ratio, the whisker its {100 * confidence:g} % bootstrap interval, "
                          f"[low, high] in the table. Hatched: within noise (the interval inside the "
                          f"±{100 * noise:g} % band shaded grey) or unsure (the interval across its edge).")
    if run_file.collapsed:
        paragraphs.append("Collapsed entries are in no comparison.")
    return Section(f"False-sharing and migration penalties: {run_file.label}", paragraphs=paragraphs,
                   figures=[Figure(f"penalties-{counter[0]}", "penalties, one bar per primitive, placement and "
                                                              "thread count", figures.penalties(rows, noise))],
                   tables=[penalty_table(rows)])


COMPARISON_TITLES = {"false_sharing": "false sharing: the layout whose writers share lines against an isolating one",
                     "migration": "migration: unpinned against pinned compactly",
                     "against_best_other": "each primitive against the best other primitive",
                     "overhead": "the harness's own cost (accounting on against off)"}
# The kinds the pairs section draws: the penalties section draws false sharing and migration, the best-other
# section each primitive against the best other.
PAIRS_DRAWN = ("overhead",)
INVERTED_NOTE = "*: the leader, its pair with the runner-up inverted"


def best_other_section(run_file: RunFile, counter: list[int]) -> Section | None:
    """Each primitive against the best other, per kind of entry, placement and thread count: the pairs as
    measured, the leader's line its pair with the runner-up read the other way round."""
    views = against_best_other_views(run_file.pairs)
    if not views:
        return None
    noise = max(pair.noise for pair in views)
    rows = [matrix.PenaltyRow("against_best_other", pair.a_key.get("sync") or "", pair.a_key.threads or 0,
                               pair.median, pair.ci_low, pair.ci_high, pair.verdict, pin=pair.a_key.get("pin") or "",
                               label=pair_label(pair) + (" *" if pair.inverted else ""))
             for pair in views]
    table = Table(["primitive vs best other", "median", "interval", "verdict", "pairs", "measured as"],
                  [[pair_label(pair), format_number(pair.median, 3, "x"),
                    f"[{format_number(pair.ci_low, 3)}, {format_number(pair.ci_high, 3)}]", pair.verdict,
                    format_count(len(pair.ratios)),
                    "the runner-up's pair, inverted" if pair.inverted else "its own pair"] for pair in views])
    paragraphs = ["Each primitive's step (or bare episode) on its best layout against the best other primitive's, "
                  "measured side by side (a / b > 1: a is slower). Each comparison is measured once: the fastest "
                  "primitive of a group (the leader) has no pair of its own, and its line (marked *) is its pair "
                  "with the runner-up read the other way round (the ratio and the interval's ends inverted, penalty "
                  "and gain swapped)."]
    if run_file.collapsed:
        paragraphs.append("Collapsed entries are in no comparison.")
    figure = Figure(f"best-other-{counter[0]}", COMPARISON_TITLES["against_best_other"],
                    figures.paired_ratios(rows, COMPARISON_TITLES["against_best_other"], noise,
                                          INVERTED_NOTE if any(pair.inverted for pair in views) else ""))
    return Section(f"Each primitive against the best other: {run_file.label}", paragraphs=paragraphs,
                   figures=[figure], tables=[table])


def pairs_section(run_file: RunFile, counter: list[int]) -> Section:
    """Every paired ratio of the file (lockstep_pairs) as measured: one table; the kinds no other section draws
    (the harness's overhead) as a figure."""
    kinds = [kind for kind in COMPARISON_TITLES if any(pair.comparison == kind for pair in run_file.pairs)]
    section_figures = []
    for kind in kinds:
        if kind in PAIRS_DRAWN:
            members = [p for p in run_file.pairs if p.comparison == kind]
            rows = [matrix.PenaltyRow(kind, "", 0, p.median, p.ci_low, p.ci_high, p.verdict, label=pair_label(p))
                    for p in members]
            section_figures.append(Figure(f"pairs-{counter[0]}-{_slug(kind)}", COMPARISON_TITLES[kind],
                                          figures.paired_ratios(rows, COMPARISON_TITLES[kind],
                                                                max(p.noise for p in members))))
    rows = []
    for kind in kinds:
        for pair in (p for p in run_file.pairs if p.comparison == kind):
            modes = sorted({mode for mode in pair.modes if mode >= 0})
            rows.append([kind.replace("_", " "), pair.group, _difference(pair.a_key, pair.b_key),
                         format_count(len(pair.ratios)), format_number(pair.median, 3, "x"),
                         f"[{format_number(pair.ci_low, 3)}, {format_number(pair.ci_high, 3)}]", pair.verdict,
                         format_number(pair.block_ms, 1, " ms"),
                         ", ".join(str(mode) for mode in modes) if modes else UNAVAILABLE])
    block = statistics.median([pair.block_ms for pair in run_file.pairs])
    drawn = ("False sharing and migration are drawn in their section above, each primitive against the best other "
             "in its own" + ("; the harness's overhead below." if section_figures else "."))
    return Section(f"Paired ratios: {run_file.label}",
                   paragraphs=["Every ratio the summary prints, measured as a pair, as the file holds it: a and b run "
                               f"in alternating short blocks (median block {format_number(block, 1, ' ms')}), one "
                               "ratio a / b per adjacent pair of blocks; the median ratio with its bootstrap interval, "
                               "and the verdict: penalty (the interval above the noise band), gain (below it), within "
                               "noise (inside it) or unsure (across an edge of it). " + drawn],
                   figures=section_figures,
                   tables=[Table(["comparison", "group", "a / b", "pairs", "median a/b", "interval", "verdict",
                                  "block", "pace modes"], rows)])


def _difference(a, b) -> str:
    """What tells two entries apart ("layout:<a's> / layout:<b's>"): the segments where they differ, or
    both names whole when their families differ."""
    if a.family != b.family:
        return f"{a.display} / {b.display}"
    a_segments, b_segments = dict(a.segments), dict(b.segments)
    keys = sorted(set(a_segments) | set(b_segments))
    differing = [key for key in keys if a_segments.get(key) != b_segments.get(key)]
    def side(segments):
        return " ".join(f"{key}:{segments[key]}" if segments.get(key) else key for key in differing
                        if key in segments) or a.family
    return f"{side(a_segments)} / {side(b_segments)}"


def per_mode_rows(run_file: RunFile) -> tuple[list[list[str]], int]:
    """The entries whose repetitions ran in more than one pace mode: each mode's median (and its count of
    repetitions), the slowest mode's median over the fastest's; and how many entries had a repetition that
    straddled a change of pace."""
    modes = run_file.pace.modes if run_file.pace else ()
    rows, straddling = [], 0
    for key in sorted(run_file.runs, key=lambda key: key.sort_key()):
        run = run_file.runs[key]
        if run.errored:
            continue
        medians, spread, straddles = mode_medians(run_file, key)
        if straddles:
            straddling += 1
        if spread is None:
            continue
        cells = [key.display]
        for mode in modes:
            median, count = medians.get(mode.mode, (None, 0))
            cells.append(f"{format_ns(median)} ({count})" if count else "")
        cells += [format_number(spread, 2, "x"), str(straddles) if straddles else ""]
        rows.append(cells)
    return rows, straddling


def pace_section(run_file: RunFile, counter: list[int]) -> Section:
    pace = run_file.pace
    paragraphs = [f"The machine's pace during the run: {pace.summary}. Between blocks of measurement the harness "
                  f"took a short reference reading ({pace.reference}); each reading is a dot, coloured by the pace "
                  "mode it falls in (grey: an outlier that belongs to no mode); dashed: each mode's median."]
    modes_table = Table(["mode", "c2c one-way", "serial step", "share of the run", "readings"],
                        [[str(mode.mode), format_ns(mode.c2c_ns), format_ns(mode.serial_ns),
                          format_number(100 * mode.share, 0, " %"), format_count(mode.readings)]
                         for mode in pace.modes], caption=f"{pace.changes} change(s) of mode")
    tables = [modes_table]
    rows, straddling = per_mode_rows(run_file)
    if rows:
        paragraphs.append(f"{len(rows)} entr{'y' if len(rows) == 1 else 'ies'} ran in more than one mode: their "
                          "median per mode (repetitions in brackets) instead of one median that mixes them.")
        tables.append(Table(["entry"] + [f"mode {mode.mode} (c2c {format_ns(mode.c2c_ns, 3)})" for mode in pace.modes]
                            + ["slowest / fastest", "straddling"], rows,
                            caption="Per-mode medians; straddling: repetitions whose pace changed while they ran"))
    if straddling:
        paragraphs.append(f"{straddling} entr{'y' if straddling == 1 else 'ies'} had a repetition that straddled a "
                          "change of pace (its readings before and after disagree).")
    figure = Figure(f"pace-{counter[0]}", f"pace trace, {run_file.label}",
                    figures.pace_trace(pace.readings, pace.modes, f"pace trace ({run_file.label}): {pace.summary}"))
    return Section(f"Pace of the machine: {run_file.label}", paragraphs=paragraphs, tables=tables, figures=[figure])


def c2c_section(item: C2cFile, counter: list[int]) -> Section:
    rows = []
    section_figures = []
    for method in item.methods():
        by_relation: dict[str, list[float]] = {}
        for pair in item.pairs:
            if pair.method == method and pair.p50_ns is not None:
                by_relation.setdefault(pair.relation, []).append(pair.p50_ns)
        for relation in sorted(by_relation, key=c2c_analysis.relation_order):
            values = sorted(by_relation[relation])
            rows.append([method, relation, str(len(values)), format_ns(values[0]),
                         format_ns(statistics.median(values)), format_ns(values[-1])])
        section_figures.append(Figure(f"c2c-{counter[0]}-{_slug(method)}", f"{item.label}, method {method}",
                                      figures.c2c_heatmap(c2c_analysis.latency_grid(item, method))))
    paragraphs = ["One-way latency of a cache line passed between two CPUs (median of its samples), CPUs "
                  "ordered so that those sharing a core or a cache sit next to each other; one map per "
                  "measuring method."]
    if item.sampled:
        paragraphs.append("Sampled: not every pair was measured (blank cells).")
    without_samples = sum(pair.p50_ns is None for pair in item.pairs)
    if without_samples:
        paragraphs.append(f"{without_samples} pair(s) without samples: {UNAVAILABLE} (blank cells, not in the "
                          "table).")
    counter[0] += 1
    return Section(f"Core-to-core latency: {item.label}", paragraphs=paragraphs, figures=section_figures,
                   tables=[Table(["method", "relation", "pairs", "min p50", "median p50", "max p50"], rows)])


def figure5_table(rows_measured, title: str) -> Table:
    paper_rows = paper.PAPER_FIGURE5
    rows = []
    measured = list(rows_measured or [])
    for index in range(max(len(paper_rows), len(measured))):
        cells = []
        if index < len(measured):
            row = measured[index]
            cells += [f"{row.thread} ({row.role})", format_number(row.cross_core_csw), str(row.total_csw),
                      format_number(row.pct, 2, " %")]
        else:
            cells += ["", "", "", ""]
        if index < len(paper_rows):
            name, cross, total, percent = paper_rows[index]
            cells += [name, f"{cross}", f"{total}", f"{percent:.2f} %"]
        else:
            cells += ["", "", "", ""]
        rows.append(cells)
    return Table(["thread (this machine)", "cross-core", "total", "%", "thread (paper)", "cross-core", "total", "%"],
                 rows, caption=title)


# What each of fields.DELAY_SETTINGS is called where the report says it is missing.
SETTING_WORDS = {"period_ns": "period", "periods": "number of periods", "duration_s": "duration",
                 "fifo_priority": "scheduling policy", "mlock": "memory locking"}


def delay_settings_rows(settings: dict, extras: DelayExtras) -> list[list[str]]:
    """A delay run's settings as a person writes them ("SCHED_FIFO priority 80", "memory not locked",
    "period 1 ms"), never as program values; a setting the file does not say is left out."""
    rows = []
    if "period_ns" in settings:
        rows.append(["period", format_duration(settings["period_ns"])])
    length = []
    if "periods" in settings:
        length.append(f"{format_count(settings['periods'])} periods")
    if "duration_s" in settings:
        length.append(format_duration(settings["duration_s"] * 1e9))
    if length:
        rows.append(["length", ", ".join(length)])
    step = [f"{settings[key]} {word}" for key, word in (("sync", "sync"), ("layout", "layout")) if key in settings]
    if "threads" in settings:
        step.append(f"{settings['threads']} thread{'s' if settings['threads'] != 1 else ''}")
    if step:
        rows.append(["step", ", ".join(step)])
    if extras.settings.get("view"):
        rows.append(["view", extras.settings["view"]])
    if "pin" in settings or "placement" in settings:
        pin = f"pin {settings['pin']}" if "pin" in settings else ""
        rows.append(["placement", f"{pin}: {settings['placement']}" if pin and "placement" in settings
                     else pin or settings["placement"]])
    if "fifo_priority" in settings:
        priority = settings["fifo_priority"]
        rows.append(["scheduling", "SCHED_OTHER (the default time-sharing policy; no real-time priority)"
                     if priority is None else f"SCHED_FIFO, priority {priority}"])
    if "mlock" in settings:
        rows.append(["memory", "locked (mlockall: no page faults while paced)" if settings["mlock"]
                     else "not locked (no mlockall)"])
    idle = extras.idle
    if idle or "dma_latency_us" in extras.settings:
        path = idle.get("path", "/dev/cpu_dma_latency")
        requested = idle.get("requested_us", extras.settings.get("dma_latency_us"))
        if requested is None:
            words = f"{path} left alone: the CPUs may enter deep idle states between periods"
        elif idle and not idle.get("held"):
            words = f"{path} could not be held at {requested} us ({idle.get('problem') or 'no reason given'}): " \
                    "idle states not limited"
        else:
            words = f"{path} held at {requested} us" + (", as cyclictest does by default" if requested == 0 else "")
            if idle.get("in_force_us") is not None and idle["in_force_us"] != requested:
                words += f" (in force: {idle['in_force_us']} us)"
        governor = [f"{name} {idle[key]}" for key, name in (("cpuidle_driver", "cpuidle driver"),
                                                             ("cpuidle_governor", "governor")) if idle.get(key)]
        rows.append(["idle states", "; ".join([words] + ([", ".join(governor)] if governor else []))])
    if idle.get("clocksource"):
        rows.append(["clock source", idle["clocksource"]])
    if extras.settings.get("histogram_bound_us"):
        rows.append(["histogram", f"1 us buckets up to {format_duration(extras.settings['histogram_bound_us'] * 1e3)}, "
                                  "later wake-ups counted as overflow"])
    if extras.settings.get("stop_above_ns"):
        rows.append(["stop above", format_duration(extras.settings["stop_above_ns"])])
    missing = [SETTING_WORDS.get(key, key) for key, _ in DELAY_SETTINGS if key not in settings]
    if missing:
        rows.append(["not in the file", ", ".join(f"{word}: {UNAVAILABLE}" for word in missing)])
    return rows


def _delay_histogram(item: DelayFile, number: int, histograms, period: str) -> Figure:
    """The wake-up histogram of every thread (cyclictest's latency_histogram, the columns summed); a file from
    before latency_histogram: the covering histogram, as before."""
    if histograms is None:
        return Figure(f"delay-{number}", item.label, figures.delay_histogram(item))
    summed = [sum(column.counts[i] for column in histograms.columns if i < len(column.counts))
              for i in range(max(len(column.counts) for column in histograms.columns))]
    marks = {name: value for name, value in (("p50", item.pinned.wakeup.statistics.get("p50")),
                                             ("p99", item.pinned.wakeup.statistics.get("p99")),
                                             ("p99.9", item.pinned.wakeup.statistics.get("p999")))
             if value is not None}
    return Figure(f"delay-{number}", item.label, figures.wakeup_histograms(
        histograms, [("all threads", summed, sum(column.overflow for column in histograms.columns), False)],
        f"paced wake-up latency, every thread ({item.label}; period {period})", marks))


def _add_per_cpu(section: Section, item: DelayFile, number: int, histograms, period: str) -> None:
    """--per-cpu: the wake-up latency per CPU as a table, and one histogram panel per CPU (the noisiest marked)."""
    extras = item.extras
    noisy = f" Noisiest CPU: {extras.noisiest[0]} ({extras.noisiest[1]})." if extras.noisiest else ""
    section.paragraphs.append("Per CPU: one paced thread on each CPU, each computing the step alone (cyclictest -S)."
                              + noisy)
    section.tables.append(Table(["cpu", "min", "p50", "p99", "p99.9", "max", "count", "deadline misses"],
                                [[UNAVAILABLE if row.cpu is None else str(row.cpu)]
                                 + [format_ns(row.wakeup.statistics.get(q)) for q in DISTRIBUTION_STATISTICS]
                                 + [format_count(row.wakeup.count), format_count(row.deadline_misses)]
                                 for row in extras.per_cpu], caption="Wake-up latency per CPU"))
    if histograms is not None:
        noisiest = extras.noisiest[0] if extras.noisiest else None
        panels = [(column.name, column.counts, column.overflow, column.cpu is not None and column.cpu == noisiest)
                  for column in histograms.columns]
        section.figures.append(Figure(f"delay-{number}-per-cpu", f"{item.label}, per CPU",
                                      figures.wakeup_histograms(histograms, panels,
                                                                f"wake-up latency per CPU (period {period})")))


def _trial_row(first: str, trial) -> list[str]:
    return [first, format_duration(trial.period_ns), format_count(trial.periods), format_count(trial.misses),
            format_rate(trial.miss_rate), format_rate(trial.upper_bound), "holds" if trial.holds else "fails"]


def _add_period_search(section: Section, item: DelayFile, number: int) -> None:
    """--find-period: the answer in a line, the trials in a table and against their miss rate in a figure."""
    search = item.extras.search
    answer = (f"{format_duration(search.found_period_ns)}" if search.found_period_ns is not None
              else "none (no period tried held)")
    failed = f"; {format_duration(search.failed_period_ns)} failed" if search.failed_period_ns is not None else ""
    cut = " The search budget cut the search: the bracket did not close." if search.budget_cut else ""
    section.paragraphs.append(f"Shortest period that holds at miss rate {format_rate(search.miss_rate)}: {answer}"
                              f"{failed} (stopped: {search.stopped_because or UNAVAILABLE}).{cut}"
                              + (f" Rule: {search.rule}." if search.rule else ""))
    trial_rows = [_trial_row(str(index), trial) for index, trial in enumerate(search.trials, start=1)]
    if search.confirm is not None:
        trial_rows.append(_trial_row("confirming run", search.confirm))
    section.tables.append(Table(["trial", "period", "periods", "misses", "miss rate", "upper bound", "verdict"],
                                trial_rows, caption="find-period: the trials in the order they ran"))
    section.figures.append(Figure(f"delay-{number}-find-period", f"{item.label}, find-period search",
                                  figures.period_search(search)))


def _add_causes(section: Section, item: DelayFile, number: int) -> None:
    """Why the late steps were late: the file's causes (delay_reader.read_causes) as stacked bars."""
    section.paragraphs.append("Why the late steps were late: each tail's excess over the median step, split by cause "
                              "(`lockstep delay` prints the same table and the latest steps one line each).")
    rows = [(f"{row.label} ({row.steps} steps)" if row.cpu is None else f"CPU {row.cpu}, {row.label}", row.cause_ns)
            for row in item.causes.rows]
    section.figures.append(Figure(f"delay-{number}-causes", f"{item.label}, causes of the tail",
                                  figures.delay_causes(rows, item.causes.names)))


def delay_section(item: DelayFile, counter: list[int]) -> Section:
    """A paced delay run: its settings and latency distributions, the wake-up histogram, what --per-cpu and
    --find-period add, the causes of the tail, and Figure 5 beside the paper's."""
    extras = item.extras
    runs = [("", item.pinned)] + ([(" (unpinned)", item.unpinned)] if item.unpinned else [])
    summary_rows = []
    for which, run in runs:
        for name, summary in (("wake-up latency", run.wakeup), ("completion", run.completion)):
            statistics = summary.statistics if summary else {}
            count = summary.count if summary else None
            summary_rows.append([name + which] + [format_ns(statistics.get(q)) for q in DISTRIBUTION_STATISTICS]
                                + [format_count(count)])
    misses = [f"{format_count(run.deadline_misses)}{which}" for which, run in runs]
    section = Section(f"Multi-core delay: {item.label}", paragraphs=[
        f"Deadline misses: {', '.join(misses)}.",
        "Figure 5 of the paper counts, per thread, the context switches that moved it to another core "
        f"(Concurrency Visualizer, {paper.PAPER_MACHINE}); lockstep counts the same from the kernel's "
        "per-thread accounting."], tables=[Table(["setting", "value"], delay_settings_rows(item.settings, extras)),
                                           Table(["measure", "min", "p50", "p99", "p99.9", "max", "count"],
                                                 summary_rows)])
    histograms = extras.histograms if extras.histograms and extras.histograms.columns else None
    period = format_duration(item.settings.get("period_ns"))
    section.figures.append(_delay_histogram(item, counter[0], histograms, period))
    if extras.per_cpu:
        _add_per_cpu(section, item, counter[0], histograms, period)
    if extras.search is not None:
        _add_period_search(section, item, counter[0])
    if item.causes is not None:
        _add_causes(section, item, counter[0])
    section.tables.append(figure5_table(item.pinned.figure5, "Figure 5: this machine (pinned) beside the paper"))
    if item.unpinned:
        section.tables.append(figure5_table(item.unpinned.figure5,
                                            "Figure 5: this machine unpinned (the paper's OpenMP case) beside the "
                                            "paper"))
    counter[0] += 1
    return section


def trajectory_section(item: VerifyFile, counter: list[int]) -> Section:
    reference = paper.trajectory_reference(item)
    deviation = paper.trajectory_deviation(item, reference)
    figure = Figure(f"trajectory-{counter[0]}", item.label, figures.trajectory(item, reference, deviation))
    counter[0] += 1
    return Section(f"Trajectory: {item.label}",
                   paragraphs=[f"x1 and x2 of the two-mass system from x(0) = (2, -3) (the paper's Figure 2), with "
                               f"the analytic normal-mode solution dashed. Largest deviation over "
                               f"{len(item.t)} samples: {deviation:.3e}."],
                   figures=[figure])


def paper_section(run_files: list[RunFile]) -> Section:
    model = paper.model_values(run_files)
    roots = Table(["root", "paper", f"model (C/m = {model.c_over_m} s^-2)", "difference"],
                  [[f"mode {i + 1}", f"±{printed:.2f}j", f"±{computed:.2f}j", f"{computed - printed:+.2f}"]
                   for i, (printed, computed) in enumerate(zip(model.paper_roots, model.roots))],
                  caption=f"The paper's printed roots fit C/m = {model.paper_implied_c_over_m:.1f} s^-2.")
    evaluations = [paper.model_values([run_file]).evaluations_per_step for run_file in run_files]
    equation_rows = []
    for equation, seconds in paper.PAPER_EQUATION_TIMES_S.items():
        cells = [equation, f"{seconds:.2e} s"]
        for run_file, count in zip(run_files, evaluations):
            serial = calibration(run_file, SERIAL_CONTEXT)
            cells.append(f"{serial / count * 1e-9:.2e} s" if serial else UNAVAILABLE)  # the paper's notation
        equation_rows.append(cells)
    equations = Table(["equation", f"paper ({paper.PAPER_MACHINE})"]
                      + [f"{f.label}: serial step / {count}" for f, count in zip(run_files, evaluations)],
                      equation_rows,
                      caption="lockstep does not time each derivative alone: its column is the in-run serial "
                              f"RK4 step (context serial_step_ns) divided by its {model.evaluations_per_step} "
                              "derivative evaluations, the same for D1..D4. The paper's times include its own timer "
                              "overhead.")
    return Section("The paper's values beside this machine's",
                   paragraphs=["Al-Oraiqat, \"Parallel implementation of the coupled harmonic oscillator\": the "
                               "values it reports, beside what lockstep measured or computed. The Figure 5 table "
                               "is in the delay section when `lockstep delay` output is given."],
                   tables=[roots, equations])


# How many sections the HTML page shows open (after the answers): the page opens a few screens long.
OPEN_SECTIONS = 2


def build_sections(loaded) -> tuple[list[AnswerBox], list[Section]]:
    """The answers (one per `lockstep run` file, shown first) and the sections after them: the results, then
    the paper's values, the inputs and machines, and the warnings; the first OPEN_SECTIONS open."""
    run_files = [item for item in loaded if isinstance(item, RunFile)]
    answers = [answer_of(item) for item in run_files if not item.mpi]
    counter = [0]
    sections = []
    for item in loaded:
        if isinstance(item, RunFile):
            sections += [mpi_section(item, counter)] if item.mpi else run_sections(item, counter)
    for item in loaded:
        if isinstance(item, C2cFile):
            sections.append(c2c_section(item, counter))
    for item in loaded:
        if isinstance(item, DelayFile):
            sections.append(delay_section(item, counter))
    for item in loaded:
        if isinstance(item, VerifyFile):
            sections.append(trajectory_section(item, counter))
    sections.append(paper_section(run_files))
    sections.append(machines_section(loaded, run_files))
    warnings = [w for f in run_files for w in f.warnings]
    if warnings:
        sections.append(Section(f"Warnings ({len(warnings)})", paragraphs=warnings))
    for section in sections[:OPEN_SECTIONS]:
        section.open = True
    return answers, sections


# ---------------------------------------------------------------- rendering

def _slug(title: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in title.lower()).strip("-")


def _md_cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


@functools.lru_cache(maxsize=1)
def _templates() -> jinja2.Environment:
    """The templates' environment, made once: it compiles each template on first use and keeps it."""
    environment = jinja2.Environment(
        loader=jinja2.FileSystemLoader(TEMPLATES), undefined=jinja2.StrictUndefined,
        autoescape=jinja2.select_autoescape(enabled_extensions=("html.j2",), default=False),
        trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True)
    # matplotlib's SVG, its ids made unique per figure: matplotlib escaped the text it put there.
    environment.filters["inline_svg"] = lambda svg, prefix: markupsafe.Markup(figures.inline_svg(svg, prefix))
    environment.filters["md_cell"] = _md_cell
    return environment


def render_html(title: str, answers: list[AnswerBox], sections: list[Section]) -> str:
    anchored = [(f"s{index}-{_slug(section.title)}", section) for index, section in enumerate(sections)]
    return _templates().get_template("report.html.j2").render(title=title, answers=answers, sections=anchored,
                                                              where=WHERE_THE_RESULTS_ARE["html"])


def render_markdown(title: str, answers: list[AnswerBox], sections: list[Section]) -> str:
    text = _templates().get_template("report.md.j2").render(
        title=title, answers=answers, sections=sections,
        figures_directory=FIGURES_DIRECTORY, where=WHERE_THE_RESULTS_ARE["markdown"])
    return text.rstrip("\n") + "\n"


def write_report(paths: list[str], out_dir: str, title: str = "lockstep report") -> list[str]:
    """Reads every input and writes the report directory whole (the command line has checked out_dir
    with output.check_directory_target first). Returns the pages written."""
    labels = unique_labels(paths)
    loaded = [load_any(path, label) for path, label in zip(paths, labels)]
    answers, sections = build_sections(loaded)
    files = {os.path.join(FIGURES_DIRECTORY, f"{figure.slug}.svg"): figure.svg
             for section in sections for figure in section.figures}
    files[HTML_PAGE] = render_html(title, answers, sections)
    files[MARKDOWN_PAGE] = render_markdown(title, answers, sections)
    write_directory(out_dir, files)
    return [os.path.join(out_dir, page) for page in PAGES]
