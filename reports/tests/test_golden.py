"""Goldens: what `lockstep compare` prints (the summary and --all, and its --out JSON) and the Markdown page
`lockstep report` writes (report.md; the figures are not pinned), byte for byte, over the real run files and a few
hand-made fixtures. A change of the code that should not change what the tools say keeps every golden as it is.
The --out JSON is pinned with its floats to 12 significant digits (rounded): the last digits vary by CPU.

The goldens live in reports/tests/golden/. To write them again after a change that is meant to change the output:

    LOCKSTEP_UPDATE_GOLDEN=1 /usr/bin/python3 -m unittest test_golden     (from reports/tests)

and read the diff (git diff reports/tests/golden) before committing it.

The real run files: tests/fixtures/run/quick-pairs.json (a `lockstep run --quick` on the development VM, an AMD
EPYC guest) and reports/tests/fixtures/xeon_default_run_trimmed.json (a default run on an Intel Xeon guest, trimmed
by reports/tests/fixtures/trim_real_run.py, which says what it kept). The tools print file names, not paths, and
read no clock; what could still vary with the machine the tests run on (the repository's and the scratch
directory's paths) is replaced here, in the test, by <repository> and <out>.
"""
import difflib
import json
import os
import tempfile
import unittest
from unittest import mock

import matplotlib.figure

from support import REPORTS_DIR, fixture, run_tool

GOLDEN = REPORTS_DIR / "tests" / "golden"
UPDATE = os.environ.get("LOCKSTEP_UPDATE_GOLDEN") == "1"
REPOSITORY = os.fspath(REPORTS_DIR.parent)

QUICK_PAIRS = os.path.join(REPOSITORY, "tests", "fixtures", "run", "quick-pairs.json")
XEON = fixture("xeon_default_run_trimmed.json")

# golden file (golden/<name>.txt) -> the compare command line (the files, then options).
COMPARES = {
    "compare-xeon-quick": (XEON, QUICK_PAIRS),
    "compare-xeon-quick-all": (XEON, QUICK_PAIRS, "--all"),
    "compare-quick-xeon-cpu-all": (QUICK_PAIRS, XEON, "--all", "--time", "cpu"),
    "compare-paced": (fixture("paced_a.json"), fixture("paced_b.json")),
    "compare-paced-all": (fixture("paced_a.json"), fixture("paced_b.json"), "--all"),
    "compare-headline-paced": (fixture("headline.json"), fixture("paced_b.json")),
    "compare-machines-all": (fixture("machine_a.json"), fixture("machine_b.json"),
                            fixture("machine_a_rerun.json"), fixture("c2c_a.json"), "--all"),
    "compare-mpi": (fixture("mpi-a.json"), fixture("mpi-b.json")),
    "compare-mpi-all": (fixture("mpi-a.json"), fixture("mpi-b.json"), "--all"),
}
# golden file (golden/<name>.json) -> the compare command line whose --out JSON it pins.
COMPARE_JSONS = {
    "compare-xeon-quick": (XEON, QUICK_PAIRS),
    "compare-paced": (fixture("paced_a.json"), fixture("paced_b.json")),
}
# golden file (golden/<name>.md, the report's Markdown page) -> the report's inputs.
REPORTS = {
    "report-quick-pairs": (QUICK_PAIRS,),
    "report-xeon": (XEON,),
    "report-cpu-split": (fixture("cpu_split.json"),),
    "report-paced-every-pair": (fixture("paced_every_pair.json"),),
    "report-mpi": (fixture("mpi.json"),),
    "report-other-kinds": (fixture("c2c_a.json"), fixture("delay_per_cpu.json"), fixture("delay_find_period.json"),
                           fixture("delay_a.json"), fixture("verify_a.csv")),
}


def _stand_in_svg(figure, stream, **_):
    """Figure.savefig for the report's goldens: every figure is built (its data, axes and layout), not rendered
    into SVG. report.md links each figure by its name and holds none of its bytes; rendering is most of a report's
    time (test_report renders every figure)."""
    stream.write('<svg xmlns="http://www.w3.org/2000/svg"/>')


def rounded(value):
    """A JSON value with every float to 12 significant digits: numpy's sums and bootstrap quantiles differ in the
    last digits between CPUs (an AMD EPYC and an Intel Xeon guest differed at the 15th), which no reader sees."""
    if isinstance(value, float):
        return float(f"{value:.12g}")
    if isinstance(value, list):
        return [rounded(item) for item in value]
    if isinstance(value, dict):
        return {key: rounded(item) for key, item in value.items()}
    return value


def normalised(text: str, out: str | None = None) -> str:
    """The text with what varies by machine replaced: the scratch directory, then the repository's path."""
    if out:
        text = text.replace(out, "<out>")
    return text.replace(REPOSITORY, "<repository>")


class Golden(unittest.TestCase):
    maxDiff = None

    def check(self, name: str, text: str):
        path = GOLDEN / name
        if UPDATE:
            GOLDEN.mkdir(exist_ok=True)
            path.write_text(text, encoding="utf-8")
            return
        self.assertTrue(path.exists(), f"{path} is missing: LOCKSTEP_UPDATE_GOLDEN=1 writes it")
        expected = path.read_text(encoding="utf-8")
        if text != expected:
            diff = difflib.unified_diff(expected.splitlines(), text.splitlines(), f"golden/{name}", "now",
                                        lineterm="", n=1)
            self.fail(f"{name} differs from its golden (LOCKSTEP_UPDATE_GOLDEN=1 writes it again):\n"
                      + "\n".join(list(diff)[:60]))

    def test_compare_prints_its_goldens(self):
        for name, argv in COMPARES.items():
            with self.subTest(name):
                status, out, err = run_tool("compare", *argv)
                self.assertEqual(status, 0, err)
                self.check(name + ".txt", normalised(out))

    def test_compares_json_is_its_golden(self):
        for name, argv in COMPARE_JSONS.items():
            with self.subTest(name), tempfile.TemporaryDirectory(prefix="lockstep-golden-") as directory:
                target = os.path.join(directory, "comparison.json")
                status, _, err = run_tool("compare", *argv, "--out", target)
                self.assertEqual(status, 0, err)
                with open(target, encoding="utf-8") as stream:
                    written = rounded(json.load(stream))
                text = json.dumps(written, indent=2, sort_keys=True, allow_nan=False) + "\n"
                self.check(name + ".json", normalised(text, directory))

    def test_the_reports_markdown_is_its_golden(self):
        for name, inputs in REPORTS.items():
            with self.subTest(name), tempfile.TemporaryDirectory(prefix="lockstep-golden-") as directory, \
                    mock.patch.object(matplotlib.figure.Figure, "savefig", _stand_in_svg):
                out = os.path.join(directory, "report")
                status, _, err = run_tool("report", *inputs, "--out", out)
                self.assertEqual(status, 0, err)
                with open(os.path.join(out, "report.md"), encoding="utf-8") as stream:
                    self.check(name + ".md", normalised(stream.read(), directory))


if __name__ == "__main__":
    unittest.main()
