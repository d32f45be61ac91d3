"""Verdicts that do not depend on where a run was cut (`litl.claims.cuts`): each verdict again at
an earlier cut, and the slopes of its curves at the end; on made-up runs."""

import csv
import pathlib

import numpy as np
import pytest

from litl.claims.cuts import CUT, cut_group, kept, slope, tail_slopes, with_cuts
from litl.claims.estimates import Estimate, falling
from litl.claims.markdown import claims_markdown
from litl.claims.tables import verdicts, write_csv
from litl.claims.verdicts import CLAIMS, HOLDS, NOT_RESOLVED, judge, with_holm
from litl.report.runs import Group, Run
from tests.test_claims import HIGH, LOW, group

STEPS = 20


def curves(name: str, losses) -> Group:
    """A group whose seed s has task loss `losses[s][step]` at every step."""
    records = tuple(
        {"seed": seed, "step": step, "episode": step // 10, "iteration": step % 10, "task_loss": float(loss)}
        for seed, row in enumerate(losses)
        for step, loss in enumerate(row)
    )
    return Group("biped", name, (Run(pathlib.Path(name), {"robot": "biped"}, records),))


def flat(finals) -> Group:
    return curves("flat", [[final] * STEPS for final in finals])


def claim(claim_id):
    return next(c for c in CLAIMS if c.id == claim_id)


BEATS = claim("4b-vae-beats-kmeans")


def test_a_cut_keeps_the_first_iterations():
    assert kept(CUT, 60) == 36 and kept(CUT, 20) == 12 and kept(CUT, 1) == 1
    cut = cut_group(flat(LOW), 12)
    assert {r["step"] for run in cut.runs for r in run.records} == set(range(12))
    assert cut.label == "flat" and cut.n_seeds == len(LOW)


def test_the_slope_is_the_least_squares_slope_of_the_last_fifth():
    # Seed s falls by 0.01 + 0.001 s per iteration, with an offset: the slopes are exact.
    rates = [0.01 + 0.001 * s for s in range(5)]
    group_ = curves("falling", [[1.0 + s - rate * t for t in range(STEPS)] for s, rate in enumerate(rates)])
    window, slopes = tail_slopes(group_)
    assert window == 4
    np.testing.assert_allclose(slopes, [-r for r in rates], rtol=1e-9)
    _, estimate = slope(group_)
    assert estimate.mean == pytest.approx(-np.mean(rates)) and estimate.high < 0
    assert falling(estimate)


def test_a_flat_or_noisy_curve_is_not_still_falling():
    rng = np.random.default_rng(0)
    noisy = curves("noisy", [list(-1.0 + 0.05 * rng.standard_normal(STEPS)) for _ in range(6)])
    _, estimate = slope(noisy)
    assert estimate.low < 0 < estimate.high and not falling(estimate)
    _, constant = slope(flat(LOW))
    assert constant.mean == 0 and not falling(constant)
    # One seed has no interval: never flagged.
    assert not falling(Estimate(-1.0, -1.0, -1.0, 1))
    assert not falling(None)


def test_skipped_iterations_are_left_out_of_the_slope():
    group_ = curves("skips", [[-0.1 * t for t in range(STEPS)]] * 2)
    records = [dict(r) for r in group_.runs[0].records]
    for r in records:
        if r["step"] == STEPS - 1:
            r["skipped"], r["task_loss"] = "particles_escaped", float("nan")
    run = Run(pathlib.Path("skips"), {"robot": "biped"}, tuple(records))
    _, slopes = tail_slopes(Group("biped", "skips", (run,)))
    np.testing.assert_allclose(slopes, [-0.1, -0.1])


def _changing():
    """vae as high as k-means up to the cut, far lower after: not resolved at 60%, holds at the end."""
    cut = kept(CUT, STEPS)
    vae = curves("vae", [[high] * cut + [low] * (STEPS - cut) for low, high in zip(LOW, HIGH, strict=True)])
    return {"vae": vae, "kmeans": flat(HIGH)}


def test_a_verdict_that_changes_between_the_cut_and_the_end_is_flagged():
    groups = _changing()
    (checked,) = with_cuts(with_holm([judge(BEATS, "litl", groups)]), {("litl", "fig4b"): groups})
    assert checked.verdict == HOLDS
    cut = checked.cut
    assert cut is not None and cut.total == STEPS and cut.iterations == 12 and cut.fraction == CUT
    assert cut.verdict == NOT_RESOLVED and cut.changed(checked)
    # Flat after the step: not still falling.
    assert cut.tail == 4 and cut.still_falling == []


def test_a_settled_verdict_is_not_flagged_and_a_falling_curve_is():
    settled = {"vae": flat(LOW), "kmeans": flat(HIGH)}
    (checked,) = with_cuts(with_holm([judge(BEATS, "litl", settled)]), {("litl", "fig4b"): settled})
    assert checked.cut is not None and checked.cut.verdict == checked.verdict == HOLDS
    assert not checked.cut.changed(checked) and checked.cut.still_falling == []
    # k-means still falling at the end (at the same final values): flagged, verdict unchanged.
    falling_kmeans = curves(
        "kmeans", [[h + 0.01 * (STEPS - t) * (1 + 0.1 * s) for t in range(STEPS)] for s, h in enumerate(HIGH)]
    )
    groups = {"vae": flat(LOW), "kmeans": falling_kmeans}
    (checked,) = with_cuts(with_holm([judge(BEATS, "litl", groups)]), {("litl", "fig4b"): groups})
    assert checked.cut is not None and checked.cut.still_falling == ["b"]


def test_table1s_claim_is_cut_too_and_has_one_curve():
    retraining = claim("table1-retraining")
    groups = {"vae": group("vae", LOW, retrain=[0.001, 0.002, 0.0, -0.001, 0.001])}
    (checked,) = with_cuts(with_holm([judge(retraining, "litl", groups)]), {("litl", "fig4b"): groups})
    assert checked.cut is not None and checked.cut.b_slope is None and checked.cut.a_slope is not None


def test_the_claims_table_gives_each_verdict_at_the_cut_and_flags_the_changed(tmp_path):
    groups = {("litl", "fig4b"): {**_changing(), "sinusoid": flat(HIGH)}}
    results = verdicts(groups, ["litl"])
    assert all(v.cut is not None for v in results)
    text = claims_markdown(results, 0.9, "python -m litl.claims", [], {})
    assert "## Where the runs were cut" in text and "first 60% of iterations" in text
    row = next(line for line in text.splitlines() if line.startswith("| on the biped, the VAE beats k-means"))
    assert "(‡)" in row
    cut_row = [
        line for line in text.splitlines() if line.startswith("| on the biped, the VAE beats k-means")
    ][1]
    assert "| 20 | holds (holds) | 12 | not resolved (not resolved) |" in cut_row and "**changed**" in cut_row
    assert "(‡) The verdict depends on where the runs were cut" in text
    with open(write_csv(results, tmp_path / "claims.csv")) as file:
        rows = {r["claim"]: r for r in csv.DictReader(file)}
    beats = rows["4b-vae-beats-kmeans"]
    assert beats["cut_verdict"] == NOT_RESOLVED and beats["cut_changed"] == "True"
    assert beats["iterations"] == "20" and beats["cut_iterations"] == "12" and beats["tail_iterations"] == "4"
    assert float(beats["a_slope"]) == 0 and beats["a_still_falling"] == "False"
    assert beats["a_stuck"] == "0"
    # Without a cut check: the table as before.
    plain = verdicts(groups, ["litl"], cut=None)
    assert all(v.cut is None for v in plain)
    assert "Where the runs were cut" not in claims_markdown(plain, 0.9, "c", [], {})


@pytest.mark.parametrize("fraction", [0, 1, 1.5, -0.2, True])
def test_a_cut_outside_the_run_is_refused(fraction):
    groups = {"vae": flat(LOW), "kmeans": flat(HIGH)}
    results = with_holm([judge(BEATS, "litl", groups)])
    with pytest.raises(ValueError, match="fraction of the iterations in \\(0, 1\\)"):
        with_cuts(results, {("litl", "fig4b"): groups}, fraction=fraction)
    with pytest.raises(ValueError, match="the tail must be"):
        with_cuts(results, {("litl", "fig4b"): groups}, tail=fraction)
