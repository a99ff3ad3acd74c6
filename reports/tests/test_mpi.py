"""`lockstep mpi` files in the report tools: read strictly, compared like run files (the ping-pong a
calibration), and reported with their per-stage latency and skew. The fixture mpi.json is a real
`lockstep mpi --ranks 4` run on the development VM (as reports/samples/mpi.json)."""
import json
import os
import tempfile
import unittest

from support import fixture, run_tool

from lockstep_reports.compare import is_calibration
from lockstep_reports.inputs import InputError, load_any
from lockstep_reports.names import parse_name

EXCHANGES = ["p2p", "allgather", "rma_put", "shm_window/futex_spin", "shm_window/mailbox"]


class Scratch(unittest.TestCase):
    def setUp(self):
        self.directory = tempfile.TemporaryDirectory()
        self.addCleanup(self.directory.cleanup)

    def write(self, name: str, text: str) -> str:
        path = os.path.join(self.directory.name, name)
        with open(path, "w", encoding="utf-8") as stream:
            stream.write(text)
        return path

    def document(self) -> dict:
        with open(fixture("mpi.json"), encoding="utf-8") as stream:
            return json.load(stream)


class ReadingMpiFiles(Scratch):
    def test_exchanges_settings_and_entries(self):
        item = load_any(fixture("mpi.json"))
        self.assertIsNotNone(item.mpi)
        self.assertEqual((item.mpi.ranks, item.mpi.hosts, item.mpi.transport), (4, 1, "shm"))
        self.assertEqual([exchange.label for exchange in item.mpi.exchanges], EXCHANGES)
        for exchange in item.mpi.exchanges:
            self.assertLessEqual(exchange.stage["p50"], exchange.stage["p99"])
            self.assertLessEqual(exchange.stage["p99"], exchange.stage["max"])
            self.assertEqual(len(exchange.slowest_counts), 4)
            self.assertIn(parse_name(exchange.name), item.runs)
        self.assertIn(parse_name("mpi/pingpong/ranks:2/hosts:1"), item.runs)

    def test_the_ping_pong_is_a_calibration_the_exchanges_are_not(self):
        self.assertTrue(is_calibration(parse_name("mpi/pingpong/ranks:2/hosts:1")))
        self.assertFalse(is_calibration(parse_name("mpi/exchange:p2p/ranks:4/hosts:1")))

    def test_a_truncated_file_is_one_line_and_status_2(self):
        with open(fixture("mpi.json"), encoding="utf-8") as stream:
            text = stream.read()
        path = self.write("truncated.json", text[: len(text) // 2])
        status, out, err = run_tool("report", path, "--out", os.path.join(self.directory.name, "report"))
        self.assertEqual(status, 2)
        self.assertEqual(out, "")
        self.assertEqual(len(err.strip().splitlines()), 1, err)

    def test_a_damaged_exchange_names_what_is_wrong(self):
        document = self.document()
        del document["exchanges"][1]["skew_ns"]
        path = self.write("damaged.json", json.dumps(document))
        with self.assertRaises(InputError) as caught:
            load_any(path)
        self.assertIn("exchanges entry 1", str(caught.exception))
        self.assertIn("skew_ns", str(caught.exception))


class ComparingMpiFiles(Scratch):
    def test_two_runs_compare_entry_by_entry(self):
        document = self.document()
        for entry in document["benchmarks"]:
            entry["real_time"] *= 1.5  # B: every exchange and the ping-pong half as fast again
        slower = self.write("slower.json", json.dumps(document))
        status, out, err = run_tool("compare", fixture("mpi.json"), slower)
        self.assertEqual(status, 0, err)
        for label in ("exchange:p2p", "exchange:shm_window/sync:mailbox"):
            self.assertIn(f"mpi/{label}/ranks:4/hosts:1", out)
        calibrations = out[out.index("calibration "):]
        self.assertIn("mpi/pingpong/ranks:2/hosts:1", calibrations)


class ReportingMpiFiles(Scratch):
    def test_the_section_draws_latency_and_skew_per_exchange(self):
        directory = os.path.join(self.directory.name, "report")
        status, _, err = run_tool("report", fixture("mpi.json"), "--out", directory)
        self.assertEqual(status, 0, err)
        self.assertEqual(sorted(os.listdir(os.path.join(directory, "figures"))),
                         ["mpi-latency-0.svg", "mpi-skew-0.svg"])
        with open(os.path.join(directory, "report.md"), encoding="utf-8") as stream:
            markdown = stream.read()
        self.assertIn("## The step across MPI ranks: mpi.json", markdown)
        self.assertIn("the step across MPI ranks (`lockstep mpi`)", markdown)
        for label in EXCHANGES:
            self.assertIn(f"| {label} |", markdown)
        self.assertIn("ping-pong's one-way time", markdown)


if __name__ == "__main__":
    unittest.main()
