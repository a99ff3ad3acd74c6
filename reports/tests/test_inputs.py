"""Reading result files: Google Benchmark 1.7 and later, and one clear line for every unusable file."""
import os
import tempfile
import unittest

from support import fixture, run_tool

from lockstep_reports.inputs import InputError, load_any, load_run_file, C2cFile, DelayFile, VerifyFile
from lockstep_reports.names import parse_name


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
        import json, os, tempfile
        with open(fixture("machine_a.json"), encoding="utf-8") as stream:
            document = json.load(stream)
        for entry in document["benchmarks"]:
            entry["real_time"] *= 64  # one Google Benchmark iteration = a batch of 64 steps
        with tempfile.TemporaryDirectory() as directory:
            path = os.path.join(directory, "batched.json")
            with open(path, "w", encoding="utf-8") as stream:
                json.dump(document, stream)
            batched = load_run_file(path)
        plain = load_run_file(fixture("machine_a.json"))
        key = parse_name("rk4/sync:seqlock/layout:padded128/pin:compact/threads:2")
        self.assertEqual(batched.runs[key].times_ns(), plain.runs[key].times_ns())
        self.assertEqual(batched.runs[key].times_ns("cpu"), plain.runs[key].times_ns("cpu"))

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
            self.assert_one_line_error(path, "lockstep c2c", "context")

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


if __name__ == "__main__":
    unittest.main()
