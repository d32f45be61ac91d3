"""The rules that turn a claim's summary statistics into a verdict (one function per kind of
claim), shared by the verdict on measured runs (`litl.claims.verdicts.judge`) and the verdict
re-judged from a published claims.csv (`litl.claims.rejudge`).

Every test is at ALPHA = 0.05 two-sided (equivalently one-sided at 0.025 in each direction), so
that each member of a table's Holm family is a two-sided p-value and Holm's correction holds the
family-wise error at 0.05:

- `beats`, "A beats B": Welch's two-sided t-test of mean(a) - mean(b); holds when A's mean is
  lower and p < ALPHA, contradicted when it is higher and p < ALPHA, else not resolved.
- `competitive`, "A is competitive with B": non-inferiority with a margin fixed before the runs,
  delta = MARGIN x B's progress (its seeds' mean decrease of the task loss from their first
  iteration to their final task loss). Holds when the upper end of the 95% Welch interval of
  mean(a) - mean(b) lies below delta (a one-sided test of H0: a - b >= delta at 0.025);
  contradicted when its lower end lies above delta (A worse by more than the margin); else not
  resolved. Without progress (<= 0) there is no margin and no test.
- `retraining`, Table 1: a one-sample two-sided t-test of the mean change against -MARGIN x the
  progress per episode; holds when the mean lies above with p < ALPHA (its 95% interval lies
  above), contradicted when below with p < ALPHA.
- `converges`, "A converges faster than B": Welch's two-sided t-test of each seed's mean task
  loss over every iteration of its run (the area under its learning curve; a curve that falls
  sooner has a lower mean); holds when A's is lower with p < ALPHA, contradicted when higher.
- `stuck`, "A gets stuck near the start less often than B": a seed is stuck when its progress
  (task loss at its first iteration minus its final task loss) is below STUCK_FRACTION of the
  median progress of the two variants' seeds pooled; Fisher's exact two-sided test of the two
  proportions; holds when fewer of A's seeds are stuck with p < ALPHA, contradicted when more.

Each judgement also gives the 95% interval of the difference, and the smallest difference the
seeds could have detected with POWER = 80% (`litl.claims.stats.Difference.detectable`; for a
proportion, `litl.claims.stats.fisher_detectable`).
"""

from __future__ import annotations

import dataclasses
import math

from litl.claims.stats import Difference, Summary, fisher_detectable, fisher_exact, one_sample, welch, wilson

ALPHA = 0.05
MARGIN = 0.1
POWER = 0.8
# A seed is stuck near its start when it made less than this fraction of the median progress of
# the two compared variants' seeds (fixed on 2026-12-02, before the runs it judges:
# docs/guide/claims.md).
STUCK_FRACTION = 0.25
HOLDS, NOT_RESOLVED, CONTRADICTED, NO_DATA = "holds", "not resolved", "contradicted", "no data"
# A row re-judged from a claims.csv that lacks what its rule needs (`litl.claims.rejudge`).
NEEDS_RUNS = "needs the runs"

BEATS_RULE = (
    "holds if {a} is lower than {b} with two-sided Welch p < {alpha} (one-sided 0.025 each way); "
    "contradicted if it is higher with p < {alpha}; else not resolved"
)
COMPETITIVE_RULE = (
    "non-inferiority: margin δ = {margin:.0%} of {b}'s progress (mean over seeds of its first "
    "iteration's task loss minus its final one); holds if the upper end of the 95% Welch interval "
    "of {a} − {b} lies below δ (one-sided 0.025), contradicted if its lower end lies above δ; "
    "else not resolved"
)
CONVERGES_RULE = (
    "convergence measure: each seed's mean task loss over all {iterations} iterations of its run "
    "(skipped ones carry its last good loss); holds if {a}'s is lower than {b}'s with two-sided "
    "Welch p < {alpha}; contradicted if higher with p < {alpha}; else not resolved"
)
STUCK_RULE = (
    "a seed is stuck when its progress (first iteration's task loss minus final) is below "
    "{fraction:.0%} of the pooled median progress of {a} and {b} ({threshold}); holds if fewer of "
    "{a}'s seeds are stuck than of {b}'s with two-sided Fisher exact p < {alpha}; contradicted if "
    "more; else not resolved"
)
RETRAINING_RULE = (
    "holds if the mean change lies above −{margin:g} × the mean progress per episode with "
    "two-sided one-sample t p < {alpha} (its 95% interval above), contradicted if below with "
    "p < {alpha}; else not resolved"
)


@dataclasses.dataclass(frozen=True)
class Judgement:
    """A rule applied to summary statistics (the measured fields of a `Verdict`).

    Attributes:
      p: the p-value of the claim's own test, on the two-sided scale (NaN: no test).
      verdict: HOLDS, NOT_RESOLVED, CONTRADICTED or NO_DATA.
      rule: the rule applied, in words.
      test_p: the two-sided-scale p-value the verdict rests on (what Holm adjusts).
      difference: mean(a) - mean(b); for Table 1 the mean change minus its threshold.
      difference_low, difference_high: its two-sided 1 - ALPHA (95%) interval.
      margin: a "competitive" claim's delta; Table 1's delta (threshold -delta); else NaN.
      detectable: the smallest |difference| a two-sided test at ALPHA finds with POWER.
    """

    p: float
    verdict: str
    rule: str
    test_p: float
    difference: float = math.nan
    difference_low: float = math.nan
    difference_high: float = math.nan
    margin: float = math.nan
    detectable: float = math.nan


def _measured(difference: Difference) -> dict[str, float]:
    """The interval and detectable difference of a `Difference`, as `Judgement` fields."""
    low, high = difference.interval(ALPHA)
    return {
        "difference": difference.estimate,
        "difference_low": low,
        "difference_high": high,
        "detectable": difference.detectable(ALPHA, POWER),
    }


def _smaller(x: float, y: float) -> float:
    """min(x, y), NaN if either is (Python's min depends on the order with NaN)."""
    return min(x, y) if math.isfinite(x) and math.isfinite(y) else math.nan


def _doubled(p: float) -> float:
    """A one-sided p-value put on the two-sided scale (2p, capped at 1)."""
    return min(1.0, 2 * p) if math.isfinite(p) else math.nan


def _by_sign(difference: Difference, positive: str, negative: str) -> str:
    """The verdict of a two-sided test: `positive`/`negative` by the estimate's sign when p <
    ALPHA, else NOT_RESOLVED."""
    if not difference.p < ALPHA:
        return NOT_RESOLVED
    return positive if difference.estimate > 0 else negative


def too_few(a: Summary, b: Summary) -> Judgement | None:
    """NO_DATA unless both sides have at least 2 seeds with a final task loss."""
    if a.n < 2 or b.n < 2:
        return Judgement(math.nan, NO_DATA, "needs at least 2 seeds with a final task loss in each", math.nan)
    return None


def after_holm(verdict: str, holm_p: float) -> str:
    """The verdict that survives Holm's correction (the primary one): a HOLDS or CONTRADICTED
    whose Holm-adjusted p is not below ALPHA becomes NOT_RESOLVED; the others are unchanged."""
    if verdict in (HOLDS, CONTRADICTED) and not holm_p < ALPHA:
        return NOT_RESOLVED
    return verdict


def beats(a: Summary, b: Summary, a_name: str, b_name: str) -> Judgement:
    """A "beats" claim, `a_name`'s final task loss lower than `b_name`'s: Welch's two-sided test."""
    if (missing := too_few(a, b)) is not None:
        return missing
    difference = welch(a, b)
    verdict = _by_sign(difference, CONTRADICTED, HOLDS)
    rule = BEATS_RULE.format(a=a_name, b=b_name, alpha=ALPHA)
    return Judgement(difference.p, verdict, rule, difference.p, **_measured(difference))


def competitive(a: Summary, b: Summary, progress: float, a_name: str, b_name: str) -> Judgement:
    """A "competitive" claim, `a_name` not worse than `b_name`: non-inferiority within MARGIN x
    `progress` (`b_name`'s mean progress over its seeds; NaN: not measured)."""
    if (missing := too_few(a, b)) is not None:
        return missing
    difference = welch(a, b)
    rule = COMPETITIVE_RULE.format(margin=MARGIN, a=a_name, b=b_name)
    if not math.isfinite(progress):
        return Judgement(
            math.nan, NO_DATA, f"needs {b_name}'s task loss at its first iteration (its progress)", math.nan
        )
    margin = MARGIN * progress
    if not margin > 0:
        why = f"not resolved: {b_name} made no progress ({progress:.3g}), so there is no margin to test"
        return Judgement(math.nan, NOT_RESOLVED, why, math.nan, **_measured(difference), margin=margin)
    holding = _doubled(difference.p_below(margin))
    opposite = _doubled(difference.p_above(margin))
    if holding < ALPHA:
        verdict, test_p = HOLDS, holding
    elif opposite < ALPHA:
        verdict, test_p = CONTRADICTED, opposite
    else:
        verdict, test_p = NOT_RESOLVED, _smaller(holding, opposite)
    return Judgement(holding, verdict, rule, test_p, **_measured(difference), margin=margin)


def retraining(change: Summary, progress: Summary) -> Judgement:
    """Table 1: is the mean change after retraining plus one step above -MARGIN x the mean
    progress per episode (a negative progress counts as none)?"""
    if change.n < 2 or not math.isfinite(progress.mean):
        return Judgement(math.nan, NO_DATA, "needs retrainings in at least 2 seeds", math.nan)
    margin = MARGIN * max(progress.mean, 0.0)
    difference = one_sample(change, -margin)
    verdict = _by_sign(difference, HOLDS, CONTRADICTED)
    rule = RETRAINING_RULE.format(margin=MARGIN, alpha=ALPHA)
    return Judgement(difference.p, verdict, rule, difference.p, **_measured(difference), margin=margin)


def converges(a: Summary, b: Summary, a_name: str, b_name: str, iterations: int) -> Judgement:
    """A "converges faster" claim: each side's per-seed mean task loss over all `iterations`
    iterations (`litl.claims.verdicts.convergence_measures`), Welch's two-sided test."""
    if (missing := too_few(a, b)) is not None:
        return missing
    difference = welch(a, b)
    verdict = _by_sign(difference, CONTRADICTED, HOLDS)
    rule = CONVERGES_RULE.format(a=a_name, b=b_name, alpha=ALPHA, iterations=iterations)
    return Judgement(difference.p, verdict, rule, difference.p, **_measured(difference))


def stuck(
    a_stuck: int, a_n: int, b_stuck: int, b_n: int, a_name: str, b_name: str, threshold: float | None
) -> Judgement:
    """A "gets stuck less" claim: `a_stuck` of `a_n` seeds against `b_stuck` of `b_n` (stuck by
    the progress `threshold`, `litl.claims.verdicts.stuck_near_start`), Fisher's exact two-sided
    test; the difference is a's proportion minus b's, its interval the difference of two Wilson
    intervals' ends (Newcombe's method 10), the detectable difference `fisher_detectable`.
    `threshold` None: the counts come from a record that applied the rule (re-judging a claims.csv)."""
    if a_n < 2 or b_n < 2:
        return Judgement(math.nan, NO_DATA, "needs at least 2 seeds with a progress in each", math.nan)
    if threshold is not None and not (math.isfinite(threshold) and threshold > 0):
        why = (
            f"not resolved: the pooled median progress of {a_name} and {b_name} is not positive, "
            "so no seed can be told stuck"
        )
        return Judgement(math.nan, NOT_RESOLVED, why, math.nan)
    p = fisher_exact(a_stuck, a_n, b_stuck, b_n)
    estimate = a_stuck / a_n - b_stuck / b_n
    verdict = NOT_RESOLVED if not p < ALPHA else (HOLDS if estimate < 0 else CONTRADICTED)
    a_low, a_high = wilson(a_stuck, a_n, ALPHA)
    b_low, b_high = wilson(b_stuck, b_n, ALPHA)
    a_p, b_p = a_stuck / a_n, b_stuck / b_n
    low = estimate - math.sqrt((a_p - a_low) ** 2 + (b_high - b_p) ** 2)
    high = estimate + math.sqrt((a_high - a_p) ** 2 + (b_p - b_low) ** 2)
    rule = STUCK_RULE.format(
        fraction=STUCK_FRACTION,
        a=a_name,
        b=b_name,
        alpha=ALPHA,
        threshold="as the record counted" if threshold is None else f"{threshold:.3g}",
    )
    pooled = (a_stuck + b_stuck) / (a_n + b_n)
    return Judgement(
        p,
        verdict,
        rule,
        p,
        difference=estimate,
        difference_low=low,
        difference_high=high,
        detectable=fisher_detectable(a_n, b_n, pooled, ALPHA, POWER),
    )
