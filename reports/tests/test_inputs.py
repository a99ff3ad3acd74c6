"""Reading result files: Google Benchmark 1.7 and later, and one clear line for every unusable file."""
import json
import math
import os
import tempfile
import unittest

from support import FIXTURES, HEADLINE, Scratch, fixture, headline_document, run_tool, typed_document

from lockstep_reports.analysis.run_analysis import against_best_other_views
from lockstep_reports.common import statistics
from lockstep_reports.common.names import parse_name, spec_of
from lockstep_reports.common.words import DELAY_CAUSES
from lockstep_reports.read.c2c_reader import C2cFile
from lockstep_reports.read.delay_reader import DelayFile
from lockstep_reports.read.inputs import InputError, load_any, load_run_file
from lockstep_reports.read.run_checks import base_name
from lockstep_reports.read.verify_reader import VerifyFile


class NameParsing(unittest.TestCase):
    def test_segments_match_in_any_order_and_without_google_benchmark_suffixes(self):
        written = parse_name("rk4/sync:futex_spin/layout:padded128/pin:compact/threads:4")
        reordered = parse_name("rk4/threads:4/pin:compact/sync:futex_spin/layout:padded128/repeats:6/real_time")
        self.assertEqual(written, reordered)
        self.assertEqual(written.display, "rk4/sync:futex_spin/layout:padded128/pin:compact/threads:4")
        self.assertEqual(written.threads, 4)

    def test_different_segments_are_different_benchmarks(self):
        self.assertNotEqual(parse_name("rk4/sync:seqlock/layout:packed/pin:compact/threads:4"),
                            parse_name("rk4/sync:seqlock/layout:packed/pin:migrate/threads:4"))
        self.assertNotEqual(parse_name("rk4/serial"), parse_name("barrier/serial"))


class RunFiles(unittest.TestCase):
    def test_google_benchmark_1_7_repetitions_and_aggregates(self):
        run_file = load_run_file(fixture("machine_a.json"))
        run = run_file.runs[parse_name("rk4/sync:seqlock/layout:padded128/pin:compact/threads:2")]
        self.assertEqual(len(run.repetitions), 10)
        self.assertEqual(sorted(run.aggregates), ["mean", "median"])  # the ones read; stddev and cv are not
        self.assertIn("futex_waits_per_step", run.repetitions[0].counters)
        self.assertNotIn("repetition_index", run.repetitions[0].counters)
        self.assertEqual(run_file.context_number("c2c_one_way_ns"), 61.5)

    def test_step_time_comes_from_ns_per_step_when_iterations_are_batches(self):
        # Before lockstep schema 2 (the fixtures' "1"), real_time and cpu_time were per batch of steps.
        import json, os, tempfile
        with open(fixture("machine_a.json"), encoding="utf-8") as stream:
            document = json.load(stream)
        self.assertEqual(document["context"]["lockstep_schema"], "1")
        for entry in document["benchmarks"]:
            entry["real_time"] *= 64  # one Google Benchmark iteration = a batch of 64 steps
            entry["cpu_time"] *= 64
        with tempfile.TemporaryDirectory() as directory:
            path = os.path.join(directory, "batched.json")
            with open(path, "w", encoding="utf-8") as stream:
                json.dump(document, stream)
            batched = load_run_file(path)
        plain = load_run_file(fixture("machine_a.json"))
        key = parse_name("rk4/sync:seqlock/layout:padded128/pin:compact/threads:2")
        self.assertEqual(batched.runs[key].times_ns(), plain.runs[key].times_ns())
        for got, want in zip(batched.runs[key].times_ns("cpu"), plain.runs[key].times_ns("cpu"), strict=True):
            self.assertAlmostEqual(got, want, delta=want * 1e-12)

    def _with_second_repetition_lacking(self, *counters):
        with open(fixture("machine_a.json"), encoding="utf-8") as stream:
            document = json.load(stream)
        name = "rk4/sync:seqlock/layout:padded128/pin:compact/threads:2"
        repetitions = [entry for entry in document["benchmarks"]
                       if entry.get("run_name") == name and entry["run_type"] == "iteration"]
        for counter in counters:
            del repetitions[1][counter]
        directory = tempfile.TemporaryDirectory()
        self.addCleanup(directory.cleanup)
        path = os.path.join(directory.name, "partial.json")
        with open(path, "w", encoding="utf-8") as stream:
            json.dump(document, stream)
        return path, parse_name(name)

    def test_a_repetition_without_its_sync_time_is_read_without_it(self):
        # lockstep run omits sync_ns_per_stage (and vs_c2c, derived from it) from a repetition whose sampled
        # steps timed no stage sync, and keeps it in the next: the file is whole, the counter is read where
        # it was measured.
        path, key = self._with_second_repetition_lacking("sync_ns_per_stage", "vs_c2c")
        run = load_run_file(path).runs[key]
        self.assertEqual(len(run.repetitions), 10)
        self.assertEqual(len(run.counter_values("sync_ns_per_stage")), 9)
        self.assertEqual(len(run.counter_values("ns_per_step")), 10)

    def test_a_repetition_without_its_step_time_is_a_damaged_file(self):
        path, _ = self._with_second_repetition_lacking("ns_per_step")
        with self.assertRaises(InputError) as caught:
            load_run_file(path)
        self.assertIn("lacks ns_per_step", str(caught.exception))

    def test_from_schema_2_real_time_and_cpu_time_are_per_step(self):
        # lockstep schema 2 (bench/run/team_driver.hpp): real_time is ns_per_step, cpu_time is per step too,
        # and neither is rescaled, whatever real_time / ns_per_step would say.
        import json, os, tempfile
        with open(fixture("machine_a.json"), encoding="utf-8") as stream:
            document = json.load(stream)
        document["context"]["lockstep_schema"] = "2"
        key = parse_name("rk4/sync:seqlock/layout:padded128/pin:compact/threads:2")
        rows = [e for e in document["benchmarks"]
                if parse_name(e.get("run_name", e["name"])) == key and e["run_type"] == "iteration"]
        for entry in rows:
            entry["cpu_time"] = entry["real_time"] * 0.5
            entry["real_time"] *= 1.001  # written from the batch times, within rounding of ns_per_step
        with tempfile.TemporaryDirectory() as directory:
            path = os.path.join(directory, "per_step.json")
            with open(path, "w", encoding="utf-8") as stream:
                json.dump(document, stream)
            per_step = load_run_file(path)
        self.assertEqual(per_step.warnings, [])  # schema 2 is known
        self.assertEqual(per_step.runs[key].times_ns(), [e["ns_per_step"] for e in rows])
        self.assertEqual(per_step.runs[key].times_ns("cpu"), [e["cpu_time"] for e in rows])

    def test_later_schema_with_new_fields_nan_and_infinity_is_read(self):
        later = load_run_file(fixture("later_schema.json"))
        baseline = load_run_file(fixture("machine_a.json"))
        self.assertEqual(set(later.runs), set(baseline.runs))
        run = later.runs[parse_name("rk4/sync:seqlock/layout:packed/pin:migrate/threads:2")]
        self.assertEqual(run.counter_values("cross_core_csw_pct"), [])  # NaN counters are unavailable
        self.assertEqual(len(run.repetitions), 10)

    def test_errored_entries_are_kept_as_errored(self):
        run_file = load_run_file(fixture("errored.json"))
        run = run_file.runs[parse_name("rk4/sync:futex_spin/layout:packed/pin:migrate/threads:4")]
        self.assertTrue(run.errored)
        self.assertIn("watchdog", run.errors[0])
        self.assertEqual(run.repetitions, [])

    def test_aggregates_only_file_is_read(self):
        run_file = load_run_file(fixture("aggregates_only.json"))
        run = run_file.runs[parse_name("rk4/serial")]
        self.assertEqual(run.repetitions, [])
        self.assertIn("median", run.aggregates)

    def test_other_kinds_are_recognised_by_content(self):
        self.assertIsInstance(load_any(fixture("c2c_b.json")), C2cFile)
        self.assertIsInstance(load_any(fixture("delay_a.json")), DelayFile)
        verify = load_any(fixture("verify_a.csv"))
        self.assertIsInstance(verify, VerifyFile)
        self.assertEqual(verify.x1[0], 2.0)
        self.assertEqual(verify.x2[0], -3.0)


class UnusableFiles(unittest.TestCase):
    """Each is exit 2 with one line on stderr that names the file and the problem."""

    def assert_one_line_error(self, path, *words):
        status, out, err = run_tool("compare", fixture("machine_a.json"), path)
        self.assertEqual(status, 2)
        self.assertEqual(out, "")
        self.assertEqual(err.count("\n"), 1, err)
        self.assertIn(path, err)
        for word in words:
            self.assertIn(word, err)
        return err

    def test_truncated(self):
        self.assert_one_line_error(fixture("truncated.json"), "truncated")

    def test_foreign_json(self):
        self.assert_one_line_error(fixture("foreign.json"), "not Google Benchmark JSON")

    def test_c2c_output_joins_only_the_fingerprint(self):
        status, out, err = run_tool("compare", fixture("machine_a.json"), fixture("c2c_a.json"))
        self.assertEqual(status, 0, err)
        self.assertIn("fingerprint only (not benchmark results): c2c_a.json (lockstep c2c)", out)
        self.assertIn("machines: ", out)

    def test_c2c_output_without_a_context(self):
        with tempfile.TemporaryDirectory() as directory:
            path = os.path.join(directory, "c2c.json")
            with open(path, "w") as file:
                file.write('{"kind": "c2c", "pairs": []}')
            self.assert_one_line_error(path, "context: is missing")

    def test_missing_file(self):
        self.assert_one_line_error(os.path.join(tempfile.gettempdir(), "lockstep-no-such-file.json"), "cannot read")

    def test_empty_and_binary_files(self):
        with tempfile.TemporaryDirectory() as directory:
            empty = os.path.join(directory, "empty.json")
            open(empty, "w").close()
            self.assert_one_line_error(empty, "empty")
            binary = os.path.join(directory, "binary.json")
            with open(binary, "wb") as stream:
                stream.write(b"\x7fELF\x02\x01\x01\x00\xff\xfe\x00")
            self.assert_one_line_error(binary, "not text")

    def test_report_rejects_a_csv_of_another_shape(self):
        with tempfile.TemporaryDirectory() as directory:
            path = os.path.join(directory, "other.csv")
            with open(path, "w") as stream:
                stream.write("time,value\n0,1\n")
            with self.assertRaises(InputError) as caught:
                load_any(path)
            self.assertIn(path, str(caught.exception))



# What Google Benchmark 1.8 writes for a program of its own (no lockstep key anywhere): the context it fills in
# and one benchmark's repetitions and median.
PLAIN_GOOGLE_BENCHMARK = {
    "context": {"date": "2026-11-26T10:00:00+00:00", "host_name": "box", "executable": "./bench_sort",
                "num_cpus": 8, "mhz_per_cpu": 3000, "cpu_scaling_enabled": False,
                "caches": [{"type": "Data", "level": 1, "size": 32768, "num_sharing": 1}],
                "load_avg": [0.5, 0.4, 0.3], "library_version": "v1.8.3", "library_build_type": "release",
                "json_schema_version": 1},
    "benchmarks": [
        {"name": "BM_Sort/1024", "family_index": 0, "per_family_instance_index": 0, "run_name": "BM_Sort/1024",
         "run_type": "iteration", "repetitions": 2, "repetition_index": index, "threads": 1,
         "iterations": 100000, "real_time": 5000.0 + index, "cpu_time": 4990.0 + index, "time_unit": "ns"}
        for index in range(2)] + [
        {"name": "BM_Sort/1024_median", "family_index": 0, "per_family_instance_index": 0,
         "run_name": "BM_Sort/1024", "run_type": "aggregate", "repetitions": 2, "threads": 1,
         "aggregate_name": "median", "aggregate_unit": "time", "iterations": 2, "real_time": 5000.5,
         "cpu_time": 4990.5, "time_unit": "ns"}],
}


class NotWrittenByLockstep(Scratch):
    """A Google Benchmark file lockstep did not write: refused by compare and by report, one line, exit 2,
    before anything is compared or written."""

    def assert_refused(self, tool: str, *argv: str):
        status, out, err = run_tool(tool, *argv)
        self.assertEqual((status, out), (2, ""), err)
        self.assertEqual(err.count("\n"), 1, err)
        self.assertIn(self.plain, err)
        self.assertIn("Google Benchmark JSON that lockstep did not write", err)

    def setUp(self):
        super().setUp()
        self.plain = self.write("plain.json", PLAIN_GOOGLE_BENCHMARK)

    def test_compare_refuses_it_either_side(self):
        self.assert_refused("compare", self.plain, fixture("machine_a.json"))
        self.assert_refused("compare", fixture("machine_a.json"), self.plain)
        self.assert_refused("compare", self.plain, self.plain)  # read and checked before the same bytes are

    def test_report_refuses_it_and_writes_nothing(self):
        out = os.path.join(self.directory.name, "report")
        self.assert_refused("report", self.plain, "--out", out)
        self.assertFalse(os.path.exists(out))

    def test_one_lockstep_key_is_enough(self):
        # The context's lockstep_schema (every lockstep file's), or a section of lockstep's at the top level.
        for where in ("context", "top"):
            document = json.loads(json.dumps(PLAIN_GOOGLE_BENCHMARK))
            if where == "context":
                document["context"]["lockstep_schema"] = "2"
            else:
                document["lockstep_pairs"] = []
            status, _, err = run_tool("compare", self.write(f"{where}.json", document), fixture("machine_a.json"))
            self.assertEqual(status, 0, err)

class PaceTraceAndPairs(unittest.TestCase):
    """The pace keys (docs/pace.md): lockstep_pace, lockstep_pairs and the per-repetition pace."""

    @staticmethod
    def document(name="paced_a.json"):
        with open(fixture(name), encoding="utf-8") as stream:
            return json.load(stream)

    def load(self, document):
        with tempfile.TemporaryDirectory() as directory:
            path = os.path.join(directory, "paced.json")
            with open(path, "w", encoding="utf-8") as stream:
                json.dump(document, stream)
            return load_run_file(path), path

    def assert_rejected(self, document, *words):
        with self.assertRaises(InputError) as caught:
            self.load(document)
        text = str(caught.exception)
        self.assertEqual(text.count("\n"), 0)
        for word in words:
            self.assertIn(word, text)
        return text

    def test_the_trace_the_pairs_and_each_repetitions_pace_are_read(self):
        run_file = load_run_file(fixture("paced_a.json"))
        pace = run_file.pace
        self.assertEqual([mode.c2c_ns for mode in pace.modes], [25.0, 118.0])
        self.assertEqual(pace.changes, 1)
        self.assertEqual(pace.cpus, (0, 1))
        self.assertEqual(len(pace.readings), 40)
        self.assertIn(-1, [reading.mode for reading in pace.readings])  # the outlier reading
        self.assertTrue(pace.summary.startswith("c2c 25 ns"))
        self.assertEqual(len(run_file.pairs), 3)
        pair = run_file.pairs[0]
        self.assertEqual(pair.comparison, "false_sharing")
        self.assertEqual(pair.a_key, parse_name(pair.a))
        self.assertEqual(len(pair.ratios), len(pair.modes))
        run = run_file.runs[parse_name("rk4/sync:futex_spin/layout:packed/pin:compact/threads:4")]
        modes = [repetition.pace.mode for repetition in run.repetitions]
        self.assertEqual(modes, [0] * 6 + [-1] + [1] * 3)
        self.assertTrue(run.repetitions[6].pace.straddles)
        self.assertGreater(run.repetitions[9].pace.c2c_ns, 100)
        self.assertNotIn("pace_mode", run.repetitions[0].counters)  # the pace is not a counter shown

    def test_an_old_file_has_no_pace_and_no_pairs(self):
        run_file = load_run_file(fixture("machine_a.json"))
        self.assertIsNone(run_file.pace)
        self.assertEqual(run_file.pairs, [])
        self.assertTrue(all(r.pace is None for run in run_file.runs.values() for r in run.repetitions))

    def test_a_nan_pace_is_unavailable_and_counted(self):
        document = self.document()
        first = next(e for e in document["benchmarks"] if e["run_type"] == "iteration")
        first["pace_c2c_ns"] = math.nan
        run_file, _ = self.load(document)
        self.assertTrue(any("pace_c2c_ns value" in warning for warning in run_file.warnings))

    def test_aggregates_may_carry_a_meaningless_pace(self):
        document = self.document()
        for entry in document["benchmarks"]:
            if entry["run_type"] == "aggregate":
                entry["pace_mode"] = 0.4  # a mean of mode indices: ignored there
        run_file, _ = self.load(document)
        self.assertIsNotNone(run_file.pace)

    def test_damaged_pace_keys_are_one_line(self):
        def changed(change):
            document = self.document()
            change(document)
            return document

        def iteration(document, index=0):
            return [e for e in document["benchmarks"] if e["run_type"] == "iteration"][index]

        cases = [
            (lambda d: d.__setitem__("lockstep_pace", []), "lockstep_pace: expected an object, not a list"),
            (lambda d: d["lockstep_pace"]["modes"].reverse(), "lockstep_pace.modes[0].mode: is 1"),
            (lambda d: d["lockstep_pace"]["modes"][1].__setitem__("c2c_ns", 10.0), "sorted fastest first"),
            (lambda d: d["lockstep_pace"]["modes"][0].__setitem__("share", 1.5), "modes[0].share: is 1.5"),
            (lambda d: d["lockstep_pace"]["readings"][3].__setitem__("t_s", 0.0), "in time order"),
            (lambda d: d["lockstep_pace"]["readings"][3].__setitem__("mode", 2), "readings[3].mode: is 2"),
            (lambda d: d["lockstep_pace"]["readings"][3].__setitem__("c2c_ns", -4.0), "readings[3].c2c_ns: is -4"),
            (lambda d: d["lockstep_pace"].__setitem__("changes", 400), "lockstep_pace.changes: is 400"),
            (lambda d: d["lockstep_pace"].__setitem__("cpus", [1, 1]), "cpus"),
            (lambda d: d["lockstep_pace"].pop("summary"), "lockstep_pace.summary: is missing"),
            (lambda d: iteration(d).__setitem__("pace_mode", 2), "pace_mode is 2"),
            (lambda d: iteration(d).__setitem__("pace_mode", 0.5), "pace_mode is 0.5"),
            (lambda d: iteration(d).__setitem__("pace_mode", "fast"), "pace_mode: expected a number, not text"),
            (lambda d: iteration(d).pop("pace_serial_ns"), "pace_serial_ns"),
            (lambda d: d.pop("lockstep_pace"), "no lockstep_pace"),
            (lambda d: d.__setitem__("lockstep_pairs", {}), "lockstep_pairs: expected a list, not an object"),
            (lambda d: d["lockstep_pairs"][0].__setitem__("comparison", "speed"), "lockstep_pairs[0].comparison: is 'speed'"),
            (lambda d: d["lockstep_pairs"][0]["ratios"].__setitem__(2, -1.3), "lockstep_pairs[0].ratios[2]: is -1.3"),
            (lambda d: d["lockstep_pairs"][0]["modes"].pop(), "one mode per pair"),
            (lambda d: d["lockstep_pairs"][0]["modes"].__setitem__(0, 7), "lockstep_pairs[0].modes[0]: is 7"),
            (lambda d: d["lockstep_pairs"][0].__setitem__("ci_low", 9.0), "above ci_high"),
            (lambda d: d["lockstep_pairs"][0].__setitem__("verdict", "faster"), "lockstep_pairs[0].verdict: is 'faster'"),
            (lambda d: d["lockstep_pairs"].append(d["lockstep_pairs"][0]), "repeats entry 0"),
        ]
        for change, words in cases:
            with self.subTest(words):
                self.assert_rejected(changed(change), words)

    def test_the_pace_keys_are_additions_a_tool_that_ignores_them_reads_the_same(self):
        document = self.document()
        for key in ("lockstep_pace", "lockstep_pairs"):
            document.pop(key)
        for entry in document["benchmarks"]:
            for key in ("pace_c2c_ns", "pace_serial_ns", "pace_mode"):
                entry.pop(key, None)
        plain, _ = self.load(document)
        paced = load_run_file(fixture("paced_a.json"))
        self.assertIsNone(plain.pace)
        self.assertEqual({key: run.times_ns() for key, run in plain.runs.items()},
                         {key: run.times_ns() for key, run in paced.runs.items()})


class ReadingTheAnswer(Scratch):
    def test_the_lines_choices_and_collapsed_entries_are_read(self):
        run_file = load_run_file(fixture(HEADLINE))
        document = headline_document()["lockstep_headline"]
        self.assertEqual(list(run_file.answer.lines), document["lines"])
        self.assertEqual(len(run_file.answer.choices), len(document["recommendations"]))
        first = run_file.answer.choices[0]
        self.assertEqual((first.threads, first.pin, first.model, first.basis), (2, "compact", "", "paired"))
        self.assertEqual(run_file.collapsed, frozenset(parse_name(name) for name in document["collapsed"]))
        self.assertIn(parse_name("rk4/sync:ck_tas/layout:packed/pin:none/threads:4"), run_file.collapsed)

    def test_the_choices_rivals_tie_and_the_answer_first_are_read(self):
        document = headline_document()
        block = document["lockstep_headline"]
        raw = block["recommendations"][0]
        first = load_run_file(fixture(HEADLINE)).answer.choices[0]
        self.assertFalse(first.tied)  # a file written before the key: no tie
        self.assertEqual((first.runner_up.entry, first.runner_up.median, first.runner_up.verdict),
                         (raw["runner_up"]["entry"], raw["runner_up"]["median"], raw["runner_up"]["verdict"]))
        self.assertEqual(first.baseline.sync, raw["baseline"]["sync"])
        self.assertEqual(first.spread_pct, raw["spread_pct"])
        self.assertIsNone(load_run_file(fixture(HEADLINE)).answer.best)
        raw["tied"] = True
        block["answer"] = {"model": "", "threads": 2, "pin": "compact", "entry": raw["entry"], "ns_per_step": 316.9,
                           "serial_ns_per_step": 182.0, "vs_serial": 1.74, "a_later_key": 1}
        answer = load_run_file(self.write("tied.json", document)).answer
        self.assertTrue(answer.choices[0].tied)
        self.assertEqual((answer.best.threads, answer.best.pin, answer.best.entry,
                          answer.best.ns_per_step, answer.best.serial_ns_per_step, answer.best.vs_serial),
                         (2, "compact", raw["entry"], 316.9, 182.0, 1.74))

    def test_it_reads_the_same_under_its_name_and_its_earlier_one(self):
        """lockstep_answer, and lockstep_headline in a file written before that name: the same answer."""
        document = headline_document()
        document["lockstep_answer"] = document.pop("lockstep_headline")
        self.assertEqual(load_run_file(self.write("answer.json", document)).answer,
                         load_run_file(fixture(HEADLINE)).answer)

    def test_a_file_without_it_reads_as_before(self):
        run_file = load_run_file(fixture("paced_a.json"))
        self.assertIsNone(run_file.answer)
        self.assertEqual(run_file.collapsed, frozenset())

    def test_unknown_keys_are_ignored(self):
        document = headline_document()
        document["lockstep_headline"]["a_later_key"] = {"anything": [1, 2]}
        document["lockstep_headline"]["recommendations"][0]["a_later_key"] = "text"
        run_file = load_run_file(self.write("later.json", document))
        self.assertEqual(run_file.answer, load_run_file(fixture(HEADLINE)).answer)

    def test_what_it_reads_is_checked_in_one_line(self):
        def set_line(block):
            block["lines"][2] = 17

        def empty_lines(block):
            block["lines"] = []

        def nameless(block):
            block["collapsed"][0] = ""

        def no_basis(block):
            del block["recommendations"][1]["basis"]

        def endless_step(block):
            block["recommendations"][0]["ns_per_step"] = math.inf

        def no_threads(block):
            block["recommendations"][0]["threads"] = 0

        def tied_as_text(block):
            block["recommendations"][0]["tied"] = "yes"

        def answer_without_entry(block):
            block["answer"] = {"model": "", "threads": 2, "pin": "compact", "ns_per_step": 300.0}

        def answer_at_no_threads(block):
            block["answer"] = {"model": "", "threads": 0, "pin": "compact", "entry": block["recommendations"][0]["entry"],
                               "ns_per_step": 300.0}

        for mutate in (set_line, empty_lines, nameless, no_basis, endless_step, no_threads, tied_as_text,
                       answer_without_entry, answer_at_no_threads):
            with self.subTest(mutate.__name__):
                document = headline_document()
                mutate(document["lockstep_headline"])
                path = self.write(f"{mutate.__name__}.json", json.dumps(document, allow_nan=True))
                with self.assertRaises(InputError) as raised:
                    load_run_file(path)
                self.assertEqual(len(str(raised.exception).splitlines()), 1)
                self.assertIn("lockstep_headline", str(raised.exception))


class TypedEntries(Scratch):
    """A file whose entries carry their spec (lockstep_entry) is read by the specs: the same keys, times, answer and
    pairs as the names give, even with every name replaced by one that says nothing; the name's parser
    (names.parse_name) reads only the files written before the spec."""

    FILES = (HEADLINE, "xeon_default_run_trimmed.json", "crossover_ceiling.json")

    def test_the_specs_give_what_the_names_gave(self):
        for name in self.FILES:
            with self.subTest(name):
                with open(fixture(name), encoding="utf-8") as stream:
                    document = json.load(stream)
                older, typed = load_run_file(fixture(name)), load_run_file(self.write(name, typed_document(document)))
                self.assertEqual(set(typed.runs), set(older.runs))
                self.assertEqual({key: run.times_ns() for key, run in typed.runs.items()},
                                 {key: run.times_ns() for key, run in older.runs.items()})
                self.assertEqual((typed.answer, typed.pairs, typed.planned, typed.rankings, typed.mode_medians),
                                 (older.answer, older.pairs, older.planned, older.rankings, older.mode_medians))
                self.assertEqual({key: run.entry for key, run in typed.runs.items()},
                                 {key: run.entry for key, run in older.runs.items()})

    def test_a_name_that_says_nothing_reads_the_same(self):
        with open(fixture(HEADLINE), encoding="utf-8") as stream:
            document = json.load(stream)
        numbers: dict = {}
        opaque = typed_document(document, rename=lambda name: numbers.setdefault(name, f"entry {len(numbers) + 1}"))
        self.assertNotIn("rk4/", json.dumps(opaque["benchmarks"][:3]))
        typed = load_run_file(self.write("opaque.json", opaque))
        older = load_run_file(fixture(HEADLINE))
        self.assertEqual({key: run.times_ns() for key, run in typed.runs.items()},
                         {key: run.times_ns() for key, run in older.runs.items()})
        self.assertEqual([choice.entry_key for choice in typed.answer.choices],
                         [choice.entry_key for choice in older.answer.choices])
        self.assertEqual(typed.collapsed, older.collapsed)
        self.assertEqual([(pair.a_key, pair.b_key) for pair in typed.pairs],
                         [(pair.a_key, pair.b_key) for pair in older.pairs])

    def test_the_spec_and_the_name_give_one_key(self):
        """names.spec_of (what a name implies) and EntrySpec.key (the identity made from the values) agree with the
        parser on every entry of every kept run file: an older file's entries match a newer file's."""
        for path in sorted(FIXTURES.glob("*.json")):
            try:
                document = json.loads(path.read_text(encoding="utf-8"))
            except ValueError:
                continue
            if not isinstance(document, dict) or "benchmarks" not in document or document.get("kind"):
                continue
            for raw in document["benchmarks"]:
                key = parse_name(base_name(raw))
                self.assertEqual(spec_of(key).key, key, raw["name"])

    def test_what_a_spec_leaves_wrong_is_one_line(self):
        with open(fixture(HEADLINE), encoding="utf-8") as stream:
            document = typed_document(json.load(stream))

        def one_without(changed):
            del changed["benchmarks"][7]["lockstep_entry"]

        def a_pair_of_no_entry(changed):
            changed["lockstep_pairs"][0]["a"] = "rk4/sync:nothing/layout:packed/pin:compact/threads:2"

        def a_step_without_its_time(changed):
            entry = next(raw for raw in changed["benchmarks"] if raw["lockstep_entry"]["kind"] == "rk4")
            del entry["ns_per_step"]

        for mutate, place in ((one_without, "benchmarks[7].lockstep_entry: is missing"),
                              (a_pair_of_no_entry, "lockstep_pairs[0].a: is 'rk4/sync:nothing"),
                              (a_step_without_its_time, "ns_per_step is missing: its lockstep_entry says its time "
                                                        "counts a step")):
            with self.subTest(mutate.__name__):
                changed = json.loads(json.dumps(document))
                mutate(changed)
                with self.assertRaises(InputError) as raised:
                    load_run_file(self.write(f"{mutate.__name__}.json", changed))
                self.assertEqual(len(str(raised.exception).splitlines()), 1)
                self.assertIn(place, str(raised.exception))


class LeaderLine(unittest.TestCase):
    def test_the_leader_has_the_runner_ups_pair_inverted(self):
        run_file = load_run_file(fixture(HEADLINE))
        views = against_best_other_views(run_file.pairs)
        measured = [pair for pair in run_file.pairs if pair.comparison == "against_best_other"]
        inverted = [view for view in views if view.inverted]
        # one inverted line per group: 2 placements x 2 thread counts of steps, 1 of bare episodes
        self.assertEqual(len(inverted), 5)
        self.assertEqual(len(views), len(measured) + len(inverted))
        for view in inverted:
            runner_up = next(pair for pair in measured if pair.a_key == view.b_key and pair.b_key == view.a_key)
            # the group's first pair in the file is the runner-up's
            group = [pair for pair in measured if pair.b_key == runner_up.b_key]
            self.assertIs(group[0], runner_up)
            self.assertAlmostEqual(view.median, 1.0 / runner_up.median)
            self.assertAlmostEqual(view.ci_low, 1.0 / runner_up.ci_high)
            self.assertAlmostEqual(view.ci_high, 1.0 / runner_up.ci_low)
            self.assertEqual(view.verdict, {"penalty": "gain", "gain": "penalty"}.get(runner_up.verdict,
                                                                                    runner_up.verdict))
            self.assertEqual(len(view.ratios), len(runner_up.ratios))
            # the leader has no pair of its own: its line comes first in its group
            self.assertFalse(any(pair.a_key == view.a_key for pair in measured))
            self.assertIs(views[views.index(view) + 1], runner_up)

    def test_within_noise_and_unsure_stay_as_they_are(self):
        run_file = load_run_file(fixture(HEADLINE))
        pair = next(pair for pair in run_file.pairs if pair.comparison == "against_best_other")
        for verdict in (statistics.WITHIN_NOISE, statistics.UNSURE):
            with self.subTest(verdict):
                turned = type(pair)(**{**pair.__dict__, "verdict": verdict}).inverse()
                self.assertEqual(turned.verdict, verdict)
                self.assertTrue(turned.inverted)
                self.assertFalse(turned.inverse().inverted)

    def test_a_file_where_every_primitive_has_its_own_pair_is_shown_as_it_is(self):
        run_file = load_run_file(fixture("paced_every_pair.json"))
        views = against_best_other_views(run_file.pairs)
        self.assertEqual(views, [pair for pair in run_file.pairs if pair.comparison == "against_best_other"])

class DelayCausesNames(Scratch):
    """The delay causes' order and words come from the file (cause_kinds, the writer's enum) where it has them;
    a file written before them reads with words.DELAY_CAUSES."""

    def document(self, names=None):
        with open(fixture("delay_a.json"), encoding="utf-8") as stream:
            document = json.load(stream)
        split = {key: 10.0 * index for index, (key, _) in enumerate(DELAY_CAUSES)}
        document["causes"] = {"unavailable": None, "worst": [], "per_cpu": [{"cpu": 1, "cause_ns": split}],
                              "tail": [{"label": "above p99", "threshold_ns": 5000.0, "steps": 10, "excess_ns": 280.0,
                                        "cause_ns": split, "explained_share": 1.0, "guest_share": 1.0,
                                        "top": "unexplained"}]}
        document.pop("cause_kinds", None)
        if names is not None:
            document["cause_kinds"] = names
        return document

    def test_a_file_without_names_reads_the_enum_as_it_was(self):
        causes = load_any(self.write("delay.json", self.document())).causes
        self.assertEqual(causes.names, DELAY_CAUSES)
        self.assertEqual([(row.label, row.steps, row.cpu) for row in causes.rows],
                         [("above p99", 10, None), ("above p99", None, 1)])

    def test_the_files_names_are_read_in_its_order(self):
        names = [{"key": key, "words": words.upper()} for key, words in reversed(DELAY_CAUSES)]
        causes = load_any(self.write("delay.json", self.document(names))).causes
        self.assertEqual(causes.names, tuple((item["key"], item["words"]) for item in names))

    def test_names_that_are_not_a_list_of_key_and_words_are_refused_in_one_line(self):
        for names, problem in (({"compute": "compute"}, "cause_kinds: expected a list, not an object"),
                               ([{"key": "compute"}], "cause_kinds[0].words: is missing"),
                               ([{"key": "compute", "words": "a"}, {"key": "compute", "words": "b"}],
                                "cause_kinds[1].key: repeats 'compute'")):
            with self.subTest(problem):
                path = self.write("delay.json", self.document(names))
                status, _, err = run_tool("report", path, "--out", os.path.join(self.directory.name, "out"))
                self.assertEqual(status, 2)
                self.assertIn(problem, err)
                self.assertEqual(len(err.splitlines()), 1)


if __name__ == "__main__":
    unittest.main()
