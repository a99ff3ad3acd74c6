"""Runs as replicates: the variance components on constructed data with known components (numpy, fixed seeds),
a run's figure (the median of its repetitions) and the components of its variance, on normal and on heavy-tailed
repetitions, the Kalibera-Jones allocation against its formula, the power arithmetic (the planner's prediction
against simulated comparisons of run medians), the planner, and compare with a directory of runs a side (its
intervals from the runs, the built-in A against A, a slow repetition in every run not read as a change). No timing:
seeded data only."""
import dataclasses
import json
import math
import os
import re
import tempfile
import unittest

import numpy as np

from support import run_tool
from synthetic_runs import FAST, SLOW, SLOWEST, matrix_document, paced_run_document

from lockstep_reports.compare import replicates
from lockstep_reports.compare.planner import (MAX_PLAN_REPETITIONS, MIN_PLAN_REPETITIONS, Pilot, _Entry,
                                              allocated_repetitions, cheapest_plan, entries_change, read_pilot)
from lockstep_reports.read.inputs import in_run_order, load_run_file


def nested_data(seed: int, sigmas: tuple[float, ...], counts: tuple[int, ...]) -> np.ndarray:
    """Balanced nested normal data: sigmas and counts from the outermost level in; every level's effect independent."""
    generator = np.random.default_rng(seed)
    data = np.zeros(counts)
    for level, sigma in enumerate(sigmas):
        shape = counts[:level + 1] + (1,) * (len(counts) - level - 1)
        data = data + generator.normal(0.0, sigma, size=shape)
    return data


class VarianceComponents(unittest.TestCase):
    def test_the_one_way_anova_recovers_known_components(self):
        data = nested_data(7, (0.05, 0.02), (400, 10))
        found = replicates.variance_components(list(data))
        self.assertAlmostEqual(math.sqrt(found.between), 0.05, delta=0.05 * 0.15)
        self.assertAlmostEqual(math.sqrt(found.within), 0.02, delta=0.02 * 0.05)
        self.assertEqual(found.runs, 400)
        self.assertAlmostEqual(found.repetitions, 10.0)

    def test_unbalanced_runs_use_n0(self):
        generator = np.random.default_rng(11)
        groups = [generator.normal(generator.normal(0.0, 0.04), 0.03, size=int(n))
                  for n in generator.integers(3, 15, size=500)]
        found = replicates.variance_components(groups)
        self.assertAlmostEqual(math.sqrt(found.between), 0.04, delta=0.04 * 0.1)
        self.assertAlmostEqual(math.sqrt(found.within), 0.03, delta=0.03 * 0.05)

    def test_no_between_run_variance_reads_near_zero_and_never_below(self):
        data = nested_data(3, (0.0, 0.02), (300, 8))
        found = replicates.variance_components(list(data))
        self.assertGreaterEqual(found.between, 0.0)
        self.assertLess(math.sqrt(found.between), 0.004)

    def test_one_run_leaves_the_between_run_part_unknown(self):
        found = replicates.variance_components([[0.1, 0.2, 0.15]])
        self.assertTrue(math.isnan(found.between))
        self.assertAlmostEqual(found.within, float(np.var([0.1, 0.2, 0.15], ddof=1)))

    def test_kalibera_jones_three_levels(self):
        # runs x repetitions x batches, as Kalibera and Jones nest executions and iterations
        data = nested_data(5, (0.04, 0.02, 0.01), (200, 8, 6))
        batches, repetitions, runs = replicates.nested_components(data)
        self.assertAlmostEqual(math.sqrt(runs), 0.04, delta=0.04 * 0.1)
        self.assertAlmostEqual(math.sqrt(repetitions), 0.02, delta=0.02 * 0.1)
        self.assertAlmostEqual(math.sqrt(batches), 0.01, delta=0.01 * 0.05)

    def test_two_levels_agree_with_the_one_way_anova_on_balanced_data(self):
        data = nested_data(9, (0.03, 0.01), (50, 6))
        within, between = replicates.nested_components(data)
        found = replicates.variance_components(list(data))
        self.assertAlmostEqual(within, found.within)
        self.assertAlmostEqual(between, found.between)


def heavy_tailed(seed: int, between: float, within: float, counts: tuple[int, int], share: float = 0.1,
                 jump: float = 0.6) -> np.ndarray:
    """Runs x repetitions of log time: normal between-run and within-run parts, and a `share` of the repetitions
    slower by `jump` (a repetition that caught the VM changing pace)."""
    generator = np.random.default_rng(seed)
    data = nested_data(int(generator.integers(1 << 30)), (between, within), counts)
    return data + jump * (generator.random(counts) < share)


class RunSummary(unittest.TestCase):
    def test_a_runs_figure_is_the_median_of_its_repetitions_log_times(self):
        self.assertAlmostEqual(replicates.run_summary([0.1, 0.5, 0.2]), 0.2)
        self.assertIsNone(replicates.run_summary([]))
        medians = replicates.run_medians([[100.0, 300.0, 110.0, 105.0, 0.0], [], [50.0]])
        self.assertEqual(len(medians), 2)  # a run without a positive time is left out
        self.assertAlmostEqual(medians[0], (math.log(105.0) + math.log(110.0)) / 2.0)
        self.assertAlmostEqual(medians[1], math.log(50.0))

    def test_a_slow_repetition_moves_a_runs_median_little_and_its_mean_much(self):
        # Half the runs have one repetition in five slower by e (the VM changing pace for a while).
        data = nested_data(5, (0.0, 0.05), (400, 5))
        data[::2, 0] += 1.0
        self.assertLess(np.median(data, axis=1).std(), 0.5 * data.mean(axis=1).std())


class MedianComponents(unittest.TestCase):
    def test_the_components_of_a_run_median_on_normal_repetitions(self):
        data = nested_data(31, (0.05, 0.05), (400, 5))
        found = replicates.median_components(list(data))
        self.assertEqual((found.runs, found.repetitions), (400, 5.0))
        self.assertAlmostEqual(math.sqrt(found.between), 0.05, delta=0.05 * 0.15)
        # What the planner's formula says a run median's variance is, and what the runs' medians show.
        self.assertAlmostEqual(found.plan_variance(1, 5), float(np.median(data, axis=1).var(ddof=1)),
                               delta=0.1 * found.plan_variance(1, 5))

    def test_the_within_part_is_robust_to_slow_repetitions_where_the_anova_is_not(self):
        clean = nested_data(33, (0.02, 0.05), (60, 5))
        generator = np.random.default_rng(34)
        dirty = clean + 0.6 * (generator.random(clean.shape) < 0.1)
        robust = [replicates.median_components(list(d)).within for d in (clean, dirty)]
        anova = [replicates.variance_components(list(d)).within for d in (clean, dirty)]
        self.assertLess(robust[1] / robust[0], 1.5)
        self.assertGreater(anova[1] / anova[0], 3.0)

    def test_one_run_leaves_the_between_run_part_unknown(self):
        found = replicates.median_components([[0.1, 0.2, 0.15, 0.12, 0.3]])
        self.assertTrue(math.isnan(found.between))
        self.assertGreater(found.within, 0.0)
        self.assertIsNone(replicates.median_components([[0.1], [0.2]]))


class Allocation(unittest.TestCase):
    def test_the_formula(self):
        # r_i = ceil(sqrt((c_{i+1} / c_i) T_i^2 / T_{i+1}^2))
        for costs, components in (([1.0, 9.0], [0.04, 0.01]), ([0.3, 12.5], [0.001, 0.0004]),
                                  ([2.0, 3.0, 50.0], [0.09, 0.01, 0.002])):
            expected = [math.ceil(math.sqrt((costs[i + 1] / costs[i]) * components[i] / components[i + 1]))
                        for i in range(len(costs) - 1)]
            self.assertEqual(replicates.allocation(costs, components), expected)
        self.assertEqual(replicates.allocation([1.0, 9.0], [0.04, 0.01]), [6])

    def test_an_upper_level_without_variance_asks_for_every_repetition_there(self):
        self.assertEqual(replicates.allocation([1.0, 5.0], [0.01, 0.0]), [math.inf])

    def test_the_planner_allocates_by_the_formula_within_its_bounds(self):
        def pilot(within, between, repetition_s, fixed_s):
            entry = _Entry(None, replicates.Components(between, within, 2, 5), (0.0, 0.0))
            return Pilot([entry], 2, 5, repetition_s, fixed_s, False)
        self.assertEqual(allocated_repetitions(pilot(0.04, 0.01, 1.0, 9.0)), 6)
        self.assertEqual(allocated_repetitions(pilot(0.0001, 0.01, 1.0, 1.0)), MIN_PLAN_REPETITIONS)
        self.assertEqual(allocated_repetitions(pilot(0.04, 0.0, 1.0, 9.0)), MAX_PLAN_REPETITIONS)


class Power(unittest.TestCase):
    def test_the_detectable_change_is_seen_at_the_stated_power(self):
        for error, degrees in ((0.02, math.inf), (0.05, 6.0), (0.01, 2.0)):
            change = replicates.detectable_at_power(error, degrees, 0.05)
            self.assertAlmostEqual(replicates.power_of(change, error, degrees, 0.05), replicates.POWER, places=6)

    def test_a_share_of_identical_entries_is_their_own_detectable_change(self):
        change = replicates.change_seen_by_share([0.03] * 10, math.inf, 0.05)
        self.assertAlmostEqual(change, replicates.detectable_at_power(0.03, math.inf, 0.05), places=6)

    def test_a_simulated_plan_calls_the_predicted_share(self):
        # 2 (between + within / n) / K: simulate K runs x n repetitions a side, a uniform change of the predicted size
        between, within, runs, repetitions, noise = 0.02 ** 2, 0.05 ** 2, 4, 10, 0.05
        error = math.sqrt(2.0 * (between + within / repetitions) / runs)
        degrees = 2 * runs - 2
        change = replicates.detectable_at_power(error, degrees, noise)
        generator = np.random.default_rng(21)
        called = 0
        trials = 4000
        for _ in range(trials):
            sides = [nested_data(int(generator.integers(1 << 30)), (math.sqrt(between), math.sqrt(within)),
                                 (runs, repetitions)).mean(axis=1) + shift for shift in (0.0, math.log1p(change))]
            evidence = replicates.RunEvidence(tuple(sides[0]), tuple(sides[1]))
            low, _ = replicates.run_interval(evidence.log_ratio, evidence.variance * evidence.scale, degrees)
            called += low > 1.0 + noise
        self.assertAlmostEqual(called / trials, replicates.POWER, delta=0.03)

    def test_the_planner_formula_predicts_comparisons_of_run_medians_on_heavy_tailed_repetitions(self):
        # Components from a large heavy-tailed pilot; the change predicted for 10 runs x 5 repetitions a side is
        # called (run medians, Student's t) in POWER of simulated comparisons of that plan.
        between, within, runs, repetitions, noise = 0.03, 0.08, 10, 5, 0.05
        found = replicates.median_components(list(heavy_tailed(41, between, within, (400, repetitions))))
        error = math.sqrt(2.0 * found.plan_variance(runs, repetitions))
        degrees = 2 * runs - 2
        change = replicates.detectable_at_power(error, degrees, noise)
        generator = np.random.default_rng(42)
        called, trials = 0, 2000
        for _ in range(trials):
            sides = [np.median(heavy_tailed(int(generator.integers(1 << 30)), between, within, (runs, repetitions)),
                               axis=1) + shift for shift in (0.0, math.log1p(change))]
            evidence = replicates.RunEvidence(tuple(sides[0]), tuple(sides[1]))
            low, _ = replicates.run_interval(evidence.log_ratio, evidence.variance * evidence.scale, degrees)
            called += low > 1.0 + noise
        self.assertAlmostEqual(called / trials, replicates.POWER, delta=0.05)


def write_group(directory: str, seeds, shift=1.0, drift: float = 0.02, spread: float = 0.03,
                slow_first: float = 1.0, file_numbers=None, numbers: bool = False) -> str:
    """Runs of matrix_document; shift one factor, or one per run; slow_first multiplies every entry's first
    repetition (a change of pace in it). file_numbers: run I is written to run-<file_numbers[I - 1]>.json (its
    index in its context stays I); numbers: the index and the count as JSON numbers, as `lockstep run --runs K`
    writes them since they were (earlier files: text)."""
    os.makedirs(directory)
    shifts = list(shift) if isinstance(shift, (list, tuple)) else [shift] * len(seeds)
    for index, (seed, factor) in enumerate(zip(seeds, shifts), start=1):
        document = matrix_document(seed, shift=factor, drift=drift, spread=spread)
        for entry in document["benchmarks"]:
            if entry["repetition_index"] == 0 and entry["repetitions"] > 1:
                for field in ("real_time", "cpu_time", "ns_per_step"):
                    entry[field] *= slow_first
        count = len(shifts)
        document["context"].update({"lockstep_run_index": index if numbers else str(index),
                                    "lockstep_runs": count if numbers else str(count),
                                    "lockstep_matrix_s": "20.000", "lockstep_wall_s": "26.000"})
        number = file_numbers[index - 1] if file_numbers else index
        with open(os.path.join(directory, f"run-{number}.json"), "w") as stream:
            json.dump(document, stream)
    return directory


class RunsASide(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scratch = tempfile.TemporaryDirectory()
        root = cls.scratch.name
        cls.a = write_group(os.path.join(root, "a"), (101, 102, 103, 104))
        cls.b = write_group(os.path.join(root, "b"), (201, 202, 203, 204))
        cls.slower = write_group(os.path.join(root, "slower"), (301, 302, 303, 304), shift=1.30)
        cls.slow_first = write_group(os.path.join(root, "slow_first"), (201, 202, 203, 204), slow_first=2.0)
        # The machine 30 % slower for the second half of the side's runs.
        cls.drifted = write_group(os.path.join(root, "drifted"), range(401, 409), shift=(1.0,) * 4 + (1.3,) * 4)
        # The same, its files named out of the order the runs ran (run 2 in run-3.json ...), their indices numbers:
        # by file name the two paces alternate.
        cls.misnamed = write_group(os.path.join(root, "misnamed"), range(401, 409), shift=(1.0,) * 4 + (1.3,) * 4,
                                   file_numbers=(1, 3, 5, 7, 2, 4, 6, 8), numbers=True)

    @classmethod
    def tearDownClass(cls):
        cls.scratch.cleanup()

    def test_a_directory_a_side_reads_its_runs_and_checks_itself(self):
        status, out, err = run_tool("compare", self.a, self.b)
        self.assertEqual(status, 0, err)
        self.assertIn("from 4 and 4 runs (the variance between runs)", out)
        self.assertRegex(out, r"A against A: \d+ of 192 changed")
        self.assertRegex(out, r"power \(80 %\): [0-9.]+ % in 80 % of entries, [0-9.]+ % on the mean")

    def test_a_uniform_change_beyond_the_drift_is_called(self):
        status, out, err = run_tool("compare", self.a, self.slower)
        self.assertEqual(status, 0, err)
        first = out.split("== B")[1]
        self.assertRegex(first, r"geometric mean of B/A over the 96 matched pairs[^\n]*\n?[^\n]*: slower")

    def test_a_slow_repetition_in_every_run_is_not_a_change(self):
        # One repetition in five twice as slow in every run of B moves a run's mean log time by 14 % and its
        # median by little: no entry and no aggregate is called slower.
        status, out, err = run_tool("compare", self.a, self.slow_first)
        self.assertEqual(status, 0, err)
        first = " ".join(out.split("== B")[1].split())
        self.assertIn("changed between runs: 0 of 96", first)
        self.assertNotRegex(first, r"geometric mean of B/A over the 96 matched pairs[^:]*: [0-9.]+, 95% interval "
                                   r"\[[0-9.]+, [0-9.]+\]: slower")

    def test_alternate_runs_are_the_false_positive_rate_and_time_order_shows_drift(self):
        status, out, err = run_tool("compare", self.a, self.b)
        self.assertEqual(status, 0, err)
        self.assertIn("odd runs against its even", out)
        self.assertNotIn("drifted", out)
        with tempfile.TemporaryDirectory() as scratch:
            path = os.path.join(scratch, "compare.json")
            status, out, err = run_tool("compare", self.a, self.drifted, "--json", path)
            self.assertEqual(status, 0, err)
            with open(path) as stream:
                replicates = json.load(stream)["comparisons"][0]["replicates"]
        text = " ".join(out.split())
        self.assertIn("the machine drifted while a side ran", text)
        splits = replicates["against_itself"]
        alternate, in_time_order = splits["alternate runs"], splits["in time order"]
        self.assertEqual(replicates["runs"], [4, 8])
        self.assertEqual(alternate["sides"][1]["runs"], [4, 4])
        # Runs 1, 3, 5, 7 and 2, 4, 6, 8 each hold two runs of either pace: nothing between them; the halves in
        # time order are the two paces.
        self.assertEqual(alternate["sides"][1]["changed"], 0)
        self.assertGreater(in_time_order["sides"][1]["changed"], in_time_order["sides"][1]["compared"] // 2)
        self.assertRegex(text, rf"A against A: {alternate['changed']} of {alternate['compared']} changed")

    def test_a_groups_runs_are_ordered_by_their_index_not_their_file_names(self):
        """The runs' order is each context's lockstep_run_index (a number; text in earlier files), so the halves in
        time order are the runs' own even where the file names say otherwise."""
        status, out, err = run_tool("compare", self.a, self.misnamed)
        self.assertEqual(status, 0, err)
        self.assertIn("the machine drifted while a side ran", " ".join(out.split()))
        runs = [load_run_file(os.path.join(self.misnamed, f"run-{i}.json")) for i in range(1, 9)]
        self.assertEqual([run.context["lockstep_run_index"] for run in in_run_order(runs)], list(range(1, 9)))
        texts = [load_run_file(os.path.join(self.drifted, f"run-{i}.json")) for i in (3, 1, 2)]
        self.assertEqual([run.context["lockstep_run_index"] for run in in_run_order(texts)], [1, 2, 3])

    def test_a_side_of_runs_reads_its_calibrations_as_their_median(self):
        from lockstep_reports.common.fields import SERIAL_CONTEXT
        from lockstep_reports.compare.replicated import merged_side
        from lockstep_reports.analysis.run_analysis import calibration

        runs = [load_run_file(os.path.join(self.a, f"run-{i}.json")) for i in range(1, 5)]
        for run_file, serial in zip(runs, ("90.0", "30.0", "31.0", "32.0")):
            run_file.context[SERIAL_CONTEXT] = serial
        side = merged_side(runs, "a", self.a)
        # The first run's context alone would read 90 ns; the runs' median is 31.5 ns.
        self.assertEqual(calibration(side, SERIAL_CONTEXT), 31.5)

    def test_comma_joined_files_are_a_side(self):
        files = ",".join(os.path.join(self.a, f"run-{i}.json") for i in range(1, 3))
        others = ",".join(os.path.join(self.b, f"run-{i}.json") for i in range(1, 3))
        status, out, err = run_tool("compare", files, others)
        self.assertEqual(status, 0, err)
        self.assertIn("from 2 and 2 runs", out)
        self.assertNotIn("A against A", out)

    def test_an_empty_directory_is_refused_in_one_line(self):
        with tempfile.TemporaryDirectory() as empty:
            status, out, err = run_tool("compare", empty, self.b)
        self.assertEqual(status, 2)
        self.assertEqual(len(err.strip().splitlines()), 1, err)
        self.assertIn("without run files", err)


def scale_times_module():
    import importlib.util
    path = os.path.join(os.path.dirname(__file__), "..", "..", "scripts", "scale_times.py")
    spec = importlib.util.spec_from_file_location("scale_times", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class ScaleTimes(unittest.TestCase):
    def test_it_scales_the_step_and_episode_times_of_rk4_and_barrier_entries_only(self):
        document = {"benchmarks": [
            {"name": "rk4/sync:a/threads:2", "real_time": 10.0, "cpu_time": 4.0, "ns_per_step": 10.0},
            {"name": "barrier/sync:a/threads:2", "real_time": 2.0, "ns_per_episode": 2.0},
            {"name": "barrier/sync:a/threads:2_cv", "real_time": 0.1, "aggregate_unit": "percentage"},
            {"name": "c2c/pin:compact/threads:2", "real_time": 100.0, "one_way_ns": 30.0},
            {"name": "rk4/serial", "real_time": 20.0, "ns_per_step": 20.0}]}
        scaled = scale_times_module().scaled_document(document, 1.15)["benchmarks"]
        self.assertAlmostEqual(scaled[0]["real_time"], 11.5)
        self.assertAlmostEqual(scaled[0]["cpu_time"], 4.6)
        self.assertAlmostEqual(scaled[0]["ns_per_step"], 11.5)
        self.assertAlmostEqual(scaled[1]["ns_per_episode"], 2.3)
        self.assertEqual(scaled[2]["real_time"], 0.1)
        self.assertEqual(scaled[3], {"name": "c2c/pin:compact/threads:2", "real_time": 100.0, "one_way_ns": 30.0})
        self.assertAlmostEqual(scaled[4]["real_time"], 23.0)  # rk4/serial is an rk4/ entry: scaled as named

    def test_an_existing_target_is_refused_and_nothing_is_written(self):
        with tempfile.TemporaryDirectory() as scratch:
            source = write_group(os.path.join(scratch, "a"), (1, 2))
            self.assertEqual(scale_times_module().main(["1.15", source, source]), 2)


class Planner(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scratch = tempfile.TemporaryDirectory()
        cls.pilot = write_group(os.path.join(cls.scratch.name, "pilot"), (401, 402, 403, 404))

    @classmethod
    def tearDownClass(cls):
        cls.scratch.cleanup()

    def test_the_cheapest_plan_reaches_the_target_and_one_run_less_does_not(self):
        files = [load_run_file(os.path.join(self.pilot, f"run-{i}.json")) for i in range(1, 5)]
        pilot = read_pilot(files, "real", 0.05)
        self.assertAlmostEqual(pilot.repetition_s, 20.0 / 5)
        self.assertAlmostEqual(pilot.fixed_s, 6.0)
        runs, repetitions = cheapest_plan(pilot, 0.15, 0.05)
        self.assertLessEqual(entries_change(pilot.entries, runs, repetitions, 0.05), 0.15)
        if runs > 2:
            self.assertGreater(entries_change(pilot.entries, runs - 1, repetitions, 0.05), 0.15)

    def test_the_plan_command(self):
        status, out, err = run_tool("compare", "--plan", self.pilot, "--detect", "15%")
        self.assertEqual(status, 0, err)
        self.assertIn("pilot of 4 run(s) x 5 repetitions", out)
        self.assertRegex(out, r"--detect 15%: \d+ runs a side x \d+ repetitions")
        self.assertIn("threads:2", out)

    def test_a_one_run_pilot_says_the_drift_is_assumed(self):
        status, out, err = run_tool("compare", "--plan", os.path.join(self.pilot, "run-1.json"))
        self.assertEqual(status, 0, err)
        self.assertIn("one run: the between-run part is assumed", " ".join(out.split()))

    def test_detect_without_plan_is_refused(self):
        status, _, err = run_tool("compare", self.pilot, self.pilot, "--detect", "15%")
        self.assertEqual(status, 2)
        self.assertIn("--detect goes with --plan", err)


def write_paced_group(directory: str, shares, seed: int, shift: float = 1.0, run_drift: float = 0.03,
                      paces=(FAST, SLOW)) -> str:
    """Runs of paced_run_document, one per slow share, indices in their contexts."""
    os.makedirs(directory)
    for index, share in enumerate(shares, start=1):
        document = paced_run_document(seed + index, share, shift, run_drift=run_drift, paces=paces)
        document["context"].update({"lockstep_run_index": index, "lockstep_runs": len(shares)})
        with open(os.path.join(directory, f"run-{index}.json"), "w") as stream:
            json.dump(document, stream)
    return directory


def compared(a: str, b: str, *options: str) -> tuple[str, dict]:
    """compare's summary (its lines joined) and its --out JSON's first comparison."""
    with tempfile.TemporaryDirectory() as scratch:
        path = os.path.join(scratch, "compare.json")
        status, out, err = run_tool("compare", a, b, "--out", path, *options)
        assert status == 0, err
        with open(path) as stream:
            return " ".join(out.split()), json.load(stream)["comparisons"][0]


def changed(comparison: dict) -> tuple[int, int]:
    return comparison["verdicts_beyond_pace"]["slower"], sum(comparison["verdicts_beyond_pace"][verdict]
                                                             for verdict in ("slower", "faster"))


# Runs of a machine that changes pace for whole runs: two of six entirely in the slow pace (2.5x slower), the others
# partly; and runs mixed throughout.
WHOLE_RUNS = (0.1, 1.0, 0.2, 0.1, 1.0, 0.3)
MIXED_RUNS = (0.4, 0.6, 0.5, 0.3, 0.7, 0.5)
# The Intel Xeon guest's kind: one pace nearly always (c2c 74 ns, 96 % of its default run), a faster one rarely.
INTEL_MAIN, INTEL_RARE = (74.0, 60.0, 1.0), (17.8, 55.0, 0.9)


class RunsWithinTheirPace(unittest.TestCase):
    """Sides of several runs compared within the pace of the machine their runs share (run_pace.py): a run entirely
    in the slow pace, mixed runs, a pace one side lacks, sides that share no pace, and the Intel kind."""

    @classmethod
    def setUpClass(cls):
        cls.scratch = tempfile.TemporaryDirectory()
        root = cls.scratch.name
        cls.groups = {}
        for name, shares in (("whole", WHOLE_RUNS), ("mixed", MIXED_RUNS)):
            cls.groups[name] = [write_paced_group(os.path.join(root, f"{name}-{side}"), shares[::step], seed, shift)
                                for side, step, seed, shift in (("a", 1, 100, 1.0), ("b", -1, 200, 1.0),
                                                                ("bx", -1, 200, 1.15))]
        cls.slowest = write_paced_group(os.path.join(root, "slowest"), MIXED_RUNS, 300, paces=(FAST, SLOW, SLOWEST))
        cls.all_fast = write_paced_group(os.path.join(root, "all-fast"), (0.0,) * 4, 400)
        cls.all_slow = write_paced_group(os.path.join(root, "all-slow"), (1.0,) * 4, 500)
        cls.intel = [write_paced_group(os.path.join(root, f"intel-{side}"), (0.04,) * 6, seed, shift,
                                       paces=(INTEL_MAIN, INTEL_RARE))
                     for side, seed, shift in (("a", 600, 1.0), ("b", 700, 1.0), ("bx", 700, 1.15))]

    @classmethod
    def tearDownClass(cls):
        cls.scratch.cleanup()

    def assert_holds(self, a: str, b: str, bx: str) -> tuple[str, dict]:
        """x1.15 called slower in at least 80 % of the entries, the same build at most 5 % changed."""
        text, scaled = compared(a, bx)
        slower, _ = changed(scaled)
        self.assertGreaterEqual(slower, 0.8 * scaled["matched"], text)
        _, unscaled = compared(a, b)
        self.assertLessEqual(changed(unscaled)[1], 0.05 * unscaled["matched"])
        return text, scaled

    def test_runs_entirely_in_the_slow_pace(self):
        text, comparison = self.assert_holds(*self.groups["whole"])
        pace = comparison["replicates"]["pace"]
        self.assertEqual(pace["reference_ns"], 35.0)
        self.assertEqual([side["runs_in_pace"] for side in pace["sides"]], [4, 4])  # the two slow runs hold none
        for side in pace["sides"]:
            # Whole runs 2.5x slower spread a run's figure far more than the pace leaves: the pace explains it.
            self.assertGreater(side["spread_every_pace"], 5 * side["spread_one_pace"])
            self.assertGreater(side["explained"], 0.9)
        self.assertRegex(text, r"the pace explained 9\d % of A's between-run variance and 9\d % of B's")
        self.assertIn("the intervals keep the rest", text)

    def test_runs_mixed_throughout(self):
        _, comparison = self.assert_holds(*self.groups["mixed"])
        self.assertEqual([side["runs_in_pace"] for side in comparison["replicates"]["pace"]["sides"]], [6, 6])
        self.assertTrue(all(row["pace"]["method"] == "between runs, one pace" for row in comparison["rows"]))

    def test_a_pace_one_side_lacks_is_named(self):
        text, comparison = compared(self.slowest, self.groups["mixed"][1])
        self.assertIn("B's runs hold no repetition at c2c about 200 ns, where 6 of A's do", text)
        self.assertEqual(comparison["replicates"]["pace"]["missing"], [{"pace_ns": 200.0, "lacking": 1,
                                                                        "runs_holding": 6}])

    def test_sides_that_share_no_pace_are_compared_on_every_repetition(self):
        text, comparison = compared(self.all_fast, self.all_slow)
        self.assertIn("no pace of the machine holds 2 runs of each side: every entry is compared on all its "
                      "repetitions", text)
        self.assertIn("A's runs hold no repetition at c2c about 110 ns, where 4 of B's do", text)
        self.assertTrue(all(row["pace"]["method"] == "between runs" for row in comparison["rows"]))

    def test_the_intel_kind_keeps_nearly_every_repetition(self):
        _, comparison = self.assert_holds(*self.intel)
        pace = comparison["replicates"]["pace"]
        self.assertEqual(pace["reference_ns"], 74.0)
        self.assertTrue(all(side["share"] > 0.9 for side in pace["sides"]))


class PlannerBound(unittest.TestCase):
    """A two-run pilot cannot estimate the between-run part: the planner plans on the larger of its estimate and the
    floor the pace trace gives, and says so."""

    def test_a_two_run_pilot_that_agrees_is_planned_on_the_floor(self):
        with tempfile.TemporaryDirectory() as root:
            pilot = write_paced_group(os.path.join(root, "pilot"), (0.2, 0.2), 800, run_drift=0.0)
            files = [load_run_file(os.path.join(pilot, f"run-{i}.json")) for i in (1, 2)]
            found = read_pilot(files, "real", 0.05)
            status, out, err = run_tool("compare", "--plan", pilot, "--detect", "15%")
        self.assertEqual(status, 0, err)
        text = " ".join(out.split())
        # The runs' readings spread by 5 % inside the fast pace; the two runs agree, so the estimate lies below it.
        self.assertAlmostEqual(found.pace.floor, 0.05, delta=0.01)
        self.assertLess(found.estimate, found.pace.floor ** 2)
        self.assertAlmostEqual(found.between, found.pace.floor)
        self.assertEqual(found.pace.floored, len(found.entries))
        self.assertRegex(text, r"between runs planned on [0-9.]+ % \(median over the entries\): the larger of the "
                               r"pilot's estimate \([0-9.]+ %\) and a floor learnt from the pace trace")
        self.assertIn(f"the floor for {len(found.entries)} of {len(found.entries)} entries", text)
        self.assertIn("a pilot of 2 runs estimates the between-run part from 1 degree of freedom", text)
        self.assertIn("--pilot", text)
        # Without the floor the same pilot would plan as if runs never differed: fewer runs for the same change.
        unfloored = dataclasses.replace(found, entries=[dataclasses.replace(e, components=dataclasses.replace(
            e.components, between=0.0)) for e in found.entries])
        self.assertLess(cheapest_plan(unfloored, 0.15, 0.05)[0], cheapest_plan(found, 0.15, 0.05)[0])


class PlanCheckedAfterTheFact(unittest.TestCase):
    """compare --pilot: the between-run part the plan assumed against each side's realised one."""

    @classmethod
    def setUpClass(cls):
        cls.scratch = tempfile.TemporaryDirectory()
        root = cls.scratch.name
        cls.pilot = write_paced_group(os.path.join(root, "pilot"), (0.2, 0.2), 900, run_drift=0.0)
        cls.drifting = [write_paced_group(os.path.join(root, f"drifting-{side}"), (0.2,) * 6, seed, run_drift=0.15)
                        for side, seed in (("a", 1000), ("b", 1100))]
        cls.steady = [write_paced_group(os.path.join(root, f"steady-{side}"), (0.2,) * 6, seed, run_drift=0.005)
                      for side, seed in (("a", 1200), ("b", 1300))]

    @classmethod
    def tearDownClass(cls):
        cls.scratch.cleanup()

    def test_runs_that_differed_more_than_assumed_are_said_with_the_plan_that_would_see_the_change(self):
        text, comparison = compared(*self.drifting, "--pilot", self.pilot, "--detect", "15%")
        check = comparison["replicates"]["plan_check"]
        self.assertTrue(check["exceeded"])
        self.assertTrue(all(value > check["assumed"] for value in check["realised"]))
        self.assertEqual(check["target"], 0.15)
        self.assertGreater(check["plan"][0], 6)
        self.assertRegex(text, rf"the plan \(from {re.escape(self.pilot)}\) assumed runs differ by [0-9.]+ % .*; "
                               r"A's by [0-9.]+ %, B's by [0-9.]+ %: more than assumed in A and B; to see 15.0 % in "
                               r"80 % of the entries now: \d+ runs a side x \d+ repetitions")

    def test_runs_within_the_assumption_are_said_to_be(self):
        text, comparison = compared(*self.steady, "--pilot", self.pilot)
        self.assertFalse(comparison["replicates"]["plan_check"]["exceeded"])
        self.assertIn("within what it assumed", text)

    def test_the_pilot_goes_with_sides_of_runs(self):
        one = os.path.join(self.steady[0], "run-1.json")
        status, _, err = run_tool("compare", one, one.replace("steady-a", "steady-b"), "--pilot", self.pilot)
        self.assertEqual(status, 2)
        self.assertIn("--pilot: the sides hold one run each", err)


if __name__ == "__main__":
    unittest.main()
