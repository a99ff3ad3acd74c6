"""statistics.py against the golden file it shares with platform/statistics.hpp
(tests/fixtures/statistics/golden.json: numpy's answers and the verdict rule's;
tests/platform/statistics_golden_test.cpp checks the C++ side against the same file)."""
import itertools
import json
import math
import os
import random
import unittest

import numpy as np

from support import REPORTS_DIR
from lockstep_reports.common import fields, statistics
from lockstep_reports.compare import comparison

GOLDEN = os.path.join(REPORTS_DIR.parent, "tests", "fixtures", "statistics", "golden.json")
with open(GOLDEN, encoding="utf-8") as golden_file:
    GOLDEN_CASES = json.load(golden_file)


class Golden(unittest.TestCase):
    def assert_near(self, actual, expected):
        # Within the file's relative tolerance: numpy's interpolation and the rule's differ by a few ulp.
        self.assertTrue(math.isclose(actual, expected, rel_tol=GOLDEN_CASES["tolerance"], abs_tol=0.0),
                        f"{actual!r} is not {expected!r}")

    def test_medians_and_quantiles(self):
        self.assertTrue(GOLDEN_CASES["samples"])
        for sample in GOLDEN_CASES["samples"]:
            with self.subTest(sample["name"]):
                self.assert_near(statistics.median(sample["values"]), sample["median"])
                for q, expected in sample["quantiles"]:
                    self.assert_near(statistics.quantile(sample["values"], q), expected)

    def test_bootstrap_intervals_over_the_files_resamples(self):
        self.assertTrue(GOLDEN_CASES["bootstraps"])
        for case in GOLDEN_CASES["bootstraps"]:
            with self.subTest(case["name"]):
                low, high = statistics.bootstrap_interval(case["values"], case["resamples"], case["confidence"])
                self.assert_near(statistics.median(case["values"]), case["median"])
                self.assert_near(low, case["low"])
                self.assert_near(high, case["high"])

    def assert_within_ulps(self, actual, expected):
        # Within the file's seeded_ulps: the same draws and expressions give the same bits, a fused multiply-add
        # on the C++ side may move an interpolated end by one ulp (platform/statistics.hpp).
        ulps = GOLDEN_CASES["seeded_ulps"]
        self.assertTrue(abs(actual - expected) <= ulps * math.ulp(expected), f"{actual!r} is not {expected!r}")

    def test_the_seeded_draws_are_splitmix64_mapped_by_multiply_shift(self):
        self.assertTrue(GOLDEN_CASES["draws"])
        for case in GOLDEN_CASES["draws"]:
            with self.subTest(seed=case["seed"], n=case["n"]):
                count = len(case["outputs"])
                outputs = list(itertools.islice(statistics._splitmix64(case["seed"]), count))
                self.assertEqual(outputs, case["outputs"])
                self.assertEqual([statistics._index_of(output, case["n"]) for output in outputs], case["indices"])
                if case["n"] <= count:  # resample after resample, index after index
                    resamples = statistics.bootstrap_indices(case["n"], count // case["n"], case["seed"])
                    flat = [index for indices in resamples for index in indices]
                    self.assertEqual(flat, case["indices"][:len(flat)])

    def test_seeded_bootstrap_medians(self):
        self.assertTrue(GOLDEN_CASES["seeded"])
        for case in GOLDEN_CASES["seeded"]:
            with self.subTest(case["name"]):
                median, low, high = statistics.bootstrap_median(case["values"], case["confidence"],
                                                                case["resamples"], case["seed"])
                self.assert_within_ulps(median, case["median"])
                self.assert_within_ulps(low, case["low"])
                self.assert_within_ulps(high, case["high"])

    def test_verdicts(self):
        self.assertTrue(GOLDEN_CASES["verdicts"])
        for case in GOLDEN_CASES["verdicts"]:
            with self.subTest(case["name"]):
                self.assertEqual(statistics.verdict(case["low"], case["high"], case["noise"]), case["verdict"])

    def test_compare_says_the_same_verdicts_in_its_words(self):
        words = {"penalty": "slower", "gain": "faster", "within noise": "within noise", "unsure": "unsure"}
        for case in GOLDEN_CASES["verdicts"]:
            with self.subTest(case["name"]):
                self.assertEqual(comparison.verdict_of((case["low"], case["high"]), 100.0 * case["noise"]),
                                 words[case["verdict"]])
        self.assertEqual(comparison.verdict_of(None, 5.0), "untested")

    # One ratio with no interval against the band [1 / (1 + noise), 1 + noise], an end on an edge inside
    # (statistics.beyond_noise): each edge, and the doubles either side of it, written out as the golden file
    # writes its verdict cases.
    SINGLE_RATIOS = [
        # (name, ratio, noise, beyond)
        ("one", 1.0, 0.05, False),
        ("on the upper edge", 1.05, 0.05, False),
        ("one double below the upper edge", 1.0499999999999998, 0.05, False),
        ("one double above the upper edge", 1.0500000000000003, 0.05, True),
        ("on the lower edge", 0.9523809523809523, 0.05, False),
        ("one double above the lower edge", 0.9523809523809524, 0.05, False),
        ("one double below the lower edge", 0.9523809523809522, 0.05, True),
        ("on the upper edge of 1 %", 1.01, 0.01, False),
        ("one double below the upper edge of 1 %", 1.0099999999999998, 0.01, False),
        ("one double above the upper edge of 1 %", 1.0100000000000002, 0.01, True),
        ("on the lower edge of 1 %", 0.9900990099009901, 0.01, False),
        ("one double above the lower edge of 1 %", 0.9900990099009902, 0.01, False),
        ("one double below the lower edge of 1 %", 0.99009900990099, 0.01, True),
        ("far above", 2.0, 0.05, True),
        ("far below", 0.5, 0.05, True),
        ("not a number: not inside", math.nan, 0.05, True),
    ]

    def test_a_single_ratio_beyond_the_noise_band(self):
        for noise in (0.05, 0.01):  # the cases hold each edge of each band and the doubles either side of it
            ratios = {ratio for _, ratio, case_noise, _ in self.SINGLE_RATIOS if case_noise == noise}
            for edge in (1.0 + noise, 1.0 / (1.0 + noise)):
                self.assertLessEqual({edge, math.nextafter(edge, 0.0), math.nextafter(edge, 2.0)}, ratios)
        for name, ratio, noise, beyond in self.SINGLE_RATIOS:
            with self.subTest(name):
                self.assertIs(statistics.beyond_noise(ratio, noise), beyond)
                # The same band as an interval's verdict: [ratio, ratio] is penalty or gain exactly when beyond.
                self.assertEqual(statistics.verdict(ratio, ratio, noise) in (statistics.PENALTY, statistics.GAIN),
                                 beyond and not math.isnan(ratio))

    def test_the_inverse_of_a_verdict(self):
        self.assertEqual([statistics.inverse_verdict(word) for word in statistics.VERDICTS],
                         [statistics.GAIN, statistics.PENALTY, statistics.WITHIN_NOISE, statistics.UNSURE])
        # Away from the edges, the verdict of the interval read the other way round, [1 / high, 1 / low], is the
        # inverse word (on an edge, 1 / x may round to either side: lockstep run mirrors the word instead).
        for low, high in ((1.1, 1.3), (0.8, 0.9), (0.98, 1.03), (1.02, 1.12), (0.9, 0.97), (0.9, 1.2)):
            with self.subTest(low=low, high=high):
                self.assertEqual(statistics.inverse_verdict(statistics.verdict(low, high, 0.05)),
                                 statistics.verdict(1.0 / high, 1.0 / low, 0.05))


class Statistics(unittest.TestCase):
    def test_quantiles_agree_with_numpy_on_random_values(self):
        rng = np.random.default_rng(11)
        for count in (1, 2, 3, 10, 101):
            values = rng.lognormal(5.0, 1.0, count)
            for q in (0.0, 0.01, 0.5, 0.99, 0.999, 1.0):
                self.assertTrue(math.isclose(statistics.quantile(values, q), float(np.quantile(values, q)),
                                             rel_tol=1e-12))
            self.assertEqual(statistics.median(values), float(np.median(values)))

    def test_the_seeded_bootstrap_is_deterministic_and_brackets_the_median(self):
        ratios = [1.02, 0.97, 1.10, 1.01, 0.99, 1.05, 1.03]
        first = statistics.bootstrap_median(ratios, 0.95, 2000, 7)
        self.assertEqual(first, statistics.bootstrap_median(ratios, 0.95, 2000, 7))
        median, low, high = first
        self.assertEqual(median, 1.02)
        self.assertLessEqual(low, median)
        self.assertGreaterEqual(high, median)
        self.assertEqual(statistics.bootstrap_median([1.5]), (1.5, 1.5, 1.5))

    def test_bad_input_is_refused(self):
        with self.assertRaises(ValueError):
            statistics.median([])
        with self.assertRaises(ValueError):
            statistics.quantile([1.0], 1.5)
        with self.assertRaises(ValueError):
            statistics.bootstrap_interval([1.0, 2.0], [[0, 2]])
        with self.assertRaises(ValueError):
            statistics.bootstrap_interval([1.0, 2.0], [[0]])
        with self.assertRaises(ValueError):
            statistics.bootstrap_interval([1.0, 2.0], [[0, 1]], 1.0)

    def test_a_result_files_pair_verdict_is_one_of_the_rules(self):
        self.assertEqual(fields.PAIR_VERDICTS, statistics.VERDICTS)


if __name__ == "__main__":
    unittest.main()


class PooledEvidence(unittest.TestCase):
    """The helpers behind compare's aggregate verdict and pooled intervals, on seeded data."""

    def test_the_geometric_mean_interval_is_seeded_and_covers_a_known_shift(self):
        noise = random.Random(7)
        ratios = [1.15 * math.exp(noise.gauss(0.0, 0.05)) for _ in range(100)]
        first = statistics.geometric_mean_interval(ratios, statistics.seed_of("all"))
        self.assertEqual(first, statistics.geometric_mean_interval(ratios, statistics.seed_of("all")))
        mean, low, high = first
        self.assertAlmostEqual(mean, statistics.geometric_mean(ratios))
        self.assertLess(low, 1.15)
        self.assertGreater(high, 1.15)
        self.assertEqual(statistics.verdict(low, high, 0.05), statistics.PENALTY)
        same = [math.exp(noise.gauss(0.0, 0.05)) for _ in range(100)]
        self.assertEqual(statistics.verdict(*statistics.geometric_mean_interval(same, 1)[1:], 0.05),
                         statistics.WITHIN_NOISE)

    def test_the_detectable_change_at_a_known_spread(self):
        # An interval of half-width 10 % (log) at the 5 % band: 1.05 e^0.1 - 1.
        self.assertAlmostEqual(statistics.detectable_change((math.exp(-0.1), math.exp(0.1)), 0.05),
                               1.05 * math.exp(0.1) - 1.0)
        self.assertIsNone(statistics.detectable_change(None, 0.05))
        # A pooled interval with no drift: sampling variance s^2 (1/5 + 1/5), t with 8 degrees.
        low, high = statistics.pooled_interval(0.0, 0.1 ** 2 * 0.4, 8, 0.0)
        self.assertAlmostEqual(math.log(high), 2.306004 * 0.1 * 0.4 ** 0.5, places=5)
        self.assertAlmostEqual(statistics.detectable_change((low, high), 0.05),
                               1.05 * math.exp(2.306004 * 0.1 * 0.4 ** 0.5) - 1.0, places=5)

    def test_the_drift_is_calibrated_from_the_spread_beyond_the_sampling(self):
        noise = random.Random(11)
        logs = [noise.gauss(0.0, (0.02 ** 2 + 0.04 ** 2) ** 0.5) for _ in range(400)]
        self.assertAlmostEqual(statistics.calibrated_drift(logs, [0.02 ** 2] * 400), 0.04, delta=0.008)
        self.assertEqual(statistics.calibrated_drift([0.0] * 400, [0.02 ** 2] * 400), 0.0)
        self.assertEqual(statistics.calibrated_drift(logs[:5], [0.02 ** 2] * 5), 0.0)  # too few to calibrate

    def test_the_prior_of_variances_and_the_moderated_variance(self):
        noise = random.Random(3)
        # 200 variances of 8 degrees each from one true variance 0.01: the prior finds it, and is strong.
        variances = [0.01 * sum(noise.gauss(0.0, 1.0) ** 2 for _ in range(8)) / 8 for _ in range(200)]
        s0, d0 = statistics.prior_variance(variances, [8] * 200)
        self.assertAlmostEqual(s0, 0.01, delta=0.002)
        self.assertGreater(d0, 30)
        moderated, degrees = statistics.moderated_variance(0.04, 8, (0.01, 24.0))
        self.assertAlmostEqual(moderated, (24 * 0.01 + 8 * 0.04) / 32)
        self.assertEqual(degrees, 32)
        self.assertIsNone(statistics.prior_variance(variances[:5], [8] * 5))

    def test_the_cluster_interval_reads_a_block_of_drifting_clusters_as_spread(self):
        noise = random.Random(5)

        def clusters(shift, drifts):
            return [[shift * math.exp(drift + noise.gauss(0.0, 0.03)) for _ in range(8)] for drift in drifts]

        # 12 clusters of 8 ratios; a shift common to every cluster stays tight and is called.
        uniform = clusters(1.15, [0.0] * 12)
        mean, low, high = statistics.cluster_geometric_mean_interval(uniform, statistics.seed_of("all"))
        self.assertEqual((mean, low, high), statistics.cluster_geometric_mean_interval(uniform, statistics.seed_of("all")))
        self.assertAlmostEqual(mean, statistics.geometric_mean([r for cluster in uniform for r in cluster]))
        self.assertLess(low, 1.15)
        self.assertGreater(high, 1.15)
        self.assertGreater(low, 1.12)
        self.assertEqual(statistics.verdict(low, high, 0.05), statistics.PENALTY)
        # A third of the clusters moved 30 % together, the rest not at all: the entries' bootstrap calls it
        # slower, the clusters' sees the block as spread.
        block = clusters(1.0, [math.log(1.3)] * 4 + [0.0] * 8)
        flat = [r for cluster in block for r in cluster]
        self.assertEqual(statistics.verdict(*statistics.geometric_mean_interval(flat, 1)[1:], 0.05), statistics.PENALTY)
        self.assertEqual(statistics.verdict(*statistics.cluster_geometric_mean_interval(block, 1)[1:], 0.05),
                         statistics.UNSURE)
        # One cluster borrows the spread of whole clusters it cannot show on its own.
        alone = statistics.cluster_geometric_mean_interval(block[4:5], 1)
        borrowed = statistics.cluster_geometric_mean_interval(block[4:5], 1, borrowed=[0.2, -0.1, -0.1])
        self.assertEqual(alone[0], borrowed[0])
        self.assertLess(borrowed[1], alone[1])
        self.assertGreater(borrowed[2], alone[2])
        self.assertIsNone(statistics.cluster_geometric_mean_interval([[], [float("nan")]], 1))
        self.assertEqual(statistics.cluster_geometric_mean_interval([[1.2]], 1), (1.2, 1.2, 1.2))
