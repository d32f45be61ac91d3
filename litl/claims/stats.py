"""The statistics behind the claims' verdicts, from summary statistics alone.

Each side of a comparison is a `Summary`: its mean over seeds, sample standard deviation (n - 1
in the denominator) and seed count. Everything a verdict needs follows from two of them (or one
and a reference value), so the verdict on measured runs (`litl.claims.verdicts.judge`) and the
verdict re-judged from a published claims.csv (`litl.claims.rejudge`) come from the same
functions: a claims.csv's 90% interval gives back its side's standard deviation
(`sd_from_interval`) exactly.

- `welch(a, b)`: mean(a) - mean(b) with Welch's standard error and Welch-Satterthwaite degrees
  of freedom, and the two-sided p-value of Welch's t-test (`scipy.stats.ttest_ind_from_stats`).
- `one_sample(x, reference)`: mean(x) - reference with the one-sample t-test's.
- `Difference`: a difference's two-sided confidence interval, its one-sided p-values against a
  bound (non-inferiority), and the smallest difference its seeds could have detected.
- `holm`: Holm-Bonferroni adjusted p-values of a family of tests.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
from numpy.typing import ArrayLike

from litl.report.stats import t_quantile


@dataclasses.dataclass(frozen=True)
class Summary:
    """One side of a comparison: `mean` and sample standard deviation `sd` over `n` seeds (`sd`
    NaN with fewer than 2)."""

    mean: float
    sd: float
    n: int


def summarize(values: ArrayLike) -> Summary:
    """The `Summary` of the finite entries of `values` (NaN ones are seeds without a value)."""
    array = np.asarray(values, np.float64)
    finite = array[np.isfinite(array)]
    n = len(finite)
    mean = float(finite.mean()) if n else math.nan
    sd = float(finite.std(ddof=1)) if n > 1 else math.nan
    return Summary(mean, sd, n)


def sd_from_interval(mean: float, high: float, n: int, level: float) -> float:
    """The sample standard deviation behind a Student-t interval of a mean: the inverse of
    `litl.report.stats.confidence_band`, whose upper end is mean + t_{(1+level)/2, n-1} s / sqrt(n).

    Returns:
      s, or NaN with fewer than 2 seeds (such a band has no interval).
    """
    if n < 2:
        return math.nan
    return float((high - mean) * math.sqrt(n) / t_quantile((1 + level) / 2, n - 1))


def _t_cdf(t: float, df: float) -> float:
    from scipy.stats import t as student

    return float(student.cdf(t, df))


def _t_sf(t: float, df: float) -> float:
    from scipy.stats import t as student

    return float(student.sf(t, df))


@dataclasses.dataclass(frozen=True)
class Difference:
    """An estimated difference with its Student-t sampling distribution.

    Attributes:
      estimate: the difference (mean(a) - mean(b), or mean(x) - reference).
      se: its standard error (0: no spread on either side; NaN: too few seeds).
      df: its degrees of freedom (Welch-Satterthwaite, or n - 1).
      p: the two-sided p-value of the test of a zero difference (NaN: no test).
    """

    estimate: float
    se: float
    df: float
    p: float

    @property
    def testable(self) -> bool:
        """Whether there is a test: a finite, positive standard error and degrees of freedom."""
        return all(math.isfinite(x) for x in (self.estimate, self.se, self.df)) and self.se > 0

    def interval(self, alpha: float) -> tuple[float, float]:
        """The two-sided 1 - `alpha` confidence interval of the difference (NaN: no test)."""
        if not self.testable:
            return math.nan, math.nan
        half = float(t_quantile(1 - alpha / 2, self.df)) * self.se
        return self.estimate - half, self.estimate + half

    def p_below(self, bound: float) -> float:
        """The one-sided p-value of H0: difference >= `bound` against difference < `bound`."""
        return _t_cdf((self.estimate - bound) / self.se, self.df) if self.testable else math.nan

    def p_above(self, bound: float) -> float:
        """The one-sided p-value of H0: difference <= `bound` against difference > `bound`."""
        return _t_sf((self.estimate - bound) / self.se, self.df) if self.testable else math.nan

    def detectable(self, alpha: float, power: float) -> float:
        """The smallest difference a two-sided test at `alpha` detects with probability `power`,
        given the observed spreads: (t_{1-alpha/2, df} + t_{power, df}) x se (the usual
        normal-approximation formula with Student-t quantiles). NaN: no test."""
        if not self.testable:
            return math.nan
        return float(t_quantile(1 - alpha / 2, self.df) + t_quantile(power, self.df)) * self.se


def welch(a: Summary, b: Summary) -> Difference:
    """mean(a) - mean(b) with Welch's standard error sqrt(s_a^2/n_a + s_b^2/n_b), the
    Welch-Satterthwaite degrees of freedom and Welch's two-sided p-value; NaN standard error with
    fewer than 2 seeds on a side, NaN p-value without a spread on either."""
    estimate = a.mean - b.mean
    if a.n < 2 or b.n < 2:
        return Difference(estimate, math.nan, math.nan, math.nan)
    va, vb = a.sd**2 / a.n, b.sd**2 / b.n
    se = math.sqrt(va + vb)
    if not se > 0:
        return Difference(estimate, se, math.nan, math.nan)
    df = (va + vb) ** 2 / (va**2 / (a.n - 1) + vb**2 / (b.n - 1))
    from scipy.stats import ttest_ind_from_stats

    p = float(ttest_ind_from_stats(a.mean, a.sd, a.n, b.mean, b.sd, b.n, equal_var=False).pvalue)
    return Difference(estimate, se, df, p)


def one_sample(x: Summary, reference: float) -> Difference:
    """mean(x) - `reference` with its standard error s / sqrt(n), n - 1 degrees of freedom and
    the one-sample t-test's two-sided p-value."""
    estimate = x.mean - reference
    if x.n < 2:
        return Difference(estimate, math.nan, math.nan, math.nan)
    se = x.sd / math.sqrt(x.n)
    if not se > 0:
        return Difference(estimate, se, math.nan, math.nan)
    df = float(x.n - 1)
    return Difference(estimate, se, df, min(1.0, 2 * _t_sf(abs(estimate) / se, df)))


def holm(p_values: ArrayLike) -> np.ndarray:
    """Holm-Bonferroni adjusted p-values (step-down; family-wise error rate at any alpha).

    Args:
      p_values: (m,) p-values of the family; NaN entries (no test) are left out of it and stay
        NaN.

    Returns:
      (m,) adjusted p-values in the input's order: the k-th smallest of the n finite ones is
      multiplied by n - k + 1, made non-decreasing along that order and capped at 1.
    """
    p = np.asarray(p_values, np.float64)
    if p.ndim != 1:
        raise ValueError(f"holm expects a 1-D sequence of p-values, got shape {p.shape}")
    finite = np.isfinite(p)
    if np.any((p[finite] < 0) | (p[finite] > 1)):
        raise ValueError(f"p-values must lie in [0, 1], got {p[finite & ((p < 0) | (p > 1))]}")
    adjusted = np.full(p.shape, math.nan)
    index = np.flatnonzero(finite)
    order = index[np.argsort(p[index], kind="stable")]
    n = len(order)
    scaled = p[order] * (n - np.arange(n))
    adjusted[order] = np.minimum(np.maximum.accumulate(scaled), 1.0)
    return adjusted


def fisher_exact(a_count: int, a_n: int, b_count: int, b_n: int) -> float:
    """Fisher's exact two-sided p-value that `a_count` of `a_n` and `b_count` of `b_n` come from
    one proportion (`scipy.stats.fisher_exact` on the 2 x 2 table)."""
    from scipy.stats import fisher_exact as fisher

    table = [[a_count, a_n - a_count], [b_count, b_n - b_count]]
    return float(fisher(table, alternative="two-sided").pvalue)


def wilson(count: int, n: int, alpha: float) -> tuple[float, float]:
    """The Wilson score interval of the proportion `count` / `n` at 1 - `alpha` (two-sided)."""
    if n < 1:
        return math.nan, math.nan
    z = float(t_quantile(1 - alpha / 2, math.inf))
    p = count / n
    centre = (p + z**2 / (2 * n)) / (1 + z**2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z**2 / (4 * n**2)) / (1 + z**2 / n)
    return max(0.0, centre - half), min(1.0, centre + half)


@functools.lru_cache(maxsize=32)
def _fisher_rejects(a_n: int, b_n: int, alpha: float) -> np.ndarray:
    """(a_n + 1, b_n + 1) bool: whether Fisher's two-sided test at `alpha` rejects each outcome."""
    return np.array([[fisher_exact(x, a_n, y, b_n) < alpha for y in range(b_n + 1)] for x in range(a_n + 1)])


def fisher_power(a_n: int, b_n: int, a_rate: float, b_rate: float, alpha: float) -> float:
    """The exact probability that Fisher's two-sided test at `alpha` rejects, with `a_n` and
    `b_n` seeds whose true proportions are `a_rate` and `b_rate` (every outcome enumerated)."""
    from scipy.stats import binom

    a_probability = binom.pmf(np.arange(a_n + 1), a_n, a_rate)
    b_probability = binom.pmf(np.arange(b_n + 1), b_n, b_rate)
    return float(a_probability @ _fisher_rejects(a_n, b_n, alpha) @ b_probability)


def fisher_detectable(a_n: int, b_n: int, pooled: float, alpha: float, power: float) -> float:
    """The smallest difference of two proportions that Fisher's two-sided test at `alpha`
    detects with probability `power`, with true proportions centred on `pooled` (pooled ± d/2,
    moved inside [0, 1] where they would leave it); inf when no difference can (too few seeds).
    Searched on a grid of 0.01."""
    centre = min(max(pooled, 0.0), 1.0) if math.isfinite(pooled) else 0.5
    for step in range(1, 101):
        d = step / 100
        low = min(max(centre - d / 2, 0.0), 1.0 - d)
        if fisher_power(a_n, b_n, low, low + d, alpha) >= power:
            return d
    return math.inf
