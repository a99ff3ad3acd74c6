"""`lockstep mpi` files in the report tools: read strictly, compared like run files (the ping-pong a
calibration), and reported with their per-stage latency and skew. The fixture mpi.json is a real
`lockstep mpi --ranks 4` run on the development VM (as reports/samples/mpi.json); mpi-a.json and mpi-b.json
are made by hand to the file's contract (fixtures/make_fixtures.py)."""
import json
import os
import tempfile
import unittest

from support import fixture, run_tool

from lockstep_reports.analysis.run_analysis import is_calibration
from lockstep_reports.common.names import parse_name
from lockstep_reports.read.inputs import InputError, load_any

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
        self.assertIn("exchanges[1].skew_ns: is missing", str(caught.exception))


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


# ---------------------------------------------------------------- the contract, by hand (mpi-a.json, mpi-b.json)

HAND_MADE = ("mpi-a.json", "mpi-b.json")
P2P, ALLGATHER = "mpi/exchange:p2p/ranks:4/hosts:1", "mpi/exchange:allgather/ranks:4/hosts:1"
PINGPONG = "mpi/pingpong/ranks:2/hosts:1"


def hand_made(name: str) -> dict:
    with open(fixture(name), encoding="utf-8") as stream:
        return json.load(stream)


class ReadingTheContract(Scratch):
    """mpi-a.json and mpi-b.json hold only the keys the file's first specification named: their exchanges
    carry no label or name, which the reader makes as lockstep mpi does."""

    def test_exchanges_rounds_and_the_ping_pong(self):
        for name in HAND_MADE:
            item = load_any(fixture(name))
            self.assertEqual((item.mpi.ranks, item.mpi.hosts, item.mpi.transport, item.mpi.model),
                             (4, 1, "shm", "two_mass"))
            self.assertEqual([exchange.label for exchange in item.mpi.exchanges], ["p2p", "allgather"])
            self.assertEqual([exchange.name for exchange in item.mpi.exchanges], [P2P, ALLGATHER])
            self.assertEqual(sorted(key.display for key in item.runs), sorted([P2P, ALLGATHER, PINGPONG]))
            for run in item.runs.values():
                self.assertEqual(len(run.repetitions), 3)  # one per round
            p2p = item.mpi.exchanges[0]
            self.assertEqual(sum(p2p.slowest_counts), 80000)  # 20000 steps of 4 stages
            self.assertEqual(p2p.transfer, {})  # not in the contract
            self.assertLess(p2p.stage["p50"], p2p.stage["p99"])
        self.assertEqual(load_any(fixture("mpi-a.json")).mpi.not_applicable, ())
        self.assertEqual([label for label, _ in load_any(fixture("mpi-b.json")).mpi.not_applicable], ["shm_window"])

    def test_the_writers_label_and_name_win(self):
        document = hand_made("mpi-a.json")
        document["exchanges"][1].update(sync="", label="allgather (ring)", name=ALLGATHER)
        item = load_any(self.write("labelled.json", json.dumps(document)))
        self.assertEqual(item.mpi.exchanges[1].label, "allgather (ring)")
        document["exchanges"][1] = dict(document["exchanges"][1], exchange="shm_window", sync="mailbox")
        del document["exchanges"][1]["name"]
        item = load_any(self.write("synced.json", json.dumps(document)))
        self.assertEqual(item.mpi.exchanges[1].name, "mpi/exchange:shm_window/sync:mailbox/ranks:4/hosts:1")

    def test_a_truncated_file_is_one_line_and_status_2_in_both_tools(self):
        with open(fixture("mpi-a.json"), encoding="utf-8") as stream:
            text = stream.read()
        path = self.write("cut.json", text[: len(text) * 2 // 3])
        with self.assertRaises(InputError):
            load_any(path)
        for argv in (("compare", path, fixture("mpi-b.json")), ("compare", fixture("mpi-b.json"), path),
                     ("report", path, "--out", os.path.join(self.directory.name, "report"))):
            status, out, err = run_tool(*argv)
            self.assertEqual(status, 2, argv)
            self.assertEqual(out, "")
            self.assertEqual(len(err.strip().splitlines()), 1, err)
            self.assertIn("cut.json", err)
        self.assertFalse(os.path.exists(os.path.join(self.directory.name, "report")))

    def test_a_wrong_value_is_one_line_naming_it(self):
        def settings_ranks_text(document):
            document["settings"]["ranks"] = "4"

        def stage_p99_text(document):
            document["exchanges"][0]["stage_latency_ns"]["p99"] = "2500"

        def skew_missing(document):
            del document["exchanges"][1]["skew_ns"]

        def counts_not_counts(document):
            document["exchanges"][0]["slowest_rank_counts"][2] = -1

        def a_count_too_many(document):
            document["exchanges"][0]["slowest_rank_counts"].append(0)

        def exchange_twice(document):
            document["exchanges"].append(document["exchanges"][0])

        def reason_not_text(document):
            document["not_applicable"] = {"rma_put": 3}

        def stage_p99_counter_negative(document):
            document["benchmarks"][1]["stage_p99_ns"] = -2500.0

        def pingpong_p50_zero(document):
            document["benchmarks"][-1]["one_way_p50_ns"] = 0

        def exchanges_missing(document):
            del document["exchanges"]

        cases = ((settings_ranks_text, "ranks"), (stage_p99_text, "p99"), (skew_missing, "skew_ns"),
                 (counts_not_counts, "slowest_rank_counts"), (a_count_too_many, "one per rank"),
                 (exchange_twice, "appears once"),
                 (reason_not_text, "rma_put"), (stage_p99_counter_negative, "stage_p99_ns"),
                 (pingpong_p50_zero, "one_way_p50_ns"), (exchanges_missing, "exchanges"))
        for mutate, named in cases:
            with self.subTest(mutate.__name__):
                document = hand_made("mpi-a.json")
                mutate(document)
                path = self.write(f"{mutate.__name__}.json", json.dumps(document))
                status, out, err = run_tool("compare", path, fixture("mpi-b.json"))
                self.assertEqual((status, out), (2, ""), err)
                self.assertEqual(len(err.strip().splitlines()), 1, err)
                self.assertIn(named, err)


class ComparingTheContract(Scratch):
    def test_a_against_b_entry_by_entry_with_the_tails_beside(self):
        out_json = os.path.join(self.directory.name, "comparison.json")
        status, out, err = run_tool("compare", fixture("mpi-a.json"), fixture("mpi-b.json"), "--out", out_json, "--all")
        self.assertEqual(status, 0, err)
        table = out[out.index("benchmark "):out.index("geometric mean")]
        self.assertIn(P2P, table)
        self.assertIn(ALLGATHER, table)
        self.assertNotIn(PINGPONG, table)  # a calibration, in its own block
        self.assertIn("stage p99 ns", table)
        self.assertIn("skew p99 ns", table)
        self.assertIn(PINGPONG, out[out.index("calibration "):])
        self.assertNotIn("Across machines", out)  # no rk4 entries to normalise
        # Three rounds a side: no interval, and the advice names lockstep mpi's option.
        self.assertIn("`lockstep mpi --rounds 10` or more", out)
        with open(out_json, encoding="utf-8") as stream:
            comparison = json.load(stream)["comparisons"][0]
        rows = {row["name"]: row for row in comparison["rows"]}
        self.assertEqual(sorted(rows), sorted([P2P, ALLGATHER]))
        self.assertAlmostEqual(rows[P2P]["ratio"], 1.3, delta=0.06)  # b's p2p is 30 % slower
        self.assertAlmostEqual(rows[ALLGATHER]["ratio"], 1.0, delta=0.06)
        self.assertEqual({row["verdict"] for row in rows.values()}, {"untested"})
        before, after = rows[P2P]["counters"]["stage_p99_ns"]
        self.assertAlmostEqual(after / before, 1.3, delta=0.06)
        self.assertIn("skew_p99_ns", rows[ALLGATHER]["counters"])
        self.assertEqual([row["name"] for row in comparison["calibrations"]], [PINGPONG])

    def test_five_rounds_a_side_get_a_verdict(self):
        paths = []
        for name in HAND_MADE:
            document = hand_made(name)
            extra = [dict(entry, repetition_index=entry["repetition_index"] + 3, real_time=entry["real_time"] * 1.01)
                     for entry in document["benchmarks"] if entry["repetition_index"] < 2]
            document["benchmarks"] += extra
            for entry in document["benchmarks"]:
                entry["repetitions"] = 5
            paths.append(self.write(name, json.dumps(document)))
        status, out, err = run_tool("compare", *paths, "--out", os.path.join(self.directory.name, "c.json"))
        self.assertEqual(status, 0, err)
        with open(os.path.join(self.directory.name, "c.json"), encoding="utf-8") as stream:
            rows = {row["name"]: row for row in json.load(stream)["comparisons"][0]["rows"]}
        self.assertEqual(rows[P2P]["verdict"], "slower")

    def test_against_a_run_file_no_entries_in_common(self):
        for files in ((fixture("mpi-a.json"), fixture("machine_a.json")),
                      (fixture("machine_a.json"), fixture("mpi-a.json"))):
            status, out, err = run_tool("compare", *files)
            self.assertEqual(status, 0, err)
            self.assertIn("no entries in common", out)
            self.assertIn(f"  {P2P}", out)  # listed as only in the mpi file
            self.assertIn("(lockstep mpi)", out)

    def test_run_files_compare_as_before(self):
        status, out, err = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"), "--all")
        self.assertEqual(status, 0, err)
        self.assertNotIn("no entries in common", out)
        self.assertNotIn("stage p99 ns", out)
        self.assertIn("Across machines", out)

    def test_beside_a_c2c_file_the_c2c_file_joins_the_fingerprint_only(self):
        status, out, err = run_tool("compare", fixture("mpi-a.json"), fixture("mpi-b.json"), fixture("c2c_a.json"))
        self.assertEqual(status, 0, err)
        self.assertIn("fingerprint only (not benchmark results): c2c_a.json (lockstep c2c)", out)


class ReportingTheContract(Scratch):
    def test_a_section_per_mpi_file_beside_the_run_sections(self):
        directory = os.path.join(self.directory.name, "report")
        status, _, err = run_tool("report", fixture("mpi-a.json"), fixture("mpi-b.json"), fixture("machine_a.json"),
                                  "--out", directory)
        self.assertEqual(status, 0, err)
        figures = os.listdir(os.path.join(directory, "figures"))
        for name in ("mpi-latency-0.svg", "mpi-skew-0.svg", "mpi-latency-1.svg", "mpi-skew-1.svg"):
            self.assertIn(name, figures)
        self.assertGreater(len(figures), 4)  # machine_a.json's own figures
        with open(os.path.join(directory, "report.md"), encoding="utf-8") as stream:
            markdown = stream.read()
        for name in HAND_MADE:
            self.assertIn(f"## The step across MPI ranks: {name}", markdown)
        self.assertIn("## Step time, sync x layout: machine_a.json", markdown)
        section = markdown[markdown.index("## The step across MPI ranks: mpi-b.json"):]
        section = section[:section.index("\n## ")]
        self.assertIn("Not applicable: shm_window: hand-made fixture", section)
        self.assertRegex(section, r"\| p2p \| 4\.\d+ us \| 910\.0 ns \| 3\.250 us \| 11\.700 us \| 52\.000 us \| "
                                  r"300\.0 ns \| 1\.500 us \| 30\.000 us \| 3 \(41 %\) \|")
        # The reference line: the ping-pong's one-way p50, median over the rounds.
        p50s = sorted(entry["one_way_p50_ns"] for entry in hand_made("mpi-b.json")["benchmarks"]
                      if entry["name"] == PINGPONG)
        self.assertIn(f"(p50, median over the rounds): {p50s[1]:.1f} ns.", section)
        with open(os.path.join(directory, "figures", "mpi-latency-1.svg"), encoding="utf-8") as stream:
            svg = stream.read()
        self.assertIn("ping-pong one-way p50", svg)

    def test_without_the_p50_the_line_is_the_mean(self):
        document = hand_made("mpi-a.json")
        for entry in document["benchmarks"]:
            entry.pop("one_way_p50_ns", None)
        directory = os.path.join(self.directory.name, "report")
        status, _, err = run_tool("report", self.write("mpi-a.json", json.dumps(document)), "--out", directory)
        self.assertEqual(status, 0, err)
        with open(os.path.join(directory, "report.md"), encoding="utf-8") as stream:
            self.assertIn("(mean, median over the rounds)", stream.read())


if __name__ == "__main__":
    unittest.main()
