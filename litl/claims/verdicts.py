"""The paper's claims as tests on measured runs, each with a stated rule and a verdict.

Every comparison uses a seed's *final task loss*: the mean of its last 10 optimization
iterations (`litl.report.summary.FINAL_WINDOW`), lower is better. The rules
(`litl.claims.rules`; every test at ALPHA = 0.05 two-sided, i.e. one-sided 0.025 each way):

- "A beats B": Welch's two-sided t-test; holds when A's mean is lower with p < ALPHA,
  contradicted when it is higher with p < ALPHA, else not resolved.
- "A is competitive with B": non-inferiority within a margin delta = MARGIN (10%) x B's progress
  (the mean over B's seeds of the task loss at their first iteration minus their final task
  loss). Holds when the 95% Welch interval of mean(a) - mean(b) lies below delta, contradicted
  when it lies above delta, else not resolved; no margin (B made no progress) resolves nothing.
- Table 1, "one optimization step cancels retraining's backward progress": per seed, the mean
  of `retrain_change` over retrainings (the change of the task objective from before a
  retraining to after it and one step; negative = progress lost) against -MARGIN times the
  progress an episode makes (mean decrease of the task loss from an episode's first iteration to
  its last), by a two-sided one-sample t-test.

A table of claims makes many such tests at once, so each verdict also gets a Holm-adjusted p
(`with_holm`): Holm-Bonferroni over the family of two-sided-scale p-values in the table, one per
claim and method (the test its verdict rests on); `Verdict.holm_verdict`, the verdict that
survives the correction, is the table's primary verdict. Each comparison also reports its 95%
interval and the smallest difference its seeds could have detected with 80% power.

A seed that ended stuck (its last iterations skipped: `litl.records.stuck`) counts with its last good
iterations (the window up to its last good one), and each side says how many did
(`Estimate.stuck`). Whether a verdict depends on where its runs were cut, or rests on curves
still falling at the end: `litl.claims.cuts`. Re-judging a published claims.csv, whose runs were
not kept, from its summary statistics: `litl.claims.rejudge`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import ArrayLike

from litl.claims import rules
from litl.claims.estimates import CutCheck, Estimate, estimate, proportion
from litl.claims.rules import (  # noqa: F401  (ALPHA and the verdicts re-exported: the tables' names)
    ALPHA,
    CONTRADICTED,
    HOLDS,
    NEEDS_RUNS,
    NO_DATA,
    NOT_RESOLVED,
    Judgement,
    after_holm,
)
from litl.claims.stats import Summary, holm, summarize
from litl.claims.suite import ClaimsError
from litl.report.runs import Group
from litl.report.stats import final_window_values, series, series_ends

FINAL_WINDOW = 10


@dataclasses.dataclass(frozen=True)
class Claim:
    """One claim of the paper (or one litl adds), as a test between two variants of a panel.

    Attributes:
      id: short name, e.g. ``"4a-kmeans-competitive"``.
      panel: the `litl.claims.suite.Panel` name it is measured on.
      statement: the claim in words.
      kind: ``"beats"`` (a's final task loss lower than b's), ``"competitive"`` (a not worse
        than b), ``"converges"`` (a's mean task loss over the run lower than b's),
        ``"stuck"`` (fewer of a's seeds stuck near their start than of b's) or ``"retraining"``
        (Table 1, on variant a alone).
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
        "4b-vae-converges-faster",
        "fig4b",
        "on the biped, the VAE converges faster than k-means",
        "converges",
        "vae",
        "kmeans",
        "paper, Discussion",
    ),
    Claim(
        "4b-vae-stuck-less",
        "fig4b",
        "on the biped, the VAE gets stuck near its start less often than k-means (the paper: "
        "k-means in 4 of 10)",
        "stuck",
        "vae",
        "kmeans",
        "paper, Sec. 5 (2D Biped) and Discussion",
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
        "4d-vae-converges-faster",
        "fig4d",
        "on the bunny, the VAE converges faster than k-means",
        "converges",
        "vae",
        "kmeans",
        "paper, Discussion",
    ),
    Claim(
        "4d-vae-stuck-less",
        "fig4d",
        "on the bunny, the VAE gets stuck near its start less often than k-means",
        "stuck",
        "vae",
        "kmeans",
        "paper, Discussion",
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
    either, or no spread in both. (The verdicts use two-sided tests: `litl.claims.rules`.)"""
    from litl.claims.stats import welch

    return welch(summarize(a), summarize(b)).p_below(0.0)


def final_losses(group: Group) -> np.ndarray:
    """(seeds,) each seed's final task loss (mean of its last FINAL_WINDOW iterations; for a seed
    that ended stuck, of those up to its last good one: `litl.records.stuck`)."""
    return final_window_values(group, "task_loss", FINAL_WINDOW)


def stuck_seeds(group: Group) -> int:
    """How many seeds of `group` ended stuck (their last iterations skipped) and still have a
    final task loss (their last good one)."""
    finals = final_losses(group)
    return sum(
        end.stuck and bool(np.isfinite(final))
        for (_, end), final in zip(series_ends(group), finals, strict=True)
    )


def progress(group: Group) -> np.ndarray:
    """(seeds,) each seed's progress over its run: its task loss at its first iteration (the
    first not skipped) minus its final task loss (positive: it improved); NaN without either.
    A "competitive" claim's margin is MARGIN times its reference's mean progress."""
    _, values = series(group, "task_loss")
    first = np.full(len(values), math.nan)
    for row, losses in enumerate(values):
        finite = np.flatnonzero(np.isfinite(losses))
        if len(finite):
            first[row] = losses[finite[0]]
    result: np.ndarray = first - final_losses(group)
    return result


def convergence_measures(group: Group, iterations: int) -> np.ndarray:
    """(seeds,) each seed's convergence measure: its mean task loss over the first `iterations`
    iterations of its run, a skipped iteration counting with the seed's last good loss before it
    (its first good one, before any). Lower is faster (and further).

    Raises:
      ClaimsError: a seed of `group` has fewer than `iterations` iterations recorded (the message
        names its run directory and what it lacks).
    """
    _, values = series(group, "task_loss")
    for index, end in series_ends(group):
        recorded = sum(1 for r in group.runs[index].records if int(r["seed"]) == end.seed)
        if recorded < iterations:
            raise ClaimsError(
                f"{group.runs[index].path}: seed {end.seed} has {recorded} iterations, but the "
                f"convergence measure needs {iterations} (the mean over every iteration of the "
                f"compared runs): finish the run (it resumes) or compare runs of one length"
            )
    measures = np.full(len(values), math.nan)
    for r, losses in enumerate(values[:, :iterations]):
        finite = np.flatnonzero(np.isfinite(losses))
        if not len(finite):
            continue
        filled = losses.copy()
        filled[: finite[0]] = losses[finite[0]]
        for t in range(finite[0] + 1, len(filled)):
            if not np.isfinite(filled[t]):
                filled[t] = filled[t - 1]
        measures[r] = float(filled.mean())
    return measures


def run_length(*groups: Group) -> int:
    """The most iterations any seed of `groups` recorded: the length the convergence measure
    compares over."""
    return max(len(series(group, "task_loss")[0]) for group in groups)


def stuck_near_start(a_progress: np.ndarray, b_progress: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Which seeds of two compared variants are stuck near their start: progress below
    `rules.STUCK_FRACTION` of the median progress of both variants' seeds pooled (NaN progress:
    left out). Returns (a's flags, b's flags, the threshold); the flags of seeds without a
    progress are False and they are not counted (`finite` masks)."""
    pooled = np.concatenate([a_progress, b_progress])
    pooled = pooled[np.isfinite(pooled)]
    threshold = rules.STUCK_FRACTION * float(np.median(pooled)) if len(pooled) else math.nan
    flag = lambda values: np.isfinite(values) & (values < threshold)  # noqa: E731
    return flag(a_progress), flag(b_progress), threshold


@dataclasses.dataclass(frozen=True)
class Verdict:
    """A claim measured under one method.

    Attributes:
      claim: the claim.
      method: ``"litl"`` or ``"paper"``.
      a, b: the compared quantities (final task losses; for Table 1, a is the remaining change
        after retraining plus one step and b the progress per episode).
      p: the p-value of the claim's own test on the two-sided scale (`litl.claims.rules`; NaN:
        none): Welch's two-sided p for "beats", twice the one-sided non-inferiority p for
        "competitive", the one-sample two-sided p for Table 1.
      verdict: the unadjusted verdict, HOLDS, NOT_RESOLVED, CONTRADICTED, NO_DATA or (re-judged
        from a claims.csv that lacks what the rule needs) NEEDS_RUNS.
      rule: the rule applied, in words.
      test_p: the two-sided-scale p-value the verdict rests on, the one Holm adjusts: p, except
        for a "competitive" claim contradicted (twice the one-sided p of a being worse by more
        than the margin) or not resolved (the smaller of the two). NaN: no test.
      holm_p: `test_p` Holm-adjusted over a table's family of tests (NaN until `with_holm`).
      cut: the same claim judged at an earlier cut of its runs, and whether their curves were
        still falling at the end (`litl.claims.estimates.CutCheck`; None until
        `litl.claims.cuts.with_cuts`).
      difference: mean(a) - mean(b) (Table 1: the mean change minus its threshold -margin).
      difference_low, difference_high: its two-sided 95% interval.
      margin: the margin delta of a "competitive" claim (and Table 1's); NaN for the others.
      detectable: the smallest |difference| a two-sided test at ALPHA would have detected with
        80% power, given the observed spreads and seed counts.
      previous_verdict, previous_holm_verdict: re-judged from a claims.csv, the verdicts it
        held (empty otherwise).
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
    difference: float = math.nan
    difference_low: float = math.nan
    difference_high: float = math.nan
    margin: float = math.nan
    detectable: float = math.nan
    previous_verdict: str = ""
    previous_holm_verdict: str = ""

    @property
    def holm_verdict(self) -> str:
        """The primary verdict: a HOLDS or CONTRADICTED whose Holm-adjusted p is not below ALPHA
        becomes NOT_RESOLVED; the rest are unchanged."""
        return after_holm(self.verdict, self.holm_p)

    @property
    def gap_below_detectable(self) -> bool | None:
        """Whether |difference| is below `detectable`: a true gap of this size would be found less
        than 80% of the time with these seeds (None: either is not measured)."""
        if not (math.isfinite(self.difference) and math.isfinite(self.detectable)):
            return None
        return abs(self.difference) < self.detectable


def from_judgement(
    claim: Claim, method: str, a: Estimate | None, b: Estimate | None, judgement: Judgement
) -> Verdict:
    """A `Verdict` with a rule's measured fields."""
    return Verdict(claim, method, a, b, **dataclasses.asdict(judgement))


def compare(claim: Claim, a: Summary, b: Summary, reference_progress: float = math.nan) -> Judgement:
    """A comparison claim judged from each side's (mean, sd, n), by its kind's rule;
    `reference_progress` is b's mean progress (`progress`), a "competitive" claim's margin."""
    assert claim.b is not None  # a comparison names both sides
    if claim.kind == "competitive":
        return rules.competitive(a, b, reference_progress, claim.a, claim.b)
    return rules.beats(a, b, claim.a, claim.b)


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


def judge(claim: Claim, method: str, groups: dict[str, Group], level: float = 0.9) -> Verdict:
    """The verdict on `claim` from `groups` ({variant name: its runs}) of one method; `level`:
    the displayed intervals' (the tests are at ALPHA whatever it is)."""
    missing = [name for name in (claim.a, claim.b) if name is not None and name not in groups]
    if missing:
        return Verdict(
            claim, method, None, None, math.nan, NO_DATA, f"no finished runs of {', '.join(missing)}"
        )
    if claim.kind == "retraining":
        changes, per_episode = retraining_effects(groups[claim.a])
        judgement = rules.retraining(summarize(changes), summarize(per_episode))
        a, b = estimate(changes, level), estimate(per_episode, level)
        return from_judgement(claim, method, a, b, judgement)
    assert claim.b is not None  # a comparison names both sides
    a_group, b_group = groups[claim.a], groups[claim.b]
    if claim.kind == "converges":
        length = run_length(a_group, b_group)
        a_values, b_values = convergence_measures(a_group, length), convergence_measures(b_group, length)
        judgement = rules.converges(summarize(a_values), summarize(b_values), claim.a, claim.b, length)
        return from_judgement(claim, method, estimate(a_values, level), estimate(b_values, level), judgement)
    if claim.kind == "stuck":
        a_progress, b_progress = progress(a_group), progress(b_group)
        a_flags, b_flags, threshold = stuck_near_start(a_progress, b_progress)
        a_n, b_n = int(np.isfinite(a_progress).sum()), int(np.isfinite(b_progress).sum())
        judgement = rules.stuck(int(a_flags.sum()), a_n, int(b_flags.sum()), b_n, claim.a, claim.b, threshold)
        return from_judgement(
            claim,
            method,
            proportion(int(a_flags.sum()), a_n, level),
            proportion(int(b_flags.sum()), b_n, level),
            judgement,
        )
    a_values, b_values = final_losses(a_group), final_losses(b_group)
    reference = summarize(progress(b_group)).mean if claim.kind == "competitive" else math.nan
    judgement = compare(claim, summarize(a_values), summarize(b_values), reference)
    # Seeds that ended stuck count with their last good loss; the table says how many.
    a = dataclasses.replace(estimate(a_values, level), stuck=stuck_seeds(a_group))
    b = dataclasses.replace(estimate(b_values, level), stuck=stuck_seeds(b_group))
    return from_judgement(claim, method, a, b, judgement)


def with_holm(results: list[Verdict]) -> list[Verdict]:
    """The verdicts with `holm_p` set: Holm over the family of their tests (one per verdict
    with a `test_p`), so `holm_verdict` says which survive the correction.

    A row that NEEDS_RUNS (re-judged from a claims.csv without what its test needs) was a test
    of the family whose p is unknown: it counts as p = 1, the worst case for the others'
    correction (a larger family member never lowers another's adjusted p), and has no Holm p.
    """
    unknown = [v.verdict == NEEDS_RUNS for v in results]
    family = [1.0 if missing else v.test_p for v, missing in zip(results, unknown, strict=True)]
    adjusted = holm(family)
    return [
        dataclasses.replace(v, holm_p=math.nan if missing else float(p))
        for v, p, missing in zip(results, adjusted, unknown, strict=True)
    ]
