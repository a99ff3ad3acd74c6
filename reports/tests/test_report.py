"""`lockstep report`: the HTML and Markdown it writes, their figures and tables, and their determinism."""
import hashlib
import json
import math
import os
import re
import tempfile
import unittest
from unittest import mock

from support import HEADLINE, Scratch, fixture, headline_document, run_tool

import matplotlib.figure

from lockstep_reports.read.c2c_reader import C2cPair
from lockstep_reports.analysis.run_analysis import run_median
from lockstep_reports.read.inputs import load_any, load_run_file
from lockstep_reports.report import answer, c2c_analysis, figures, matrix, paper, report

# headline.json with team_cpu_* and the split of a step: fixtures/make_cpu_fixture.py.
CPU_SPLIT = "cpu_split.json"
# A real `lockstep run --quick` file with team_cpu_* and the split (3 primitives, 2 threads).
REAL_SPLIT = "run_quick_split.json"
ALL_INPUTS = ["machine_a.json", "machine_b.json", "c2c_a.json", "c2c_b.json", "delay_a.json", "verify_a.csv"]



_REAL_SAVEFIG = matplotlib.figure.Figure.savefig
_stand_in_figures = None


def setUpModule():
    """Every figure is built and none rendered (_stand_in_svg), except in Report, which renders the whole sample
    report for real, twice: rendering is most of a report's time, and the pages are what these tests read."""
    global _stand_in_figures
    _stand_in_figures = mock.patch.object(matplotlib.figure.Figure, "savefig", _stand_in_svg)
    _stand_in_figures.start()


def tearDownModule():
    _stand_in_figures.stop()


def digest_tree(directory):
    digests = {}
    for root, _, files in os.walk(directory):
        for name in sorted(files):
            path = os.path.join(root, name)
            with open(path, "rb") as stream:
                digests[os.path.relpath(path, directory)] = hashlib.sha256(stream.read()).hexdigest()
    return digests


class Report(unittest.TestCase):
    """The whole sample report with its figures rendered."""

    @classmethod
    def setUpClass(cls):
        cls.rendered = mock.patch.object(matplotlib.figure.Figure, "savefig", _REAL_SAVEFIG)
        cls.rendered.start()
        cls.addClassCleanup(cls.rendered.stop)
        cls.directory = tempfile.TemporaryDirectory()
        cls.out = os.path.join(cls.directory.name, "first")
        status, _, err = run_tool("report", *[fixture(name) for name in ALL_INPUTS], "--out", cls.out)
        assert status == 0, err
        with open(os.path.join(cls.out, "report.html"), encoding="utf-8") as stream:
            cls.html = stream.read()
        with open(os.path.join(cls.out, "report.md"), encoding="utf-8") as stream:
            cls.markdown = stream.read()

    @classmethod
    def tearDownClass(cls):
        cls.directory.cleanup()

    def test_same_input_gives_the_same_bytes(self):
        again = os.path.join(self.directory.name, "second")
        status, _, _ = run_tool("report", *[fixture(name) for name in ALL_INPUTS], "--out", again)
        self.assertEqual(status, 0)
        self.assertEqual(digest_tree(self.out), digest_tree(again))

    def test_html_is_self_contained(self):
        self.assertNotRegex(self.html, r"<(script|img|link|iframe)[^>]+(src|href)=\"(https?:)?//")
        self.assertNotIn("@import", self.html)
        self.assertNotIn("<?xml", self.html)
        self.assertNotIn("<dc:date>", self.html)  # matplotlib's date metadata is removed

    def test_ids_are_unique_across_inline_figures(self):
        ids = re.findall(r'\bid="([^"]+)"', self.html)
        self.assertEqual(len(ids), len(set(ids)))

    def test_every_figure_the_issue_lists_is_there(self):
        for slug in ("heatmap-", "bars-", "penalties-", "c2c-", "delay-", "trajectory-"):
            self.assertIn(f'<figure id="{slug}', self.html, slug)
        # Two run files x (compact, migrate) x (2, 4 threads), for heat maps and bars each.
        self.assertEqual(self.html.count('<figure id="heatmap-'), 8)
        self.assertEqual(self.html.count('<figure id="bars-'), 8)
        figure_files = os.listdir(os.path.join(self.out, "figures"))
        self.assertEqual(len(figure_files), self.html.count("<figure "))
        for name in figure_files:
            self.assertIn(f"](figures/{name})", self.markdown)

    def test_one_c2c_map_per_measuring_method(self):
        self.assertIn('<figure id="c2c-2-cas"', self.html)
        self.assertIn('<figure id="c2c-2-store-load"', self.html)
        self.assertIn("| store_load | shared L3 |", self.markdown)

    def test_layout_effects_side_by_side_for_two_machines(self):
        self.assertIn("machine_b.json: vs packed", self.markdown)

    def test_paper_values_beside_this_machines(self):
        for text in ("±51.47j", "±19.66j", "±51.49j", "±19.67j", "4.12e-07 s", "5.24e-07 s",
                     "48.94 %", "30691", "29225", "27146", "26903"):
            self.assertIn(text, self.markdown, text)
            self.assertIn(text, self.html, text)
        self.assertIn("Figure 5: this machine (pinned) beside the paper", self.markdown)
        self.assertIn("Figure 5: this machine unpinned", self.markdown)

    def test_machines_and_ranks(self):
        self.assertIn("AMD EPYC 7232P 8-Core Processor", self.markdown)
        self.assertIn("Fastest combinations: machine_b.json", self.markdown)

    def test_report_of_run_results_alone(self):
        out = os.path.join(self.directory.name, "alone")
        status, _, _ = run_tool("report", fixture("machine_a.json"), "--out", out)
        self.assertEqual(status, 0)
        with open(os.path.join(out, "report.md"), encoding="utf-8") as stream:
            markdown = stream.read()
        self.assertNotIn("Multi-core delay", markdown)
        self.assertIn("±51.47j", markdown)

    def test_a_hostile_file_name_is_text_everywhere(self):
        # The label is the file name: in the page's tables and headings (autoescaped by the template) and
        # in the figure's SVG (matplotlib escapes the text it writes, comments included).
        import shutil
        hostile = os.path.join(self.directory.name, "x--><script>alert(1)<b>.csv")
        shutil.copy(fixture("verify_a.csv"), hostile)
        out = os.path.join(self.directory.name, "hostile")
        status, _, err = run_tool("report", hostile, "--out", out)
        self.assertEqual(status, 0, err)
        with open(os.path.join(out, "report.html"), encoding="utf-8") as stream:
            page = stream.read()
        self.assertEqual(page.count("<script"), 1)  # the page's own check script
        self.assertNotIn("<b>", page)
        self.assertIn("x--&gt;&lt;script&gt;alert(1)&lt;b&gt;.csv", page)

    def test_bad_input_is_one_line_and_exit_2(self):
        for name in ("truncated.json", "foreign.json"):
            status, _, err = run_tool("report", fixture(name), "--out", os.path.join(self.directory.name, "bad"))
            self.assertEqual(status, 2)
            self.assertEqual(err.count("\n"), 1)
            self.assertIn(name, err)


class PaceAndDelayReport(unittest.TestCase):
    """The report of a file with the pace keys and of delay files with the per-CPU and period-search keys: the sections and
    figures they add, checked by structure (which figures, which table columns), never by pixels."""

    @classmethod
    def setUpClass(cls):
        cls.directory = tempfile.TemporaryDirectory()
        cls.out = os.path.join(cls.directory.name, "paced")
        status, _, err = run_tool("report", fixture("paced_every_pair.json"), fixture("delay_per_cpu.json"),
                                  fixture("delay_find_period.json"), "--out", cls.out)
        assert status == 0, err
        with open(os.path.join(cls.out, "report.html"), encoding="utf-8") as stream:
            cls.html = stream.read()
        with open(os.path.join(cls.out, "report.md"), encoding="utf-8") as stream:
            cls.markdown = stream.read()

    @classmethod
    def tearDownClass(cls):
        cls.directory.cleanup()

    def test_pace_trace_and_modes(self):
        self.assertIn('<figure id="pace-0"', self.html)
        self.assertIn("Pace of the machine: paced_every_pair.json", self.markdown)
        self.assertIn("| mode | c2c one-way | serial step | share of the run | readings |", self.markdown)
        self.assertIn("c2c 25 ns for 57 % of the run, 118 ns for 40 %; 1 change", self.markdown)

    def test_per_mode_medians_for_entries_in_two_modes(self):
        self.assertIn("| entry | mode 0 (c2c 25.0 ns) | mode 1 (c2c 118 ns) | slowest / fastest | straddling |",
                      self.markdown)
        self.assertRegex(self.markdown, r"\| rk4/sync:futex_spin/layout:packed/pin:compact/threads:4 \| [0-9.]+ us \(6\) "
                                        r"\| [0-9.]+ us \(3\) \| 2\.[0-9]+x \| 1 \|")

    def test_paired_penalties_carry_their_interval_and_verdict(self):
        # Its interval straddles the band's upper edge: unsure (platform/statistics.hpp), not within noise.
        self.assertRegex(self.markdown, r"\| false sharing \(paired\): shared lines / isolated \| seqlock \| compact \| 2 \| "
                                        r"1\.0[0-9]x \| \[0\.9[0-9]+, 1\.[0-9]+\] \| unsure \|")
        self.assertIn("| migration (paired): pin:migrate / pin:compact | std_barrier | migrate | 4 | 1.60x |", self.markdown)
        # Each kind drawn once: false sharing and migration in the penalties, each primitive against the best other
        # in its section, the harness's overhead with the table of every pair.
        for slug in ("penalties-0", "best-other-0", "pairs-0-overhead"):
            self.assertIn(f'<figure id="{slug}"', self.html)
        self.assertEqual(self.html.count('<figure id="pairs-'), 1)

    def test_within_noise_cells_are_said(self):
        self.assertIn("Hatched, marked ≈", self.markdown)

    def test_delay_figures(self):
        for slug in ('delay-1"', 'delay-1-per-cpu"', 'delay-2"', 'delay-2-find-period"'):
            self.assertIn(f'<figure id="{slug}', self.html)
        self.assertIn("Noisiest CPU: 1", self.markdown)
        self.assertIn("| cpu | min | p50 | p99 | p99.9 | max | count | deadline misses |", self.markdown)
        self.assertIn("| confirming run | 420.448 us |", self.markdown)
        self.assertIn("The search budget cut the search", self.markdown)

    def test_delay_settings_are_written_for_people(self):
        self.assertIn("| scheduling | SCHED_FIFO, priority 80 |", self.markdown)
        self.assertIn("| memory | locked (mlockall: no page faults while paced) |", self.markdown)
        self.assertIn("| period | 1 ms |", self.markdown)
        self.assertIn("/dev/cpu_dma_latency held at 0 us, as cyclictest does by default", self.markdown)
        for program_value in ("fifo_priority", "mlock False", "period_ns", "None"):
            self.assertNotIn(program_value, self.markdown)

    def test_every_figure_is_linked_from_the_markdown(self):
        figure_files = os.listdir(os.path.join(self.out, "figures"))
        self.assertEqual(len(figure_files), self.html.count("<figure "))
        for name in figure_files:
            self.assertIn(f"](figures/{name})", self.markdown)


class WithoutPaceKeys(unittest.TestCase):
    def test_an_older_file_reports_as_before(self):
        with tempfile.TemporaryDirectory() as directory:
            out = os.path.join(directory, "old")
            status, _, err = run_tool("report", fixture("machine_a.json"), fixture("delay_a.json"), "--out", out)
            self.assertEqual(status, 0, err)
            with open(os.path.join(out, "report.md"), encoding="utf-8") as stream:
                markdown = stream.read()
        for added in ("Pace of the machine", "Paired ratios", "(paired)", "per CPU", "find-period", "≈"):
            self.assertNotIn(added, markdown)
        self.assertIn("| scheduling | SCHED_OTHER", markdown)
        self.assertIn("| memory | not locked (no mlockall) |", markdown)


def scaling_point(sync, threads, value, low, high, oversubscribed):
    return {"sync": sync, "threads": threads, "layout": "per_thread", "model": "two_mass" if threads <= 4 else "chain4",
            "sync_ns_per_stage": value, "ns_per_step": 10 * value, "repetitions_min": low, "repetitions_max": high,
            "oversubscribed": oversubscribed}


class ScalingReport(unittest.TestCase):
    """A `run --scaling` file: the section, its figure and whether the best is separated from the next."""

    def report_of(self, points, best):
        with open(fixture("machine_a.json"), encoding="utf-8") as stream:
            document = json.load(stream)
        document["lockstep_scaling"] = {"pin": "compact", "counter": "sync_ns_per_stage", "threads": [2, 8],
                                        "points": points, "best": best, "c2c_one_way_ns": 23.0}
        with tempfile.TemporaryDirectory() as directory:
            path = os.path.join(directory, "scaling.json")
            with open(path, "w", encoding="utf-8") as stream:
                json.dump(document, stream)
            out = os.path.join(directory, "report")
            status, _, err = run_tool("report", path, "--out", out)
            self.assertEqual(status, 0, err)
            with open(os.path.join(out, "report.md"), encoding="utf-8") as stream:
                markdown = stream.read()
            self.assertTrue(os.path.exists(os.path.join(out, "figures", "scaling-0.svg")))
        return markdown

    def test_a_clear_lead_is_said_clear(self):
        markdown = self.report_of([scaling_point("fast", 2, 20, 19, 21, False), scaling_point("fast", 8, 2000, 1900, 2100, True),
                                   scaling_point("slow", 2, 50, 49, 51, False), scaling_point("slow", 8, 5000, 4900, 5100, True)],
                                  "fast")
        self.assertIn("## Scaling: scaling.json", markdown)
        self.assertIn("Scales best: fast", markdown)
        self.assertIn("clear of every other primitive's", markdown)
        self.assertIn("| slow | 50.0 ns | 5.000 us* |", markdown)

    def test_overlapping_ranges_are_said_not_separated(self):
        markdown = self.report_of([scaling_point("fast", 2, 20, 19, 21, False), scaling_point("fast", 8, 2000, 1900, 2600, True),
                                   scaling_point("slow", 2, 50, 49, 51, False), scaling_point("slow", 8, 2100, 2050, 2200, True)],
                                  "fast")
        self.assertIn("not separated from slow", markdown)

    def test_a_file_without_ranges_reports_the_best_alone(self):
        points = [scaling_point("fast", 2, 20, 19, 21, False), scaling_point("fast", 8, 2000, 1900, 2100, True)]
        for point in points:
            del point["repetitions_min"], point["repetitions_max"]
        markdown = self.report_of(points, "fast")
        self.assertIn("Scales best: fast (the lowest sync time per stage at 8 threads among the primitives measured at "
                      "every count).", markdown)


class Pieces(unittest.TestCase):
    def test_topology_order_puts_siblings_and_cache_domains_together(self):
        order = c2c_analysis.topology_order(load_any(fixture("c2c_b.json")).pairs)
        self.assertEqual(order[:4], [0, 8, 1, 9])
        self.assertEqual(set(order[:8]), {0, 1, 2, 3, 8, 9, 10, 11})

    def test_topology_order_ranks_the_labels_the_binary_writes(self):
        # A 2-package machine of 2 nodes, numbered so that numeric order is not topology order: CPU c sits in
        # package c % 2, SMT siblings c and c + 4.
        place = {cpu: (cpu % 4, cpu % 2) for cpu in range(8)}  # cpu -> (core, package)
        pairs = []
        for a in range(8):
            for b in range(a + 1, 8):
                relation = ("SMT siblings" if place[a][0] == place[b][0] else
                            "shared L3" if place[a][1] == place[b][1] else "different package")
                pairs.append(C2cPair(a, b, "cas", relation, 30.0))
        self.assertEqual(c2c_analysis.topology_order(pairs), [0, 4, 2, 6, 1, 5, 3, 7])
        closest_first = ("same PU", "SMT siblings", "shared L2", "shared L3", "same package", "different L3",
                         "other NUMA node", "different package")
        self.assertEqual(c2c_analysis.topology_order(pairs, closest_first), [0, 4, 2, 6, 1, 5, 3, 7])
        # The file's order ranks a label; one it does not list comes after all of them.
        self.assertEqual(c2c_analysis.relation_rank("other NUMA node", closest_first), 6)
        self.assertEqual(c2c_analysis.relation_rank("a label from the future", closest_first), 8)

    def test_model_roots_and_the_papers(self):
        fast, slow = paper.model_roots()
        self.assertAlmostEqual(fast, 51.49, places=2)
        self.assertAlmostEqual(slow, 19.67, places=2)
        self.assertAlmostEqual(paper.c_over_m_from_roots(), 1011.9, delta=0.3)

    def test_analytic_trajectory_starts_at_the_initial_state(self):
        x1, x2 = paper.analytic_trajectory([0.0])
        self.assertAlmostEqual(float(x1[0]), 2.0)
        self.assertAlmostEqual(float(x2[0]), -3.0)


class LeaderLineInTheReport(unittest.TestCase):
    def test_the_report_names_every_bars_primitive_and_marks_the_leader(self):
        with tempfile.TemporaryDirectory() as directory:
            out = os.path.join(directory, "report")
            status, _, err = run_tool("report", fixture(HEADLINE), "--out", out)
            self.assertEqual(status, 0, err)
            with open(os.path.join(out, "report.md"), encoding="utf-8") as stream:
                markdown = stream.read()
        self.assertRegex(markdown, r"\| ck_tas vs seqlock \(step, pin:compact, 2 threads\) \| 0\.[0-9]+x \| "
                                   r"\[0\.[0-9]+, 0\.[0-9]+\] \| gain \| 12 \| the runner-up's pair, inverted \|")
        self.assertRegex(markdown, r"\| seqlock vs ck_tas \(step, pin:compact, 2 threads\) \| 1\.[0-9]+x \| .* \| "
                                   r"penalty \| 12 \| its own pair \|")
        self.assertIn("| ck_tas vs seqlock (episode, pin:compact, 2 threads) |", markdown)
        self.assertNotIn("| RK4 step pin:compact threads:2 |", markdown.split("## Paired ratios")[0])


class AnswerFirst(Scratch):
    def test_the_answer_comes_first_as_a_table_then_where_the_rest_is(self):
        html, markdown = self.report(fixture(HEADLINE))
        document = headline_document()["lockstep_headline"]
        body = html[html.index("<body>"):]
        answer = body.index('<section class="answer"')
        self.assertLess(answer, body.index("<details"))
        self.assertNotIn("<pre", body[answer:body.index("<details")])  # not the terminal's monospace text
        box = re.search(r'<table class="choices">(.*?)</table>', body, re.S).group(1)
        self.assertEqual(box.count("<tr>") - 1, len(document["recommendations"]))  # a row per choice
        self.assertLess(body.index("The full results: the sections below"), body.index("<details"))
        self.assertTrue(markdown.startswith("# lockstep report\n\n## The answer: headline.json\n\n| threads, placement |"))
        self.assertNotIn("```", markdown.split("## Step time")[0])
        # the terminal's pointers (its result file, the next commands) are not in the box
        self.assertNotIn("lockstep report ", markdown.split("The full results")[0])

    def test_every_section_folds_and_only_the_first_two_are_open(self):
        html, _ = self.report(fixture(HEADLINE))
        sections = re.findall(r"<details id=\"[^\"]+\"( open)?>\s*<summary><h2>([^<]+)</h2>", html)
        self.assertEqual([title for opened, title in sections if opened],
                         ["Step time, sync x layout: headline.json", "Spread per primitive: headline.json"])
        self.assertGreater(len(sections), 6)
        titles = [title for _, title in sections]
        # the raw context table moved down, behind a fold
        self.assertEqual(titles[-1], "Machines and inputs")
        self.assertNotIn("<details open", html[html.index("Machines and inputs") - 200:])

    def test_a_file_without_a_headline_says_so_in_one_line(self):
        html, markdown = self.report(fixture("machine_a.json"))
        notes = [line for line in markdown.splitlines() if "has no answer" in line]
        self.assertEqual(len(notes), 1)
        self.assertTrue(notes[0].startswith("machine_a.json has no answer"))
        self.assertNotIn('<section class="answer"', html)
        self.assertIn("## Step time, sync x layout: machine_a.json", markdown)

    def test_a_line_of_the_answer_reads_whole_whatever_it_holds(self):
        document = headline_document()
        lines = document["lockstep_headline"]["lines"]
        index = next(i for i, line in enumerate(lines) if line.startswith("Pace:"))
        lines[index] = "Pace: a line with ``` and ```` and | and <b>not bold</b> in it"
        html, markdown = self.report(self.write("ticks.json", document))
        self.assertIn("\n- Pace: a line with ``` and ```` and | and <b>not bold</b> in it\n", markdown)
        self.assertIn("<li>Pace: a line with ``` and ```` and | and &lt;b&gt;not bold&lt;/b&gt; in it</li>", html)

    def test_collapsed_entries_are_said_once_and_left_out_of_rankings(self):
        _, markdown = self.report(fixture(HEADLINE))
        said = [line for line in markdown.splitlines() if line.startswith("Collapse when threads outnumber CPUs")]
        self.assertEqual(len(said), 2)  # the heat maps' and the bars' sections, the same line
        self.assertEqual(said[0].split(" Their cells")[0], said[1])
        self.assertRegex(said[1], r"^Collapse when threads outnumber CPUs: ck_tas, seqlock \(at 4 threads\), "
                                  r"[0-9.]+ ms-[0-9.]+ ms a step; left out")
        ranking = markdown.split("## Fastest combinations: headline.json")[1].split("\n## ")[0]
        four = [line for line in ranking.splitlines() if "threads:4 |" in line]
        self.assertEqual(len(four), 10)  # 5 per placement
        self.assertFalse(any("ck_tas" in line or "seqlock" in line for line in four))
        pairs = markdown.split("## Paired ratios: headline.json")[1].split("\n## ")[0]
        self.assertNotIn("sync:ck_tas pin:compact threads:4", pairs)

    def test_the_false_sharing_table_says_its_placements(self):
        _, markdown = self.report(fixture(HEADLINE))
        section = markdown.split("## False-sharing and migration penalties: headline.json")[1].split("\n## ")[0]
        self.assertIn("at each placement measured: pin:compact, pin:none.", section)
        self.assertNotIn("pinned compactly", section.split("Migration:")[0])
        rows = [line for line in section.splitlines() if line.startswith("| false sharing")]
        self.assertEqual({line.split(" | ")[2] for line in rows}, {"compact", "none"})


class Figures(unittest.TestCase):
    """What the figures draw, read from matplotlib's figure before it becomes SVG."""

    def drawn(self, function, *arguments):
        captured = []
        with mock.patch.object(figures, "to_svg", side_effect=lambda figure: captured.append(figure) or "<svg/>"):
            function(*arguments)
        self.assertEqual(len(captured), 1)
        return captured[0]

    def test_the_heat_map_ranks_its_rows_and_keeps_collapsed_cells_out_of_its_scale(self):
        run_file = load_run_file(fixture(HEADLINE))
        cells = matrix.heatmap_cells(run_file, "compact", 4, frozenset(), run_file.collapsed, ("futex_spin", "padded128"))
        figure = self.drawn(figures.heatmap, cells)
        axes = figure.axes[0]
        rows = [label.get_text() for label in axes.get_yticklabels()]
        self.assertEqual(rows, ["futex_spin", "std_barrier", "ck_tas", "seqlock"])  # fastest first, collapsed last
        norm = axes.images[0].norm
        self.assertLess(norm.vmax, 1e5)  # the collapsed cells' milliseconds are not on the scale
        self.assertGreater(norm.vmax, 1e4)  # std_barrier's packed step is
        colorbar_labels = [label.get_text() for label in figure.axes[1].get_yticklabels()]
        self.assertTrue(any(label.endswith(" us") for label in colorbar_labels), colorbar_labels)
        self.assertEqual(axes.get_xlabel(), "layout")

    def test_penalty_bars_each_have_a_line_and_the_axis_covers_them(self):
        rows = [matrix.PenaltyRow("false sharing", "mailbox", 4, 1.3, 1.2, 1.4, "penalty", pin="compact"),
                matrix.PenaltyRow("false sharing", "mailbox", 4, 0.97, 0.9, 1.02, "unsure", pin="none"),
                matrix.PenaltyRow("false sharing", "ck_tas", 4, 3500.0, pin="compact")]
        figure = self.drawn(figures.penalties, rows, 0.05)
        axes = figure.axes[0]
        labels = [label.get_text() for label in axes.get_yticklabels()]
        self.assertEqual(len(set(labels)), 3)  # compact and none on lines of their own, named
        self.assertIn("mailbox, pin:none, 4 threads", labels)
        low, high = axes.get_xlim()
        self.assertGreater(high, 3500.0)
        self.assertLess(low, 0.9)
        ticks = [tick for tick in axes.get_xticks() if low <= tick <= high]
        self.assertLessEqual(len(ticks), 8)
        gaps = [math.log10(b / a) for a, b in zip(ticks, ticks[1:])]
        self.assertGreaterEqual(min(gaps), 0.9 * max(gaps) / 3)  # evenly spread, none crowded
        legend = [text.get_text() for text in axes.get_legend().get_texts()]
        self.assertIn("ratio of medians (no interval)", legend)

    def test_ratio_ticks_never_crowd(self):
        for low, high in ((0.9, 1.1), (0.8, 1.6), (0.3, 2.6), (0.2, 12.0), (0.5, 3500.0), (1e-4, 3500.0),
                          (1e-7, 1e9)):
            with self.subTest(low=low, high=high):
                ticks = figures.ratio_ticks(low, high)
                self.assertGreaterEqual(len(ticks), 2)
                self.assertLessEqual(len(ticks), 8)
                self.assertIn(1.0, ticks)
                self.assertTrue(all(low <= tick <= high for tick in ticks))
        self.assertEqual([figures.ratio_text(t) for t in figures.ratio_ticks(0.5, 3500.0)],
                         ["1x", "10x", "100x", "1,000x"])


class CpuPerStep(Scratch):
    """Step time against the team's CPU per step (report.cpu_section, matrix.cpu_points, figures.cpu_against_time)
    and the split of a step (report.split_section), on fixtures/cpu_split.json: headline.json with team_cpu_* and
    the split (fixtures/make_cpu_fixture.py: every entry's team CPU is a fixed number of CPUs busy x its time)."""

    CPUS_BUSY = {"ck_tas": {2: 2.0, 4: 2.0}, "seqlock": {2: 2.0, 4: 2.0}, "futex_spin": {2: 1.9, 4: 1.6},
                 "std_barrier": {2: 0.5, 4: 0.8}}  # as make_cpu_fixture.py writes them

    def document(self):
        with open(fixture(CPU_SPLIT), encoding="utf-8") as stream:
            return json.load(stream)

    def test_one_point_per_entry_but_the_collapsed_at_its_medians(self):
        run_file = load_run_file(fixture(CPU_SPLIT))
        points = matrix.cpu_points(run_file, "rk4", run_file.collapsed)
        entries = [key for key in run_file.runs if key.family == "rk4" and key.get("sync")]
        self.assertEqual(len(entries), 48)  # 4 primitives x 3 layouts x 2 placements x 2 thread counts
        self.assertEqual(len(run_file.collapsed), 12)  # ck_tas and seqlock at 4 threads
        self.assertEqual({point.key for point in points}, {key for key in entries if key not in run_file.collapsed})
        self.assertEqual(len(points), 36)
        for point in points:
            self.assertEqual(point.unit_ns, run_median(run_file, point.key))  # the median every table shows
            self.assertAlmostEqual(point.cpus_busy, self.CPUS_BUSY[point.key.get("sync")][point.key.threads],
                                   places=4)
        barrier = matrix.cpu_points(run_file, "barrier", run_file.collapsed)
        self.assertEqual(len(barrier), 4)
        self.assertEqual({point.key.get("sync"): round(point.cpus_busy, 4) for point in barrier},
                         {sync: busy[2] for sync, busy in self.CPUS_BUSY.items()})

    def test_the_figure_draws_them_log_log_with_a_line_per_cpu_count(self):
        run_file = load_run_file(fixture(CPU_SPLIT))
        points = matrix.cpu_points(run_file, "rk4", run_file.collapsed)
        captured = []
        chosen = frozenset(item.entry_key for item in run_file.answer.choices)
        with mock.patch.object(figures, "to_svg", side_effect=lambda figure: captured.append(figure) or "<svg/>"):
            figures.cpu_against_time(points, "step", 2, chosen)
        panels = captured[0].axes
        self.assertEqual([axes.get_title() for axes in panels], ["2 threads", "4 threads on 2 CPUs"])
        for axes, threads in zip(panels, (2, 4)):
            self.assertEqual((axes.get_xscale(), axes.get_yscale()), ("log", "log"))
            drawn = sorted(tuple(offset) for collection in axes.collections for offset in collection.get_offsets())
            expected = sorted((point.unit_ns, point.team_cpu_ns) for point in points if point.key.threads == threads)
            self.assertEqual(len(drawn), len(expected))
            for (x, y), (unit, cpu) in zip(drawn, expected):
                self.assertAlmostEqual(x / unit, 1.0, places=9)
                self.assertAlmostEqual(y / cpu, 1.0, places=9)
            texts = [text.get_text() for text in axes.texts]
            # 1 .. the machine's 2 CPUs, and the thread count where the threads outnumber them
            self.assertEqual([text for text in texts if text.endswith("busy")],
                             ["1 CPU busy", "2 CPUs busy"] + (["4 CPUs busy"] if threads == 4 else []))
            named = [text for text in texts if not text.endswith("busy")]
            self.assertIn("std_barrier (padded128)" if threads == 4 else "std_barrier (packed)", named)  # fewest CPUs
            low, high = axes.get_xlim()
            self.assertTrue(all(low < x < high for x, _ in drawn))
        self.assertIn("ck_tas (padded128)", [text.get_text() for text in panels[0].texts])  # the fastest
        ringed = {(float(line.get_xdata()[0]), float(line.get_ydata()[0])) for axes in panels for line in axes.lines
                  if line.get_markeredgecolor() == "#d62728"}
        self.assertEqual(ringed, {(point.unit_ns, point.team_cpu_ns) for point in points if point.key in chosen})
        self.assertEqual(len(ringed), 4)  # one per placement and thread count

    def test_the_report_shows_it_with_what_a_user_reads_from_it(self):
        html, markdown = self.report(fixture(CPU_SPLIT))
        self.assertIn('<figure id="cpu-0-rk4"', html)
        self.assertIn('<figure id="cpu-0-barrier"', html)
        section = markdown.split("## Step time against CPU per step: cpu_split.json")[1].split("\n## ")[0]
        self.assertIn("A spinning primitive sits on k = its threads", section)
        self.assertIn("Not drawn: the 12 collapsed entries", section)
        self.assertNotIn("No figure", section)

    def test_an_older_file_gets_no_figure_and_one_line_saying_why(self):
        html, markdown = self.report(fixture(HEADLINE))
        self.assertNotIn('<figure id="cpu-', html)
        said = [line for line in markdown.splitlines() if line.startswith("No figure: headline.json")]
        self.assertEqual(len(said), 1)
        self.assertIn("team_cpu_ns_per_step", said[0])
        self.assertNotIn("## Where a step's time goes", markdown)

    def split_rows(self, markdown):
        section = markdown.split("## Where a step's time goes: ")[1].split("\n## ")[0]
        return section, [line.split(" | ") for line in section.splitlines() if line.startswith("| pin:")]

    def test_the_split_renders_when_present(self):
        html, markdown = self.report(fixture(CPU_SPLIT))
        self.assertEqual(html.count('<figure id="split-'), 4)  # one per placement and thread count
        _, rows = self.split_rows(markdown)
        # Each primitive at its fastest layout (the collapsed ones left out): 4 + 2 primitives per placement.
        self.assertEqual(len(rows), 12)
        first = rows[0]
        self.assertEqual(first[:2], ["| pin:compact, 2 threads", "ck_tas + padded128"])
        step, compute, waiting, release = (float(cell.split()[0]) for cell in first[2:6])
        self.assertAlmostEqual(compute / step, 0.5, places=3)
        self.assertAlmostEqual(waiting / step, 0.3, places=3)
        self.assertAlmostEqual(release / step, 0.2, places=2)
        futex = next(row for row in rows if row[0] == "| pin:none, 2 threads" and row[1].startswith("futex_spin"))
        self.assertEqual(futex[5], "-0.5 ns")  # a release just below 0, as the writer may measure it
        self.assertAlmostEqual(compute + waiting + release, step, places=1)  # the three add up to the step
        self.assertEqual(first[6:], ["50 %", "0 of 5 |"])  # the syncs' share; no repetition clamped

    def test_the_split_of_some_repetitions_only_still_reads(self):
        document = self.document()
        for entry in document["benchmarks"]:  # one repetition without the split, as the writer may leave it
            if entry["name"] == "rk4/sync:ck_tas/layout:padded128/pin:compact/threads:2" \
                    and entry.get("repetition_index") == 0:
                for counter in ("compute_ns_per_step", "waiting_ns_per_step", "release_ns_per_step"):
                    del entry[counter]
        _, markdown = self.report(self.write("split_partly.json", document))
        _, rows = self.split_rows(markdown)
        self.assertEqual(rows[0][1], "ck_tas + padded128")

    def test_no_split_without_its_counters(self):
        document = self.document()
        for entry in document["benchmarks"]:
            for counter in ("compute_ns_per_step", "waiting_ns_per_step", "release_ns_per_step"):
                entry.pop(counter, None)
        html, markdown = self.report(self.write("cpu_only.json", document))
        self.assertNotIn("## Where a step's time goes", markdown)
        self.assertIn('<figure id="cpu-0-rk4"', html)

    def test_a_real_run_file_with_both(self):
        """fixtures/run_quick_split.json: `lockstep run --quick --threads 2 --sync mailbox,std_barrier,futex_spin
        --pairs 0` on a 2-CPU VM, as bench/run/rk4_entries.cpp writes the split."""
        run_file = load_run_file(fixture(REAL_SPLIT))
        points = matrix.cpu_points(run_file, "rk4", run_file.collapsed)
        self.assertEqual(len(points), 18)  # 3 primitives x (4 layouts, mailbox 1) x 2 placements, at 2 threads
        self.assertTrue(all(0.0 < point.cpus_busy < 2.1 for point in points))  # the team has the VM's 2 CPUs
        # The same fact reads the same everywhere: the headline's "CPUs busy" (bench/run/answer.hpp, the
        # medians' ratio) is the point's, to the bit.
        by_key = {point.key: point for point in points}
        with open(fixture(REAL_SPLIT), encoding="utf-8") as stream:
            written = json.load(stream)["lockstep_headline"]["recommendations"]
        for read, raw in zip(run_file.answer.choices, written):
            self.assertEqual(by_key[read.entry_key].cpus_busy, raw["cpus_busy"], read.entry)
        html, markdown = self.report(fixture(REAL_SPLIT))
        self.assertIn('<figure id="cpu-0-rk4"', html)
        _, rows = self.split_rows(markdown)
        self.assertEqual([row[1] for row in rows if row[0] == "| pin:compact, 2 threads"],
                         ["mailbox + per_thread", "futex_spin + per_thread", "std_barrier + packed"])

    def test_split_bars_are_shares_of_the_parts(self):
        run_file = load_run_file(fixture(CPU_SPLIT))
        splits = matrix.step_splits(run_file, "none", 2, run_file.collapsed)
        self.assertEqual([split.key.get("sync") for split in splits],
                         ["ck_tas", "seqlock", "futex_spin", "std_barrier"])  # fastest first
        captured = []
        with mock.patch.object(figures, "to_svg", side_effect=lambda figure: captured.append(figure) or "<svg/>"):
            figures.step_split_bars(splits, "title")
        bars = captured[0].axes[0].patches
        widths = [[round(bar.get_width(), 3) for bar in bars[row * 3:row * 3 + 3]] for row in range(len(splits))]
        self.assertEqual(widths[0], [50.0, 30.0, 20.0])  # shares of the step
        futex = splits[2]
        self.assertEqual(widths[2], [round(100 * futex.parts_ns[0] / futex.step_ns, 3),
                                     round(100 * futex.parts_ns[1] / futex.step_ns, 3), 0.0])  # release < 0 drawn as 0


if __name__ == "__main__":
    unittest.main()


class DelayCauses(Scratch):
    """A delay file's causes object (bench/delay/delay_report.cpp, causes_json), read by delay_reader.read_causes,
    becomes the delay section's stacked bars (figures.delay_causes), placed by report.py's delay_section; a file
    without one gets none."""

    def delay_document(self):
        with open(fixture("delay_a.json"), encoding="utf-8") as stream:
            return json.load(stream)

    def test_a_file_with_causes_gets_the_causes_figure(self):
        document = self.delay_document()
        split = {"compute": 0.0, "run_queue_wait": 300.0, "migration": 0.0, "page_faults": 0.0, "interrupts": 0.0,
                 "wake_up_latency": 700.0, "machine_stall": 0.0, "unexplained": 0.0}
        row = {"label": "above p99", "threshold_ns": 5000.0, "steps": 10, "excess_ns": 1000.0, "cause_ns": split,
               "explained_share": 1.0, "guest_share": 1.0, "top": "wake_up_latency"}
        document["causes"] = {"unavailable": None, "tail": [row], "per_cpu": [{"cpu": 1, "cause_ns": split}],
                              "worst": []}
        html, markdown = self.report(self.write("delay_causes.json", document))
        self.assertIn("causes of the tail", html)
        self.assertIn("delay-0-causes", markdown)

    def test_a_file_without_causes_gets_none(self):
        document = self.delay_document()
        document.pop("causes", None)
        html, _ = self.report(self.write("delay_plain.json", document))
        self.assertNotIn("causes of the tail", html)


# Two real `lockstep run --quick --repetitions 1 --threads 2 --pin compact --sync mailbox,std_barrier
# --layout per_thread --pairs 2 --crossover --crossover-max-masses 4096 --crossover-budget 40s` files, written whole
# (about 50 KB each) by a Debug build (the dev preset) on the 2-vCPU Intel Xeon guest while other processes shared
# it (most pairs set aside: points with nothing measured), 2026-11-27: mailbox crossed and std_barrier paid off at
# every size measured.
CROSSOVER_A = "crossover_a.json"
CROSSOVER_B = "crossover_b.json"
# The same command with the machine's ceiling beside the series (lockstep_crossover.ceilings), by the same build on
# the same machine, quiet, 2026-11-27.
CROSSOVER_CEILING = "crossover_ceiling.json"


class Crossover(Scratch):
    """`lockstep run --crossover` in the report: the answer shows the run's crossover lines as written
    (lockstep_headline.crossover), and a section draws step time against S per thread count (figures.crossover_curves,
    placed by report.crossover_section) with the series and their points as tables; a file without the sweep gets
    neither."""

    def document(self, name=CROSSOVER_A):
        with open(fixture(name), encoding="utf-8") as stream:
            return json.load(stream)

    def test_the_line_is_shown_as_written_and_the_figure_drawn(self):
        written = self.document()["lockstep_headline"]["crossover"]
        self.assertEqual(len(written), 1)
        html, markdown = self.report(fixture(CROSSOVER_A))
        line = written[0]
        answer = markdown[:markdown.index("\n## ", markdown.index("## The answer") + 1)]
        # Under the answer first, before the table of choices, and not taken for the choices' title.
        self.assertLess(answer.index("**Best of the run"), answer.index(line))
        self.assertLess(answer.index(line), answer.index("| threads, placement |"))
        self.assertNotIn("*Crossover at", answer)
        self.assertIn("*Best here: ", answer)  # the choices' title is still theirs
        self.assertIn(f'<p class="crossover">{html_escaped(line)}</p>', html)
        self.assertIn("**crossover, S***", answer)  # the word is said in the glossary
        self.assertIn(f"The run's answer: {line}", markdown)  # and again in its section
        self.assertIn("## Crossover: crossover_a.json", markdown)
        self.assertIn('<figure id="crossover-0-2"', html)
        self.assertIn("](figures/crossover-0-2.svg)", markdown)
        self.assertTrue(os.path.isfile(os.path.join(self.directory.name, "report", "figures", "crossover-0-2.svg")))

    def test_a_file_without_the_sweep_shows_nothing_of_it(self):
        html, markdown = self.report(fixture(REAL_SPLIT))
        self.assertNotIn("## Crossover", markdown)
        self.assertNotIn('<p class="crossover">', html)
        for page in (html, markdown):
            self.assertNotIn("Crossover at", page)
            self.assertNotIn("crossover, S*", page)
        self.assertFalse(any(name.startswith("crossover-")
                             for name in os.listdir(os.path.join(self.directory.name, "report", "figures"))))

    def test_the_tables_hold_what_the_file_holds(self):
        written = self.document()["lockstep_crossover"]["crossovers"]
        _, markdown = self.report(fixture(CROSSOVER_A))
        start = markdown.index("## Crossover: ")
        section = markdown[start:markdown.index("\n## ", start)].splitlines()
        rows = [line for line in section if line.startswith("| 2 threads, pin:compact | ")]
        self.assertEqual(len(rows), len(written))
        for row, series in zip(rows, written):
            self.assertIn(f"{series['sync']} + {series['layout']}", row)
            if series["ci_low"] is not None and series["ci_high"] is not None:
                self.assertIn(f"| {series['masses']:.0f} [{series['ci_low']:.0f}, {series['ci_high']:.0f}] |", row)
        points = [line for line in section if line.startswith("| 2, ")]
        self.assertEqual(len(points), sum(len(series["points"]) for series in written))
        unmeasured = [point for series in written for point in series["points"] if point["failure"]]
        self.assertTrue(unmeasured)  # the real run set pairs aside: those sizes say why, with no numbers
        self.assertEqual(sum(1 for line in points if unmeasured[0]["failure"] in line), len(unmeasured))

    def test_the_figure_draws_each_series_its_serial_step_its_model_and_its_crossover(self):
        run_file = load_run_file(fixture(CROSSOVER_A))
        series = run_file.crossover.crossovers
        captured = []
        with mock.patch.object(figures, "to_svg", side_effect=lambda figure: captured.append(figure) or "<svg/>"):
            report.crossover_section(run_file, [0])
        self.assertEqual(len(captured), 1)  # one thread count swept
        axes = captured[0].axes[0]
        self.assertEqual((axes.get_xscale(), axes.get_yscale()), ("log", "log"))
        lines = {line.get_label(): line for line in axes.get_lines()}
        for crossover in series:
            measured = [point for point in crossover.points if point.measured]
            self.assertTrue(measured)
            label = f"{crossover.sync} + {crossover.layout}: S* {report.format_crossover(crossover)}"
            self.assertEqual(list(lines[label].get_ydata()), [point.parallel_ns for point in measured])
            serial = lines[f"serial step, paired with {crossover.sync}"]
            self.assertEqual(list(serial.get_ydata()), [point.serial_ns for point in measured])
            model = lines[f"model beside {crossover.sync}"]
            self.assertEqual(model.get_linestyle(), "--")
            self.assertEqual(list(model.get_ydata()), [point.model_ns for point in measured])
            # S*: a dotted vertical line at the file's value.
            self.assertTrue(any(line.get_linestyle() == ":" and list(line.get_xdata()) == [crossover.masses] * 2
                                for line in axes.get_lines()))

    def test_the_ceiling_is_drawn_and_tabled_as_the_file_holds_it(self):
        document = self.document(CROSSOVER_CEILING)
        written = document["lockstep_crossover"]["ceilings"]
        self.assertEqual(len(written), 1)
        ceiling_line = next(line for line in document["lockstep_headline"]["crossover"] if line.startswith("Ceiling"))
        run_file = load_run_file(fixture(CROSSOVER_CEILING))
        (ceiling,) = run_file.crossover.ceilings
        self.assertEqual((ceiling.threads, ceiling.pin), (written[0]["threads"], written[0]["pin"]))
        measured = [point for point in ceiling.points if point.measured]
        self.assertTrue(measured)
        captured = []
        with mock.patch.object(figures, "to_svg", side_effect=lambda figure: captured.append(figure) or "<svg/>"):
            report.crossover_section(run_file, [0])
        lines = {line.get_label(): line for line in captured[0].axes[0].get_lines()}
        drawn = lines["the blocks at once, no sync (the ceiling)"]
        self.assertEqual(drawn.get_linestyle(), "-.")
        self.assertEqual(list(drawn.get_ydata()), [point.blocks_ns for point in measured])
        # Each series point's share of it, as written.
        shares = [point.of_ceiling for series in run_file.crossover.crossovers for point in series.points]
        self.assertEqual(shares, [point.get("of_ceiling") for series in document["lockstep_crossover"]["crossovers"]
                                  for point in series["points"]])
        self.assertTrue(any(share is not None for share in shares))
        _, markdown = self.report(fixture(CROSSOVER_CEILING))
        self.assertIn(f"The run's answer: {ceiling_line}", markdown)
        start = markdown.index("## Crossover: ")
        section = markdown[start:markdown.index("\n## ", start)]
        self.assertIn("| threads, placement | S | serial step | the blocks at once |", section)
        self.assertEqual(sum(1 for line in section.splitlines() if line.startswith("| 2, pin:compact | ")),
                         len(ceiling.points))

    def test_a_damaged_point_is_one_line_naming_it(self):
        document = self.document()
        document["lockstep_crossover"]["crossovers"][0]["points"][1]["serial_ns"] = "1 us"
        out = os.path.join(self.directory.name, "never")
        status, _, err = run_tool("report", self.write("damaged.json", document), "--out", out)
        self.assertEqual(status, 2)
        self.assertEqual(err.count("\n"), 1, err)
        self.assertIn("lockstep_crossover.crossovers[0].points[1]", err)
        self.assertFalse(os.path.exists(out))


def html_escaped(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace("'", "&#39;").replace(
        '"', "&#34;")


# ---------------------------------------------------------------- what a person reads, over the real run files

REPOSITORY = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
QUICK_PAIRS = os.path.join(REPOSITORY, "tests", "fixtures", "run", "quick-pairs.json")
XEON = fixture("xeon_default_run_trimmed.json")
# The rows of the Xeon run's entry whose repetitions errored (fixtures/trim_real_run.py writes them).
XEON_ERRORED = fixture("xeon_errored_entry.json")


def _stand_in_svg(figure, stream, **_):
    """Figure.savefig where a test reads the pages only: every figure is built, none rendered."""
    stream.write('<svg xmlns="http://www.w3.org/2000/svg"/>')


def load_document(path):
    with open(path, encoding="utf-8") as stream:
        return json.load(stream)


def answer_boxes(html, markdown):
    """The answer box of each page: the HTML <section class="answer">, the Markdown from its heading to "The
    full results"."""
    section = re.search(r'<section class="answer".*?</section>', html, re.S).group(0)
    box = markdown.split("## The answer: ")[1].split("\nThe full results")[0]
    return section, box


def html_texts(section):
    """The text of every cell, caption, paragraph and list item of an HTML fragment (tags inside removed)."""
    texts = re.findall(r"<(td|th|li|p|caption|dd)\b[^>]*>(.*?)</\1>", section, re.S)
    return [re.sub(r"<[^>]+>", "", text).strip() for _, text in texts]


class Pages(Scratch):
    def pages(self, *paths):
        with mock.patch.object(matplotlib.figure.Figure, "savefig", _stand_in_svg):
            return self.report(*paths)


class AnswerBox(Pages):
    """The answer a person reads first: the recommendations as a table, the headline's other lines whole, the
    words explained (answer.py), over the real run files."""

    def test_no_answer_line_ends_cut(self):
        for path in (QUICK_PAIRS, XEON):
            with self.subTest(os.path.basename(path)):
                html, markdown = self.pages(path)
                section, box = answer_boxes(html, markdown)
                lines = [line.strip() for line in box.splitlines() if line.strip()]
                texts = html_texts(section)
                self.assertTrue(lines and texts)
                for text in lines + texts:
                    self.assertFalse(text.rstrip("*").endswith("..."), text)
                written = load_document(path)["lockstep_headline"]["lines"]
                for line in written:  # a line the file holds cut is said to be cut, in words
                    if line.endswith(" ..."):
                        self.assertIn(line[:-4].strip() + answer.CUT_NOTE, box)
                        self.assertIn(line[:-4].strip() + answer.CUT_NOTE, html.replace("&#39;", "'"))

    def test_whole_lines_read_whole_in_both_pages(self):
        document = load_document(XEON)
        lines = document["lockstep_headline"]["lines"]
        long_lines = ["Collapsed when threads outnumber CPUs (50 entries at threads:4, 4.00 ms..52.01 ms a step or "
                      "episode, left out of rankings): ck_centralized, ck_combining, ck_dissemination, ck_mcs, "
                      "ck_tournament and 12 more, each of them named here so that the line runs past any width",
                      "Not applicable (36): a dataflow channel carries each producer's values in its own slots "
                      "straight into the consumers' copies, so a layout of the shared state has nothing to lay out "
                      "for it and only its private copy runs"]
        for index, line in enumerate(lines):
            if line.startswith("Collapsed when"):
                lines[index] = long_lines[0]
            elif line.startswith("Not applicable"):
                lines[index] = long_lines[1]
        html, markdown = self.pages(self.write("whole.json", document))
        section, box = answer_boxes(html, markdown)
        for line in long_lines:
            self.assertIn(f"\n- {line}\n", box)
            self.assertIn(f"<li>{line.replace(chr(39), '&#39;')}</li>", section)
        self.assertNotIn(answer.CUT_NOTE, box)

    def test_the_table_is_the_files_recommendations(self):
        html, markdown = self.pages(XEON)
        _, box = answer_boxes(html, markdown)
        rows = [line.split(" | ") for line in box.splitlines() if line.startswith("| ") and "threads" in line]
        recommendations = load_document(XEON)["lockstep_headline"]["recommendations"]
        self.assertEqual(len(rows) - 1, len(recommendations))  # the headings, then a row per choice
        self.assertEqual(rows[0], ["| threads, placement", "use", "step (median ± spread)",
                                   "a stage's sync, in c2c transfers", "runner-up: its step / the choice's",
                                   "std_barrier: its step / the choice's |"])
        self.assertEqual(rows[1], ["| 2 threads, pin:compact", "mailbox + per_thread", "767.0 ns ±12.6 %", "1.56",
                                   "seqlock + per_thread: 1.03x [0.91, 1.09], unsure",
                                   "11.45x [5.98, 25.34], slower |"])
        self.assertEqual(rows[3][:3], ["| 4 threads on 2 CPUs, pin:compact", "seqlock + per_thread",
                                       "5.232 us ±89.3 % over 2 paces: uncertain"])
        # the choices' lines are the table's: none of them is repeated under it, nor the terminal's pointers
        self.assertNotIn("next seqlock takes", box)
        self.assertNotIn("Results: ", box)
        self.assertNotIn("Report: lockstep report", box)
        self.assertIn("- False sharing: two writers 8 B apart", box)

    def test_a_tie_names_both(self):
        document = load_document(XEON)
        last = document["lockstep_headline"]["recommendations"][3]
        last["tied"] = True
        _, markdown = self.pages(self.write("tied.json", document))
        row = next(line for line in markdown.splitlines() if line.startswith("| 4 threads on 2 CPUs, pin:none"))
        cells = row.split(" | ")
        self.assertEqual(cells[1], "spsc_queue + per_thread or mailbox + per_thread: tied")
        self.assertEqual(cells[4], "tied: mailbox + per_thread: 0.88x [0.79, 0.96], unsure")

    def test_the_answer_first_comes_before_the_table(self):
        document = load_document(XEON)
        block = document["lockstep_headline"]
        block["answer"] = {"model": "", "threads": 2, "pin": "compact", "entry": block["recommendations"][0]["entry"],
                           "ns_per_step": 767.0364218455744, "serial_ns_per_step": 26.8, "vs_serial": 28.62}
        block["lines"].insert(0, "Best: threads:2 pin:compact mailbox + per_thread, 28.6x the serial step")
        html, markdown = self.pages(self.write("first.json", document))
        section, box = answer_boxes(html, markdown)
        first = ("Best of the run: 2 threads, pin:compact, mailbox + per_thread, 767.0 ns a step: 28.6x the serial "
                 "step (26.8 ns); one thread alone computes it faster: the synchronisation costs more than sharing "
                 "the work saves.")
        self.assertTrue(box.startswith(f"default-run.json\n\n**{first}**\n\n| threads, placement |".replace(
            "default-run.json", "first.json")), box[:400])
        self.assertLess(section.index('<p class="first">'), section.index("<table"))
        self.assertNotIn("Best: threads:2", box)  # the object says it; its line is not repeated

    def test_choices_the_run_does_not_separate_are_a_tie_in_the_first_line(self):
        document = load_document(XEON)
        block = document["lockstep_headline"]
        block["answer"] = {"model": "", "threads": 2, "pin": "none", "entry": block["recommendations"][1]["entry"],
                           "ns_per_step": 893.7, "serial_ns_per_step": 29.1, "vs_serial": 30.71,
                           "level": [{"threads": 2, "pin": "compact", "entry": block["recommendations"][0]["entry"],
                                      "ns_per_step": 899.7}]}
        _, markdown = self.pages(self.write("level.json", document))
        self.assertIn("893.7 ns a step, tied with 2 threads, pin:compact (899.7 ns): their repetitions overlap and no "
                      "pair compared them: 30.7x the serial step", markdown)

    def test_the_words_it_uses_are_explained_in_the_box(self):
        html, markdown = self.pages(XEON)
        section, box = answer_boxes(html, markdown)
        words = box.split("Words used above:")[1]
        for word in ("**pace**", "Over 2 paces", "**c2c transfers a stage**", "**one line against apart (false sharing)**",
                     "measured plain stores only", "**Nx [low, high]**", "tied"):
            self.assertIn(word, words)
        self.assertIn('<dl class="glossary">', section)
        self.assertLess(box.index("gain a write"), box.index("Words used above:"))


class ErroredEntries(Pages):
    """An entry whose repetitions errored (the real Xeon run's rk4/sync:win_event_faithful/layout:padded128/
    pin:compact/threads:4, lost wake-ups) is counted and named in the answer and drawn apart from the cells not
    run in the heat maps."""

    NAME = "rk4/sync:win_event_faithful/layout:padded128/pin:compact/threads:4"

    def path(self):
        document = load_document(XEON)
        document["benchmarks"] += load_document(XEON_ERRORED)
        return self.write("with_errored.json", document)

    def test_it_is_counted_and_named_in_the_answer_and_its_section(self):
        html, markdown = self.pages(self.path())
        section, box = answer_boxes(html, markdown)
        self.assertIn(f"- Errored: 1 entry with failed repetitions, so no time: {self.NAME} (3 of 5 repetitions "
                      "failed).", box)
        self.assertIn('<li class="errored">Errored: 1 entry', section)
        errored = markdown.split("## Errored entries: with_errored.json")[1].split("\n## ")[0]
        self.assertIn(f"| {self.NAME} | 3 of 5 repetitions failed | an earlier call stopped: bounded:", errored)
        self.assertNotIn("Errored", answer_boxes(*self.pages(XEON))[1])  # none in the trimmed file

    def test_the_heat_map_draws_it_apart_from_the_cells_not_run(self):
        run_file = load_run_file(self.path())
        cells = matrix.heatmap_cells(run_file, "compact", 4, frozenset(), run_file.collapsed)
        row, column = cells.syncs.index("win_event_faithful"), cells.layouts.index("padded128")
        self.assertEqual(cells.errored, frozenset({(row, column)}))
        self.assertIsNone(cells.values[row][column])
        not_run = {(r, c) for r, values in enumerate(cells.values) for c, value in enumerate(values) if value is None}
        self.assertGreater(len(not_run - cells.errored), 0)  # the not-applicable cells, n/a
        captured = []
        with mock.patch.object(figures, "to_svg", side_effect=lambda figure: captured.append(figure) or "<svg/>"):
            figures.heatmap(cells)
        axes = captured[0].axes[0]
        at = {(round(text.get_position()[1]), round(text.get_position()[0])): text.get_text() for text in axes.texts}
        self.assertEqual(at[(row, column)], "error")
        self.assertEqual({at[cell] for cell in not_run - cells.errored}, {"n/a"})
        legend = [text.get_text() for text in axes.get_legend().get_texts()]
        self.assertEqual(legend, ["error: the entry ran and failed (no time)", "n/a: not run (not applicable)"])


class StepSplitAddsUp(Pages):
    """Where a step's time goes: each split adds up to its step or is marked clamped (matrix.StepSplit), never a
    compute of 0 that no measurement gave."""

    def test_every_split_adds_up_or_is_marked(self):
        for path in (fixture(REAL_SPLIT), XEON, fixture(CPU_SPLIT)):
            with self.subTest(os.path.basename(path)):
                run_file = load_run_file(path)
                splits = [split for pin, threads in matrix.rk4_groups(run_file)
                          for split in matrix.step_splits(run_file, pin, threads, run_file.collapsed)]
                self.assertTrue(splits)
                for split in splits:
                    if split.clamped:
                        self.assertGreaterEqual(split.syncs_ns, split.step_ns)
                    else:
                        self.assertAlmostEqual(sum(split.parts_ns), split.step_ns, delta=1e-6 * split.step_ns + 2e-3)
                _, markdown = self.pages(path)
                section = markdown.split("## Where a step's time goes: ")[1].split("\n## ")[0]
                rows = [line.split(" | ") for line in section.splitlines() if line.startswith("| pin:")]
                self.assertEqual(len(rows), len(splits))
                for row, split in zip(rows, splits):
                    self.assertNotEqual(row[3], "0.0 ns")
                    self.assertEqual(row[3] == "not measured (clamped)", split.clamped)
                    self.assertEqual(row[6].endswith("more than the step"), split.syncs_ns > split.step_ns)
                clamped = sum(split.clamped for split in splits)
                self.assertEqual(f"{clamped} of the {len(splits)} splits shown are so." in section, clamped > 0)

    def test_the_real_runs_have_clamped_splits(self):
        # run_quick_split.json's futex_spin and the Xeon run's 4-thread entries: the writer's compute read 0
        for path in (fixture(REAL_SPLIT), XEON):
            run_file = load_run_file(path)
            self.assertTrue(any(split.clamped for pin, threads in matrix.rk4_groups(run_file)
                                for split in matrix.step_splits(run_file, pin, threads, run_file.collapsed)))

    def test_the_split_is_its_median_repetitions(self):
        run_file = load_run_file(XEON)
        split = matrix.step_splits(run_file, "compact", 2, run_file.collapsed)[0]
        run = run_file.runs[split.key]
        steps = sorted(repetition.real_ns for repetition in run.repetitions)
        self.assertEqual(split.step_ns, steps[len(steps) // 2])  # 5 repetitions: the median
        self.assertEqual(split.step_ns, run_median(run_file, split.key))


class RatioAxis(unittest.TestCase):
    """A ratio figure's axis holds every bar readably when one interval is degenerate: it spans the medians (with
    1 and the noise band) and clips a whisker that reaches beyond figures.WHISKER_ROOM of them, marking it."""

    def test_a_degenerate_interval_does_not_stretch_the_axis(self):
        ratios = [0.95, 1.01, 0.88, 1.14]
        intervals = [(0.91, 0.99), (0.97, 1.05), (0.000478, 1.005), (1.01, 1.25)]
        low, high = figures.ratio_axis_range(ratios, intervals, 0.05)
        self.assertAlmostEqual(low, 0.88 / figures.WHISKER_ROOM)
        self.assertEqual(high, 1.25)
        self.assertEqual(figures.ratio_axis_range(ratios[:2], intervals[:2], 0.05), (0.91, 1.05))  # whiskers, band

    def test_the_real_runs_false_sharing_figure_clips_and_marks(self):
        run_file = load_run_file(XEON)
        rows = [row for row in report.paired_penalty_rows(run_file) if row.kind.startswith("false sharing")]
        wide = [row for row in rows if row.ci_high / row.ci_low > 4]  # std_barrier's [0.15, 2.21] and [0.41, 7.44]
        self.assertEqual(len(wide), 2)
        captured = []
        with mock.patch.object(figures, "to_svg", side_effect=lambda figure: captured.append(figure) or "<svg/>"):
            figures.penalties(rows, 0.05)
        axes = captured[0].axes[0]
        low, high = axes.get_xlim()
        self.assertLess(high / low, 10.0)  # about one decade, not 0.15x..7.4x
        self.assertTrue(all(low < row.ratio < high for row in rows))
        arrows = [line for line in axes.lines if line.get_marker() in ("<", ">")]
        bound_low, bound_high = figures.ratio_axis_range([row.ratio for row in rows],
                                                         [(row.ci_low, row.ci_high) for row in rows], 0.05)
        clipped_ends = sum((row.ci_low < bound_low) + (row.ci_high > bound_high) for row in rows)
        self.assertEqual(len(arrows), clipped_ends)
        self.assertGreaterEqual(clipped_ends, 2)
        legend = [text.get_text() for text in axes.get_legend().get_texts()]
        self.assertIn(figures.CLIPPED_NOTE, legend)

    def test_without_a_degenerate_interval_nothing_is_clipped(self):
        rows = [matrix.PenaltyRow("false sharing", "a", 2, 1.3, 1.2, 1.4, "penalty", pin="compact"),
                matrix.PenaltyRow("false sharing", "b", 2, 0.97, 0.9, 1.02, "unsure", pin="compact")]
        captured = []
        with mock.patch.object(figures, "to_svg", side_effect=lambda figure: captured.append(figure) or "<svg/>"):
            figures.penalties(rows, 0.05)
        axes = captured[0].axes[0]
        self.assertFalse([line for line in axes.lines if line.get_marker() in ("<", ">")])
        self.assertNotIn(figures.CLIPPED_NOTE, [text.get_text() for text in axes.get_legend().get_texts()])
