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
from dataclasses import dataclass, field

import jinja2
import markupsafe

from . import figures, paper
from .compare import calibration, fingerprint, layout_effects, rank_tables
from .fields import DELAY_SETTINGS, DISTRIBUTION_STATISTICS, FINGERPRINT_KEYS, SERIAL_CONTEXT, UNAVAILABLE
from .formatting import format_ns, format_number
from .inputs import C2cFile, DelayFile, RunFile, VerifyFile, load_any, unique_labels
from .output import FIGURES_DIRECTORY, HTML_PAGE, MARKDOWN_PAGE, PAGES, write_directory
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


# ---------------------------------------------------------------- sections

def inputs_section(loaded) -> Section:
    kinds = {RunFile: "benchmark results (`lockstep run`)", C2cFile: "core-to-core latency (`lockstep c2c`)",
             DelayFile: "paced delay run (`lockstep delay`)", VerifyFile: "trajectory (`lockstep verify --csv`)"}
    rows = [[item.label, kinds[type(item)]] for item in loaded]
    return Section("Inputs", tables=[Table(["file", "kind"], rows)])


def machines_section(run_files: list[RunFile]) -> Section | None:
    if not run_files:
        return None
    prints = [fingerprint(f) for f in run_files]
    rows = [[key] + [p[key] or UNAVAILABLE for p in prints] for key in FINGERPRINT_KEYS]
    tables = [Table(["context"] + [f.label for f in run_files], rows)]
    if len(run_files) > 1:
        effects = [[sync, pin, str(threads), layout] + [format_number(s, 2, "x") for s in speedups]
                   for sync, pin, threads, layout, speedups in layout_effects(run_files)]
        tables.append(Table(["sync", "pin", "threads", "layout"] + [f"{f.label}: vs packed" for f in run_files],
                            effects, caption="Each layout's speed-up over packed (packed time / layout time), "
                                             "on each machine: the false-sharing effect read side by side."))
    return Section("Machines", paragraphs=["Each result file's context: what a comparison across machines needs. "
                                           "`lockstep compare` tests the differences."], tables=tables)


def run_sections(run_file: RunFile, counter: list[int]) -> list[Section]:
    sections = []
    groups = figures.rk4_groups(run_file)
    if not groups:
        return [Section(f"Results: {run_file.label}",
                        paragraphs=["No `rk4/sync:.../layout:.../pin:.../threads:...` entries in this file."])]
    heat = Section(f"Step time, sync x layout: {run_file.label}",
                   paragraphs=["Median step time of each synchronisation primitive (rows) with each data layout "
                               "(columns), one map per placement and thread count. Darker is slower; n/a: the "
                               "combination was not run or errored."])
    bars = Section(f"Spread per primitive: {run_file.label}",
                   paragraphs=["Bars at the median over repetitions, whiskers over the interquartile range, one "
                               "dot per repetition."])
    for pin, threads in groups:
        heat.figures.append(Figure(f"heatmap-{counter[0]}-{pin}-{threads}", f"pin:{pin} threads:{threads}",
                                   figures.heatmap(run_file, pin, threads)))
        bars.figures.append(Figure(f"bars-{counter[0]}-{pin}-{threads}", f"pin:{pin} threads:{threads}",
                                   figures.bars_with_spread(run_file, pin, threads)))
    sections += [heat, bars]
    rows = figures.penalty_rows(run_file)
    if rows:
        table = Table(["penalty", "sync", "threads", "time ratio"],
                      [[kind, sync, str(threads), format_number(ratio, 2, "x")] for kind, sync, threads, ratio in rows])
        sections.append(Section(f"False-sharing and migration penalties: {run_file.label}",
                                paragraphs=["False sharing: the packed layout's step time over the padded one's, "
                                            "threads pinned compactly. Migration: the step time when threads are "
                                            "moved on purpose (pin:migrate) or left to the OS (pin:none), over "
                                            "compact pinning. 1.0 is no penalty."],
                                figures=[Figure(f"penalties-{counter[0]}", "penalties", figures.penalties(rows))],
                                tables=[table]))
    rank_rows = []
    for (pin, threads), per_file in rank_tables([run_file], top=5).items():
        for rank, (name, step, vs_serial) in enumerate(per_file[0], start=1):
            rank_rows.append([f"pin:{pin} threads:{threads}", str(rank), name, format_ns(step),
                              format_number(vs_serial, 2, "x")])
    sections.append(Section(f"Fastest combinations: {run_file.label}",
                            paragraphs=["The five fastest sync/layout pairs per placement and thread count; x serial "
                                        "is the step time over this run's serial RK4 step."],
                            tables=[Table(["group", "rank", "sync/layout", "step (median)", "x serial"], rank_rows)]))
    counter[0] += 1
    return sections


def c2c_section(item: C2cFile, counter: list[int]) -> Section:
    rows = []
    section_figures = []
    for method in item.methods():
        by_relation: dict[str, list[float]] = {}
        for pair in item.pairs:
            if pair.method == method and pair.p50_ns is not None:
                by_relation.setdefault(pair.relation, []).append(pair.p50_ns)
        for relation in sorted(by_relation, key=figures.relation_order):
            values = sorted(by_relation[relation])
            rows.append([method, relation, str(len(values)), format_ns(values[0]),
                         format_ns(values[len(values) // 2]), format_ns(values[-1])])
        section_figures.append(Figure(f"c2c-{counter[0]}-{_slug(method)}", f"{item.label}, method {method}",
                                      figures.c2c_heatmap(item, method)))
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


def _setting(settings: dict, key: str) -> str:
    if key not in settings:
        return UNAVAILABLE
    value = settings[key]
    if value is None:
        return "none"  # fifo_priority: SCHED_OTHER
    if isinstance(value, bool):
        return "yes" if value else "no"
    return str(value)


def delay_section(item: DelayFile, counter: list[int]) -> Section:
    runs = [("", item.pinned)] + ([(" (unpinned)", item.unpinned)] if item.unpinned else [])
    summary_rows = []
    for which, run in runs:
        for name, summary in (("wake-up latency", run.wakeup), ("completion", run.completion)):
            statistics = summary.statistics if summary else {}
            count = summary.count if summary else None
            summary_rows.append([name + which] + [format_ns(statistics.get(q)) for q in DISTRIBUTION_STATISTICS]
                                + [format_number(count)])
    misses = [f"{format_number(run.deadline_misses)}{which}" for which, run in runs]
    paragraphs = [
        "Settings: " + ", ".join(f"{key} {_setting(item.settings, key)}" for key, _ in sorted(DELAY_SETTINGS)) + ".",
        f"Deadline misses: {', '.join(misses)}.",
        "Figure 5 of the paper counts, per thread, the context switches that moved it to another core "
        f"(Concurrency Visualizer, {paper.PAPER_MACHINE}); lockstep counts the same from the kernel's "
        "per-thread accounting.",
    ]
    tables = [Table(["measure", "min", "p50", "p99", "p99.9", "max", "count"], summary_rows),
              figure5_table(item.pinned.figure5, "Figure 5: this machine (pinned) beside the paper")]
    if item.unpinned:
        tables.append(figure5_table(item.unpinned.figure5,
                                    "Figure 5: this machine unpinned (the paper's OpenMP case) beside the paper"))
    figure = Figure(f"delay-{counter[0]}", item.label, figures.delay_histogram(item))
    counter[0] += 1
    return Section(f"Multi-core delay: {item.label}", paragraphs=paragraphs, tables=tables, figures=[figure])


def trajectory_section(item: VerifyFile, counter: list[int]) -> Section:
    deviation = figures.trajectory_deviation(item)
    figure = Figure(f"trajectory-{counter[0]}", item.label, figures.trajectory(item, deviation))
    counter[0] += 1
    return Section(f"Trajectory: {item.label}",
                   paragraphs=[f"x1 and x2 of the two-mass system from x(0) = (2, -3) (the paper's Figure 2), with "
                               f"the analytic normal-mode solution dashed. Largest deviation over "
                               f"{len(item.t)} samples: {deviation:.3e}."],
                   figures=[figure])


def paper_section(run_files: list[RunFile]) -> Section:
    fast, slow = paper.model_roots()
    roots = Table(["root", "paper", f"model (C/m = {paper.C_OVER_M} s^-2)", "difference"],
                  [[f"mode {i + 1}", f"±{printed:.2f}j", f"±{computed:.2f}j", f"{computed - printed:+.2f}"]
                   for i, (printed, computed) in enumerate(zip(paper.PAPER_ROOTS, (fast, slow)))],
                  caption=f"The paper's printed roots fit C/m = {paper.c_over_m_from_roots():.1f} s^-2.")
    equation_rows = []
    for equation, seconds in paper.PAPER_EQUATION_TIMES_S.items():
        cells = [equation, f"{seconds:.2e} s"]
        for run_file in run_files:
            serial = calibration(run_file, SERIAL_CONTEXT)
            # A serial RK4 step evaluates D1..D4 once per stage: 16 evaluations.
            cells.append(f"{serial / 16 * 1e-9:.2e} s" if serial else UNAVAILABLE)  # the paper's notation
        equation_rows.append(cells)
    equations = Table(["equation", f"paper ({paper.PAPER_MACHINE})"]
                      + [f"{f.label}: serial step / 16" for f in run_files], equation_rows,
                      caption="lockstep does not time each derivative alone: its column is the in-run serial "
                              "RK4 step (context serial_step_ns) divided by its 16 derivative evaluations, the same "
                              "for D1..D4. The paper's times include its own timer overhead.")
    return Section("The paper's values beside this machine's",
                   paragraphs=["Al-Oraiqat, \"Parallel implementation of the coupled harmonic oscillator\": the "
                               "values it reports, beside what lockstep measured or computed. The Figure 5 table "
                               "is in the delay section when `lockstep delay` output is given."],
                   tables=[roots, equations])


def build_sections(loaded) -> list[Section]:
    run_files = [item for item in loaded if isinstance(item, RunFile)]
    counter = [0]
    sections = [inputs_section(loaded)]
    machines = machines_section(run_files)
    if machines:
        sections.append(machines)
    for item in loaded:
        if isinstance(item, RunFile):
            sections += run_sections(item, counter)
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
    warnings = [w for f in run_files for w in f.warnings]
    if warnings:
        sections.append(Section("Warnings", paragraphs=warnings))
    return sections


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


def render_html(title: str, sections: list[Section]) -> str:
    anchored = [(f"s{index}-{_slug(section.title)}", section) for index, section in enumerate(sections)]
    return _templates().get_template("report.html.j2").render(title=title, sections=anchored)


def render_markdown(title: str, sections: list[Section]) -> str:
    text = _templates().get_template("report.md.j2").render(title=title, sections=sections,
                                                            figures_directory=FIGURES_DIRECTORY)
    return text.rstrip("\n") + "\n"


def write_report(paths: list[str], out_dir: str, title: str = "lockstep report") -> list[str]:
    """Reads every input and writes the report directory whole (the command line has checked out_dir
    with output.check_directory_target first). Returns the pages written."""
    labels = unique_labels(paths)
    loaded = [load_any(path, label) for path, label in zip(paths, labels)]
    sections = build_sections(loaded)
    files = {os.path.join(FIGURES_DIRECTORY, f"{figure.slug}.svg"): figure.svg
             for section in sections for figure in section.figures}
    files[HTML_PAGE] = render_html(title, sections)
    files[MARKDOWN_PAGE] = render_markdown(title, sections)
    write_directory(out_dir, files)
    return [os.path.join(out_dir, page) for page in PAGES]
