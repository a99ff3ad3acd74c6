"""`lockstep compare` on the fixtures: matching, statistics, listings, machines, exit status."""
import json
import math
import os
import re
import shutil
import subprocess
import tempfile
import unittest

import synthetic_runs
from support import HEADLINE, REPORTS_DIR, Scratch, fixture, headline_document, logical_line, run_tool

from lockstep_reports.analysis.normalisation import layout_effects, normalised, rank_tables
from lockstep_reports.common import statistics
from lockstep_reports.common.names import parse_name
from lockstep_reports.compare import compare_text, pace_statistics
from lockstep_reports.compare.compare import compare_pair
from lockstep_reports.compare.comparison import PaceAware, verdict_of
from lockstep_reports.main import compare_parser, report_parser
from lockstep_reports.read.inputs import load_run_file

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

    def test_benjamini_hochberg_q_values(self):
        adjusted = statistics.benjamini_hochberg([0.01, None, 0.04, 0.03])
        self.assertAlmostEqual(adjusted[0], 0.03)  # 3 * 0.01 / 1
        self.assertIsNone(adjusted[1])
        self.assertAlmostEqual(adjusted[2], 0.04)  # 3 * 0.04 / 3
        self.assertAlmostEqual(adjusted[3], 0.04)  # min(3 * 0.03 / 2, 0.04): monotone
        # 5 against 5 completely apart: p 0.008 each. Over 236 tests Holm gives 1; BH with 40 of them apart
        # gives 0.008 * 236 / 40 = 0.047.
        q = statistics.benjamini_hochberg([2 / 252] * 40 + [0.5] * 196)
        self.assertLess(q[0], 0.05)

    def test_the_exact_shift_interval(self):
        a = [100.0, 101.0, 99.0, 102.0, 98.0]
        b = [value * 2.0 for value in a]
        low, high = statistics.shift_interval(a, b)
        self.assertLess(low, 2.0)
        self.assertGreater(high, 2.0)
        # 5 against 5: the 3rd smallest to the 3rd largest of the 25 ratios b_j / a_i.
        ratios = sorted(y / x for x in a for y in b)
        self.assertAlmostEqual(low, ratios[2])
        self.assertAlmostEqual(high, ratios[22])
        self.assertEqual(statistics.shift_interval(a, b), statistics.shift_interval(a[::-1], b))  # order-free
        self.assertIsNone(statistics.shift_interval([1.0, 2.0, 3.0], [1.0, 2.0, 3.0]))  # 3 a side: no 95 %
        self.assertIsNotNone(statistics.shift_interval([1.0, 2.0, 3.0, 4.0], [1.0, 2.0, 3.0, 4.0]))

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
        self.assertEqual(comparison.verdict(row), "slower")
        self.assertGreater(row.interval[0], 1.3)  # 1.4x forced
        self.assertLess(row.interval[1], 1.5)
        self.assertIn("futex_waits_per_step", row.counters)

    def test_a_counter_the_primitive_cannot_count_is_unavailable_not_zero(self):
        comparison = compare_pair(load("machine_a.json"), load("machine_a_rerun.json"))
        hidden = next(row for row in comparison.rows
                      if row.key.display == "rk4/sync:std_barrier/layout:packed/pin:compact/threads:2")
        self.assertNotIn("futex_waits_per_step", hidden.counters)
        self.assertIn("csw_vol_per_kstep", hidden.counters)
        status, out, _ = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"), "--all")
        self.assertEqual(status, 0)
        line = next(line for line in out.splitlines()
                    if line.startswith("rk4/sync:std_barrier/layout:packed/pin:compact/threads:2 "))
        self.assertRegex(line, r"0\.00 -> 0\.00 +unavailable +0\.00 -> 0\.00$")  # migr, futex, timeouts

    def test_geometric_mean_counts_matched_pairs_only(self):
        comparison = compare_pair(load("machine_a.json"), load("entry_sets_differ.json"))
        self.assertEqual(len(comparison.rows), 2 * 12)  # the two shared primitives; serial and c2c apart
        self.assertEqual([row.key.display for row in comparison.calibrations],
                         ["c2c/pin:compact/threads:2", "rk4/serial"])
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

    def test_cpu_time_of_files_before_schema_2_is_flagged(self):
        # lockstep schema 1: a team entry's cpu_time was Google Benchmark's thread replaying the batch times.
        warning = "predate lockstep schema 2"
        cpu = compare_pair(load("machine_a.json"), load("machine_a_rerun.json"), "cpu")
        self.assertTrue(any(warning in line and "machine_a.json and machine_a_rerun.json" in line
                            for line in cpu.warnings), cpu.warnings)
        real = compare_pair(load("machine_a.json"), load("machine_a_rerun.json"), "real")
        self.assertFalse(any(warning in line for line in real.warnings), real.warnings)

    def test_later_schema_matches_the_older_file(self):
        comparison = compare_pair(load("machine_a.json"), load("later_schema.json"))
        self.assertEqual(len(comparison.rows), 36)
        self.assertEqual(len(comparison.calibrations), 2)
        self.assertEqual(comparison.added, [])
        self.assertEqual(comparison.removed, [])

    def test_few_repetitions_are_not_tested_and_say_so(self):
        # 3 against 3: no 95 % interval exists (the widest, min to max ratio, covers 1 - 2/20 = 90 %).
        comparison = compare_pair(load("few_repetitions.json"), load("few_repetitions.json"))
        self.assertTrue(all(row.p_adjusted is None for row in comparison.rows))
        self.assertTrue(all(comparison.verdict(row) == "untested" for row in comparison.rows))
        self.assertTrue(any("too few repetitions for a 95 % interval" in warning for warning in comparison.warnings))
        # 10 against 3: the exact interval exists (P(U = 0) = 1/286), the Mann-Whitney test does not.
        comparison = compare_pair(load("machine_a.json"), load("few_repetitions.json"))
        self.assertTrue(all(row.p_adjusted is None for row in comparison.rows))
        self.assertTrue(all(row.interval is not None for row in comparison.rows))
        status, _, _ = run_tool("compare", fixture("few_repetitions.json"), fixture("few_repetitions.json"),
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
    def test_the_machines_and_their_differences_come_first(self):
        status, out, _ = run_tool("compare", fixture("machine_a.json"), fixture("machine_b.json"))
        self.assertEqual(status, 0)
        self.assertIn("machines: 2 distinct", out)
        lines = out.splitlines()
        answers, differs, comparison = (next(index for index, line in enumerate(lines) if line.startswith(start))
                                        for start in ("Each machine's answer", "What differs between the machines",
                                                      "== B"))
        self.assertLess(answers, differs)
        self.assertLess(differs, comparison)
        self.assertIn("AMD EPYC 7232P", "\n".join(lines[answers:differs]))
        for key in ("topology", "hypervisor", "kernel", "num_cpus"):  # these machines differ in each
            self.assertIn(key, "\n".join(lines[differs:comparison]))
        self.assertNotIn("Benjamini-Hochberg", out)  # terms a person reads: the q-values are --all's
        self.assertIn("cpu_model*", run_tool("compare", fixture("machine_a.json"), fixture("machine_b.json"),
                                             "--all")[1])

    def test_normalisation_uses_each_machines_own_calibration(self):
        # The entry's own vs_serial / vs_c2c counters, as lockstep run derived them against its machine's in-run
        # calibrations (the fixtures write them to 6 significant digits).
        a, b = load("machine_a.json"), load("machine_b.json")
        key = parse_name("rk4/sync:seqlock/layout:padded128/pin:compact/threads:2")
        vs_serial_a, vs_c2c_a = normalised(a, key)
        vs_serial_b, _ = normalised(b, key)
        self.assertEqual(vs_serial_a, statistics.median(a.runs[key].counter_values("vs_serial")))
        self.assertEqual(vs_c2c_a, statistics.median(a.runs[key].counter_values("vs_c2c")))
        median_a = statistics.median(a.runs[key].times_ns())
        self.assertAlmostEqual(vs_serial_a, median_a / 182.0, places=4)
        sync_a = statistics.median(a.runs[key].counter_values("sync_ns_per_stage"))
        self.assertAlmostEqual(vs_c2c_a, sync_a / 61.5, places=4)
        median_b = statistics.median(b.runs[key].times_ns())
        self.assertAlmostEqual(vs_serial_b, median_b / 121.0, places=4)

    def test_normalisation_without_the_counters_divides_by_the_calibrations(self):
        # A file without vs_serial / vs_c2c (written before lockstep run derived them): the same division here.
        run_file = load("machine_a.json")
        key = parse_name("rk4/sync:seqlock/layout:padded128/pin:compact/threads:2")
        for repetition in run_file.runs[key].repetitions:
            repetition.counters.pop("vs_serial", None)
            repetition.counters.pop("vs_c2c", None)
        for aggregate in run_file.runs[key].aggregates.values():
            aggregate.counters.pop("vs_serial", None)
            aggregate.counters.pop("vs_c2c", None)
        vs_serial, vs_c2c = normalised(run_file, key)
        self.assertAlmostEqual(vs_serial, statistics.median(run_file.runs[key].times_ns()) / 182.0)
        sync = statistics.median(run_file.runs[key].counter_values("sync_ns_per_stage"))
        self.assertAlmostEqual(vs_c2c, sync / 61.5)

    def test_in_run_entries_stand_in_for_missing_context_calibrations(self):
        from lockstep_reports.analysis.run_analysis import calibration
        run_file = load("machine_a.json")
        del run_file.context["serial_step_ns"]
        run_file.context["c2c_one_way_ns"] = "unavailable"
        serial = statistics.median(run_file.runs[parse_name("rk4/serial")].times_ns())
        c2c = statistics.median(run_file.runs[parse_name("c2c/pin:compact/threads:2")].counter_values("one_way_ns"))
        self.assertEqual(calibration(run_file, "serial_step_ns"), serial)
        self.assertEqual(calibration(run_file, "c2c_one_way_ns"), c2c)

    def test_layout_effect_read_side_by_side(self):
        rows = layout_effects([load("machine_a.json"), load("machine_b.json")], "packed")
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
        self.assertEqual(document["comparisons"][0]["correction"], "benjamini-hochberg")
        self.assertEqual(document["comparisons"][0]["matched"], 36)
        self.assertEqual(document["comparisons"][0]["noise_pct"], 5.0)
        self.assertEqual(len(document["comparisons"][0]["calibrations"]), 2)

    def test_three_files_compare_each_with_the_first(self):
        status, out, _ = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"),
                                  fixture("machine_b.json"))
        self.assertEqual(status, 0)
        self.assertIn("== B (machine_a_rerun.json) against A (machine_a.json)", out)
        self.assertIn("== C (machine_b.json) against A (machine_a.json)", out)


# ---------------------------------------------------------------- noise threshold and calibrations
# Derived files, written per test: a few entries with deterministic repetitions (12 a side, so that
# complete separation gives a tiny p even after Holm's correction), the context's calibrations as given.

SHIFTED = "rk4/sync:futex_spin/layout:padded64/pin:compact/threads:2"
STEADY = "rk4/sync:seqlock/layout:per_thread/pin:compact/threads:2"
BARRIER = "barrier/sync:std_barrier/pin:compact/threads:2"
OVERHEAD = "overhead/sync:futex_spin/layout:padded64/pin:compact/threads:2/accounting:{}"
C2C = "c2c/pin:compact/threads:2"
WIGGLE = [0.000, 0.004, -0.003, 0.002, -0.001, 0.003, -0.004, 0.001, -0.002, 0.0035, -0.0025, 0.0015]


def entries(name, median_ns, counters=None, time_ns=None):
    """Google Benchmark 1.7 iteration entries of one benchmark: 12 repetitions within +-0.4 % of the median."""
    result = []
    for index, wiggle in enumerate(WIGGLE):
        value = median_ns * (1.0 + wiggle)
        entry = {"name": name, "run_name": name, "run_type": "iteration", "repetitions": len(WIGGLE),
                 "repetition_index": index, "threads": 1, "iterations": 1000,
                 "real_time": time_ns * (1.0 + wiggle) if time_ns else value, "cpu_time": value, "time_unit": "ns"}
        if name.startswith("rk4/") or name.startswith("overhead/"):
            entry["ns_per_step"] = value
        for counter, counter_value in (counters or {}).items():
            entry[counter] = counter_value * (1.0 + wiggle)
        result.append(entry)
    return result


def run_document(c2c_context, serial_context, shifted, c2c_counter=25.0, c2c_time=1.5e6, barrier=200e3):
    benchmarks = (entries("rk4/serial", 20.0) + entries(C2C, c2c_counter, {"one_way_ns": c2c_counter}, c2c_time)
                  + entries(OVERHEAD.format("off"), 500.0) + entries(OVERHEAD.format("on"), 530.0)
                  + entries(SHIFTED, shifted) + entries(STEADY, 290.0) + entries(BARRIER, barrier))
    context = {"lockstep_schema": "1", "cpu_model": "AMD EPYC", "topology": "packages=1 l3=1 cores=2 pus=2",
               "hypervisor": "kvm", "kernel": "6.1", "num_cpus": 2}
    if c2c_context is not None:
        context["c2c_one_way_ns"] = c2c_context
    if serial_context is not None:
        context["serial_step_ns"] = serial_context
    return {"context": context, "benchmarks": benchmarks}


class ScratchFiles(unittest.TestCase):
    """A test case with a scratch directory to write JSON documents into."""

    def setUp(self):
        self.directory = tempfile.TemporaryDirectory()
        self.addCleanup(self.directory.cleanup)

    def write(self, name, document):
        path = os.path.join(self.directory.name, name)
        with open(path, "w", encoding="utf-8") as stream:
            json.dump(document, stream)
        return path


class NoiseThreshold(ScratchFiles):
    def pair(self, shifted_b, c2c_b="25.0", serial_b="20.00", **contender):
        a = self.write("a.json", run_document("25.0", "20.00", 560.0))
        b = self.write("b.json", run_document(c2c_b, serial_b, shifted_b, **contender))
        return a, b

    def row(self, comparison, name):
        return next(row for row in comparison.rows + comparison.calibrations if row.key.display == name)

    def test_a_shift_inside_the_threshold_with_tiny_p_is_within_noise(self):
        a, b = self.pair(560.0 * 1.03)  # +3 %, completely separated: tiny p
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        row = self.row(comparison, SHIFTED)
        self.assertTrue(row.significant(comparison.alpha))
        self.assertLess(row.p_adjusted, 0.001)
        self.assertEqual(comparison.verdict(row), "within noise")
        self.assertEqual(comparison.verdict(self.row(comparison, STEADY)), "within noise")
        self.assertEqual(comparison.verdict_counts(),
                         {"slower": 0, "faster": 0, "unsure": 0, "within noise": 3, "untested": 0, "collapsed": 0})
        status, out, err = run_tool("compare", a, b, "--fail-above", "1", "--all")
        self.assertEqual(status, 0, err)  # within noise never fails the gate
        self.assertIn("0 slower, 0 faster, 0 unsure, 3 within noise", out)
        self.assertIn("noise threshold: 5 % (the default", out)

    def test_a_lower_threshold_makes_the_same_shift_slower(self):
        a, b = self.pair(560.0 * 1.03)
        comparison = compare_pair(load_run_file(a), load_run_file(b), noise_percent=1.0)
        self.assertEqual(comparison.verdict(self.row(comparison, SHIFTED)), "slower")
        status, out, err = run_tool("compare", a, b, "--noise", "1", "--fail-above", "1", "--all")
        self.assertEqual(status, 1)
        self.assertIn(SHIFTED, err)
        self.assertIn("1 slower, 0 faster, 0 unsure, 2 within noise", out)
        self.assertIn("noise threshold: 1 %", out)

    def test_a_barrier_entry_is_compared_per_episode_not_per_batch(self):
        # Each run sizes its batches by its own probe: the same 70 ns episode in batches of
        # 3000 (210 us per iteration) in A and of 2000 (140 us) in B is no change.
        episode = {"ns_per_episode": 70.0}
        b_document = run_document("25.0", "20.00", 560.0)
        a_document = run_document("25.0", "20.00", 560.0)
        for document, batch in ((a_document, 3000), (b_document, 2000)):
            document["benchmarks"] = [entry for entry in document["benchmarks"] if entry["name"] != BARRIER]
            document["benchmarks"] += entries(BARRIER, 70.0 * batch, episode)
        a = self.write("a.json", a_document)
        b = self.write("b.json", b_document)
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        row = self.row(comparison, BARRIER)
        self.assertEqual(comparison.verdict(row), "within noise")
        self.assertAlmostEqual(row.ratio, 1.0, places=6)

    def test_a_big_shift_is_slower_and_fails_the_gate(self):
        a, b = self.pair(560.0 * 1.40)
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        row = self.row(comparison, SHIFTED)
        self.assertEqual(comparison.verdict(row), "slower")
        self.assertGreater(row.interval[0], 1.05)
        self.assertEqual([r.key.display for r in comparison.regressions_beyond(10)], [SHIFTED])
        status, _, err = run_tool("compare", a, b, "--fail-above", "10")
        self.assertEqual(status, 1)
        self.assertEqual(err.count("\n"), 1, err)
        self.assertIn(SHIFTED, err)

    def test_a_big_speed_up_is_faster(self):
        a, b = self.pair(560.0 / 1.40)
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        self.assertEqual(comparison.verdict(self.row(comparison, SHIFTED)), "faster")
        self.assertEqual(run_tool("compare", a, b, "--fail-above", "0")[0], 0)

    def test_bad_noise_values_are_one_line_and_exit_2(self):
        a, b = self.pair(560.0)
        for value in ("-1", "abc", "nan", "inf", "", "5%%"):
            status, out, err = run_tool("compare", a, b, "--noise", value)
            self.assertEqual(status, 2, value)
            self.assertEqual(out, "", value)
            self.assertEqual(err.count("\n"), 1, err)
            self.assertIn("--noise", err)
        self.assertEqual(run_tool("compare", a, b, "--noise")[0], 2)
        for value in ("0", "2.5", "5%"):
            self.assertEqual(run_tool("compare", a, b, "--noise", value)[0], 0, value)

    def test_the_calibration_line_says_how_far_the_machine_moved(self):
        a, b = self.pair(560.0, c2c_b="27.0", serial_b="20.10")
        status, out, _ = run_tool("compare", a, b)
        self.assertEqual(status, 0)
        line = logical_line(out, "calibrations moved")
        self.assertIn("c2c one-way 25.0 -> 27.0 ns (+8.0 %)", line)
        self.assertIn("serial step 20.00 -> 20.10 ns (+0.5 %)", line)
        self.assertIn("c2c one-way moved beyond the ±5 % noise threshold", line)
        self.assertIn("not rescaled", line)
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        self.assertEqual(self.row(comparison, SHIFTED).ratio, 1.0)  # the times are not rescaled by it

    def test_a_calibration_line_inside_the_threshold_says_so(self):
        a, b = self.pair(560.0, c2c_b="25.5", serial_b="19.90")
        _, out, _ = run_tool("compare", a, b)
        line = logical_line(out, "calibrations moved")
        self.assertIn("(+2.0 %)", line)
        self.assertIn("(-0.5 %)", line)
        self.assertIn("inside the ±5 % noise threshold", line)

    def test_missing_context_calibrations_come_from_the_entries_or_are_unavailable(self):
        a = self.write("a.json", run_document(None, None, 560.0))
        b = self.write("b.json", run_document("unavailable", None, 560.0, c2c_counter=26.0))
        _, out, _ = run_tool("compare", a, b)
        line = logical_line(out, "calibrations moved")
        self.assertIn("c2c one-way 25.0 -> 26.0 ns (+4.0 %)", line)  # one_way_ns counters, not iteration times
        self.assertRegex(line, r"serial step 20\.0\d -> 20\.0\d ns \(\+0\.0 %\)")
        without_c2c = run_document(None, "20.00", 560.0)
        without_c2c["benchmarks"] = [e for e in without_c2c["benchmarks"] if not e["name"].startswith("c2c/")]
        c = self.write("c.json", without_c2c)
        status, out, _ = run_tool("compare", a, c)
        self.assertEqual(status, 0)
        line = logical_line(out, "calibrations moved")
        self.assertIn("c2c one-way unavailable", line)

    def test_c2c_is_compared_by_its_one_way_counter_and_kept_apart(self):
        # The c2c iteration time (thread start-up) doubles; its one-way latency does not move.
        a, b = self.pair(560.0, c2c_time=3.0e6)
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        self.assertNotIn(C2C, [row.key.display for row in comparison.rows])
        row = self.row(comparison, C2C)
        self.assertEqual(row.measure, "one_way_ns")
        self.assertAlmostEqual(row.ratio, 1.0)
        self.assertEqual(comparison.verdict(row), "within noise")
        self.assertEqual(sorted(r.key.display for r in comparison.calibrations),
                         sorted([C2C, "rk4/serial", OVERHEAD.format("off"), OVERHEAD.format("on")]))
        self.assertEqual(len(comparison.rows), 3)
        self.assertEqual(comparison.geometric_mean, statistics.geometric_mean([r.ratio for r in comparison.rows]))
        (base, overhead_a, overhead_b), = comparison.accounting_overheads()
        self.assertAlmostEqual(overhead_a, 1.06)
        self.assertAlmostEqual(overhead_b, 1.06)
        _, out, _ = run_tool("compare", a, b, "--all")
        self.assertIn("calibrations (4): the machine and the instrumentation", out)
        self.assertIn("geometric mean of B/A over the 3 matched pairs", out)
        self.assertIn("accounting overhead of " + base.display, out)

    def test_back_to_back_repetitions_are_warned_about(self):
        first = run_document("25.0", "20.00", 560.0)
        first["context"]["lockstep_order"] = "registration order: every entry's repetitions back to back"
        second = run_document("25.0", "20.00", 560.0)
        second["context"]["lockstep_order"] = "random interleaving: the repetitions of every entry shuffled"
        a, b = self.write("a.json", first), self.write("b.json", second)
        _, out, _ = run_tool("compare", a, b)
        warning = logical_line(out, "warning: a.json measured every entry's repetitions back to back")
        self.assertIn("a.json measured", warning)
        self.assertNotIn("b.json", warning)
        self.assertIn("--no-interleave", warning)
        self.assertIn("lockstep_order*", out)
        _, out, _ = run_tool("compare", b, b)
        self.assertNotIn("back to back (context lockstep_order)", out)

    def test_a_moved_calibration_never_fails_the_gate(self):
        a, b = self.pair(560.0, c2c_counter=40.0)
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        self.assertEqual(comparison.verdict(self.row(comparison, C2C)), "slower")
        self.assertEqual(run_tool("compare", a, b, "--fail-above", "0")[0], 0)


# ---------------------------------------------------------------- power, pace, old files

def swapped_names(document, first="sync:std_barrier", second="sync:futex_spin"):
    """document with the entries of two primitives exchanging names: the same repetitions, the same context,
    a known difference with nothing else changed."""
    swapped = json.loads(json.dumps(document))
    for entry in swapped["benchmarks"]:
        for key in ("name", "run_name"):
            if key in entry:
                entry[key] = entry[key].replace(first, "\0").replace(second, first).replace("\0", second)
    return swapped


def paced_document(scale=1.0, c2c=25.0):
    """run_document's entries, every repetition in the one pace mode of a trace whose c2c is `c2c`, every
    time multiplied by `scale`."""
    document = run_document("25.0", "20.00", 560.0)
    for entry in document["benchmarks"]:
        for key in ("real_time", "cpu_time", "ns_per_step", "one_way_ns"):
            if key in entry:
                entry[key] *= scale
        entry.update(pace_c2c_ns=c2c, pace_serial_ns=20.0, pace_mode=0)
    document["lockstep_pace"] = {
        "reference": "one-way c2c between CPUs 0 and 1; the serial RK4 step", "cpus": [0, 1],
        "readings": [{"t_s": 0.1 * index, "c2c_ns": c2c, "serial_ns": 20.0, "mode": 0} for index in range(10)],
        "modes": [{"mode": 0, "c2c_ns": c2c, "serial_ns": 20.0, "share": 1.0, "readings": 10}],
        "changes": 0, "summary": f"c2c {c2c:.0f} ns for 100 % of the run; 0 changes"}
    return document


class PowerAndPace(ScratchFiles):
    def test_a_known_difference_is_seen_a_b_power(self):
        # A default run of this VM (5 repetitions an entry, 236 combinations), against itself with the
        # entries of std_barrier and futex_spin exchanging names: at the default settings compare calls
        # slower or faster at least 90 % of the entries whose medians differ by 2x or more (Holm over 236
        # tests called none).
        with open(REPORTS_DIR / "samples" / "run.json", encoding="utf-8") as stream:
            document = json.load(stream)
        a = self.write("run.json", document)
        b = self.write("swapped.json", swapped_names(document))
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        far_apart = [row for row in comparison.rows if max(row.ratio, 1.0 / row.ratio) >= 2.0]
        self.assertGreaterEqual(len(far_apart), 10)
        called = [row for row in far_apart if comparison.verdict(row) in ("slower", "faster")]
        self.assertGreaterEqual(len(called) / len(far_apart), 0.9,
                                [(row.key.display, row.ratio, row.interval) for row in far_apart if row not in called])
        for row in called:  # the direction is the ratio's
            self.assertEqual(comparison.verdict(row), "slower" if row.ratio > 1 else "faster")
        # Nothing about the other primitives changed: none of their entries is called.
        others = [row for row in comparison.rows if row.key.get("sync") not in ("std_barrier", "futex_spin")]
        self.assertGreater(len(others), 100)
        self.assertEqual([row.key.display for row in others if comparison.verdict(row) in ("slower", "faster")], [])
        status, out, _ = run_tool("compare", a, b)
        self.assertEqual(status, 0)
        self.assertNotIn("Benjamini-Hochberg", out)  # the summary's words; --all gives the q-values
        self.assertIn("Benjamini-Hochberg", run_tool("compare", a, b, "--all")[1])
        self.assertIn(f"changed (raw verdicts: pace unavailable): {len([r for r in comparison.rows if comparison.verdict(r) in ('slower', 'faster')])} of {len(comparison.rows)}", out)

    def test_a_pace_change_alone_is_slower_raw_and_within_noise_beyond_the_pace(self):
        # The same entries; B's every repetition 3x slower, and its pace (c2c) 3x slower too: another mode.
        a = self.write("a.json", paced_document())
        b = self.write("b.json", paced_document(scale=3.0, c2c=75.0))
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        self.assertTrue(comparison.different_modes)
        self.assertEqual(len(comparison.rows), 3)
        for row in comparison.rows:
            self.assertEqual(comparison.verdict(row), "slower", row.key.display)
            self.assertEqual(row.pace.method, "pace-normalised")
            self.assertAlmostEqual(row.pace.ratio, 1.0)
            self.assertEqual(comparison.pace_verdict(row), "within noise", row.key.display)
            self.assertEqual(comparison.beyond_pace(row), "within noise")
        self.assertEqual(comparison.verdict_counts()["slower"], 3)
        self.assertEqual(comparison.pace_verdict_counts()["slower"], 0)
        self.assertEqual(comparison.regressions_beyond(10), [])
        status, out, err = run_tool("compare", a, b, "--fail-above", "10", "--all")
        self.assertEqual(status, 0, err)  # nothing changed beyond the pace
        self.assertIn("the runs ran in different pace modes: no mode in common", out)
        self.assertIn("pace of A: c2c 25 ns (100 %)", out)
        self.assertIn("pace of B: c2c 75 ns (100 %)", out)
        self.assertIn("raw verdicts at the 5 % noise band: 3 slower", out)
        self.assertIn("pace-aware verdicts: 0 slower, 0 faster, 0 unsure, 3 within noise", out)
        self.assertIn("changed beyond the pace (pace-aware verdicts; the raw one where an entry has no pace): 0 of 3", out)
        with tempfile.TemporaryDirectory() as directory:
            path = os.path.join(directory, "c.json")
            run_tool("compare", a, b, "--json", path)
            with open(path, encoding="utf-8") as stream:
                written = json.load(stream)["comparisons"][0]
        self.assertEqual(written["pace"], "different modes")
        self.assertEqual(written["verdicts"]["slower"], 3)
        self.assertEqual(written["verdicts_beyond_pace"]["slower"], 0)
        self.assertEqual({row["pace"]["method"] for row in written["rows"]}, {"pace-normalised"})

    def test_the_same_change_in_the_same_mode_stays_slower_beyond_the_pace(self):
        # 3x slower with the pace unchanged: the pace explains nothing, both verdicts say slower.
        a = self.write("a.json", paced_document())
        b = self.write("b.json", paced_document(scale=3.0))
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        self.assertFalse(comparison.different_modes)
        for row in comparison.rows:
            self.assertEqual(row.pace.method, "one mode")
            self.assertEqual(comparison.pace_verdict(row), "slower")
        status, out, err = run_tool("compare", a, b, "--fail-above", "10")
        self.assertEqual(status, 1)
        self.assertIn("the runs ran in the same pace modes", out)
        self.assertIn("pace-aware, one mode", err)

    def test_runs_in_two_shared_modes_compare_within_matching_modes(self):
        comparison = compare_pair(load("paced_a.json"), load("paced_b.json"))
        self.assertFalse(comparison.different_modes)
        self.assertEqual({row.pace.method for row in comparison.rows}, {"matching modes"})
        self.assertEqual({(row.pace.repetitions_a, row.pace.repetitions_b) for row in comparison.rows}, {(6, 6)})
        # The raw intervals span both modes (2.5x apart); within the fast mode they are narrow.
        row = next(row for row in comparison.rows if row.key.display == FORCED)
        self.assertGreater(row.interval[1] / row.interval[0], 2.0)
        self.assertLess(row.pace.interval[1] / row.pace.interval[0], 1.2)

    def test_an_old_file_compares_as_before(self):
        comparison = compare_pair(load("machine_a.json"), load("machine_a_rerun.json"))
        self.assertIsNone(comparison.different_modes)
        self.assertTrue(all(row.pace is None for row in comparison.rows))
        self.assertEqual([row.key.display for row in comparison.rows
                          if comparison.verdict(row) in ("slower", "faster")], [FORCED])
        status, out, err = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"))
        self.assertEqual(status, 0, err)
        self.assertIn("pace: unavailable in machine_a.json and machine_a_rerun.json", out)
        self.assertNotIn("paced verdict", out)
        self.assertIn("changed (raw verdicts: pace unavailable): 1 of 36 (1 slower", out)
        # One file with the pace, one without: compared, raw verdicts only.
        status, out, err = run_tool("compare", fixture("machine_a.json"), fixture("paced_a.json"))
        self.assertEqual(status, 0, err)
        self.assertIn("pace: unavailable in machine_a.json (no lockstep_pace", out)


# ---------------------------------------------------------------- models (two masses and s-mass chains)
# Beyond four threads `lockstep run` integrates an s-mass chain and names it by a model segment
# (kernels/model_choice.hpp): rk4/model:chain4/sync:.../threads:8, with the chain's own serial step
# rk4/model:chain4/serial. The paper's two masses carry no model segment, so a file written before chains
# existed names them as a new file does.

CHAIN = "rk4/model:chain4/sync:seqlock/layout:per_thread/pin:compact/threads:8"
CHAIN_SERIAL = "rk4/model:chain4/serial"
# `--masses 8` on 8 threads: the same sync, layout, pin and threads as CHAIN, another chain.
CHAIN_OF_8 = "rk4/model:chain8/sync:seqlock/layout:per_thread/pin:compact/threads:8"
# `--masses 4` on 2 threads: the same sync, layout, pin and threads as STEADY (the paper's system).
STEADY_AS_CHAIN = "rk4/model:chain4/sync:seqlock/layout:per_thread/pin:compact/threads:2"


def with_chain(document, chain_ns=900.0, names=(CHAIN,), serial_ns=45.0):
    """document plus chain entries and the chain's serial step, as a run beyond four threads adds them."""
    extended = json.loads(json.dumps(document))
    extended["benchmarks"] += entries(CHAIN_SERIAL, serial_ns)
    for name in names:
        extended["benchmarks"] += entries(name, chain_ns)
    return extended


def displays(keys):
    return sorted(key.display for key in keys)


class Models(ScratchFiles):
    def test_chain_entries_match_by_their_model(self):
        a = self.write("a.json", with_chain(run_document("25.0", "20.00", 560.0)))
        b = self.write("b.json", with_chain(run_document("25.0", "20.00", 560.0), chain_ns=900.0 * 1.4))
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        row = next(row for row in comparison.rows if row.key.display == CHAIN)
        self.assertAlmostEqual(row.ratio, 1.4)
        self.assertEqual(comparison.verdict(row), "slower")
        self.assertEqual((comparison.added, comparison.removed), ([], []))
        status, out, err = run_tool("compare", a, b, "--fail-above", "10")
        self.assertEqual(status, 1)
        self.assertIn(CHAIN, err)
        self.assertIn("only in A (a.json): removed: 0", out)
        self.assertIn("only in B (b.json): added: 0", out)

    def test_a_chain_entry_never_matches_a_two_mass_entry_nor_another_chain(self):
        # A: the paper's system on 2 threads (STEADY) and an 8-mass chain on 8 threads; B: `--masses 4`, the
        # same primitives, layouts, placements and thread counts with another model each. Nothing of them matches.
        document_a = with_chain(run_document("25.0", "20.00", 560.0), names=(CHAIN_OF_8,))
        document_b = with_chain(run_document("25.0", "20.00", 560.0), names=(CHAIN, STEADY_AS_CHAIN))
        document_b["benchmarks"] = [entry for entry in document_b["benchmarks"] if entry["name"] != STEADY]
        a, b = self.write("a.json", document_a), self.write("b.json", document_b)
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        matched = displays(row.key for row in comparison.rows + comparison.calibrations)
        for name in (STEADY, STEADY_AS_CHAIN, CHAIN, CHAIN_OF_8):
            self.assertNotIn(name, matched)
        self.assertIn(SHIFTED, matched)  # the rest of the two files still matches
        self.assertEqual(displays(comparison.removed), sorted([STEADY, CHAIN_OF_8]))
        self.assertEqual(displays(comparison.added), sorted([STEADY_AS_CHAIN, CHAIN]))
        status, out, err = run_tool("compare", a, b)
        self.assertEqual(status, 0, err)
        lines = out.splitlines()
        removed = lines.index("only in A (a.json): removed: 2")
        self.assertEqual(sorted(lines[removed + 1:removed + 3]), sorted(f"  {name}" for name in (STEADY, CHAIN_OF_8)))
        added = lines.index("only in B (b.json): added: 2")
        self.assertEqual(sorted(lines[added + 1:added + 3]), sorted(f"  {name}" for name in (STEADY_AS_CHAIN, CHAIN)))

    def test_a_file_written_before_models_compares_with_a_new_one(self):
        # machine_a.json's names carry no model segment (written before chains existed); a new run of the same
        # entries adds chains beyond four threads. Every old entry matches its new namesake.
        with open(fixture("machine_a.json"), encoding="utf-8") as stream:
            old_document = json.load(stream)
        old = fixture("machine_a.json")
        new = self.write("new.json", with_chain(old_document))
        old_keys = set(load("machine_a.json").runs)
        self.assertFalse(any(key.get("model") for key in old_keys))
        comparison = compare_pair(load("machine_a.json"), load_run_file(new))
        self.assertEqual(comparison.removed, [])
        self.assertEqual(displays(comparison.added), sorted([CHAIN, CHAIN_SERIAL]))
        self.assertEqual(len(comparison.rows) + len(comparison.calibrations) + len(comparison.errored), len(old_keys))
        self.assertTrue(all(row.ratio == 1.0 for row in comparison.rows))
        status, out, err = run_tool("compare", old, new)
        self.assertEqual(status, 0, err)
        self.assertIn("only in A (machine_a.json): removed: 0", out)
        self.assertIn("only in B (new.json): added: 2", out)


    def test_a_chains_serial_step_is_a_calibration(self):
        # The chain's serial step moves by 40 % and nothing else does: a calibration that moved, compared apart,
        # never in the geometric mean, the counts or the gate.
        a = self.write("a.json", with_chain(run_document("25.0", "20.00", 560.0)))
        b = self.write("b.json", with_chain(run_document("25.0", "20.00", 560.0), serial_ns=45.0 * 1.4))
        comparison = compare_pair(load_run_file(a), load_run_file(b))
        self.assertNotIn(CHAIN_SERIAL, displays(row.key for row in comparison.rows))
        row = next(row for row in comparison.calibrations if row.key.display == CHAIN_SERIAL)
        self.assertEqual(comparison.verdict(row), "slower")
        self.assertEqual(displays(row.key for row in comparison.calibrations),
                         sorted([C2C, "rk4/serial", CHAIN_SERIAL, OVERHEAD.format("off"), OVERHEAD.format("on")]))
        self.assertEqual(comparison.verdict_counts()["slower"], 0)
        self.assertEqual(run_tool("compare", a, b, "--fail-above", "0")[0], 0)

    def test_a_chain_is_normalised_by_its_own_serial_step(self):
        # The context's serial_step_ns (20 ns) is the paper's system's; the chain's step (900 ns) is divided by
        # the chain's serial step (45 ns), as the harness's own vs_serial is.
        run_file = load_run_file(self.write("a.json", with_chain(run_document("25.0", "20.00", 560.0))))
        vs_serial, _ = normalised(run_file, parse_name(CHAIN))
        self.assertAlmostEqual(vs_serial, 900.0 / 45.0)
        steady = parse_name(STEADY)
        vs_serial, _ = normalised(run_file, steady)
        self.assertAlmostEqual(vs_serial, statistics.median(run_file.runs[steady].times_ns()) / 20.0)
        (name, step, vs_serial), = rank_tables([run_file])[("compact", 8)][0]
        self.assertEqual(name, "seqlock/per_thread")
        self.assertAlmostEqual(vs_serial, 900.0 / 45.0)


class CompareSummary(Scratch):
    def test_the_same_file_twice_is_one_line(self):
        status, out, err = run_tool("compare", fixture(HEADLINE), fixture(HEADLINE))
        self.assertEqual((status, err), (0, ""))
        self.assertEqual(out.count("\n"), 1)
        self.assertIn("the same file given twice", out)

    def test_two_files_with_the_same_bytes_are_one_line(self):
        copy = os.path.join(self.directory.name, "copy.json")
        shutil.copy(fixture("machine_a.json"), copy)
        status, out, err = run_tool("compare", fixture("machine_a.json"), copy, "--fail-above", "0")
        self.assertEqual((status, err), (0, ""))
        self.assertEqual(out, f"lockstep compare: {fixture('machine_a.json')} and {copy} are identical (the same "
                              "bytes): nothing changed, nothing to compare\n")

    def test_a_damaged_file_twice_is_still_refused(self):
        status, out, err = run_tool("compare", fixture("truncated.json"), fixture("truncated.json"))
        self.assertEqual((status, out), (2, ""))
        self.assertEqual(err.count("\n"), 1)

    def test_the_default_is_a_summary_of_about_40_lines(self):
        status, out, err = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"))
        self.assertEqual(status, 0, err)
        lines = out.splitlines()
        self.assertLessEqual(len(lines), 45)
        self.assertIn("changed (raw verdicts: pace unavailable): 1 of 36 (1 slower, 0 faster", out)
        slower = lines.index("slower (1, largest first):")
        self.assertTrue(lines[slower + 3].lstrip().startswith("rk4/sync:futex_spin/layout:packed/pin:compact/threads:4 "))
        self.assertIn("geometric mean of B/A over the 36 matched pairs", out)
        self.assertIn("context: the same 21 fingerprint keys in every file", out)
        self.assertNotIn("Across machines", out)
        self.assertTrue(lines[-1].startswith("(lockstep compare --all prints every entry"))

    def test_all_prints_everything_it_printed_before(self):
        _, summary, _ = run_tool("compare", fixture("machine_a.json"), fixture("machine_b.json"))
        status, everything, err = run_tool("compare", fixture("machine_a.json"), fixture("machine_b.json"), "--all")
        self.assertEqual(status, 0, err)
        self.assertGreater(len(everything.splitlines()), 3 * len(summary.splitlines()))
        for text in ("== Across machines", "Rank per machine", "raw verdicts at the 5 % noise band",
                     "noise threshold: 5 % (the default"):
            self.assertIn(text, everything)
        # the machines' differences are in both; the summary lists only the machine's keys that differ
        self.assertIn("What differs between the machines", summary)
        self.assertIn("What differs between the machines", everything)
        self.assertNotIn("compiler ", summary)
        self.assertIn("compiler ", everything)

    def test_the_changed_list_is_capped(self):
        document = headline_document()
        collapsed = set(document["lockstep_headline"]["collapsed"])
        for entry in document["benchmarks"]:
            if entry["name"].startswith("rk4/sync:") and entry["run_type"] == "iteration":
                for key in ("real_time", "ns_per_step"):
                    entry[key] *= 3.0 if entry["name"] in collapsed else 2.0
        slower = self.write("slower.json", document)
        status, out, err = run_tool("compare", fixture(HEADLINE), slower)
        self.assertEqual(status, 0, err)
        shown = [line for line in out.splitlines() if line.startswith("  rk4/sync:")]
        self.assertEqual(len(shown), compare_text.SHOWN_CHANGES)
        self.assertRegex(out, r"\n  \.\.\. and [0-9]+ more slower \(--all lists every entry\)\n")
        self.assertLessEqual(len(out.splitlines()), 45)
        # a collapsed entry is said to be one: counted as collapsed, never listed as slower, nor untested
        self.assertIn(f"{len(collapsed)} collapsed (in a file's answer", " ".join(out.split()))
        self.assertFalse(any(line.split()[0] in collapsed for line in shown))
        self.assertIn("0 untested", out)


LOCKSTEP_BINARY = os.environ.get("LOCKSTEP", os.path.join(REPORTS_DIR.parent, "build", "dev", "bench", "lockstep"))


def tool_help(tool: str) -> str:
    """`lockstep <tool> --help` as reports/cli.py prints it (argparse exits after printing: a process of its own),
    its lines joined by single spaces (a wrapped `lockstep verify --csv` reads whole)."""
    helped = subprocess.run(["/usr/bin/python3", os.path.join(REPORTS_DIR, "cli.py"), tool, "--help"],
                            capture_output=True, text=True, timeout=60)
    assert helped.returncode == 0, helped.stderr
    return " ".join(helped.stdout.split())


class CommandLines(Scratch):
    def test_noise_takes_a_percent_sign_or_not(self):
        outputs = [run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"), "--noise", value)
                   for value in ("5", "5%", "5 %")]
        self.assertEqual({status for status, _, _ in outputs}, {0})
        self.assertEqual(len({out for _, out, _ in outputs}), 1)
        self.assertEqual(run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"),
                                  "--noise=2%")[1],
                         run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"),
                                  "--noise", "2")[1])

    def test_a_mistyped_option_names_the_one_meant(self):
        for argv, expected in (
                (("compare", "a.json", "b.json", "--nosie", "5"), "unknown option --nosie; did you mean --noise?"),
                (("compare", "a.json", "b.json", "--fail-abve=3"), "unknown option --fail-abve; did you mean "
                                                                    "--fail-above?"),
                (("compare", "a.json", "b.json", "--nois", "5"), "unknown option --nois; did you mean --noise?"),
                (("report", "a.json", "--ttile", "x"), "unknown option --ttile; did you mean --title?"),
                (("report", "a.json", "--zzzz"), "unknown option --zzzz (`lockstep report --help` lists the "
                                                 "options)")):
            with self.subTest(argv):
                status, out, err = run_tool(*argv)
                self.assertEqual((status, out), (2, ""))
                self.assertEqual(err, f"lockstep {argv[0]}: {expected}\n")

    def test_a_mistyped_value_names_the_one_meant(self):
        for value, expected in (("rael", "--time: unknown value 'rael' (did you mean real?)"),
                                ("wall", "--time: unknown value 'wall' (valid: real, cpu)")):
            with self.subTest(value):
                status, out, err = run_tool("compare", "a.json", "b.json", "--time", value)
                self.assertEqual((status, out), (2, ""))
                self.assertEqual(err, f"lockstep compare: {expected}\n")

    def test_the_help_reads_as_every_other_commands_help(self):
        """The other commands' help (CLI11's): a first line that says what the command does, then
        'Usage: lockstep X [OPTIONS] ...', 'Options:' with '-h,--help'; compare's and report's alike."""
        for tool in ("compare", "report"):
            with self.subTest(tool):
                helped = subprocess.run(["/usr/bin/python3", os.path.join(REPORTS_DIR, "cli.py"), tool, "--help"],
                                        capture_output=True, text=True, check=True)
                lines = helped.stdout.splitlines()
                self.assertFalse(lines[0].lower().startswith("usage"), lines[0])
                usage = next(line for line in lines if line.startswith("Usage: "))
                self.assertTrue(usage.startswith(f"Usage: lockstep {tool} [OPTIONS] "), usage)
                self.assertIn("Options:", lines)
                self.assertIn("Positionals:", lines)
                self.assertTrue(any(line.strip().startswith("-h,--help") for line in lines))
                self.assertLess(lines.index(usage), lines.index("Options:"))

    def test_option_values_and_negative_numbers_are_not_taken_for_options(self):
        status, _, err = run_tool("compare", fixture("machine_a.json"), fixture("machine_a_rerun.json"),
                                  "--noise", "-5")
        self.assertEqual(status, 2)
        self.assertIn("--noise", err)
        self.assertNotIn("unknown option", err)
        out = os.path.join(self.directory.name, "titled")
        self.assertEqual(run_tool("report", fixture("verify_a.csv"), "--title=--not-an-option", "--out", out)[0], 0)

    def test_the_help_names_only_options_that_exist(self):
        for tool, parser in (("compare", compare_parser()), ("report", report_parser())):
            with self.subTest(tool):
                out = tool_help(tool)
                own = set(parser._option_string_actions)
                # `lockstep X --flag` names another command's option; a bare --flag one of this tool's
                named = re.findall(r"`lockstep ([a-z]+)((?: --?[a-z-]+)*)", out)
                others = {(command, flag) for command, flags in named for flag in flags.split()
                          if command not in ("compare", "report")}
                for flag in set(re.findall(r"(?<![`\w-])(--[a-z][a-z-]*)", out)) - {flag for _, flag in others}:
                    self.assertIn(flag, own, f"{tool} --help names {flag}")
                self.assertNotIn("c2c --json", out)
                self.assertNotIn("delay --json", out)

    def test_the_other_commands_options_the_help_names_exist(self):
        if not os.access(LOCKSTEP_BINARY, os.X_OK):
            self.skipTest(f"no lockstep binary at {LOCKSTEP_BINARY} (build it, or set LOCKSTEP)")
        for tool in ("compare", "report"):
            out = tool_help(tool)
            named = {(command, flag) for command, flags in re.findall(r"`lockstep ([a-z]+)((?: --?[a-z-]+)*)", out)
                     for flag in flags.split() if command not in ("compare", "report")}
            self.assertTrue(named, tool)
            for command, flag in sorted(named):
                with self.subTest(tool=tool, option=f"lockstep {command} {flag}"):
                    helped = subprocess.run([LOCKSTEP_BINARY, "help", command], capture_output=True, text=True,
                                            timeout=60)
                    self.assertEqual(helped.returncode, 0, helped.stderr)
                    self.assertRegex(helped.stdout, rf"(^|[\s,]){re.escape(flag)}\b")

if __name__ == "__main__":
    unittest.main()


# ---------------------------------------------------------------- aggregates, pooled evidence, collapsed

class AggregatesAndPooledEvidence(ScratchFiles):
    """Seeded synthetic matrices (synthetic_runs.py): 96 entries, 5 repetitions each, 5 % spread within a run,
    3 % drift per entry and run between the runs (4.2 % on the log ratio)."""

    COLLAPSED = tuple(name for name in synthetic_runs.entry_names() if "std_barrier" in name and "threads:4" in name)

    def compared(self, shift):
        a = self.write("a.json", synthetic_runs.matrix_document(1, drift=0.03, spread=0.05, collapsed=self.COLLAPSED))
        b = self.write("b.json", synthetic_runs.matrix_document(2, shift=shift, drift=0.03, spread=0.05,
                                                                collapsed=self.COLLAPSED))
        return a, b, compare_pair(load_run_file(a), load_run_file(b))

    def overall(self, comparison):
        return next(aggregate for aggregate in comparison.aggregates() if aggregate.group == "all")

    def test_a_uniform_shift_is_called_by_the_aggregate_and_its_groups(self):
        a, b, comparison = self.compared(1.15)
        overall = self.overall(comparison)
        self.assertEqual(overall.entries, 88)  # the 8 collapsed entries apart
        self.assertEqual(overall.verdict, "slower")
        self.assertGreater(overall.interval[0], 1.05)
        self.assertLess(overall.interval[0], 1.15)
        self.assertGreater(overall.interval[1], 1.13)
        for group in ("threads:2", "threads:4", "pin:compact", "pin:none", "sync:futex_spin"):
            self.assertEqual(next(x for x in comparison.aggregates() if x.group == group).verdict, "slower", group)
        status, out, err = run_tool("compare", a, b)
        self.assertEqual(status, 0, err)
        # the answer first: right after the comparison's title
        lines = out.splitlines()
        title = next(index for index, line in enumerate(lines) if line.startswith("== B"))
        self.assertTrue(lines[title + 1].startswith("geometric mean of B/A over the 88 matched pairs"), lines[title + 1])
        self.assertRegex(logical_line(out, "geometric mean of B/A"), r"\]: slower( \(one run a side|$)")
        # --fail-above names the groups that failed, even where no single entry is called slower beyond 10 %
        status, out, err = run_tool("compare", a, b, "--fail-above", "10")
        self.assertEqual(status, 1, err)
        self.assertIn("every matched combination (88 entries) is", err)
        self.assertIn("the group threads:2", err)
        status, out, err = run_tool("compare", a, b, "--fail-above", "40")
        self.assertEqual(status, 0, err)

    def test_an_a_a_pair_stays_within_noise(self):
        a, b, comparison = self.compared(1.0)
        self.assertEqual(self.overall(comparison).verdict, "within noise")
        called = [row for row in comparison.combinations if comparison.beyond_pace(row) in ("slower", "faster")]
        self.assertLessEqual(len(called), 0.05 * len(comparison.combinations))
        # the drift between the runs is calibrated from the pair: sqrt(2) x 3 % on the log ratio
        self.assertAlmostEqual(comparison.drift, 0.03 * 2 ** 0.5, delta=0.012)
        self.assertEqual(comparison.pooled_entries, 88)
        err = run_tool("compare", a, b, "--fail-above", "5")[2]
        self.assertNotIn("every matched combination", err)  # an entry may drift; no group fails
        self.assertNotIn("the group", err)

    def drifted(self, shift, cells):
        """A against B (B/A = shift on average) where B's entries of the given (primitive, thread count) cells
        moved together by a factor each: a block drift between the runs, or a real change of those cells."""
        a = self.write("a.json", synthetic_runs.matrix_document(1, drift=0.03, spread=0.05))
        document = synthetic_runs.matrix_document(2, shift=shift, drift=0.03, spread=0.05)
        for benchmark in document["benchmarks"]:
            key = parse_name(benchmark["name"])
            factor = cells.get((key.get("sync"), key.threads), 1.0)
            for name in ("real_time", "cpu_time", "ns_per_step"):
                benchmark[name] *= factor
        b = self.write("b.json", document)
        return compare_pair(load_run_file(a), load_run_file(b))

    def test_a_block_of_primitives_drifting_together_is_spread_not_a_change(self):
        # 4 of the 12 primitive x thread count cells 30 % slower as blocks, the rest unchanged (an A/A pair whose
        # sleeping primitives slowed between the runs): the entries' bootstrap would call the mean slower.
        block = {(sync, threads): 1.3 for sync in ("std_barrier", "ck_mcs") for threads in synthetic_runs.THREADS}
        comparison = self.drifted(1.0, block)
        overall = self.overall(comparison)
        self.assertEqual(overall.clusters, 12)
        self.assertEqual(overall.verdict, "unsure")
        ratios = [row.beyond_pace_ratio() for row in comparison.combinations]
        entries_only = statistics.geometric_mean_interval(ratios, statistics.seed_of("all"))
        self.assertEqual(verdict_of(entries_only[1:], 5.0), "slower")
        # A one-cluster drift is not called either; a uniform shift on top of the block still is.
        self.assertNotEqual(self.overall(self.drifted(1.0, {("futex_spin", 4): 2.0})).verdict, "slower")
        shifted = self.overall(self.drifted(1.15, block))
        self.assertEqual(shifted.verdict, "slower")
        self.assertGreater(shifted.interval[0], 1.05)

    def test_a_primitive_group_borrows_the_spread_of_whole_clusters(self):
        comparison = self.drifted(1.0, {(sync, 2): 1.3 for sync in ("std_barrier", "ck_mcs", "mailbox")})
        groups = {aggregate.group: aggregate for aggregate in comparison.aggregates()}
        seqlock = groups["sync:seqlock"]
        self.assertEqual(seqlock.clusters, 2)
        # seqlock did not move; its interval is as wide as two cells of this pair could have drifted
        self.assertLess(seqlock.interval[0], 0.96)
        self.assertGreater(seqlock.interval[1], 1.04)
        self.assertNotIn(groups["all"].verdict, ("slower", "faster"))

    def two_states(self, shift):
        """A against B, each entry's first repetition on both sides run in a second state of the machine (c2c
        14 ns instead of 30, the step 2x faster) that the trace's one mode does not tell apart."""
        paths = []
        for seed, factor in ((1, 1.0), (2, shift)):
            document = synthetic_runs.matrix_document(seed, shift=factor, drift=0.01, spread=0.02)
            for benchmark in document["benchmarks"]:
                if benchmark["repetition_index"] == 0:
                    for name in ("real_time", "cpu_time", "ns_per_step"):
                        benchmark[name] *= 0.5
                    benchmark["pace_c2c_ns"] = 14.0
            paths.append(self.write(f"{seed}.json", document))
        return compare_pair(load_run_file(paths[0]), load_run_file(paths[1]))

    def test_repetitions_in_another_c2c_state_of_one_mode_are_set_apart(self):
        shifted = self.two_states(1.15)
        self.assertEqual({row.pace.method for row in shifted.rows}, {pace_statistics.PACE_ONE_STATE})
        self.assertEqual({(row.pace.repetitions_a, row.pace.repetitions_b) for row in shifted.rows}, {(4, 4)})
        self.assertIn("within 1.2x of 30 ns (A 4 of 5, B 4 of 5)", shifted.rows[0].pace.detail)
        slower = [row for row in shifted.rows if shifted.beyond_pace(row) == "slower"]
        self.assertGreaterEqual(len(slower), 0.9 * len(shifted.rows))
        # All five repetitions, the fast one included, leave every entry's interval too wide to call it.
        for row in shifted.rows:
            row.pace = PaceAware("one mode", "", row.ratio, None, 5, 5, *(
                tuple(run.times_ns("real")) for run in (shifted.baseline.runs[row.key], shifted.contender.runs[row.key])))
        pace_statistics.pool_evidence(shifted.rows)
        self.assertLess(sum(shifted.beyond_pace(row) == "slower" for row in shifted.rows), 0.5 * len(shifted.rows))
        same = self.two_states(1.0)
        called = [row for row in same.rows if same.beyond_pace(row) in ("slower", "faster")]
        self.assertLessEqual(len(called), 0.05 * len(same.rows))

    STATES = (14.0, 30.0, 100.0)  # c2c of the machine's three states, fastest first: the trace's three modes

    def states_document(self, seed, shift, states):
        """A synthetic run whose repetitions ran in the given states (indices into STATES, one per repetition):
        std_barrier's steps do not follow the c2c reading at all, every other primitive's in proportion."""
        document = synthetic_runs.matrix_document(seed, shift=shift, drift=0.01, spread=0.02)
        for benchmark in document["benchmarks"]:
            state = states[benchmark["repetition_index"]]
            follows = 0.0 if "std_barrier" in benchmark["name"] else 1.0
            for name in ("real_time", "cpu_time", "ns_per_step"):
                benchmark[name] *= (self.STATES[state] / 30.0) ** follows
            benchmark.update(pace_c2c_ns=self.STATES[state], pace_mode=state)
        document["lockstep_pace"].update(
            readings=[{"t_s": 0.1 * index, "c2c_ns": self.STATES[index % 3], "serial_ns": 20.0, "mode": index % 3}
                      for index in range(30)],
            modes=[{"mode": index, "c2c_ns": c2c, "serial_ns": 20.0, "share": 1 / 3, "readings": 10}
                   for index, c2c in enumerate(self.STATES)], changes=29,
            summary="c2c 14 ns for 33 % of the run, 30 ns for 33 %, 100 ns for 33 %; 29 changes")
        return document

    def test_a_step_is_divided_by_the_pace_as_far_as_its_cluster_follows_it(self):
        # No state or mode holds 3 repetitions of both sides: every entry is pace-normalised. B ran more of
        # its repetitions in the slow state, which std_barrier's steps do not feel.
        a = self.write("a.json", self.states_document(1, 1.0, (0, 1, 2, 0, 1)))
        for shift in (1.0, 1.15):
            b = self.write("b.json", self.states_document(2, shift, (0, 2, 2, 1, 2)))
            comparison = compare_pair(load_run_file(a), load_run_file(b))
            self.assertEqual({row.pace.method for row in comparison.rows}, {pace_statistics.PACE_NORMALISED})
            elasticities = pace_statistics.pace_elasticities(comparison.baseline, comparison.contender, "real")
            for (sync, threads), elasticity in elasticities.items():
                if sync == "std_barrier":
                    self.assertLess(elasticity, 0.1, threads)
                else:
                    self.assertGreater(elasticity, 0.9, (sync, threads))
            for row in comparison.rows:
                self.assertAlmostEqual(math.log(row.pace.ratio), math.log(shift), delta=0.1, msg=row.key.display)
            barrier = [row for row in comparison.rows if row.key.get("sync") == "std_barrier"]
            self.assertEqual(len(barrier), 16)
            if shift == 1.0:
                self.assertFalse([row.key.display for row in comparison.rows
                                  if comparison.beyond_pace(row) in ("slower", "faster")])
                # Divided by the whole reading, std_barrier's entries would read 2-3x faster.
                row = barrier[0]
                whole = pace_statistics.pace_aware(comparison.baseline.runs[row.key], comparison.contender.runs[row.key],
                                           comparison.baseline, comparison.contender, [(0, 0), (1, 1), (2, 2)], "real")
                self.assertLess(whole.ratio, 0.5)
            else:
                slower = [row for row in comparison.rows if comparison.beyond_pace(row) == "slower"]
                self.assertGreaterEqual(len(slower), 0.8 * len(comparison.rows))

    def test_collapsed_entries_are_collapsed_not_untested(self):
        a, b, comparison = self.compared(1.15)
        collapsed = [row for row in comparison.rows if row.collapsed]
        self.assertEqual(sorted(row.key.display for row in collapsed), sorted(self.COLLAPSED))
        self.assertTrue(all(comparison.beyond_pace(row) == "collapsed" for row in collapsed))
        self.assertEqual(comparison.pace_verdict_counts()["collapsed"], 8)
        self.assertEqual(comparison.pace_verdict_counts()["untested"], 0)
        self.assertFalse(any("untested" in warning for warning in comparison.warnings), comparison.warnings)
        status, out, err = run_tool("compare", a, b, "--out", os.path.join(self.directory.name, "c.json"))
        self.assertIn("8 collapsed (in a file's answer", " ".join(out.split()))
        self.assertNotIn("--repetitions 10` or more", out)
        with open(os.path.join(self.directory.name, "c.json"), encoding="utf-8") as stream:
            document = json.load(stream)
        import jsonschema  # Debian's python3-jsonschema, as lockstep_reports/read/schemas.py
        with open(REPORTS_DIR.parent / "docs" / "schemas" / "compare.schema.json", encoding="utf-8") as stream:
            jsonschema.Draft202012Validator(json.load(stream)).validate(document)
        written = document["comparisons"][0]
        self.assertEqual(written["verdicts_beyond_pace"]["collapsed"], 8)
        self.assertEqual(written["aggregates"][0]["group"], "all")
        self.assertEqual(written["aggregates"][0]["verdict"], "slower")

    def test_an_unsure_entry_says_what_it_could_have_seen(self):
        a, b, comparison = self.compared(1.05)
        self.assertIn(self.overall(comparison).verdict, ("unsure", "slower"))
        unsure = [row for row in comparison.combinations if comparison.beyond_pace(row) == "unsure"]
        self.assertTrue(unsure)
        for row in unsure:
            low, high = row.pace.interval
            self.assertAlmostEqual(row.detectable(5.0), (1.05 * (high / low) ** 0.5 - 1.0) * 100.0)
        out = run_tool("compare", a, b)[1]
        self.assertRegex(out, r"the [0-9]+ unsure could not have seen less than ±[0-9]+ % \(median")
        self.assertIn("--repetitions 10", out)
        self.assertIn("--noise", out)
        self.assertIn("could see", run_tool("compare", a, b, "--all")[1])
