"""`lockstep compare` on the fixtures: matching, statistics, listings, machines, exit status."""
import json
import os
import tempfile
import unittest

from support import fixture, run_tool

from lockstep_reports import statistics
from lockstep_reports.compare import compare_pair, layout_effects, normalised, rank_tables
from lockstep_reports.inputs import load_run_file
from lockstep_reports.names import parse_name

FORCED = "rk4/sync:futex_spin/layout:packed/pin:compact/threads:4"


def load(name):
    return load_run_file(fixture(name))


class Statistics(unittest.TestCase):
    def test_holm_adjusts_step_down_and_keeps_order(self):
        adjusted = statistics.holm([0.01, None, 0.04, 0.03])
        self.assertAlmostEqual(adjusted[0], 0.03)
        self.assertIsNone(adjusted[1])
        self.assertAlmostEqual(adjusted[3], 0.06)
        self.assertAlmostEqual(adjusted[2], 0.06)

    def test_bootstrap_interval_is_deterministic_and_contains_the_ratio(self):
        a = [100, 102, 98, 101, 99, 103, 97, 100]
        b = [150, 149, 152, 151, 148, 150, 153, 147]
        first = statistics.ratio_interval(a, b, "x")
        self.assertEqual(first, statistics.ratio_interval(a, b, "x"))
        self.assertLess(first[0], 1.5)
        self.assertGreater(first[1], 1.5)

    def test_mann_whitney_needs_enough_repetitions(self):
        self.assertIsNone(statistics.mann_whitney_p([1, 2, 3], [4, 5, 6]))
        self.assertLess(statistics.mann_whitney_p([1, 2, 3, 4, 5], [6, 7, 8, 9, 10]), 0.01)

    def test_geometric_mean(self):
        self.assertAlmostEqual(statistics.geometric_mean([2.0, 0.5, None]), 1.0)


class SameMachine(unittest.TestCase):
    def test_the_forced_loser_is_significant_and_nothing_else_is(self):
        comparison = compare_pair(load("machine_a.json"), load("machine_a_rerun.json"))
        significant = [row.key.display for row in comparison.rows if row.significant(comparison.alpha)]
        self.assertEqual(significant, [FORCED])
        row = next(row for row in comparison.rows if row.key.display == FORCED)
        self.assertEqual(row.verdict(comparison.alpha), "slower")
        self.assertGreater(row.interval[0], 1.3)  # 1.4x forced
        self.assertLess(row.interval[1], 1.5)
        self.assertIn("futex_waits_per_step", row.counters)

    def test_a_counter_the_primitive_cannot_count_is_unavailable_not_zero(self):
        comparison = compare_pair(load("machine_a.json"), load("machine_a_rerun.json"))
        hidden = next(row for row in comparison.rows
                      if row.key.display == "rk4/sync:std_barrier/layout:packed/pin:compact/threads:2")
        self.assertNotIn("futex_waits_per_step", hidden.counters)
        self.assertIn("csw_vol_per_kstep", hidden.counters)
        status, out, _ = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"))
        self.assertEqual(status, 0)
        line = next(line for line in out.splitlines()
                    if line.startswith("rk4/sync:std_barrier/layout:packed/pin:compact/threads:2 "))
        self.assertRegex(line, r"0\.00 -> 0\.00 +unavailable +0\.00 -> 0\.00$")  # migr, futex, timeouts

    def test_geometric_mean_counts_matched_pairs_only(self):
        comparison = compare_pair(load("machine_a.json"), load("entry_sets_differ.json"))
        self.assertEqual(len(comparison.rows), 2 + 2 * 12)  # serial, c2c, and the two shared primitives
        expected = statistics.geometric_mean([row.ratio for row in comparison.rows])
        self.assertEqual(comparison.geometric_mean, expected)

    def test_added_and_removed_are_listed(self):
        comparison = compare_pair(load("machine_a.json"), load("entry_sets_differ.json"))
        self.assertEqual(len(comparison.added), 12)
        self.assertEqual(len(comparison.removed), 12)
        self.assertTrue(all(key.get("sync") == "ck_centralized" for key in comparison.added))
        self.assertTrue(all(key.get("sync") == "seqlock" for key in comparison.removed))
        status, out, _ = run_tool("compare", fixture("machine_a.json"), fixture("entry_sets_differ.json"))
        self.assertEqual(status, 0)
        self.assertIn("added: 12", out)
        self.assertIn("removed: 12", out)
        self.assertIn("rk4/sync:ck_centralized/layout:packed/pin:compact/threads:2", out)

    def test_errored_entries_are_listed_not_compared_nor_zero(self):
        comparison = compare_pair(load("machine_a.json"), load("errored.json"))
        errored = {key.display: message for key, _, message in comparison.errored}
        self.assertIn("rk4/sync:futex_spin/layout:packed/pin:migrate/threads:4", errored)
        self.assertIn("rk4/sync:seqlock/layout:per_thread/pin:migrate/threads:2", errored)
        compared = {row.key.display for row in comparison.rows}
        self.assertNotIn("rk4/sync:futex_spin/layout:packed/pin:migrate/threads:4", compared)
        self.assertTrue(all(row.median_b > 0 for row in comparison.rows))
        status, out, _ = run_tool("compare", fixture("machine_a.json"), fixture("errored.json"))
        self.assertIn("errored (not compared): 2", out)
        self.assertIn("watchdog expired", out)

    def test_later_schema_matches_the_older_file(self):
        comparison = compare_pair(load("machine_a.json"), load("later_schema.json"))
        self.assertEqual(len(comparison.rows), 38)
        self.assertEqual(comparison.added, [])
        self.assertEqual(comparison.removed, [])

    def test_few_repetitions_are_not_tested_and_say_so(self):
        comparison = compare_pair(load("machine_a.json"), load("few_repetitions.json"))
        self.assertTrue(all(row.p_adjusted is None for row in comparison.rows))
        self.assertTrue(all(row.verdict(0.05) == "untested" for row in comparison.rows))
        self.assertTrue(any("fewer than 5 repetitions" in warning for warning in comparison.warnings))
        status, _, _ = run_tool("compare", fixture("machine_a.json"), fixture("few_repetitions.json"),
                                "--fail-above", "0")
        self.assertEqual(status, 0)


class FailAbove(unittest.TestCase):
    def test_significant_regression_beyond_the_limit_is_exit_1(self):
        status, _, err = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"),
                                  "--fail-above", "10")
        self.assertEqual(status, 1)
        self.assertIn(FORCED, err)

    def test_regression_below_the_limit_is_exit_0(self):
        status, _, _ = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"),
                                "--fail-above", "50")
        self.assertEqual(status, 0)

    def test_no_limit_is_exit_0(self):
        status, _, _ = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"))
        self.assertEqual(status, 0)

    def test_bad_options_are_one_line_and_exit_2(self):
        for argv in (["compare", fixture("machine_a.json")],
                     ["compare", fixture("machine_a.json"), fixture("machine_b.json"), "--fail-above", "x"],
                     ["compare", fixture("machine_a.json"), fixture("machine_b.json"), "--bogus"]):
            status, out, err = run_tool(*argv)
            self.assertEqual(status, 2, argv)
            self.assertEqual(err.count("\n"), 1, err)


class AcrossMachines(unittest.TestCase):
    def test_fingerprints_are_shown_and_differences_marked(self):
        status, out, _ = run_tool("compare", fixture("machine_a.json"), fixture("machine_b.json"))
        self.assertEqual(status, 0)
        self.assertIn("cpu_model*", out)
        self.assertIn("AMD EPYC 7232P", out)
        self.assertIn("machines: 2 distinct", out)
        self.assertIn("Holm", out)

    def test_normalisation_uses_each_machines_own_calibration(self):
        a, b = load("machine_a.json"), load("machine_b.json")
        key = parse_name("rk4/sync:seqlock/layout:padded128/pin:compact/threads:2")
        vs_serial_a, vs_c2c_a = normalised(a, key)
        vs_serial_b, _ = normalised(b, key)
        median_a = statistics.median(a.runs[key].times_ns())
        self.assertAlmostEqual(vs_serial_a, median_a / 182.0)
        sync_a = statistics.median(a.runs[key].counter_values("sync_ns_per_stage"))
        self.assertAlmostEqual(vs_c2c_a, sync_a / 61.5)
        median_b = statistics.median(b.runs[key].times_ns())
        self.assertAlmostEqual(vs_serial_b, median_b / 121.0)

    def test_in_run_entries_stand_in_for_missing_context_calibrations(self):
        from lockstep_reports.compare import calibration
        run_file = load("machine_a.json")
        del run_file.context["serial_step_ns"]
        run_file.context["c2c_one_way_ns"] = "unavailable"
        serial = statistics.median(run_file.runs[parse_name("rk4/serial")].times_ns())
        c2c = statistics.median(run_file.runs[parse_name("c2c/pin:compact/threads:2")].times_ns())
        self.assertEqual(calibration(run_file, "serial_step_ns"), serial)
        self.assertEqual(calibration(run_file, "c2c_one_way_ns"), c2c)

    def test_layout_effect_read_side_by_side(self):
        rows = layout_effects([load("machine_a.json"), load("machine_b.json")])
        row = next(r for r in rows if r[:4] == ("futex_spin", "compact", "4", "padded128"))
        speedup_a, speedup_b = row[4]
        self.assertGreater(speedup_a, 1.4)  # the VM suffers more from false sharing
        self.assertLess(speedup_b, 1.3)

    def test_rank_table_per_machine(self):
        tables = rank_tables([load("machine_a.json"), load("machine_b.json")])
        self.assertIn(("compact", 4), tables)
        first_a = tables[("compact", 4)][0][0][0]
        first_b = tables[("compact", 4)][1][0][0]
        self.assertEqual(first_a, "seqlock/padded128")
        self.assertEqual(first_b, "seqlock/padded128")


class Output(unittest.TestCase):
    def test_same_input_same_output_and_json(self):
        with tempfile.TemporaryDirectory() as directory:
            path = os.path.join(directory, "c.json")
            first = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"), "--json", path)
            with open(path, encoding="utf-8") as stream:
                document = json.load(stream)
            second = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"))
        self.assertEqual(first[1], second[1])
        self.assertEqual(document["comparisons"][0]["correction"], "holm")
        self.assertEqual(document["comparisons"][0]["matched"], 38)

    def test_three_files_compare_each_with_the_first(self):
        status, out, _ = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"),
                                  fixture("machine_b.json"))
        self.assertEqual(status, 0)
        self.assertIn("== B (machine_a_rerun.json) against A (machine_a.json)", out)
        self.assertIn("== C (machine_b.json) against A (machine_a.json)", out)


if __name__ == "__main__":
    unittest.main()
