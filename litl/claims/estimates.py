"""What a claim's verdict rests on, apart from the verdict itself: a mean over seeds with its
interval (`Estimate`), and the same claim judged at an earlier cut of its runs with its curves'
slopes at the end (`CutCheck`).

Both `litl.claims.verdicts` (a `Verdict` holds its `CutCheck`) and `litl.claims.cuts` (which
computes it from verdicts) build on these, so they live below both: the two modules would
otherwise import each other.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from litl.report.stats import confidence_band


@dataclasses.dataclass(frozen=True)
class Estimate:
    """A mean over seeds with its two-sided interval; `stuck`: how many of the `n` seeds ended
    stuck and count with their last good loss (`litl.records.stuck`; None: not known, re-judged from a
    claims.csv without the count)."""

    mean: float
    low: float
    high: float
    n: int
    stuck: int | None = 0


def estimate(values: ArrayLike, level: float = 0.9) -> Estimate:
    """The mean of `values` (one per seed; NaN ones left out) with its interval at `level`."""
    array = np.asarray(values, np.float64)
    mean, low, high = confidence_band(array, level)
    return Estimate(float(mean), float(low), float(high), int(np.isfinite(array).sum()))


def proportion(count: int, n: int, level: float = 0.9) -> Estimate:
    """The proportion `count` / `n` of seeds with its Wilson interval at `level`."""
    from litl.claims.stats import wilson

    low, high = wilson(count, n, 1 - level)
    return Estimate(count / n if n else math.nan, low, high, n, stuck=None)


def falling(slope: Estimate | None) -> bool:
    """Whether a slope's interval lies below 0 (needs 2 seeds with a slope)."""
    return slope is not None and slope.n >= 2 and math.isfinite(slope.high) and slope.high < 0


class Judged(Protocol):
    """What `CutCheck.changed` reads of a verdict (`litl.claims.verdicts.Verdict`)."""

    @property
    def verdict(self) -> str: ...

    @property
    def holm_verdict(self) -> str: ...


@dataclasses.dataclass(frozen=True)
class CutCheck:
    """A verdict's claim judged at an earlier cut, and its curves' slopes at the end
    (`litl.claims.cuts.with_cuts` computes it).

    Attributes:
      fraction: the cut, as a fraction of the iterations (`litl.claims.cuts.CUT`).
      iterations: the iterations kept at the cut (the first ones).
      total: the runs' iterations (the longest of the compared groups).
      verdict, holm_verdict: the verdict at the cut, and after Holm over the cut's family.
      tail: the iterations over which the slopes are measured (the last ones).
      a_slope, b_slope: each compared curve's task-loss slope per iteration over the `tail`,
        mean over seeds with its interval (None: no such group; for Table 1's claim, b).
    """

    fraction: float
    iterations: int
    total: int
    verdict: str
    holm_verdict: str
    tail: int
    a_slope: Estimate | None
    b_slope: Estimate | None

    def changed(self, end: Judged) -> bool:
        """Whether the verdict after Holm at the end, or the unadjusted one, differs from the cut's."""
        return end.verdict != self.verdict or end.holm_verdict != self.holm_verdict

    @property
    def still_falling(self) -> list[str]:
        """Which compared curves (``"a"``, ``"b"``) were still falling at the end."""
        return [side for side, slope in (("a", self.a_slope), ("b", self.b_slope)) if falling(slope)]
