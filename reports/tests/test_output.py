"""Where the tools write: checked before any work, written whole or not at all (output.py), and the one
formatter of durations."""
import os
import stat
import tempfile
import unittest
from unittest import mock

from support import fixture, run_tool

from lockstep_reports.common import output
from lockstep_reports.common.formatting import format_ns, format_number

REPORT_INPUTS = [fixture("machine_a.json"), fixture("verify_a.csv")]


class Scratch(unittest.TestCase):
    def setUp(self):
        self.directory = tempfile.mkdtemp(prefix="lockstep-output-test-")
        self.addCleanup(lambda: __import__("shutil").rmtree(self.directory, ignore_errors=True))

    def path(self, *names):
        return os.path.join(self.directory, *names)

    def entries(self, *names):
        return sorted(os.listdir(self.path(*names)))

    def assert_one_line(self, status, out, err, *words):
        self.assertEqual(status, 2, err)
        self.assertEqual(out, "")
        self.assertEqual(err.count("\n"), 1, err)
        for word in words:
            self.assertIn(word, err)


class CompareJson(Scratch):
    def compare(self, *extra, first="machine_a.json"):
        return run_tool("compare", fixture(first), fixture("machine_a_rerun.json"), *extra)

    def test_a_missing_directory_is_refused_before_the_inputs_are_read(self):
        target = self.path("no-such-directory", "c.json")
        # truncated.json would be refused too: the output location is checked first.
        status, out, err = self.compare("--json", target, first="truncated.json")
        self.assert_one_line(status, out, err, target, "does not exist")
        self.assertNotIn("truncated", err)
        self.assertEqual(self.entries(), [])

    def test_a_place_where_no_file_can_be_created_is_refused(self):
        for target in ("/proc/lockstep-compare.json", "/sys/lockstep-compare.json"):
            status, out, err = self.compare("--json", target)
            self.assert_one_line(status, out, err, target, "cannot create")

    def test_a_directory_is_not_a_file_name(self):
        status, out, err = self.compare("--json", self.directory)
        self.assert_one_line(status, out, err, "is a directory")

    def test_an_input_is_never_overwritten(self):
        with open(fixture("machine_a_rerun.json"), encoding="utf-8") as stream:
            before = stream.read()
        status, out, err = self.compare("--json", fixture("machine_a_rerun.json"))
        self.assert_one_line(status, out, err, "is one of the result files")
        with open(fixture("machine_a_rerun.json"), encoding="utf-8") as stream:
            self.assertEqual(stream.read(), before)

    def test_an_input_is_refused_under_the_name_the_option_was_given(self):
        target = fixture("machine_a_rerun.json")
        for spelling in ("--out", "--json"):
            for argv in ((spelling, target), (f"{spelling}={target}",)):
                status, out, err = self.compare(*argv)
                self.assert_one_line(status, out, err, f"{spelling} {target} is one of the result files")
                other = "--json" if spelling == "--out" else "--out"
                self.assertNotIn(other, err)

    def test_the_file_is_whole_with_the_usual_permissions_and_nothing_beside_it(self):
        target = self.path("c.json")
        status, _, err = self.compare("--json", target)
        self.assertEqual(status, 0, err)
        self.assertEqual(self.entries(), ["c.json"])
        mask = os.umask(0)
        os.umask(mask)
        self.assertEqual(stat.S_IMODE(os.stat(target).st_mode), 0o666 & ~mask)

    def test_a_failed_write_leaves_the_earlier_file_and_no_temporary(self):
        target = self.path("c.json")
        with open(target, "w", encoding="utf-8") as stream:
            stream.write("earlier\n")
        with mock.patch.object(output, "_write_whole", side_effect=OSError(28, "No space left on device")):
            status, out, err = self.compare("--json", target)
        self.assert_one_line(status, out, err, target, "No space left on device")
        self.assertEqual(self.entries(), ["c.json"])
        with open(target, encoding="utf-8") as stream:
            self.assertEqual(stream.read(), "earlier\n")


class ReportDirectory(Scratch):
    def report(self, out_dir, inputs=REPORT_INPUTS):
        return run_tool("report", *inputs, "--out", out_dir)

    def test_a_missing_parent_is_refused_before_the_inputs_are_read(self):
        target = self.path("no-such-parent", "report")
        status, out, err = self.report(target, [fixture("truncated.json")])
        self.assert_one_line(status, out, err, target, "does not exist")
        self.assertNotIn("truncated", err)
        self.assertEqual(self.entries(), [])

    def test_a_place_where_nothing_can_be_created_is_refused(self):
        status, out, err = self.report("/proc/lockstep-report")
        self.assert_one_line(status, out, err, "/proc/lockstep-report", "cannot create")

    def test_a_file_is_not_a_report_directory(self):
        target = self.path("report")
        open(target, "w").close()
        status, out, err = self.report(target)
        self.assert_one_line(status, out, err, "is a file")

    def test_a_directory_of_other_files_is_never_replaced(self):
        target = self.path("notes")
        os.makedirs(target)
        with open(os.path.join(target, "todo.txt"), "w", encoding="utf-8") as stream:
            stream.write("keep me\n")
        status, out, err = self.report(target)
        self.assert_one_line(status, out, err, "todo.txt", "not part of a lockstep report")
        self.assertEqual(self.entries("notes"), ["todo.txt"])

    def test_an_empty_directory_takes_the_report(self):
        target = self.path("report")
        os.makedirs(target)
        status, _, err = self.report(target)
        self.assertEqual(status, 0, err)
        self.assertEqual(self.entries("report"), ["figures", "report.html", "report.md"])
        self.assertEqual(self.entries(), ["report"])

    def test_an_earlier_report_is_replaced_whole(self):
        target = self.path("report")
        status, _, err = self.report(target, [fixture("verify_a.csv")])
        self.assertEqual(status, 0, err)
        self.assertEqual(self.entries("report", "figures"), ["trajectory-0.svg"])
        status, _, err = self.report(target, [fixture("delay_a.json")])
        self.assertEqual(status, 0, err)
        self.assertEqual(self.entries("report", "figures"), ["delay-0.svg"])  # no figure of the earlier one
        self.assertEqual(self.entries(), ["report"])  # nothing aside, nothing half-built

    def test_a_failed_write_leaves_the_earlier_report_and_nothing_beside_it(self):
        target = self.path("report")
        status, _, err = self.report(target, [fixture("verify_a.csv")])
        self.assertEqual(status, 0, err)
        with open(os.path.join(target, "report.md"), encoding="utf-8") as stream:
            before = stream.read()
        calls = []

        def failing_write(handle, text):  # the third file fails, as on a full disk
            calls.append(handle)
            if len(calls) == 3:
                os.close(handle)
                raise OSError(28, "No space left on device")
            return real_write(handle, text)

        real_write = output._write_whole
        with mock.patch.object(output, "_write_whole", side_effect=failing_write):
            status, out, err = self.report(target)
        self.assert_one_line(status, out, err, target, "No space left on device")
        self.assertEqual(self.entries(), ["report"])
        self.assertEqual(self.entries("report", "figures"), ["trajectory-0.svg"])
        with open(os.path.join(target, "report.md"), encoding="utf-8") as stream:
            self.assertEqual(stream.read(), before)

    def test_an_interruption_leaves_nothing_half_built(self):
        target = self.path("report")
        with mock.patch.object(output, "_publish", side_effect=KeyboardInterrupt):
            with self.assertRaises(KeyboardInterrupt):
                self.report(target)
        self.assertEqual(self.entries(), [])


class Formatting(unittest.TestCase):
    def test_one_formatter_picks_the_unit_and_never_prints_a_non_number(self):
        self.assertEqual(format_ns(61.54), "61.5 ns")
        self.assertEqual(format_ns(1234.5), "1.234 us")
        self.assertEqual(format_ns(7_887_000.0), "7.887 ms")
        self.assertEqual(format_ns(2.5e9), "2.500 s")
        self.assertEqual(format_ns(950.0, 3), "950 ns")
        self.assertEqual(format_ns(1234.5, 3), "1.23 us")
        self.assertEqual(format_ns(12345.0, 3), "12.3 us")
        for missing in (None, float("nan"), float("inf"), -float("inf"), "12", True):
            self.assertEqual(format_ns(missing), "unavailable")
            self.assertEqual(format_number(missing), "unavailable")
        self.assertEqual(format_number(None, missing="-"), "-")
        self.assertEqual(format_number(1.456, 2, "x"), "1.46x")
        self.assertEqual(format_number(10 ** 400), str(10 ** 400))  # an int of any size is a number


if __name__ == "__main__":
    unittest.main()
