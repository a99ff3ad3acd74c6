"""`lockstep report RESULT... [--out DIR]`: one self-contained HTML page and one Markdown file.

The page carries its figures as inline SVG and its style inline: it loads
nothing from anywhere (no network, no other file). A few lines of script
record, on the <body> element, how many figures the browser laid out and
whether any error occurred: the browser test reads them back. The Markdown
file shows the same tables and links the same figures, written as SVG files
under figures/.

Deterministic: the same inputs give the same bytes (figures.py fixes
matplotlib's hash salt and drops its date; nothing here reads the clock).
"""
from __future__ import annotations

import html
import math
import os
import tempfile
from dataclasses import dataclass, field

from . import figures, paper
from .compare import calibration, fingerprint, FINGERPRINT_KEYS, format_ns, layout_effects, rank_tables
from .inputs import C2cFile, DelayFile, InputError, RunFile, VerifyFile, load_any, unique_labels


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


def _fmt(value, digits: int = 1, unit: str = "") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "unavailable"
    if isinstance(value, float):
        return f"{value:.{digits}f}{unit}"
    return f"{value}{unit}"


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
    rows = [[key] + [p[key] or "unavailable" for p in prints] for key in FINGERPRINT_KEYS]
    tables = [Table(["context"] + [f.label for f in run_files], rows)]
    if len(run_files) > 1:
        effects = [[sync, pin, str(threads), layout] + [f"{s:.2f}x" if s else "unavailable" for s in speedups]
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
    penalties = figures.penalties(run_file)
    if penalties is not None:
        svg, rows = penalties
        table = Table(["penalty", "sync", "threads", "time ratio"],
                      [[kind, sync, str(threads), f"{ratio:.2f}x"] for kind, sync, threads, ratio in rows])
        sections.append(Section(f"False-sharing and migration penalties: {run_file.label}",
                                paragraphs=["False sharing: the packed layout's step time over the padded one's, "
                                            "threads pinned compactly. Migration: the step time when threads are "
                                            "moved on purpose (pin:migrate) or left to the OS (pin:none), over "
                                            "compact pinning. 1.0 is no penalty."],
                                figures=[Figure(f"penalties-{counter[0]}", "penalties", svg)], tables=[table]))
    rank_rows = []
    for (pin, threads), per_file in rank_tables([run_file], top=5).items():
        for rank, (name, step, vs_serial) in enumerate(per_file[0], start=1):
            rank_rows.append([f"pin:{pin} threads:{threads}", str(rank), name, format_ns(step),
                              _fmt(vs_serial, 2, "x")])
    sections.append(Section(f"Fastest combinations: {run_file.label}",
                            paragraphs=["The five fastest sync/layout pairs per placement and thread count; x serial "
                                        "is the step time over this run's serial RK4 step."],
                            tables=[Table(["group", "rank", "sync/layout", "step (median)", "x serial"], rank_rows)]))
    counter[0] += 1
    return sections


def c2c_section(item: C2cFile, counter: list[int]) -> Section:
    pairs = item.document["pairs"]
    rows = []
    section_figures = []
    for method in figures.c2c_methods(item.document):
        by_relation: dict[str, list[float]] = {}
        for pair in pairs:
            value = pair["one_way_ns"].get("p50")
            if str(pair.get("method", "unknown")) == method and isinstance(value, (int, float)) \
                    and math.isfinite(value):
                by_relation.setdefault(pair.get("relation", "unknown"), []).append(float(value))
        for relation, values in sorted(by_relation.items(), key=lambda kv: (figures.RELATION_RANK.get(kv[0], 6), kv[0])):
            values = sorted(values)
            rows.append([method, relation, str(len(values)), _fmt(values[0]), _fmt(values[len(values) // 2]),
                         _fmt(values[-1])])
        section_figures.append(Figure(f"c2c-{counter[0]}-{_slug(method)}", f"{item.label}, method {method}",
                                      figures.c2c_heatmap(item.document, item.label, method)))
    paragraphs = ["One-way latency of a cache line passed between two CPUs (median of its samples, ns), CPUs "
                  "ordered so that those sharing a core or a cache sit next to each other; one map per "
                  "measuring method."]
    if item.document.get("sampled"):
        paragraphs.append("Sampled: not every pair was measured (blank cells).")
    counter[0] += 1
    return Section(f"Core-to-core latency: {item.label}", paragraphs=paragraphs, figures=section_figures,
                   tables=[Table(["method", "relation", "pairs", "min p50 (ns)", "median p50 (ns)", "max p50 (ns)"],
                                 rows)])


def figure5_table(rows_measured, title: str) -> Table:
    paper_rows = paper.PAPER_FIGURE5
    rows = []
    measured = list(rows_measured or [])
    for index in range(max(len(paper_rows), len(measured))):
        cells = []
        if index < len(measured):
            row = measured[index]
            cells += [f"{row.get('thread', '?')} ({row.get('role', '')})", str(row.get("cross_core_csw", "?")),
                      str(row.get("total_csw", "?")), _fmt(row.get("pct"), 2, " %")]
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


def delay_section(item: DelayFile, counter: list[int]) -> Section:
    document = item.document
    settings = document.get("settings", {})
    summary_rows = []
    for name, key in (("wake-up latency", "wakeup_latency_ns"), ("completion", "completion_ns")):
        summary = document.get(key) or {}
        summary_rows.append([name] + [format_ns(summary.get(q)) if isinstance(summary.get(q), (int, float)) else "unavailable"
                                      for q in ("min", "p50", "p99", "p999", "max")]
                            + [str(summary.get("count", "unavailable"))])
    paragraphs = [
        "Settings: " + ", ".join(f"{key} {settings[key]}" for key in sorted(settings)) + ".",
        f"Deadline misses: {document.get('deadline_misses', 'unavailable')}.",
        "Figure 5 of the paper counts, per thread, the context switches that moved it to another core "
        f"(Concurrency Visualizer, {paper.PAPER_MACHINE}); lockstep counts the same from the kernel's "
        "per-thread accounting.",
    ]
    tables = [Table(["measure", "min", "p50", "p99", "p99.9", "max", "count"], summary_rows),
              figure5_table(document.get("figure5"), "Figure 5: this machine (pinned) beside the paper")]
    if document.get("figure5_unpinned"):
        tables.append(figure5_table(document["figure5_unpinned"],
                                    "Figure 5: this machine unpinned (the paper's OpenMP case) beside the paper"))
    figure = Figure(f"delay-{counter[0]}", item.label, figures.delay_histogram(document, item.label))
    counter[0] += 1
    return Section(f"Multi-core delay: {item.label}", paragraphs=paragraphs, tables=tables, figures=[figure])


def trajectory_section(item: VerifyFile, counter: list[int]) -> Section:
    svg, deviation = figures.trajectory(item, item.label)
    figure = Figure(f"trajectory-{counter[0]}", item.label, svg)
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
            serial = calibration(run_file, "serial_step_ns")
            # A serial RK4 step evaluates D1..D4 once per stage: 16 evaluations.
            cells.append(f"{serial / 16 * 1e-9:.2e} s" if serial else "unavailable")
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

STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 72em; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; padding-bottom: .2em; margin-top: 2em; }
table { border-collapse: collapse; margin: .8em 0; font-size: .85em; }
th, td { border: 1px solid #ccc; padding: .2em .5em; text-align: left; vertical-align: top; }
th { background: #f2f2f2; }
caption { caption-side: bottom; font-size: .85em; color: #555; text-align: left; padding-top: .3em; }
.figures { display: flex; flex-wrap: wrap; gap: 1em; align-items: flex-start; }
figure { margin: 1em 0; } figure svg { max-width: 100%; height: auto; }
figcaption { font-size: .85em; color: #555; }
nav ul { columns: 2; font-size: .9em; }
"""

# Records what the browser did with the page, for the headless browser test:
# data-errors counts script errors and failed loads, data-figures the inline
# figures, data-figures-shown those laid out at a visible size, data-resources
# whatever the page fetched (it must be 0: the page is self-contained).
CHECK_SCRIPT = """
document.documentElement.dataset.errors = "0";
window.addEventListener("error", function () {
  document.documentElement.dataset.errors = String(Number(document.documentElement.dataset.errors) + 1);
}, true);
window.addEventListener("load", function () {
  var svgs = document.querySelectorAll("figure > svg");
  var shown = 0;
  for (var i = 0; i < svgs.length; i++) {
    var box = svgs[i].getBoundingClientRect();
    if (box.width > 100 && box.height > 50 && svgs[i].querySelector("path, use")) shown++;
  }
  document.body.dataset.figures = String(svgs.length);
  document.body.dataset.figuresShown = String(shown);
  document.body.dataset.resources = String(performance.getEntriesByType("resource").length);
  document.body.dataset.loaded = "yes";
});
"""


def _slug(title: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in title.lower()).strip("-")


def render_html(title: str, sections: list[Section]) -> str:
    e = html.escape
    out = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
           '<meta name="viewport" content="width=device-width, initial-scale=1">',
           f"<title>{e(title)}</title>", f"<style>{STYLE}</style>", f"<script>{CHECK_SCRIPT}</script>",
           "</head>", "<body>", f"<h1>{e(title)}</h1>", "<nav><ul>"]
    anchors = []
    for index, section in enumerate(sections):
        anchor = f"s{index}-{_slug(section.title)}"
        anchors.append(anchor)
        out.append(f'<li><a href="#{anchor}">{e(section.title)}</a></li>')
    out.append("</ul></nav>")
    for anchor, section in zip(anchors, sections):
        out.append(f'<section id="{anchor}">')
        out.append(f"<h2>{e(section.title)}</h2>")
        out += [f"<p>{e(p)}</p>" for p in section.paragraphs]
        for table in section.tables:
            out.append("<table>")
            if table.caption:
                out.append(f"<caption>{e(table.caption)}</caption>")
            out.append("<thead><tr>" + "".join(f"<th>{e(h)}</th>" for h in table.headings) + "</tr></thead>")
            out.append("<tbody>")
            out += ["<tr>" + "".join(f"<td>{e(cell)}</td>" for cell in row) + "</tr>" for row in table.rows]
            out.append("</tbody></table>")
        if section.figures:
            out.append('<div class="figures">')
            for figure in section.figures:
                out.append(f'<figure id="{e(figure.slug)}">')
                out.append(figures.inline_svg(figure.svg, figure.slug))
                out.append(f"<figcaption>{e(figure.title)}</figcaption></figure>")
            out.append("</div>")
        out.append("</section>")
    out += ["</body>", "</html>"]
    return "\n".join(out) + "\n"


def _md_cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def render_markdown(title: str, sections: list[Section]) -> str:
    out = [f"# {title}", ""]
    for section in sections:
        out += [f"## {section.title}", ""]
        for paragraph in section.paragraphs:
            out += [paragraph, ""]
        for table in section.tables:
            out.append("| " + " | ".join(_md_cell(h) for h in table.headings) + " |")
            out.append("|" + "|".join("---" for _ in table.headings) + "|")
            out += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in table.rows]
            out.append("")
            if table.caption:
                out += [f"*{table.caption}*", ""]
        for figure in section.figures:
            out += [f"![{figure.title}](figures/{figure.slug}.svg)", ""]
    return "\n".join(out).rstrip("\n") + "\n"


def _write_atomically(path: str, text: str) -> None:
    directory = os.path.dirname(os.path.abspath(path))
    handle, temporary = tempfile.mkstemp(prefix=".report-", dir=directory)
    try:
        with os.fdopen(handle, "w", encoding="utf-8", newline="\n") as stream:
            stream.write(text)
        os.chmod(temporary, 0o644)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def write_report(paths: list[str], out_dir: str, title: str = "lockstep report") -> list[str]:
    labels = unique_labels(paths)
    loaded = [load_any(path, label) for path, label in zip(paths, labels)]
    sections = build_sections(loaded)
    try:
        os.makedirs(os.path.join(out_dir, "figures"), exist_ok=True)
    except OSError as error:
        raise InputError(out_dir, f"cannot create the output directory: {error.strerror or error}") from None
    written = []
    for section in sections:
        for figure in section.figures:
            path = os.path.join(out_dir, "figures", f"{figure.slug}.svg")
            _write_atomically(path, figure.svg)
    html_path = os.path.join(out_dir, "report.html")
    markdown_path = os.path.join(out_dir, "report.md")
    _write_atomically(html_path, render_html(title, sections))
    _write_atomically(markdown_path, render_markdown(title, sections))
    written += [html_path, markdown_path]
    return written
