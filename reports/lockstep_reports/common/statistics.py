"""The statistics of the report tools, each chosen so the output is deterministic.

The shared vocabulary, defined in platform/statistics.hpp and here alike (tests/fixtures/statistics/golden.json
holds both to the same answers: tests/platform/statistics_golden_test.cpp, reports/tests/test_statistics.py):

- quantile: linear interpolation between closest ranks (Hyndman and Fan 7, numpy.quantile's default):
  h = (n - 1) q, Q(q) = x[floor h] + (h - floor h) (x[floor h + 1] - x[floor h]) over the sorted values.
- median: the middle value of an odd count, the mean of the two middle values of an even count (numpy.median;
  Q(0.5) up to rounding).
- bootstrap interval of a median (percentile bootstrap): the median of each resample (n indices drawn with
  replacement), and [Q((1 - c) / 2), Q(1 - (1 - c) / 2)] of those medians at confidence c. bootstrap_interval
  takes the resamples' indices; bootstrap_median draws them by the one portable rule (bootstrap_indices):
  splitmix64 started at the seed, an output x giving the index (x n) >> 64 in [0, n), resample after resample,
  index after index. lockstep run draws its pairs' intervals the same way (PAIR_RESAMPLES resamples from
  PAIR_SEED), so bootstrap_median(ratios, confidence, PAIR_RESAMPLES, PAIR_SEED) recomputes a run file's interval
  from its ratios: the same integers, the same IEEE expressions in the same order, the same bits on x86-64
  (reports/tests/test_run_fixture.py; the golden tests allow 1 ulp for a C++ compiler that fuses a multiply-add).
- verdict of a ratio's interval [low, high] against the noise band [1 / (1 + noise), 1 + noise]: penalty (the
  whole interval above the band), gain (wholly below it), within noise (wholly inside it, an end on an edge
  counting as inside), unsure (anything else: it straddles an edge). compare.py says "slower" / "faster" for
  penalty / gain of B/A.

Besides, for comparing two runs:

- The interval of B/A that decides a verdict: the exact distribution-free
  confidence interval of the scale shift between the two sides' repetitions
  (Mann-Whitney U inverted, on log time: Hodges-Lehmann / Bauer 1972). Of the
  m x n ratios b_j / a_i it keeps the k-th smallest to the k-th largest, k
  the largest rank with P(U < k) <= (1 - CONFIDENCE) / 2 under no shift, so its
  coverage is at least CONFIDENCE for any distribution of times, with as few as
  5 repetitions a side (5 against 5: the 3rd to the 23rd of the 25 ratios,
  96.8 %). No resampling: the same repetitions give the same interval in any
  order. Fewer than 4 a side cannot reach 95 %: no interval (untested).
- Ratio of medians B/A, the figure shown (the geometric mean is taken of it).
- A percentile bootstrap interval of the ratio of medians (ratio_interval),
  kept for tools that want one; compare's verdicts use the exact interval,
  whose coverage holds for 5 repetitions, where the bootstrap's falls short.
- Mann-Whitney U, two-sided (scipy), when each side has at least
  MIN_REPETITIONS repetitions. With 5 against 5 the smallest two-sided p is
  2/252 = 0.008.
- Benjamini-Hochberg's adjustment over the tests of one comparison of two
  files (q-values): it controls the expected share of false discoveries among
  the entries called different, which fits hundreds of related tests; Holm's
  family-wise control multiplies 5 against 5's smallest p, 0.008, past 0.05
  as soon as there are 7 tests, so it could never call anything in a matrix.
- Geometric mean of the ratios over matched pairs only; with an interval (geometric_mean_interval): the
  percentile bootstrap of the mean log ratio over the entries (bootstrap_indices from a seed per group), so
  the entry-to-entry spread, drift included, is in it. compare's aggregates resample in two stages
  (cluster_geometric_mean_interval): clusters of entries that drift together between runs, then the entries
  of each drawn cluster, so that a block of clusters that moved reads as spread rather than as a change. The
  drift common to every entry of a run is what the noise band stands for.
- An entry's interval from the whole file pair's evidence (pooled_interval): the log ratio of the medians
  with a t interval whose variance is (1) the entry's own variance of log times, moderated towards the
  file pair's typical variance (Smyth 2004, limma's empirical Bayes: prior_variance fits a scaled inverse
  chi-square prior to every entry's variance, so an entry of 3 repetitions a side borrows the degrees of
  freedom of hundreds), over the repetitions, plus (2) the drift between the runs, calibrated from the file
  pair (calibrated_drift: the variance the entries' log ratios spread by around their median beyond what
  their own variances explain, robustly: the median of the standardised squares set to chi-square(1)'s).
  Repetitions inside a run cannot see the drift; (2) puts it back, so an A/A pair stays specific.
- The smallest detectable change of an interval (detectable_change): the band edge times the interval's
  half-width, (1 + noise) exp(log(high / low) / 2) - 1: no shift smaller than that could have put an
  interval this wide wholly beyond the band.
"""
from __future__ import annotations

import functools
import math
import zlib

import numpy as np

BOOTSTRAP_RESAMPLES = 2000
CONFIDENCE = 0.95
MIN_REPETITIONS = 5
# The exact interval's null distribution is built in O(m n (m + n)); beyond this many repetitions a side
# (never written by lockstep run) there is no interval.
MAX_EXACT = 200
BASE_SEED = 20260101
# The resamples and seed of a run file's pair intervals: bench/results/paired_ratio.hpp's kBootstrapResamples and
# kBootstrapSeed (the file does not carry them; tests/fixtures/run/quick-pairs.json pins both sides to them).
PAIR_RESAMPLES = 4000
PAIR_SEED = 0x5EED1234

_MASK64 = (1 << 64) - 1


def median(values) -> float:
    """The median, as numpy computes it (the mean of the two middle values of an even count), without
    numpy's overhead: the tools take it of a handful of repetitions, thousands of times per report."""
    ordered = sorted(float(value) for value in values)
    if not ordered:
        raise ValueError("the median of no values")
    middle = len(ordered) // 2
    return ordered[middle] if len(ordered) % 2 else (ordered[middle - 1] + ordered[middle]) / 2.0


def quantile(values, q: float) -> float:
    """Q(q) of the values, in any order, by the rule above; ValueError on no values or q outside [0, 1]."""
    ordered = sorted(float(value) for value in values)
    if not ordered:
        raise ValueError("the quantile of no values")
    return _quantile_of_sorted(ordered, q)


def _quantile_of_sorted(ordered, q: float) -> float:
    if not 0.0 <= q <= 1.0:
        raise ValueError(f"quantile fraction {q!r} outside [0, 1]")
    rank = q * (len(ordered) - 1)
    below = math.floor(rank)
    above = min(below + 1, len(ordered) - 1)
    low, high = float(ordered[below]), float(ordered[above])
    return low + (rank - below) * (high - low)


def percentile_interval(estimates, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """[Q((1 - c) / 2), Q(1 - (1 - c) / 2)] of a bootstrap's estimates: the percentile interval."""
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence {confidence!r} outside (0, 1)")
    ordered = sorted(float(value) for value in estimates)
    if not ordered:
        raise ValueError("the interval of no estimates")
    tail = (1.0 - confidence) / 2.0
    return _quantile_of_sorted(ordered, tail), _quantile_of_sorted(ordered, 1.0 - tail)


def bootstrap_interval(values, resamples, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The percentile bootstrap interval of the median of `values` over the given resamples, each a list of
    len(values) indices into them; no resamples: (median, median). ValueError on bad indices."""
    values = [float(value) for value in values]
    whole = median(values)
    resamples = [list(indices) for indices in resamples]
    if not resamples:
        return whole, whole
    for indices in resamples:
        if len(indices) != len(values):
            raise ValueError("a resample of another length than the values")
        if any(not 0 <= index < len(values) for index in indices):
            raise ValueError("a resample index beyond the values")
    return percentile_interval([median([values[index] for index in indices]) for indices in resamples],
                               confidence)


def _splitmix64(seed: int):
    """splitmix64's outputs from `seed` (mod 2^64), without end (platform/statistics.hpp, bootstrap_draws)."""
    state = seed & _MASK64
    while True:
        state = (state + 0x9E3779B97F4A7C15) & _MASK64
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK64
        yield z ^ (z >> 31)


def _splitmix64_block(seed: int, count: int, start: int = 0) -> np.ndarray:
    """Outputs start .. start + count - 1 of _splitmix64(seed), at once (uint64): output k is the mix of
    seed + (k + 1) * gamma alone, so a block of the stream needs none of the outputs before it."""
    state = (np.arange(start + 1, start + count + 1, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15)
             + np.uint64(seed & _MASK64))
    z = (state ^ (state >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def _indices_of(outputs: np.ndarray, n) -> np.ndarray:
    """_index_of of each output (n one count, or one per output), exact without 128-bit products: with
    x = h 2^32 + l, (x n) >> 64 = (h n + ((l n) >> 32)) >> 32 for n below 2^32."""
    n = np.asarray(n, dtype=np.uint64)
    if np.any(n >= np.uint64(1 << 32)):
        raise ValueError("draws into 2^32 values or more")
    high, low = outputs >> np.uint64(32), outputs & np.uint64(0xFFFFFFFF)
    return ((high * n + ((low * n) >> np.uint64(32))) >> np.uint64(32)).astype(np.int64)


def _starts(sizes: np.ndarray) -> np.ndarray:
    """Where each of consecutive blocks of these sizes starts: 0, then the running total before each."""
    return np.concatenate(([0], np.cumsum(sizes)[:-1])).astype(np.int64)


def _row_sums(rows: np.ndarray) -> np.ndarray:
    """Each row's sum added left to right, as a Python loop adds it (a cumulative sum's last column): the
    same float, bit for bit, as the per-resample loops these sums replace. Trailing zeros change nothing."""
    if rows.shape[1] == 0:
        return np.zeros(rows.shape[0])
    return np.cumsum(rows, axis=1)[:, -1]


def _index_of(output: int, n: int) -> int:
    """An output x of the generator as an index in [0, n): (x n) >> 64 (Lemire's multiply-shift)."""
    return (output * n) >> 64


def bootstrap_indices(n: int, resamples: int, seed: int) -> list[list[int]]:
    """The seeded bootstrap's draws (platform/statistics.hpp, bootstrap_draws): `resamples` lists of n indices in
    [0, n), from splitmix64 started at `seed`, each output x mapped to (x n) >> 64, resample after resample, index
    after index."""
    return _bootstrap_draws(n, resamples, seed).tolist()


def _bootstrap_draws(n: int, resamples: int, seed: int) -> np.ndarray:
    """bootstrap_indices as an array of `resamples` rows of n indices."""
    if n < 1:
        raise ValueError("draws into no values")
    return _indices_of(_splitmix64_block(seed, n * resamples), n).reshape(resamples, n)


def bootstrap_median(values, confidence: float = CONFIDENCE, resamples: int = BOOTSTRAP_RESAMPLES,
                     seed: int = BASE_SEED) -> tuple[float, float, float]:
    """(median, low, high): the median and its bootstrap interval over `resamples` resamples drawn by
    bootstrap_indices from `seed`, platform::bootstrap_median's rule and draws. One value or no resamples: the
    interval is the median; no values: ValueError."""
    values = [float(value) for value in values]
    whole = median(values)
    if len(values) < 2 or resamples == 0:
        return whole, whole, whole
    low, high = bootstrap_interval(values, bootstrap_indices(len(values), resamples, seed), confidence)
    return whole, low, high


PENALTY, GAIN, WITHIN_NOISE, UNSURE = "penalty", "gain", "within noise", "unsure"
VERDICTS = (PENALTY, GAIN, WITHIN_NOISE, UNSURE)


def verdict(low: float, high: float, noise: float) -> str:
    """The interval [low, high] of a ratio against the noise band of half-width `noise` (a fraction: 0.05 is
    5 %), by the rule above: penalty, gain, within noise or unsure."""
    upper_edge = 1.0 + noise
    lower_edge = 1.0 / upper_edge
    if low > upper_edge:
        return PENALTY
    if high < lower_edge:
        return GAIN
    if low >= lower_edge and high <= upper_edge:
        return WITHIN_NOISE
    return UNSURE


def beyond_noise(ratio: float, noise: float) -> bool:
    """Whether a single ratio, with no interval, lies outside the noise band [1 / (1 + noise), 1 + noise] (an
    end on an edge counting as inside, as in verdict; a NaN is not inside). The verdict of the interval
    [ratio, ratio]: penalty or gain."""
    return verdict(ratio, ratio, noise) != WITHIN_NOISE


def inverse_verdict(word: str) -> str:
    """The verdict of a ratio read the other way round (1 / ratio, its interval [1 / high, 1 / low]): penalty
    and gain swapped, within noise and unsure (and any other word) unchanged. Mirrored, not recomputed, as
    lockstep run mirrors it (bench/results/paired_ratio.hpp, inverse): the band is symmetric on a log scale, and
    rounding at its edge cannot make the two directions of one comparison disagree."""
    return {PENALTY: GAIN, GAIN: PENALTY}.get(word, word)


def _resample_medians(ordered: list[float], outputs: np.ndarray) -> list[float]:
    """The median of each resample of the sorted values drawn by `outputs` (len(ordered) draws a resample),
    as median() takes it: the values of the sorted indices are sorted too."""
    n = len(ordered)
    drawn = np.sort(_indices_of(outputs, n).reshape(-1, n), axis=1)
    values = np.asarray(ordered, dtype=float)
    middle = n // 2
    if n % 2:
        return values[drawn[:, middle]].tolist()
    return ((values[drawn[:, middle - 1]] + values[drawn[:, middle]]) / 2.0).tolist()


def ratio_interval(a, b, name: str) -> tuple[float, float] | None:
    """Percentile bootstrap interval of median(b)/median(a); None with fewer than 2 values a side.
    Each side is sorted first, so the interval does not depend on the order of the repetitions in a file. The
    draws are bootstrap_median's rule from one seed per name: a's resamples, then b's from the same generator."""
    a = sorted(float(value) for value in a)
    b = sorted(float(value) for value in b)
    if len(a) < 2 or len(b) < 2:
        return None
    seed = BASE_SEED + zlib.crc32(name.encode("utf-8"))
    draws_a = len(a) * BOOTSTRAP_RESAMPLES
    medians_a = _resample_medians(a, _splitmix64_block(seed, draws_a))
    medians_b = _resample_medians(b, _splitmix64_block(seed, len(b) * BOOTSTRAP_RESAMPLES, start=draws_a))
    ratios = [of_b / of_a for of_a, of_b in zip(medians_a, medians_b) if of_a != 0.0]
    ratios = [ratio for ratio in ratios if math.isfinite(ratio)]
    if not ratios:
        return None
    return percentile_interval(ratios)


@functools.lru_cache(maxsize=None)
def _u_null_cdf(m: int, n: int) -> tuple[float, ...]:
    """P(U <= u) for u = 0..m*n under no shift (U = how many of the m*n pairs have b below a), exact: the
    recurrence P_{m,n}(u) = m/(m+n) P_{m-1,n}(u-n) + n/(m+n) P_{m,n-1}(u)."""
    table = {}
    for i in range(m + 1):
        for j in range(n + 1):
            if i == 0 or j == 0:
                table[i, j] = np.ones(1)
                continue
            current = np.zeros(i * j + 1)
            current[j:j + (i - 1) * j + 1] += i / (i + j) * table[i - 1, j]
            current[: i * (j - 1) + 1] += j / (i + j) * table[i, j - 1]
            table[i, j] = current
    return tuple(np.cumsum(table[m, n]))


def shift_interval(a, b, confidence: float = CONFIDENCE) -> tuple[float, float] | None:
    """The exact distribution-free interval of the scale shift B/A (Mann-Whitney U inverted on log times);
    None when the sides are too small to reach `confidence` (or larger than MAX_EXACT a side)."""
    m, n = len(a), len(b)
    if m < 1 or n < 1 or max(m, n) > MAX_EXACT:
        return None
    cdf = _u_null_cdf(m, n)
    tail = (1.0 - confidence) / 2.0
    k = 0  # the number of ratios cut off each end: the largest k with P(U <= k - 1) <= tail
    while k < len(cdf) and cdf[k] <= tail:
        k += 1
    if k == 0:
        return None
    logs_a = np.log(np.asarray(a, dtype=float))
    logs_b = np.log(np.asarray(b, dtype=float))
    differences = np.sort((logs_b[None, :] - logs_a[:, None]).ravel())
    return float(np.exp(differences[k - 1])), float(np.exp(differences[m * n - k]))


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


def benjamini_hochberg(p_values: list[float | None]) -> list[float | None]:
    """Benjamini-Hochberg q-values (None stays None): q_(i) = min over j >= i of m p_(j) / j, capped at 1;
    monotone in the raw p."""
    tested = sorted((p, index) for index, p in enumerate(p_values) if p is not None)
    count = len(tested)
    adjusted: list[float | None] = [None] * len(p_values)
    running = 1.0
    for rank in range(count, 0, -1):
        p, index = tested[rank - 1]
        running = min(running, count * p / rank)
        adjusted[index] = running
    return adjusted


def geometric_mean(ratios) -> float | None:
    values = [r for r in ratios if r is not None and math.isfinite(r) and r > 0]
    if not values:
        return None
    return float(math.exp(sum(math.log(r) for r in values) / len(values)))


# The pooled interval (pooled_interval) needs the variances of this many entries to fit its prior; with
# fewer, compare keeps each entry's exact interval.
MIN_POOLED_ENTRIES = 10


def _trigamma_inverse(value: float) -> float:
    """y with trigamma(y) = value (limma's Newton iteration, from y = 0.5 + 1 / value)."""
    from scipy import special

    y = 0.5 + 1.0 / value
    for _ in range(50):
        trigamma = float(special.polygamma(1, y))
        step = trigamma * (1.0 - trigamma / value) / float(special.polygamma(2, y))
        y += step
        if -step / y < 1e-8:
            break
    return y


def prior_variance(variances, degrees) -> tuple[float, float] | None:
    """(s0^2, d0): the scaled inverse chi-square prior of a family of variances, each with its degrees of
    freedom (limma's fitFDist, by moments of log s^2); d0 is infinite when the variances spread no more than
    their sampling does. Only positive variances with degrees >= 1 count; None with fewer than
    MIN_POOLED_ENTRIES of them."""
    from scipy import special

    pairs = [(float(v), float(d)) for v, d in zip(variances, degrees) if v is not None and v > 0 and d >= 1]
    if len(pairs) < MIN_POOLED_ENTRIES:
        return None
    logs = np.array([math.log(v) for v, _ in pairs])
    halves = np.array([d / 2.0 for _, d in pairs])
    centred = logs - special.digamma(halves) + np.log(halves)
    mean = float(centred.mean())
    excess = float(((centred - mean) ** 2).sum() / (len(pairs) - 1) - special.polygamma(1, halves).mean())
    if excess <= 0:
        return math.exp(mean), math.inf
    d0 = 2.0 * _trigamma_inverse(excess)
    return math.exp(mean + float(special.digamma(d0 / 2.0)) - math.log(d0 / 2.0)), d0


def moderated_variance(variance: float | None, degrees: float, prior: tuple[float, float]) -> tuple[float, float]:
    """(posterior variance, its degrees of freedom): the entry's variance shrunk towards the prior,
    (d0 s0^2 + d s^2) / (d0 + d) with d0 + d degrees; no variance of its own (d = 0): the prior's."""
    s0, d0 = prior
    own = variance if (variance is not None and degrees >= 1) else 0.0
    degrees = degrees if variance is not None else 0.0
    if math.isinf(d0):
        return s0, math.inf
    return (d0 * s0 + degrees * own) / (d0 + degrees), d0 + degrees


def calibrated_drift(log_ratios, variances) -> float:
    """The drift's standard deviation (log scale) between two runs, from every entry's log ratio and its
    sampling variance: the tau >= 0 for which the median of (x - median x)^2 / (variance + tau^2) is
    chi-square(1)'s median, 0 when the variances alone explain the spread. Robust: a minority of entries that
    really changed moves the median little."""
    from scipy import optimize, stats

    values = np.asarray(log_ratios, dtype=float)
    spreads = np.asarray(variances, dtype=float)
    if len(values) < MIN_POOLED_ENTRIES:
        return 0.0
    squares = (values - np.median(values)) ** 2
    target = float(stats.chi2.ppf(0.5, 1))

    def excess(tau):
        return float(np.median(squares / (spreads + tau * tau))) - target

    if excess(0.0) <= 0:
        return 0.0
    high = 1.0
    while excess(high) > 0:
        high *= 2.0
    return float(optimize.brentq(excess, 0.0, high, xtol=1e-9))


def pooled_interval(log_ratio: float, variance: float, degrees: float, drift: float,
                    confidence: float = CONFIDENCE) -> tuple[float, float]:
    """exp(log_ratio -+ t sqrt(variance + drift^2)), t the two-sided quantile of Student's t with `degrees`
    (the normal's when infinite): an entry's interval of B/A from its moderated sampling variance of the log
    ratio and the calibrated drift."""
    from scipy import stats

    quantile = 0.5 + confidence / 2.0
    t = float(stats.norm.ppf(quantile)) if math.isinf(degrees) else float(stats.t.ppf(quantile, degrees))
    half = t * math.sqrt(variance + drift * drift)
    return math.exp(log_ratio - half), math.exp(log_ratio + half)


def geometric_mean_interval(ratios, seed: int, confidence: float = CONFIDENCE,
                            resamples: int = BOOTSTRAP_RESAMPLES) -> tuple[float, float, float] | None:
    """(geometric mean, low, high) of positive finite ratios: the percentile bootstrap interval of the mean log
    ratio over resamples of the entries (bootstrap_indices from `seed`). One ratio: the interval is the ratio
    itself (no spread to resample: the caller says so); none: None."""
    logs = [math.log(r) for r in ratios if r is not None and math.isfinite(r) and r > 0]
    if not logs:
        return None
    whole = math.exp(sum(logs) / len(logs))
    if len(logs) < 2:
        return whole, whole, whole
    means = (_row_sums(np.asarray(logs)[_bootstrap_draws(len(logs), resamples, seed)]) / len(logs)).tolist()
    low, high = percentile_interval(means, confidence)
    return whole, math.exp(low), math.exp(high)


def cluster_geometric_mean_interval(clusters, seed: int, confidence: float = CONFIDENCE,
                                    resamples: int = BOOTSTRAP_RESAMPLES,
                                    borrowed=()) -> tuple[float, float, float] | None:
    """(geometric mean, low, high) of the positive finite ratios of `clusters` (lists of ratios that drift
    together between two runs: one primitive at one thread count), with the percentile interval of a
    two-stage bootstrap: each resample draws as many clusters as there are, with replacement, then within
    each drawn cluster as many of its ratios as it holds, and takes the mean log ratio of everything drawn.
    A block of clusters that moved together reads as spread; a shift common to every cluster stays tight.

    `borrowed`: the centred mean log ratios of the clusters of a wider family (the whole file pair), for a
    group of too few clusters to show their spread: each resample adds the mean of len(clusters) draws from
    them, the drift a group of that many clusters would share. Draws: splitmix64 from `seed` (bootstrap_indices'
    rule), per resample the clusters, then each drawn cluster's ratios in turn, then the borrowed ones.
    None with no ratio; one ratio: the interval is the ratio itself."""
    groups = [[math.log(r) for r in cluster if r is not None and math.isfinite(r) and r > 0] for cluster in clusters]
    groups = [group for group in groups if group]
    if not groups:
        return None
    every = [value for group in groups for value in group]
    whole = math.exp(sum(every) / len(every))
    borrowed = [float(value) for value in borrowed]
    if len(every) < 2 and not borrowed:
        return whole, whole, whole
    means = _cluster_resample_means(groups, borrowed, seed, resamples)
    low, high = percentile_interval(means, confidence)
    return whole, math.exp(low), math.exp(high)


def _cluster_resample_means(groups: list[list[float]], borrowed: list[float], seed: int,
                            resamples: int) -> list[float]:
    """The resamples' mean log ratios of cluster_geometric_mean_interval, its draws in its order: per resample,
    a cluster, then that many of its values, cluster after cluster, then len(groups) borrowed values. Where a
    cluster's draw starts depends on the sizes drawn before it, so the walk over clusters is a loop; the values
    are gathered and summed at once, each resample's sum in the loop's order (_row_sums)."""
    clusters, lengths = len(groups), np.array([len(group) for group in groups], dtype=np.int64)
    per_resample = clusters * (1 + int(lengths.max())) + (clusters if borrowed else 0)
    outputs = _splitmix64_block(seed, resamples * per_resample)
    picks = _indices_of(outputs, clusters)
    after = (np.arange(outputs.size) + 1 + lengths[picks]).tolist()  # where the draw after a cluster's starts
    draws, borrowed_starts, position = [], [], 0
    for _ in range(resamples):
        for _ in range(clusters):
            draws.append(position)
            position = after[position]
        if borrowed:
            borrowed_starts.append(position)
            position += clusters
    drawn = picks[draws]
    starts = np.asarray(draws) + 1
    drawn_sizes = lengths[drawn]
    within = np.arange(int(drawn_sizes.sum())) - np.repeat(_starts(drawn_sizes), drawn_sizes)
    picked = _indices_of(outputs[np.repeat(starts, drawn_sizes) + within], np.repeat(drawn_sizes, drawn_sizes))
    values = np.concatenate([np.asarray(group, dtype=float) for group in groups])[
        np.repeat(_starts(lengths)[drawn], drawn_sizes) + picked]
    counts = drawn_sizes.reshape(resamples, clusters).sum(axis=1)
    rows = np.zeros((resamples, int(counts.max())))
    column = np.arange(values.size) - np.repeat(_starts(counts), counts)
    rows[np.repeat(np.arange(resamples), counts), column] = values
    means = _row_sums(rows) / counts
    if borrowed:
        at = np.asarray(borrowed_starts)[:, None] + np.arange(clusters)
        means = means + _row_sums(np.asarray(borrowed)[_indices_of(outputs[at], len(borrowed))]) / clusters
    return means.tolist()


def seed_of(name: str) -> int:
    """The bootstrap seed of a named estimate: BASE_SEED + crc32 of the name (ratio_interval's rule)."""
    return BASE_SEED + zlib.crc32(name.encode("utf-8"))


def detectable_change(interval: tuple[float, float] | None, noise: float) -> float | None:
    """The smallest change (a fraction: 0.23 is 23 %) an interval this wide could have shown beyond the noise
    band of half-width `noise`: (1 + noise) sqrt(high / low) - 1. None without an interval."""
    if interval is None or not (interval[0] > 0 and interval[1] >= interval[0]):
        return None
    return (1.0 + noise) * math.sqrt(interval[1] / interval[0]) - 1.0
