"""The paper's claims as tests on measured runs, each with a stated rule and a verdict.

Every comparison uses a seed's *final task loss*: the mean of its last 10 optimization
iterations (`litl.report.summary.FINAL_WINDOW`), lower is better. Rules (ALPHA = 0.05, one-sided,
the same 5% tail on each side as the paper's 90% intervals):

- "A beats B" holds when a one-sided Welch t-test finds A's mean lower (p < ALPHA), is
  contradicted when the opposite one-sided test finds it higher (p < ALPHA), and is not resolved
  otherwise.
- "A is competitive with B" is contradicted when A is worse with p < ALPHA; it holds when it is
  not, and A's mean is within MARGIN (10%) of B's |mean| or better; otherwise not resolved.
- Table 1, "one optimization step cancels retraining's backward progress": per seed, the mean
  of `retrain_change` over retrainings (the change of the task objective from before a
  retraining to after it and one step; negative = progress lost) against MARGIN times the
  progress an episode makes (mean decrease of the task loss from an episode's first iteration to
  its last). Holds when the 90% interval of the mean change lies above -MARGIN x progress, is
  contradicted when it lies below, not resolved when it straddles.

A table of claims makes many such tests at once, so each verdict also gets a Holm-adjusted p
(`with_holm`): Holm-Bonferroni over the family of one-sided tests in the table, one per claim and
method (the test its verdict rests on), and the verdict that survives the correction.

A seed that ended stuck (its last iterations skipped: `litl.stuck`) counts with its last good
iterations (the window up to its last good one), and each side says how many did
(`Estimate.stuck`). Whether a verdict depends on where its runs were cut, or rests on curves
still falling at the end: `litl.claims.cuts`.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from litl.report.runs import Group
from litl.report.stats import confidence_band, final_window_values, series_ends

if TYPE_CHECKING:
    from litl.claims.cuts import CutCheck

ALPHA = 0.05
MARGIN = 0.1
FINAL_WINDOW = 10
HOLDS, NOT_RESOLVED, CONTRADICTED, NO_DATA = "holds", "not resolved", "contradicted", "no data"


@dataclasses.dataclass(frozen=True)
class Claim:
    """One claim of the paper (or one litl adds), as a test between two variants of a panel.

    Attributes:
      id: short name, e.g. ``"4a-kmeans-competitive"``.
      panel: the `litl.claims.suite.Panel` name it is measured on.
      statement: the claim in words.
      kind: ``"beats"`` (a's final task loss lower than b's), ``"competitive"`` (a not worse
        than b) or ``"retraining"`` (Table 1, on variant a alone).
      a, b: variant names (b is None for ``"retraining"``).
      source: where the claim comes from (the paper's section, or litl).
      comparator: an optional comparator's claim, judged only where its variant was run
        (`python -m litl.claims --comparators pca`), so the default table is unchanged.
    """

    id: str
    panel: str
    statement: str
    kind: str
    a: str
    b: str | None = None
    source: str = "paper"
    comparator: bool = False


CLAIMS = (
    Claim(
        "4a-kmeans-competitive",
        "fig4a",
        "on the arm, k-means is competitive with the VAE",
        "competitive",
        "kmeans",
        "vae",
        "paper, Sec. 5 (2D Arm)",
    ),
    Claim(
        "4a-one-shot-fails",
        "fig4a",
        "on the arm, training the observer once (one-shot) does worse than retraining it",
        "beats",
        "vae",
        "vae_one_shot",
        "paper, Sec. 5 (2D Arm), Fig. 4a",
    ),
    Claim(
        "4a-no-replay-fails",
        "fig4a",
        "on the arm, the VAE without a replay buffer does worse than with it",
        "beats",
        "vae",
        "vae_no_replay",
        "paper, Sec. 5 (2D Arm), Fig. 4a",
    ),
    Claim(
        "4b-vae-beats-kmeans",
        "fig4b",
        "on the biped, the VAE beats k-means",
        "beats",
        "vae",
        "kmeans",
        "paper, Fig. 4b",
    ),
    Claim(
        "4b-vae-beats-open-loop",
        "fig4b",
        "on the biped, the VAE's closed loop beats open-loop sinusoids",
        "beats",
        "vae",
        "sinusoid",
        "litl's baseline (not in the paper)",
    ),
    Claim(
        "table1-retraining",
        "fig4b",
        "on the biped, one optimization step cancels retraining's backward progress",
        "retraining",
        "vae",
        None,
        "paper, Table 1",
    ),
    Claim(
        "4c-vae-beats-kmeans-4",
        "fig4c",
        "on the elephant, the VAE beats k-means at size 4",
        "beats",
        "vae_s4",
        "kmeans_s4",
        "paper, Fig. 4c",
    ),
    Claim(
        "4c-vae-beats-kmeans-8",
        "fig4c",
        "on the elephant, the VAE beats k-means at size 8",
        "beats",
        "vae_s8",
        "kmeans_s8",
        "paper, Fig. 4c",
    ),
    Claim(
        "4d-vae-beats-kmeans",
        "fig4d",
        "on the bunny, the VAE beats k-means",
        "beats",
        "vae",
        "kmeans",
        "paper, Fig. 4d",
    ),
    Claim(
        "4d-vae-beats-open-loop",
        "fig4d",
        "on the bunny, the VAE's closed loop beats open-loop sinusoids",
        "beats",
        "vae",
        "sinusoid",
        "litl's baseline (not in the paper)",
    ),
    Claim(
        "4b-vae-beats-pca",
        "fig4b",
        "on the biped, the VAE beats a linear observer (PCA of the same field)",
        "beats",
        "vae",
        "pca",
        "litl's comparator (not in the paper): does the VAE's nonlinearity matter?",
        comparator=True,
    ),
    Claim(
        "4d-vae-beats-pca",
        "fig4d",
        "on the bunny, the VAE beats a linear observer (PCA of the same field)",
        "beats",
        "vae",
        "pca",
        "litl's comparator (not in the paper): does the VAE's nonlinearity matter?",
        comparator=True,
    ),
)


def welch_p_lower(a: ArrayLike, b: ArrayLike) -> float:
    """One-sided Welch t-test p-value for mean(a) < mean(b); NaN with fewer than 2 values in
    either, or no spread in both."""
    from scipy.stats import ttest_ind

    x = np.asarray(a, np.float64)
    y = np.asarray(b, np.float64)
    x, y = x[np.isfinite(x)], y[np.isfinite(y)]
    if len(x) < 2 or len(y) < 2 or (np.ptp(x) == 0 and np.ptp(y) == 0):
        return math.nan
    return float(ttest_ind(x, y, equal_var=False, alternative="less").pvalue)


@dataclasses.dataclass(frozen=True)
class Estimate:
    """A mean over seeds with its two-sided interval; `stuck`: how many of the `n` seeds ended
    stuck and count with their last good loss (`litl.stuck`)."""

    mean: float
    low: float
    high: float
    n: int
    stuck: int = 0


def estimate(values: ArrayLike, level: float = 0.9) -> Estimate:
    array = np.asarray(values, np.float64)
    mean, low, high = confidence_band(array, level)
    return Estimate(float(mean), float(low), float(high), int(np.isfinite(array).sum()))


def final_losses(group: Group) -> np.ndarray:
    """(seeds,) each seed's final task loss (mean of its last FINAL_WINDOW iterations; for a seed
    that ended stuck, of those up to its last good one: `litl.stuck`)."""
    return final_window_values(group, "task_loss", FINAL_WINDOW)


def stuck_seeds(group: Group) -> int:
    """How many seeds of `group` ended stuck (their last iterations skipped) and still have a
    final task loss (their last good one)."""
    finals = final_losses(group)
    return sum(
        end.stuck and bool(np.isfinite(final))
        for (_, end), final in zip(series_ends(group), finals, strict=True)
    )


@dataclasses.dataclass(frozen=True)
class Verdict:
    """A claim measured under one method.

    Attributes:
      claim: the claim.
      method: ``"litl"`` or ``"paper"``.
      a, b: the compared quantities (final task losses; for Table 1, a is the remaining change
        after retraining plus one step and b the progress per episode).
      p: the one-sided Welch p-value of the test that would make the claim hold (NaN: none).
      verdict: HOLDS, NOT_RESOLVED, CONTRADICTED or NO_DATA.
      rule: the rule applied, in words.
      test_p: the one-sided p-value of the test the verdict rests on: the test that makes the
        claim hold for HOLDS, the opposite one for CONTRADICTED, the smaller of the two for
        NOT_RESOLVED; for a "competitive" claim always the test of a being worse (its HOLDS
        rests on a margin, not a test). NaN: no test.
      holm_p: `test_p` Holm-adjusted over a table's family of tests (NaN until `with_holm`).
      cut: the same claim judged at an earlier cut of its runs, and whether their curves were
        still falling at the end (`litl.claims.cuts.CutCheck`; None until `with_cuts`).
    """

    claim: Claim
    method: str
    a: Estimate | None
    b: Estimate | None
    p: float
    verdict: str
    rule: str
    test_p: float = math.nan
    holm_p: float = math.nan
    cut: CutCheck | None = None

    @property
    def holm_verdict(self) -> str:
        """The verdict once its test is Holm-adjusted: a HOLDS or CONTRADICTED whose adjusted p
        is not below ALPHA becomes NOT_RESOLVED (a "competitive" claim that is no longer
        contradicted holds if its mean is within the margin); the rest are unchanged."""
        if self.verdict not in (HOLDS, CONTRADICTED):
            return self.verdict
        if self.claim.kind == "competitive":
            if self.verdict == HOLDS or self.holm_p < ALPHA:
                return self.verdict  # holding rests on the margin; the correction only helps it
            assert self.a is not None and self.b is not None  # a judged comparison has both
            return HOLDS if _within_margin(self.a, self.b) else NOT_RESOLVED
        return self.verdict if self.holm_p < ALPHA else NOT_RESOLVED


def _within_margin(a: Estimate, b: Estimate) -> bool:
    """A "competitive" claim's margin: a's mean within MARGIN of b's |mean|, or lower."""
    return a.mean <= b.mean + MARGIN * abs(b.mean)


def _test_p(verdict: str, holding: float, opposite: float) -> float:
    """The p-value a verdict rests on, from the two one-sided tests of a claim."""
    if verdict == HOLDS:
        return holding
    if verdict == CONTRADICTED:
        return opposite
    return min(holding, opposite) if math.isfinite(holding) and math.isfinite(opposite) else math.nan


# (a, b, p, verdict, rule, test_p): a `Verdict`'s measured fields.
Result = tuple[Estimate, Estimate, float, str, str, float]


def _compare(claim: Claim, a_values: np.ndarray, b_values: np.ndarray, level: float) -> Result:
    a, b = estimate(a_values, level), estimate(b_values, level)
    better = welch_p_lower(a_values, b_values)
    worse = welch_p_lower(b_values, a_values)
    if a.n < 2 or b.n < 2:
        return a, b, better, NO_DATA, "needs at least 2 seeds with a final task loss in each", math.nan
    if claim.kind == "beats":
        verdict = HOLDS if better < ALPHA else CONTRADICTED if worse < ALPHA else NOT_RESOLVED
        rule = (
            f"holds if {claim.a} is lower with one-sided Welch p < {ALPHA}; contradicted if "
            f"it is higher with p < {ALPHA}"
        )
        return a, b, better, verdict, rule, _test_p(verdict, better, worse)
    verdict = CONTRADICTED if worse < ALPHA else HOLDS if _within_margin(a, b) else NOT_RESOLVED
    rule = (
        f"contradicted if {claim.a} is higher with one-sided Welch p < {ALPHA}; else holds "
        f"if its mean is within {MARGIN:.0%} of {claim.b}'s |mean| or lower"
    )
    return a, b, worse, verdict, rule, worse


def retraining_effects(group: Group) -> tuple[np.ndarray, np.ndarray]:
    """Per seed: mean `retrain_change` over retrainings, and mean progress per episode (task
    loss at an episode's first iteration minus at its last; positive = improving)."""
    changes: dict[tuple[int, int], list[float]] = {}
    progress: dict[tuple[int, int], list[float]] = {}
    for index, run in enumerate(group.runs):
        episodes: dict[tuple[int, int], dict[int, float]] = {}
        for record in run.records:
            key = (index, int(record["seed"]))
            change = record.get("retrain_change")
            if isinstance(change, (int, float)) and math.isfinite(change):
                changes.setdefault(key, []).append(float(change))
            loss = record.get("task_loss")
            if isinstance(loss, (int, float)) and math.isfinite(loss):
                episodes.setdefault((key[1], int(record["episode"])), {})[int(record["iteration"])] = float(
                    loss
                )
        for (seed, _), losses in episodes.items():
            if len(losses) > 1:
                progress.setdefault((index, seed), []).append(losses[min(losses)] - losses[max(losses)])
    keys = sorted(set(changes) | set(progress))
    mean = lambda values: float(np.mean(values)) if values else math.nan  # noqa: E731
    return (
        np.array([mean(changes.get(k, [])) for k in keys]),
        np.array([mean(progress.get(k, [])) for k in keys]),
    )


def _retraining(claim: Claim, group: Group, level: float) -> Result:
    change_values, progress_values = retraining_effects(group)
    change, progress = estimate(change_values, level), estimate(progress_values, level)
    rule = (
        f"holds if the {level:.0%} interval of the mean change lies above -{MARGIN:g} x the "
        f"mean progress per episode; contradicted if it lies below; else not resolved"
    )
    if change.n < 2 or not math.isfinite(progress.mean):
        return change, progress, math.nan, NO_DATA, "needs retrainings in at least 2 seeds", math.nan
    threshold = -MARGIN * max(progress.mean, 0.0)
    verdict = HOLDS if change.low > threshold else CONTRADICTED if change.high < threshold else NOT_RESOLVED
    # The p-value of "the mean change is above the threshold" (one-sample, one-sided).
    from scipy.stats import ttest_1samp

    finite = change_values[np.isfinite(change_values)]
    p, opposite = (
        (
            float(ttest_1samp(finite, threshold, alternative="greater").pvalue),
            float(ttest_1samp(finite, threshold, alternative="less").pvalue),
        )
        if np.ptp(finite) > 0
        else (math.nan, math.nan)
    )
    return change, progress, p, verdict, rule, _test_p(verdict, p, opposite)


def judge(claim: Claim, method: str, groups: dict[str, Group], level: float = 0.9) -> Verdict:
    """The verdict on `claim` from `groups` ({variant name: its runs}) of one method."""
    missing = [name for name in (claim.a, claim.b) if name is not None and name not in groups]
    if missing:
        return Verdict(
            claim, method, None, None, math.nan, NO_DATA, f"no finished runs of {', '.join(missing)}"
        )
    if claim.kind == "retraining":
        result = _retraining(claim, groups[claim.a], level)
    else:
        assert claim.b is not None  # a comparison names both sides
        a_group, b_group = groups[claim.a], groups[claim.b]
        a, b, p, verdict, rule, test_p = _compare(claim, final_losses(a_group), final_losses(b_group), level)
        # Seeds that ended stuck count with their last good loss; the table says how many.
        a = dataclasses.replace(a, stuck=stuck_seeds(a_group))
        b = dataclasses.replace(b, stuck=stuck_seeds(b_group))
        result = (a, b, p, verdict, rule, test_p)
    return Verdict(claim, method, *result)


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


def with_holm(results: list[Verdict]) -> list[Verdict]:
    """The verdicts with `holm_p` set: Holm over the family of their tests (one per verdict
    with a `test_p`), so `holm_verdict` says which survive the correction."""
    adjusted = holm([v.test_p for v in results])
    return [dataclasses.replace(v, holm_p=float(p)) for v, p in zip(results, adjusted, strict=True)]
