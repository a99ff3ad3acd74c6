"""`lockstep report`: the HTML and Markdown it writes, their figures and tables, and their determinism."""
import hashlib
import json
import os
import re
import tempfile
import unittest

from support import fixture, run_tool

from lockstep_reports import figures, paper
from lockstep_reports.inputs import load_any

ALL_INPUTS = ["machine_a.json", "machine_b.json", "c2c_a.json", "c2c_b.json", "delay_a.json", "verify_a.csv"]



def digest_tree(directory):
    digests = {}
    for root, _, files in os.walk(directory):
        for name in sorted(files):
            path = os.path.join(root, name)
            with open(path, "rb") as stream:
                digests[os.path.relpath(path, directory)] = hashlib.sha256(stream.read()).hexdigest()
    return digests


class Report(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
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
        self.assertRegex(self.markdown, r"\| seqlock \| 2 \| 1\.0[0-9]x \[0\.9[0-9]+, 1\.[0-9]+\] unsure \|")
        self.assertIn("false sharing (paired): packed / padded", self.markdown)
        self.assertIn("migration (paired): pin:migrate / pin:compact", self.markdown)
        for kind in ("false-sharing", "migration", "against-best-other", "overhead"):
            self.assertIn(f'<figure id="pairs-0-{kind}"', self.html)

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
        order = figures.topology_order(load_any(fixture("c2c_b.json")).pairs)
        self.assertEqual(order[:4], [0, 8, 1, 9])
        self.assertEqual(set(order[:8]), {0, 1, 2, 3, 8, 9, 10, 11})

    def test_model_roots_and_the_papers(self):
        fast, slow = paper.model_roots()
        self.assertAlmostEqual(fast, 51.49, places=2)
        self.assertAlmostEqual(slow, 19.67, places=2)
        self.assertAlmostEqual(paper.c_over_m_from_roots(), 1011.9, delta=0.3)

    def test_analytic_trajectory_starts_at_the_initial_state(self):
        x1, x2 = paper.analytic_trajectory([0.0])
        self.assertAlmostEqual(float(x1[0]), 2.0)
        self.assertAlmostEqual(float(x2[0]), -3.0)


if __name__ == "__main__":
    unittest.main()
