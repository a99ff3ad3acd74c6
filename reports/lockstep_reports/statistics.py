"""The statistics of a comparison, each chosen so the output is deterministic.

- Ratio of medians B/A with a percentile bootstrap confidence interval: each
  side sorted, then resampled independently, BOOTSTRAP_RESAMPLES times, from a
  generator seeded by the benchmark's name, so the same files give the same
  interval whatever the order of their entries.
- Mann-Whitney U, two-sided (scipy), when each side has at least
  MIN_REPETITIONS repetitions. With 5 against 5 the smallest two-sided p is
  2/252 = 0.008; with 3 against 3 it is 0.1, so fewer repetitions can never
  show a difference and the test is not run (the comparison says so).
- Holm's step-down correction over the tests of one comparison of two files:
  it controls the chance of any false "significant" (family-wise error), which
  is what a CI gate (--fail-above) needs, and is never less powerful than
  Bonferroni.
- Geometric mean of the ratios over matched pairs only.
"""
from __future__ import annotations

import math
import zlib

import numpy as np

BOOTSTRAP_RESAMPLES = 2000
CONFIDENCE = 0.95
MIN_REPETITIONS = 5
BASE_SEED = 20260101


def median(values) -> float:
    """The median, as numpy computes it (the mean of the two middle values of an even count), without
    numpy's overhead: the tools take it of a handful of repetitions, thousands of times per report."""
    ordered = sorted(float(value) for value in values)
    if not ordered:
        raise ValueError("the median of no values")
    middle = len(ordered) // 2
    return ordered[middle] if len(ordered) % 2 else (ordered[middle - 1] + ordered[middle]) / 2.0


def ratio_interval(a, b, name: str) -> tuple[float, float] | None:
    """Percentile bootstrap interval of median(b)/median(a); None with fewer than 2 values a side.
    Each side is sorted first, so the interval does not depend on the order of the repetitions in a file."""
    a = np.sort(np.asarray(a, dtype=float))
    b = np.sort(np.asarray(b, dtype=float))
    if a.size < 2 or b.size < 2:
        return None
    rng = np.random.default_rng(BASE_SEED + zlib.crc32(name.encode("utf-8")))
    medians_a = np.median(a[rng.integers(0, a.size, (BOOTSTRAP_RESAMPLES, a.size))], axis=1)
    medians_b = np.median(b[rng.integers(0, b.size, (BOOTSTRAP_RESAMPLES, b.size))], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = medians_b / medians_a
    ratios = ratios[np.isfinite(ratios)]
    if ratios.size == 0:
        return None
    tail = (1.0 - CONFIDENCE) / 2.0 * 100.0
    low, high = np.percentile(ratios, [tail, 100.0 - tail])
    return float(low), float(high)


def mann_whitney_p(a, b) -> float | None:
    """Two-sided Mann-Whitney U p-value, or None when a side has fewer than MIN_REPETITIONS values."""
    if len(a) < MIN_REPETITIONS or len(b) < MIN_REPETITIONS:
        return None
    from scipy import stats  # here, not at the top: importing scipy.stats takes half a second

    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if np.all(a == a[0]) and np.all(b == a[0]):
        return 1.0
    result = stats.mannwhitneyu(a, b, alternative="two-sided")
    p = float(result.pvalue)
    return p if math.isfinite(p) else 1.0


def smallest_p(count_a: int, count_b: int) -> float:
    """The smallest two-sided p Mann-Whitney U can give for these sample sizes (complete separation)."""
    return min(1.0, 2.0 / math.comb(count_a + count_b, count_a))


def holm(p_values: list[float | None]) -> list[float | None]:
    """Holm-adjusted p-values (None stays None); the adjusted values are monotone in the raw ones."""
    tested = sorted((p, index) for index, p in enumerate(p_values) if p is not None)
    count = len(tested)
    adjusted: list[float | None] = [None] * len(p_values)
    running = 0.0
    for rank, (p, index) in enumerate(tested):
        running = max(running, min(1.0, (count - rank) * p))
        adjusted[index] = running
    return adjusted


def geometric_mean(ratios) -> float | None:
    values = [r for r in ratios if r is not None and math.isfinite(r) and r > 0]
    if not values:
        return None
    return float(math.exp(sum(math.log(r) for r in values) / len(values)))
