"""A delay file's causes are read in the file's own order and words (`cause_kinds`, as `lockstep delay` writes it:
bench/delay/attribution_output.cpp), and only a file without them takes words.DELAY_CAUSES, the copy for older
files (delay_reader.read_causes); the figure draws the words it is given (figures.delay_causes)."""
import json
import unittest

from support import fixture

from lockstep_reports.common.words import DELAY_CAUSES
from lockstep_reports.read import delay_reader
from lockstep_reports.read.checks import InputError
from lockstep_reports.report import figures

SPLIT = {"compute": 0.0, "run_queue_wait": 300.0, "migration": 0.0, "page_faults": 0.0, "interrupts": 0.0,
         "wake_up_latency": 700.0, "machine_stall": 0.0, "unexplained": 0.0}


def document_with_causes() -> dict:
    with open(fixture("delay_a.json"), encoding="utf-8") as stream:
        document = json.load(stream)
    row = {"label": "above p99", "threshold_ns": 5000.0, "steps": 10, "excess_ns": 1000.0, "cause_ns": SPLIT,
           "explained_share": 1.0, "guest_share": 1.0, "top": "wake_up_latency"}
    document["causes"] = {"unavailable": None, "tail": [row], "per_cpu": [], "worst": []}
    return document


def figure_of(causes) -> str:
    return figures.delay_causes([(row.label, row.cause_ns) for row in causes.rows], causes.names)


class CauseKinds(unittest.TestCase):
    def test_the_files_list_gives_the_order_and_the_words(self):
        document = document_with_causes()
        document["cause_kinds"] = [{"key": "wake_up_latency", "words": "late wake-up"},
                                   {"key": "run_queue_wait", "words": "waiting to run"}]
        causes = delay_reader.read_causes("delay.json", document)
        self.assertEqual(causes.names, (("wake_up_latency", "late wake-up"), ("run_queue_wait", "waiting to run")))
        svg = figure_of(causes)
        self.assertIn("late wake-up", svg)
        self.assertNotIn("run-queue wait", svg)

    def test_a_file_without_the_list_reads_as_older_files_did(self):
        document = document_with_causes()
        document.pop("cause_kinds", None)
        causes = delay_reader.read_causes("delay.json", document)
        self.assertEqual(causes.names, DELAY_CAUSES)
        self.assertIn("run-queue wait", figure_of(causes))

    def test_a_cause_named_twice_is_refused(self):
        document = document_with_causes()
        document["cause_kinds"] = [{"key": "compute", "words": "compute"}, {"key": "compute", "words": "again"}]
        with self.assertRaises(InputError):
            delay_reader.read_causes("delay.json", document)


if __name__ == "__main__":
    unittest.main()
