"""The paper's two other claims on a learning curve (`litl.claims`): *converges faster* (each
seed's mean task loss over every iteration, Welch) and *gets stuck less* (seeds whose progress is
under a quarter of the pooled median, Fisher's exact test), with their refusals."""

import dataclasses
import math
import pathlib

import numpy as np
import pytest
from scipy import stats

from litl.claims import rules
from litl.claims.rejudge import rejudge
from litl.claims.stats import fisher_detectable, fisher_exact, fisher_power, wilson
from litl.claims.suite import ClaimsError
from litl.claims.verdicts import (
    CONTRADICTED,
    HOLDS,
    NEEDS_RUNS,
    NOT_RESOLVED,
    convergence_measures,
    judge,
    stuck_near_start,
)
from litl.report.runs import Group, Run
from tests.test_claims import claim

CONVERGES = claim("4b-vae-converges-faster")
STUCK = claim("4b-vae-stuck-less")


def curves(name: str, curves_by_seed, skipped=()) -> Group:
    """A group whose seed s has the task losses `curves_by_seed[s]`, one per iteration; (seed,
    step) pairs in `skipped` are skipped iterations."""
    records = [
        {
            "seed": seed,
            "step": step,
            "episode": step // 10,
            "iteration": step % 10,
            "task_loss": math.nan if (seed, step) in skipped else float(loss),
            "skipped": "escaped" if (seed, step) in skipped else None,
        }
        for seed, losses in enumerate(curves_by_seed)
        for step, loss in enumerate(losses)
    ]
    return Group("biped", name, (Run(pathlib.Path(f"runs/{name}"), {"robot": "biped"}, tuple(records)),))


def falling(rate: float, end: float, seeds: int = 6, iterations: int = 20, jitter: float = 0.01):
    """Curves from 0 that fall to `end` at `rate` (1 - exp(-rate t)), each seed a little apart."""
    t = np.arange(iterations)
    return [end * (1 - np.exp(-rate * t)) + jitter * s for s in range(seeds)]


def test_the_convergence_measure_is_each_seeds_mean_over_the_run_with_skips_carrying_the_last_loss():
    group = curves("vae", [[0.0, -1.0, -2.0, -3.0], [5.0, -1.0, -2.0, -4.0]], skipped={(1, 0), (0, 2)})
    # seed 0: 0, -1, (-1 carried), -3; seed 1: (-1 before its first good one), -1, -2, -4.
    np.testing.assert_allclose(convergence_measures(group, 4), [-5.0 / 4, -8.0 / 4])


@pytest.mark.parametrize(
    ("vae_rate", "kmeans_rate", "verdict"),
    [(1.0, 0.1, HOLDS), (0.1, 1.0, CONTRADICTED), (0.5, 0.5, NOT_RESOLVED)],
)
def test_a_curve_that_falls_sooner_to_the_same_end_converges_faster(vae_rate, kmeans_rate, verdict):
    groups = {
        "vae": curves("vae", falling(vae_rate, -0.4)),
        "kmeans": curves("kmeans", falling(kmeans_rate, -0.4)),
    }
    result = judge(CONVERGES, "paper", groups)
    assert result.verdict == verdict
    a = [np.mean(c) for c in falling(vae_rate, -0.4)]
    b = [np.mean(c) for c in falling(kmeans_rate, -0.4)]
    if verdict != NOT_RESOLVED:
        assert result.p == pytest.approx(stats.ttest_ind(a, b, equal_var=False).pvalue, rel=1e-9)
    assert "all 20 iterations" in result.rule


def test_a_run_shorter_than_the_compared_one_is_refused_naming_it():
    short = curves("kmeans", [c[:12] for c in falling(0.5, -0.4)])
    with pytest.raises(ClaimsError, match=r"runs/kmeans: seed 0 has 12 iterations.*needs 20"):
        judge(CONVERGES, "paper", {"vae": curves("vae", falling(0.5, -0.4)), "kmeans": short})


def test_stuck_seeds_are_those_under_a_quarter_of_the_pooled_median_progress():
    a_progress, b_progress = np.array([0.4, 0.04, np.nan, 0.3]), np.array([0.4, 0.2, 0.03, 0.11])
    a_flags, b_flags, threshold = stuck_near_start(a_progress, b_progress)
    assert threshold == pytest.approx(
        rules.STUCK_FRACTION * np.median([0.4, 0.04, 0.3, 0.4, 0.2, 0.03, 0.11])
    )
    assert a_flags.tolist() == [False, True, False, False] and b_flags.tolist() == [False, False, True, False]


def test_the_papers_four_of_ten_stuck_against_none_is_not_resolved_at_ten_seeds_but_is_at_thirty():
    def stuck_in(n_stuck: int, seeds: int):
        # A seed walks 0.4 from a start at 0, or stays within 0.01 of it.
        return [np.linspace(0.0, -0.01 if s < n_stuck else -0.4, 20) for s in range(seeds)]

    ten = judge(
        STUCK, "paper", {"vae": curves("vae", stuck_in(0, 10)), "kmeans": curves("kmeans", stuck_in(4, 10))}
    )
    assert (ten.a.mean, ten.b.mean) == (0.0, 0.4)
    assert ten.p == pytest.approx(stats.fisher_exact([[0, 10], [4, 6]]).pvalue)
    assert ten.verdict == NOT_RESOLVED and ten.detectable > 0.4  # 10 seeds cannot tell 0 from 4 in 10
    thirty = judge(
        STUCK, "paper", {"vae": curves("vae", stuck_in(0, 30)), "kmeans": curves("kmeans", stuck_in(12, 30))}
    )
    assert thirty.verdict == HOLDS and thirty.difference == pytest.approx(-0.4)
    worse = judge(
        STUCK, "paper", {"vae": curves("vae", stuck_in(12, 30)), "kmeans": curves("kmeans", stuck_in(0, 30))}
    )
    assert worse.verdict == CONTRADICTED


def test_no_progress_anywhere_defines_no_stuck_seed():
    flat = [np.zeros(20) for _ in range(5)]
    result = judge(STUCK, "paper", {"vae": curves("vae", flat), "kmeans": curves("kmeans", flat)})
    assert result.verdict == NOT_RESOLVED and "not positive" in result.rule


def test_fishers_power_and_detectable_difference_are_exact():
    # Power by hand: the probability of the outcomes that Fisher's test rejects.
    rejecting = sum(
        stats.binom.pmf(x, 10, 0.1) * stats.binom.pmf(y, 10, 0.7)
        for x in range(11)
        for y in range(11)
        if stats.fisher_exact([[x, 10 - x], [y, 10 - y]]).pvalue < 0.05
    )
    assert fisher_power(10, 10, 0.1, 0.7, 0.05) == pytest.approx(rejecting, rel=1e-9)
    d = fisher_detectable(10, 10, 0.2, 0.05, 0.8)
    assert 0.5 < d < 0.7 and fisher_detectable(30, 30, 0.2, 0.05, 0.8) < d
    assert fisher_exact(0, 10, 4, 10) == pytest.approx(stats.fisher_exact([[0, 10], [4, 6]]).pvalue)
    low, high = wilson(4, 10, 0.1)
    assert low < 0.4 < high and wilson(0, 10, 0.1)[0] == 0.0


def test_a_claims_csv_cannot_judge_curves_and_says_what_it_lacks(tmp_path):
    from litl.claims.tables import CSV_FIELDS

    row = {field: "" for field in CSV_FIELDS}
    sides = {"a_mean": "-0.3", "a_low": "-0.35", "a_high": "-0.25", "a_n": "10"}
    sides |= {"b_mean": "-0.2", "b_low": "-0.25", "b_high": "-0.15", "b_n": "10"}
    row |= {
        "claim": "4b-vae-beats-kmeans",
        "method": "paper",
        "a": "vae",
        "b": "kmeans",
        "verdict": "holds",
        **sides,
    }
    path = tmp_path / "claims.csv"
    import csv

    with open(path, "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=CSV_FIELDS)
        writer.writeheader()
        writer.writerow(row)
    results = {v.claim.id: v for v in rejudge(path)}
    for claim_id in ("4b-vae-converges-faster", "4b-vae-stuck-less"):
        assert results[claim_id].verdict == NEEDS_RUNS
        assert str(path) in results[claim_id].rule and "per iteration" in results[claim_id].rule
    # The two rows the record cannot judge count in the Holm family as p = 1: 3 tests, not 1.
    assert results["4b-vae-beats-kmeans"].holm_p == pytest.approx(
        min(1.0, 3 * results["4b-vae-beats-kmeans"].test_p)
    )


def test_the_stuck_seeds_are_drawn_thick_and_each_seeds_first_phase_is_tabled(tmp_path):
    from litl.claims.seeds import first_phase_markdown, plot_stuck_seeds

    def stuck_in(n_stuck: int, seeds: int = 5):
        return [np.linspace(0.0, -0.01 if s < n_stuck else -0.4, 20) for s in range(seeds)]

    vae, kmeans = curves("vae", stuck_in(1)), curves("kmeans", stuck_in(3))
    learning = [
        {"seed": s, "phase": 0, "recon_explained": e, "active_units": u, "sgd_steps": 40}
        for s, (e, u) in enumerate([(0.5, 8), (0.0, 1), (0.3, 3), (0.25, 4), (0.6, 8)])
    ]
    vae = Group("biped", "vae", (dataclasses.replace(vae.runs[0], learning=tuple(learning)),))
    groups = {("paper", "fig4b"): {"vae": vae, "kmeans": kmeans}}
    (path,) = plot_stuck_seeds(groups, ["paper"], tmp_path)
    assert path.name == "fig4b_seeds_paper.png" and path.stat().st_size > 0
    text = first_phase_markdown(groups, ["paper"])
    assert "fig4b, vae, method=paper: the first phase learned in 3 of 5 seeds" in text
    assert "| 1 | 0.000 | 1 | 40 | no |" in text and "| 2 | 0.300 | 3 | 40 | no |" in text
    assert first_phase_markdown({("paper", "fig4b"): {"kmeans": kmeans}}, ["paper"]) == ""
