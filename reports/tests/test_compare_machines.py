"""`lockstep compare` across machines and builds: each machine's answer first, what makes files incomparable said
before anything else, a Debug build's times kept out of every aggregate verdict, and a default text no wider than
120 columns. On the real run files of two kinds of machine (reports/tests/fixtures/trim_real_run.py says what was
kept of each) and the hand-made fixtures."""
import json
import os
import unittest

from support import REPORTS_DIR, Scratch, fixture, logical_line, run_tool

from lockstep_reports.common.text_layout import WIDTH, table
from lockstep_reports.compare.compare import compare_pair
from lockstep_reports.read.answer_reader import read_answer
from lockstep_reports.read.inputs import load_run_file

# An Intel Xeon guest's Release default run and an AMD EPYC guest's: its Debug --quick run (with the headline),
# its Release --quick run (with the headline) and its Release default run (written before the headline).
XEON = fixture("xeon_default_run_trimmed.json")
AMD_DEBUG_QUICK = os.path.join(REPORTS_DIR.parent, "tests", "fixtures", "run", "quick-pairs.json")
AMD_QUICK = fixture("run_quick_split.json")
AMD_DEFAULT = fixture("amd_default_run_trimmed.json")
# lockstep run's headline of that quick run, as the harness writes it today (tests/run/run_fixture_test.cpp).
LOCKSTEP_HEADLINE = os.path.join(REPORTS_DIR.parent, "tests", "fixtures", "run", "quick-pairs.headline.json")
# How many lines "about 40" may take.
ABOUT_40 = 50


def compared(*argv):
    status, out, err = run_tool("compare", *argv)
    assert status == 0, err
    return out


def line_index(text: str, start: str) -> int:
    return next(index for index, line in enumerate(text.splitlines()) if line.startswith(start))


class AnswerFirst(unittest.TestCase):
    def test_a_debug_quick_run_against_a_release_default_run(self):
        # The AMD guest's Debug --quick run against the Intel guest's Release default run, as a new user tried it.
        out = compared(AMD_DEBUG_QUICK, XEON)
        lines = out.splitlines()
        first = " ".join(" ".join(lines[:12]).split())
        self.assertIn("[A] quick-pairs.json is a Debug build (-g): its times are the unoptimised code's, not its "
                      "machine's", first)
        self.assertIn("the modes differ: [A] --quick (3 repetitions an entry); [B] default (5 repetitions an entry)",
                      first)
        self.assertIn("c971c66b8b12-dirty", first)
        # each machine's answer, side by side, within the first 40 lines
        answers = line_index(out, "Each machine's answer")
        self.assertLess(line_index(out, "migration"), 40)
        self.assertIn("[A] quick-pairs.json", lines[answers + 1])
        self.assertIn("[B] xeon_default_run_trimmed.json", lines[answers + 1])
        for row in ("core-to-core, one way", "2 threads, pin:compact", "4 threads, pin:none", "  std_barrier takes",
                    "false sharing"):
            self.assertLess(line_index(out, row), 40, row)
        chosen = lines[line_index(out, "2 threads, pin:compact")]
        self.assertRegex(chosen, r"^2 threads, pin:compact +- +mailbox \+ per_thread$")
        self.assertIn("767 ns", lines[line_index(out, "2 threads, pin:compact") + 1])
        self.assertLess(line_index(out, "Each machine's answer"), line_index(out, "What differs between the machines"))
        # no aggregate verdict reads the Debug times as the machine's
        aggregate = logical_line(out, "geometric mean of B/A")
        self.assertIn("withheld: A is a Debug build", aggregate)
        self.assertNotRegex(aggregate, r"\]: (slower|faster)")
        self.assertLessEqual(len(lines), ABOUT_40)
        # the machine is never blamed for what the build did
        everything = compared(AMD_DEBUG_QUICK, XEON, "--all")
        self.assertNotIn("the machine itself changed", everything)
        self.assertIn("moved beyond the ±5 % noise threshold: the builds differ ([A] Debug, GNU 12.2.0, -g; [B] "
                      "Release, GNU 12.2.0, -O3 -DNDEBUG)", everything)

    def test_two_release_default_runs_of_two_kinds_of_machine(self):
        out = compared(XEON, AMD_DEFAULT)
        lines = out.splitlines()
        self.assertLessEqual(len(lines), ABOUT_40)
        self.assertNotIn("Debug", out)
        self.assertNotIn("the modes differ", out)
        answers = line_index(out, "Each machine's answer")
        self.assertRegex(lines[line_index(out, "build, run")], r"Release, default run +Release, default run$")
        self.assertRegex(lines[line_index(out, "the run's answer")], r"in the file +none: the file predates it$")
        self.assertRegex(lines[line_index(out, "core-to-core, one way")], r"72\.3 ns +27\.4 ns$")
        self.assertLess(answers, line_index(out, "What differs between the machines"))
        self.assertIn("different lockstep revisions: [A] 6ce60e04cc3b, [B] c89cd6d8b01a-dirty", " ".join(out.split()))
        # an aggregate across two Release builds is given, with its verdict
        self.assertRegex(logical_line(out, "geometric mean of B/A"), r"95% interval \[[0-9.]+, [0-9.]+\]: [a-z]")

    def test_the_answers_of_two_runs_with_headlines_fill_both_columns(self):
        out = compared(XEON, AMD_QUICK)
        row = out.splitlines()[line_index(out, "2 threads, pin:compact")]
        self.assertRegex(row, r"mailbox \+ per_thread +mailbox \+ per_thread$")
        self.assertRegex(out.splitlines()[line_index(out, "false sharing")], r"0\.846x .* 3\.09x \[2\.90, 3\.16\]")
        self.assertRegex(out.splitlines()[line_index(out, "migration")], r"move 9\.35 us, refill 8\.22 us +move "
                                                                          r"28\.1 us, refill 7\.73 us$")

    def test_runs_of_one_machine_keep_their_summary(self):
        out = compared(fixture("paced_a.json"), fixture("paced_b.json"))
        self.assertNotIn("Each machine's answer", out)
        self.assertNotIn("Read first", out)
        self.assertIn("only in A (paced_a.json): removed: 0", out)

    def test_across_machines_the_entries_are_only_on_one_not_added_or_removed(self):
        everything = compared(XEON, AMD_DEBUG_QUICK, "--all")
        self.assertIn("only on A (xeon_default_run_trimmed.json): 60", everything)
        self.assertIn("only on B (quick-pairs.json): 8", everything)
        self.assertNotIn("removed", everything)
        self.assertNotIn(": added", everything)

    def test_up_to_four_files_one_column_each(self):
        out = compared(XEON, AMD_DEBUG_QUICK, AMD_QUICK, AMD_DEFAULT)
        lines = out.splitlines()
        # the files one a line where they do not fit on the first; a column headed by its letter where its name
        # would not fit
        self.assertEqual(lines[:5], ["lockstep compare:", "  [A] xeon_default_run_trimmed.json",
                                     "  [B] quick-pairs.json", "  [C] run_quick_split.json",
                                     "  [D] amd_default_run_trimmed.json"])
        heading = lines[line_index(out, "Each machine's answer") + 1]
        self.assertRegex(heading, r"^ +\[A\] +\[B\] quick-pairs\.json +\[C\] +\[D\]$")
        self.assertRegex(lines[line_index(out, "serial RK4 step")], r"26\.8 ns +685\.2 ns +20\.9 ns +21\.0 ns$")
        self.assertLessEqual(max(len(line) for line in lines), WIDTH)


class DefaultTextWidth(unittest.TestCase):
    """No line of compare's default text is wider than 120 columns, across machines or between runs of one."""

    CASES = ((AMD_DEBUG_QUICK, XEON), (XEON, AMD_DEFAULT), (XEON, AMD_QUICK, AMD_DEFAULT),
             (fixture("paced_a.json"), fixture("paced_b.json")), (fixture("headline.json"), fixture("paced_b.json")),
             (fixture("machine_a.json"), fixture("machine_b.json"), fixture("machine_a_rerun.json"),
              fixture("c2c_a.json")),
             (fixture("mpi-a.json"), fixture("mpi-b.json")), (fixture("machine_a.json"), fixture("errored.json")),
             (fixture("machine_a.json"), fixture("entry_sets_differ.json")))

    def test_no_line_is_wider_than_120_columns(self):
        for argv in self.CASES:
            with self.subTest(argv=[os.path.basename(path) for path in argv]):
                wide = [line for line in compared(*argv).splitlines() if len(line) > WIDTH]
                self.assertEqual(wide, [])

    def test_the_summary_speaks_words_not_formulas(self):
        for argv in self.CASES:
            with self.subTest(argv=[os.path.basename(path) for path in argv]):
                out = compared(*argv)
                for term in ("Benjamini-Hochberg", "q < alpha", "/ pace c2c^"):
                    self.assertNotIn(term, out)

    def test_a_table_too_wide_wraps_its_cells_within_their_columns(self):
        lines = table(["", "a", "b"], [["row", "x " * 60, "short"], ["next", "y", "z"]], width=50)
        self.assertLessEqual(max(len(line) for line in lines), 50)
        self.assertTrue(lines[2].startswith("row "))
        self.assertTrue(lines[3].startswith("    "))  # the wrapped cell's second line, under its column
        self.assertEqual(table(["a"], [["b"]]), ["a", "-", "b"])


class DebugBuilds(Scratch):
    """A Debug build's times are not its machine's: named first, out of every aggregate (and so of --fail-above's
    groups), never taken for the machine's move."""

    def release_copy(self) -> str:
        with open(AMD_DEBUG_QUICK, encoding="utf-8") as stream:
            document = json.load(stream)
        document["context"].update(build_type="Release", cxx_flags="-O3 -DNDEBUG")
        return self.write("release.json", document)

    def test_a_debug_build_against_a_release_build_of_one_machine(self):
        release = self.release_copy()
        out = compared(AMD_DEBUG_QUICK, release)
        self.assertNotIn("Each machine's answer", out)  # one machine: the summary of runs
        self.assertEqual(line_index(out, "Read first"), line_index(out, "- [A] quick-pairs.json is a Debug build") - 1)
        self.assertLess(line_index(out, "Read first"), line_index(out, "== B"))
        self.assertIn("withheld: A is a Debug build", logical_line(out, "geometric mean of B/A"))
        self.assertNotIn("by group", out)
        # the same bytes of times: the calibrations did not move, but the builds are named where they would have
        comparison = compare_pair(load_run_file(AMD_DEBUG_QUICK), load_run_file(release))
        self.assertTrue(comparison.withheld)
        self.assertEqual(comparison.aggregates(), [])
        self.assertIsNone(comparison.geometric_mean)
        self.assertEqual(comparison.failed_groups(0.0), [])

    def test_the_json_holds_no_aggregate_for_a_debug_build_and_says_why(self):
        target = os.path.join(self.directory.name, "c.json")
        self.assertEqual(run_tool("compare", XEON, AMD_DEBUG_QUICK, "--out", target)[0], 0)
        with open(target, encoding="utf-8") as stream:
            written = json.load(stream)["comparisons"][0]
        self.assertEqual(written["aggregates"], [])
        self.assertIsNone(written["geometric_mean"])
        self.assertIn("no aggregate verdict: quick-pairs.json is a Debug build: its times are the build's, not its "
                      "machine's", written["warnings"])

    def test_a_moved_calibration_between_builds_names_the_builds(self):
        with open(XEON, encoding="utf-8") as stream:
            document = json.load(stream)
        document["context"].update(build_type="RelWithDebInfo", cxx_flags="-O2 -g", serial_step_ns="30.10")
        other = self.write("relwithdebinfo.json", document)
        out = compared(XEON, other)
        line = logical_line(out, "calibrations moved")
        self.assertIn("the builds differ ([A] Release, GNU 12.2.0, -O3 -DNDEBUG; [B] RelWithDebInfo, GNU 12.2.0, -O2 "
                      "-g)", line)
        self.assertNotIn("the machine itself changed", line)
        self.assertIn("- the builds differ", out)  # first, among what makes the files incomparable
        self.assertNotIn("withheld", out)  # an optimised build's times are its machine's


class TheAnswersParts(Scratch):
    """What the answer shows of fields later lockstep revisions write: false sharing per access pattern
    (lockstep_headline.false_sharing_patterns) and the crossover (lockstep_crossover); silent without them."""

    # As lockstep run writes them (docs/schemas/run.schema.json), but for the words, which a file may leave out.
    WHERE = {"cpus": "0,1", "sharing_stride_bytes": 8, "apart_stride_bytes": 128, "pairs": 9}
    PATTERNS = [{"pattern": "relaxed load + store", "median": 0.93, "ci_low": 0.80, "ci_high": 1.05,
                 "verdict": "within noise", **WHERE},
                {"pattern": "fetch_add", "median": 4.6, "ci_low": 4.1, "ci_high": 4.8, "verdict": "penalty", **WHERE}]
    CROSSOVERS = {"crossovers": [{"threads": 2, "pin": "compact", "sync": "mailbox", "masses": 2048, "ci_low": 1500,
                                  "ci_high": 3000},
                                 {"threads": 2, "pin": "compact", "sync": "std_barrier", "masses": None}]}

    def with_parts(self, patterns=None, crossovers=None) -> str:
        with open(XEON, encoding="utf-8") as stream:
            document = json.load(stream)
        if patterns is not None:
            document["lockstep_headline"]["false_sharing_patterns"] = patterns
        if crossovers is not None:
            document["lockstep_crossover"] = crossovers
        return self.write("later.json", document)

    def test_patterns_and_crossovers_are_shown_where_a_file_has_them(self):
        out = compared(self.with_parts(self.PATTERNS, self.CROSSOVERS), AMD_DEBUG_QUICK)
        lines = out.splitlines()
        self.assertRegex(lines[line_index(out, "  relaxed load + store")], r"0\.930x \[0\.800, 1\.05\], no penalty +-$")
        self.assertRegex(lines[line_index(out, "  fetch_add")], r"4\.60x \[4\.10, 4\.80\] +-$")
        group = line_index(out, "2 threads, pin:compact")
        crossover = line_index(out, "  crossover")
        self.assertEqual(crossover, group + 3)  # the combination, its step, the baseline, then the crossover
        heading = lines[line_index(out, "Each machine's answer") + 1]
        column = slice(heading.index("[A]"), heading.index("[B]"))
        cell = " ".join(line[column].strip() for line in lines[crossover:line_index(out, "2 threads, pin:none")])
        self.assertEqual(cell, "mailbox from 2048 masses [1500, 3000]; std_barrier: none within the sweep")
        self.assertNotIn("crossover", compared(XEON, AMD_DEBUG_QUICK))  # absent from both: not a word

    def test_the_patterns_lockstep_run_writes_are_read_as_written(self):
        """The writer and the reader agree: lockstep run's own answer (answer_json in bench/run/answer.cpp,
        whose output tests/run/run_fixture_test.cpp pins as tests/fixtures/run/quick-pairs.headline.json) read
        through answer_reader gives each pattern's figures as the file holds them, named by the answer's words,
        and compare shows them."""
        with open(LOCKSTEP_HEADLINE, encoding="utf-8") as stream:
            written = json.load(stream)
        self.assertTrue(written["false_sharing_patterns"])
        answer = read_answer({"lockstep_headline": written})
        self.assertEqual([(p.name, p.median, p.ci_low, p.ci_high, p.verdict) for p in answer.patterns],
                         [(w["words"], w["median"], w["ci_low"], w["ci_high"], w["verdict"])
                          for w in written["false_sharing_patterns"]])
        out = compared(self.with_parts(written["false_sharing_patterns"]), AMD_DEBUG_QUICK)
        for pattern in answer.patterns:
            row = out.splitlines()[line_index(out, f"  {pattern.name}")]
            self.assertIn(f"{pattern.median:#.3g}x [{pattern.ci_low:#.3g}, {pattern.ci_high:#.3g}]", row)

    def test_a_refill_below_zero_is_read_as_written(self):
        """The migration probe's refill is a difference of two medians: when refilling added nothing measurable it
        is below 0, and the file is read, not refused (a run once wrote -338.5 ns)."""
        with open(XEON, encoding="utf-8") as stream:
            document = json.load(stream)
        document["lockstep_headline"]["migration_probe"] = {"cpus": "0,1", "bytes": 262144, "moves": 60,
                                                            "move_p50_ns": 10230.0, "refill_p50_ns": -338.5}
        path = self.write("refill.json", document)
        self.assertEqual(read_answer(document).migration.refill_ns, -338.5)
        compared(path, AMD_DEBUG_QUICK)

    def test_a_malformed_part_is_one_line_naming_its_place(self):
        bad = [(dict(self.PATTERNS[0], median="4x"), None, "lockstep_headline.false_sharing_patterns[0].median"),
               ([{"median": 2.0, "ci_low": 1.0, "ci_high": 3.0, "verdict": "penalty", **self.WHERE}], None,
                "lockstep_headline.false_sharing_patterns[0].pattern"),
               (None, {"crossovers": [{"threads": 0, "sync": "mailbox", "masses": 8}]},
                "lockstep_crossover.crossovers[0].threads"),
               (None, {"crossovers": {"threads": 2}}, "lockstep_crossover.crossovers")]
        for patterns, crossovers, place in bad:
            with self.subTest(place):
                path = self.with_parts([patterns] if isinstance(patterns, dict) else patterns, crossovers)
                status, out, err = run_tool("compare", path, AMD_DEBUG_QUICK)
                self.assertEqual((status, out), (2, ""), err)
                self.assertEqual(err.count("\n"), 1, err)
                self.assertIn(place, err)


if __name__ == "__main__":
    unittest.main()


class CrossoversSideBySide(Scratch):
    """Two files of one machine that both swept the crossover (lockstep run --crossover; the real files
    fixtures/crossover_a.json and crossover_b.json, test_report.Crossover says how they were made): compare sets
    their crossovers side by side as each file wrote them, after the comparison; a file without the sweep gets a
    "-" in its column, and nothing is shown unless two files have one."""

    A, B = fixture("crossover_a.json"), fixture("crossover_b.json")

    def written(self, path):
        with open(path, encoding="utf-8") as stream:
            return json.load(stream)["lockstep_crossover"]["crossovers"]

    def test_both_sides_crossovers_as_written(self):
        out = compared(self.A, self.B)
        lines = out.splitlines()
        title = line_index(out, "Crossovers (S* in masses [interval]")
        self.assertGreater(title, line_index(out, "== B (crossover_b.json) against A (crossover_a.json)"))
        heading = lines[title + 1]
        columns = (slice(heading.index("[A]"), heading.index("[B]")), slice(heading.index("[B]"), None))
        for a, b in zip(self.written(self.A), self.written(self.B)):
            self.assertEqual((a["threads"], a["pin"], a["sync"]), (b["threads"], b["pin"], b["sync"]))
            row = line_index(out, f"2 threads, pin:compact, {a['sync']}")
            end = next(index for index in range(row + 1, len(lines) + 1)
                       if index == len(lines) or not lines[index].startswith(" "))  # the row's wrapped lines
            cells = [" ".join(line[column].strip() for line in lines[row:end]).strip() for column in columns]
            for cell, series in zip(cells, (a, b)):
                if series["status"] == "crossed":
                    self.assertEqual(cell, f"from {series['masses']:.0f} masses [{series['ci_low']:.0f}, "
                                           f"{series['ci_high']:.0f}]")
                elif series["status"] == "always":
                    self.assertEqual(cell, f"at every size measured, from {series['masses']:.0f} masses")
        self.assertTrue(all(len(line) <= WIDTH for line in lines))

    def test_the_ceiling_as_its_run_quoted_it(self):
        """A file with the machine's ceiling (fixtures/crossover_ceiling.json) beside one written before it."""
        with_ceiling = fixture("crossover_ceiling.json")
        with open(with_ceiling, encoding="utf-8") as stream:
            document = json.load(stream)
        (ceiling,) = document["lockstep_crossover"]["ceilings"]
        point = next(p for p in ceiling["points"] if p["masses"] == ceiling["quoted_masses"])
        leader = next(c for c in document["lockstep_crossover"]["crossovers"] if c["leader"])
        share = next(p["of_ceiling"] for p in leader["points"] if p["masses"] == ceiling["quoted_masses"])
        out = compared(self.A, with_ceiling)
        lines = out.splitlines()
        row = line_index(out, "2 threads, pin:compact, the ceiling")
        heading = lines[line_index(out, "Crossovers (S* in masses [interval]") + 1]
        columns = (slice(heading.index("[A]"), heading.index("[B]")), slice(heading.index("[B]"), None))
        end = next(index for index in range(row + 1, len(lines) + 1)
                   if index == len(lines) or not lines[index].startswith(" "))
        cells = [" ".join(line[column].strip() for line in lines[row:end]).strip() for column in columns]
        self.assertEqual(cells[0], "-")  # written before the ceiling
        self.assertEqual(cells[1], f"{point['speedup']:.2f}x [{point['ci_low']:.2f}, {point['ci_high']:.2f}] at "
                                   f"{point['masses']} masses, {leader['sync']} {share:.2f} of it")
        # The run's own line says the same figures.
        line = next(text for text in document["lockstep_headline"]["crossover"] if text.startswith("Ceiling"))
        self.assertIn(f"give {point['speedup']:.2f}x [{point['ci_low']:.2f}, {point['ci_high']:.2f}]", line)
        self.assertIn(f"{share:.2f} of it", line)

    def test_a_file_without_the_sweep(self):
        self.assertNotIn("Crossovers (", compared(self.A, AMD_QUICK))  # only one file swept
        with open(self.B, encoding="utf-8") as stream:
            document = json.load(stream)
        document["lockstep_crossover"]["crossovers"][0]["sync"] = "ck_centralized"
        for point in document["lockstep_crossover"]["crossovers"][0]["points"]:
            point.update(pairs=0, failure="every pair set aside: another process took a CPU")
        document["lockstep_crossover"]["crossovers"][0].update(masses=None, ci_low=None, ci_high=None,
                                                               status="none_within_sweep")
        out = compared(self.A, self.write("other.json", document))
        self.assertRegex(out.splitlines()[line_index(out, "2 threads, pin:compact, ck_centralized")],
                         r"^2 threads, pin:compact, ck_centralized +- +nothing measured$")
        mailbox = next(series for series in self.written(self.A) if series["sync"] == "mailbox")
        self.assertRegex(out.splitlines()[line_index(out, "2 threads, pin:compact, mailbox")],
                         rf"from {mailbox['masses']:.0f} masses \[{mailbox['ci_low']:.0f}, "
                         rf"{mailbox['ci_high']:.0f}\] +-$")
