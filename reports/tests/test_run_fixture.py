"""One real run file through the Python side: tests/fixtures/run/quick-pairs.json (a `lockstep run --quick` file,
written by the binary, never edited) read through inputs.read_document, each pair's median, interval and verdict
recomputed from its ratios by statistics.py and equal to the file's to the last bit, and what compare and report
would print for each pair the same. tests/run/run_fixture_test.cpp holds the harness (the code behind run's
summary) to the same file: a change of the rule (median, quantile, draws, verdict edge) on one side alone fails one
of the two."""
import dataclasses
import os
import re
import tempfile
import unittest

from support import REPORTS_DIR, run_tool
from lockstep_reports.analysis import run_analysis
from lockstep_reports.common import statistics
from lockstep_reports.common.formatting import format_number
from lockstep_reports.compare import comparison
from lockstep_reports.read import inputs, run_file, run_reader

FIXTURE = os.path.join(REPORTS_DIR.parent, "tests", "fixtures", "run", "quick-pairs.json")

# "1.24x [1.17, 1.33] penalty": a paired figure as the summary and the answer print it.
PAIRED_FIGURE = re.compile(r"\d+\.\d\dx \[\d+\.\d\d, \d+\.\d\d\] (?:penalty|gain|within noise|unsure)")


def figure(median: float, low: float, high: float, verdict: str) -> str:
    return f"{median:.2f}x [{low:.2f}, {high:.2f}] {verdict}"


def recomputed(pair: run_file.PacePair) -> run_file.PacePair:
    """The pair with its median, interval and verdict recomputed from its ratios by statistics.py, with lockstep
    run's resamples and seed (the file carries its confidence and noise band, not those two)."""
    median, low, high = statistics.bootstrap_median(pair.ratios, pair.confidence, statistics.PAIR_RESAMPLES,
                                                    statistics.PAIR_SEED)
    return dataclasses.replace(pair, median=median, ci_low=low, ci_high=high,
                               verdict=statistics.verdict(low, high, pair.noise))


class RunFixture(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        kind, document = inputs.read_document(FIXTURE)
        cls.kind = kind
        cls.run_file = run_reader.run_file_from_document(FIXTURE, "quick-pairs.json", document)
        cls.recomputed = [recomputed(pair) for pair in cls.run_file.pairs]

    def test_the_file_is_a_run_with_pairs_of_every_kind_and_both_kinds_of_verdict(self):
        self.assertEqual(self.kind, "run")
        self.assertEqual({pair.comparison for pair in self.run_file.pairs},
                         {"false_sharing", "migration", "against_best_other"})
        verdicts = {pair.verdict for pair in self.run_file.pairs}
        self.assertTrue(verdicts & {statistics.PENALTY, statistics.GAIN})
        self.assertTrue(verdicts & {statistics.WITHIN_NOISE, statistics.UNSURE})

    def test_every_pairs_median_interval_and_verdict_are_the_files_to_the_last_bit(self):
        for pair, again in zip(self.run_file.pairs, self.recomputed):
            with self.subTest(f"{pair.a} / {pair.b}"):
                self.assertEqual((again.median, again.ci_low, again.ci_high), (pair.median, pair.ci_low, pair.ci_high))
                self.assertEqual(again.verdict, pair.verdict)
                self.assertEqual(statistics.median(pair.ratios), pair.median)

    def test_compare_says_each_pairs_verdict_in_its_words(self):
        for pair, again in zip(self.run_file.pairs, self.recomputed):
            with self.subTest(f"{pair.a} / {pair.b}"):
                self.assertEqual(comparison.verdict_of((again.ci_low, again.ci_high), 100.0 * pair.noise),
                                 comparison.VERDICT_WORDS[pair.verdict])

    def test_the_report_prints_each_pairs_figures(self):
        """The report's Markdown holds a row per pair, and per "against the best other" group the leader's row
        (its pair with the runner-up inverted, run_analysis.against_best_other_views), each with the median, interval
        and verdict statistics.py recomputes."""
        with tempfile.TemporaryDirectory(prefix="lockstep-run-fixture-") as directory:
            status, _, err = run_tool("report", FIXTURE, "--out", directory)
            self.assertEqual(status, 0, err)
            with open(os.path.join(directory, "report.md"), encoding="utf-8") as page:
                rows = [line for line in page.read().splitlines() if line.startswith("|")]
        expected = self.recomputed + [view for view in run_analysis.against_best_other_views(self.recomputed)
                                      if view.inverted]
        self.assertTrue(any(view.inverted for view in expected))
        for pair in expected:
            cells = [f"| {format_number(pair.median, 3, 'x')} |",
                     f"| [{format_number(pair.ci_low, 3)}, {format_number(pair.ci_high, 3)}] |", f"| {pair.verdict} |"]
            with self.subTest(f"{pair.a} / {pair.b}", cells=cells):
                self.assertTrue(any(all(cell in row for cell in cells) for row in rows))

    def test_every_figure_of_the_answer_is_a_pairs_or_the_probes(self):
        """The answer (the summary's last lines, shown verbatim by the report) prints paired figures: each is
        a recomputed pair's, read either way round, or the false-sharing probe's, whose verdict is the rule's."""
        known = set()
        for pair in self.recomputed:
            for view in (pair, pair.inverse()):
                known.add(figure(view.median, view.ci_low, view.ci_high, view.verdict))
        self.assertIsNotNone(self.run_file.answer)
        _, document = inputs.read_document(FIXTURE)
        # The plain stores' figure (false_sharing_probe) and, in files that have them, every access pattern's.
        probes = [document["lockstep_headline"].get("false_sharing_probe")]
        probes += document["lockstep_headline"].get("false_sharing_patterns", [])
        for probe in filter(None, probes):
            # The probe is judged against the default band, whatever --noise says (bench/results/paired_ratio.hpp,
            # kDefaultNoise; bench/probe_reports/falseshare_report.cpp).
            self.assertEqual(statistics.verdict(probe["ci_low"], probe["ci_high"], 0.05), probe["verdict"])
            known.add(figure(probe["median"], probe["ci_low"], probe["ci_high"], probe["verdict"]))
        found = [match for line in self.run_file.answer.lines for match in PAIRED_FIGURE.findall(line)]
        self.assertTrue(found)
        for match in found:
            self.assertIn(match, known)


if __name__ == "__main__":
    unittest.main()
