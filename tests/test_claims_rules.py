"""The claims' rules (`litl.claims.rules`, `litl.claims.stats`): two-sided tests under Holm,
non-inferiority within a stated margin, the detectable difference, and re-judging a claims.csv
from its summary statistics (`python -m litl.claims --rejudge`)."""

import csv
import math

import numpy as np
import pytest
from scipy import stats

import litl
from litl.claims import rules
from litl.claims.cli import main
from litl.claims.rejudge import rejudge
from litl.claims.stats import Summary, holm, one_sample, sd_from_interval, summarize, welch
from litl.claims.suite import ClaimsError
from litl.claims.tables import CSV_FIELDS, verdicts, write_csv
from litl.claims.verdicts import (
    CONTRADICTED,
    HOLDS,
    NEEDS_RUNS,
    NO_DATA,
    NOT_RESOLVED,
    estimate,
    judge,
    welch_p_lower,
    with_holm,
)
from litl.records import provenance
from litl.report.stats import confidence_band
from tests.test_claims import HIGH, LOW, TIGHT, claim, group

BEATS = claim("4b-vae-beats-kmeans")
COMPETITIVE = claim("4a-kmeans-competitive")


# --- two-sided tests ---------------------------------------------------------------------------


def test_a_beats_claims_p_is_scipys_two_sided_welch_p():
    rng = np.random.default_rng(1)
    a, b = rng.normal(0.0, 1.0, 10), rng.normal(0.8, 2.0, 7)  # unequal spreads and seed counts
    result = judge(BEATS, "litl", {"vae": group("vae", a), "kmeans": group("kmeans", b)})
    expected = stats.ttest_ind(a, b, equal_var=False)
    assert result.p == result.test_p == pytest.approx(expected.pvalue, rel=1e-9)
    low, high = expected.confidence_interval(0.95)
    assert (result.difference_low, result.difference_high) == pytest.approx((low, high), rel=1e-9)
    assert result.difference == pytest.approx(a.mean() - b.mean())


def test_a_gap_one_sided_005_called_holds_is_not_resolved_two_sided():
    # t = 2 with 8 degrees of freedom: one-sided p 0.040, two-sided 0.081.
    a, b = LOW, [x + 0.1 for x in LOW]
    assert 0.025 < welch_p_lower(a, b) < 0.05  # the old rule's "holds"
    result = judge(BEATS, "litl", {"vae": group("vae", a), "kmeans": group("kmeans", b)})
    assert result.p == pytest.approx(2 * welch_p_lower(a, b), rel=1e-9)
    assert result.verdict == NOT_RESOLVED and result.holm_verdict == NOT_RESOLVED


def test_table1s_p_is_the_two_sided_one_sample_p_and_agrees_with_its_interval():
    changes = [0.001, -0.002, 0.0, 0.001, -0.001]
    result = judge(claim("table1-retraining"), "litl", {"vae": group("vae", LOW, retrain=changes)})
    threshold = -0.1 * 0.45  # -MARGIN x the progress per episode (test_claims's groups)
    assert result.margin == pytest.approx(0.045)
    assert result.p == pytest.approx(stats.ttest_1samp(changes, threshold).pvalue, rel=1e-9)
    assert result.verdict == HOLDS and result.difference_low > 0  # the 95% interval above -delta


def test_each_test_holds_its_level_and_holm_the_familys():
    # 800 families of 5 comparisons of equal normal means (n = 10): the old rule (one-sided
    # Welch at 0.05 each way) resolves ~10% of null comparisons; the two-sided rule ~5%, and
    # after Holm ~5% of families have any resolved.
    rng = np.random.default_rng(7)
    families, size = 800, 5
    a, b = rng.normal(size=(2, families, size, 10))
    one_sided = stats.ttest_ind(a, b, axis=-1, equal_var=False, alternative="less").pvalue
    old_rate = np.mean((one_sided < 0.05) | (one_sided > 0.95))
    judged = [
        [rules.beats(summarize(x), summarize(y), "a", "b") for x, y in zip(xs, ys, strict=True)]
        for xs, ys in zip(a, b, strict=True)
    ]
    new_rate = np.mean([[j.verdict != NOT_RESOLVED for j in family] for family in judged])
    family_errors = []
    for family in judged:
        p = [j.test_p for j in family]
        adjusted = holm(p)
        assert np.all(adjusted >= np.asarray(p) - 1e-15)  # Holm never lowers a p-value
        family_errors.append(bool(np.any(adjusted < rules.ALPHA)))
    assert 0.08 < old_rate < 0.12
    assert 0.035 < new_rate < 0.065
    assert np.mean(family_errors) < 0.05 + 3 * math.sqrt(0.05 * 0.95 / families)


def test_the_holm_family_is_the_two_sided_ps():
    groups = {"vae": group("vae", LOW), "kmeans": group("kmeans", HIGH), "sinusoid": group("s", LOW)}
    results = verdicts({("litl", "fig4b"): groups}, ["litl"], cut=None)
    tested = [v for v in results if math.isfinite(v.test_p)]
    assert [v.holm_p for v in tested] == pytest.approx(list(holm([v.test_p for v in tested])))
    beats = next(v for v in tested if v.claim.id == "4b-vae-beats-kmeans")
    assert beats.test_p == pytest.approx(stats.ttest_ind(LOW, HIGH, equal_var=False).pvalue)
    assert all(v.holm_p >= v.test_p for v in tested)


# --- non-inferiority ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "a_mean, verdict",
    [(0.0, HOLDS), (-3.0, HOLDS), (2.0, CONTRADICTED), (0.5, NOT_RESOLVED), (1.0, NOT_RESOLVED)],
)
def test_non_inferiority_within_a_known_margin(a_mean, verdict):
    # sd 1, n 10 each side: se = sqrt(0.2), df = 18, the 95% half-width 2.101 x 0.447 = 0.940;
    # progress 10 makes the margin 1.
    a, b = Summary(a_mean, 1.0, 10), Summary(0.0, 1.0, 10)
    result = rules.competitive(a, b, 10.0, "kmeans", "vae")
    assert result.margin == pytest.approx(1.0) and result.verdict == verdict
    half = stats.t.ppf(0.975, 18) * math.sqrt(0.2)
    assert (result.difference_low, result.difference_high) == pytest.approx((a_mean - half, a_mean + half))
    # p: H0 a - b >= 1, one-sided, doubled (capped at 1).
    one_sided = stats.ttest_ind_from_stats(a_mean - 1.0, 1.0, 10, 0.0, 1.0, 10, equal_var=False).pvalue / 2
    less = one_sided if a_mean < 1.0 else 1 - one_sided
    assert result.p == pytest.approx(min(1.0, 2 * less), rel=1e-9)
    assert (result.p < rules.ALPHA) == (verdict == HOLDS)


def test_non_inferiority_without_progress_has_no_margin():
    a, b = Summary(0.0, 1.0, 10), Summary(0.0, 1.0, 10)
    stalled = rules.competitive(a, b, -0.2, "kmeans", "vae")
    assert stalled.verdict == NOT_RESOLVED and "vae made no progress" in stalled.rule
    assert math.isnan(stalled.test_p)  # no test: not in the Holm family
    unknown = rules.competitive(a, b, math.nan, "kmeans", "vae")
    assert unknown.verdict == NO_DATA and "first iteration" in unknown.rule


def test_the_margin_is_a_tenth_of_the_references_progress_from_its_runs():
    # test_claims's groups start each seed 1.0 above its final task loss: a margin of 0.1.
    result = judge(COMPETITIVE, "litl", {"kmeans": group("k", TIGHT), "vae": group("vae", TIGHT)})
    assert result.margin == pytest.approx(0.1) and result.verdict == HOLDS


# --- the detectable difference -----------------------------------------------------------------


@pytest.mark.parametrize("n_a, n_b, sd_a, sd_b", [(10, 10, 1.0, 1.0), (10, 7, 0.5, 2.0), (5, 5, 0.1, 0.3)])
def test_the_detectable_difference_is_the_80_percent_power_formula(n_a, n_b, sd_a, sd_b):
    difference = welch(Summary(0.0, sd_a, n_a), Summary(0.0, sd_b, n_b))
    se = math.sqrt(sd_a**2 / n_a + sd_b**2 / n_b)
    df = se**4 / ((sd_a**2 / n_a) ** 2 / (n_a - 1) + (sd_b**2 / n_b) ** 2 / (n_b - 1))
    expected = (stats.t.ppf(0.975, df) + stats.t.ppf(0.8, df)) * se
    assert difference.detectable(0.05, 0.8) == pytest.approx(expected, rel=1e-12)
    # Its power by the noncentral t: about 80% (the formula's approximation).
    critical, ncp = stats.t.ppf(0.975, df), expected / se
    power = stats.nct.sf(critical, df, ncp) + stats.nct.cdf(-critical, df, ncp)
    assert power == pytest.approx(0.8, abs=0.01)


def test_a_welch_test_finds_the_detectable_difference_80_percent_of_the_time():
    rng = np.random.default_rng(3)
    delta = welch(Summary(0.0, 1.0, 10), Summary(0.0, 1.0, 10)).detectable(0.05, 0.8)
    a = rng.normal(0.0, 1.0, (4000, 10))
    b = rng.normal(delta, 1.0, (4000, 10))
    found = stats.ttest_ind(a, b, axis=1, equal_var=False).pvalue < 0.05
    assert found.mean() == pytest.approx(0.8, abs=0.025)


def test_one_sample_detectable_and_gap_flag():
    x = Summary(0.3, 1.0, 10)
    difference = one_sample(x, 0.0)
    expected = (stats.t.ppf(0.975, 9) + stats.t.ppf(0.8, 9)) / math.sqrt(10)
    assert difference.detectable(0.05, 0.8) == pytest.approx(expected)
    close = group("kmeans", [x + 0.1 for x in LOW])
    result = judge(BEATS, "litl", {"vae": group("vae", LOW), "kmeans": close})
    assert result.gap_below_detectable is True and result.detectable > 0.1
    clear = judge(BEATS, "litl", {"vae": group("vae", LOW), "kmeans": group("kmeans", HIGH)})
    assert clear.gap_below_detectable is False


# --- re-judging a claims.csv -------------------------------------------------------------------


def test_a_student_t_interval_gives_back_its_standard_deviation():
    values = np.array([0.3, 0.1, 0.7, 0.2, 0.45, 0.5])
    mean, _, high = confidence_band(values, 0.9)
    assert sd_from_interval(float(mean), float(high), 6, 0.9) == pytest.approx(values.std(ddof=1), rel=1e-12)


def _suite(tmp_path):
    """Runs with known seeds for the biped (beats x 2, Table 1) and the arm (competitive and
    beats), judged and written as a claims.csv."""
    rng = np.random.default_rng(11)
    biped = {
        "vae": group("vae", rng.normal(-1.0, 0.1, 10), retrain=rng.normal(-0.01, 0.02, 10)),
        "kmeans": group("kmeans", rng.normal(-0.9, 0.1, 9)),
        "sinusoid": group("sinusoid", rng.normal(-0.95, 0.2, 10)),
    }
    arm = {
        name: group(name, rng.normal(0.5, 0.05, 10))
        for name in ("vae", "kmeans", "vae_one_shot", "vae_no_replay")
    }
    groups = {(method, "fig4b"): biped for method in ("litl", "paper")} | {("litl", "fig4a"): arm}
    results = verdicts(groups, ["litl", "paper"])
    return results, write_csv(results, tmp_path / "claims.csv")


def test_rejudging_a_csv_reproduces_the_runs_verdicts(tmp_path):
    results, path = _suite(tmp_path)
    again = rejudge(path)
    assert [(v.claim.id, v.method) for v in again] == [(v.claim.id, v.method) for v in results]
    for runs, csv_row in zip(results, again, strict=True):
        assert csv_row.previous_verdict == runs.verdict
        assert csv_row.previous_holm_verdict == runs.holm_verdict
        assert csv_row.difference == pytest.approx(runs.difference, rel=1e-9, nan_ok=True)
        assert csv_row.detectable == pytest.approx(runs.detectable, rel=1e-9, nan_ok=True)
        if runs.claim.kind == "competitive" and runs.verdict != NO_DATA:  # its margin needs the runs
            assert csv_row.verdict == NEEDS_RUNS and math.isnan(csv_row.holm_p)
            continue
        assert csv_row.verdict == runs.verdict
        assert csv_row.p == pytest.approx(runs.p, rel=1e-9, abs=1e-12, nan_ok=True)
        assert csv_row.margin == pytest.approx(runs.margin, rel=1e-9, nan_ok=True)
    kinds = {v.claim.kind for v in again if math.isfinite(v.p)}
    assert kinds == {"beats", "retraining", "converges", "stuck"}
    assert [v.verdict for v in again].count(NEEDS_RUNS) == 1
    # Holm: the competitive row counts as p = 1, the worst case for the others.
    family = [1.0 if v.verdict == NEEDS_RUNS else v.test_p for v in again]
    expected = holm(family)
    for v, p in zip(again, expected, strict=True):
        if v.verdict != NEEDS_RUNS:
            assert v.holm_p == pytest.approx(p, rel=1e-9, nan_ok=True)


def test_without_a_competitive_claim_holm_is_reproduced_too(tmp_path):
    results, _ = _suite(tmp_path)
    biped = [v for v in results if v.claim.panel == "fig4b"]
    path = write_csv(with_holm(biped), tmp_path / "biped.csv")
    again = rejudge(path)
    assert [v.holm_p for v in again] == pytest.approx([v.holm_p for v in with_holm(biped)], rel=1e-9)
    assert [v.holm_verdict for v in again] == [v.holm_verdict for v in with_holm(biped)]


def test_the_rejudge_command_writes_the_same_format_without_the_cut_check(tmp_path, capsys):
    _, path = _suite(tmp_path)
    out = tmp_path / "rejudged"
    assert main(["--rejudge", str(path), "--out", str(out)]) == 0
    with open(out / "claims.csv") as file:
        reader = csv.DictReader(file)
        rows = list(reader)
    assert tuple(reader.fieldnames or ()) == CSV_FIELDS
    assert all(row["cut_verdict"] == "" and row["a_slope"] == "" for row in rows)
    assert all(row["previous_verdict"] for row in rows)
    text = (out / "claims.md").read_text()
    assert "needs the runs, which were not kept" in text and "Re-judged" in text
    assert "| before |" in text
    # The table names the code that judged it (the runs' commit is another matter: origins).
    commit, _ = provenance.checkout()
    judged = f"judged by litl {litl.__version__}" + (f", commit {commit[:12]}" if commit else "")
    assert judged in text
    assert "needs the runs" in capsys.readouterr().out


def test_an_old_csv_without_the_stuck_count_leaves_it_unknown(tmp_path):
    _, path = _suite(tmp_path)
    with open(path) as file:
        rows = list(csv.DictReader(file))
    old = tmp_path / "old.csv"
    keep = ["claim", "method", "panel", "statement", "a", "a_mean", "a_low", "a_high", "a_n"]
    keep += ["b", "b_mean", "b_low", "b_high", "b_n", "p", "verdict", "rule", "source"]
    with open(old, "w", newline="") as file:
        writer = csv.DictWriter(file, keep, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    again = rejudge(old)
    assert all(v.a is None or v.a.stuck is None for v in again)
    with open(write_csv(again, tmp_path / "again.csv")) as file:
        assert {row["a_stuck"] for row in csv.DictReader(file)} == {""}


def _csv(tmp_path, rows, fields=None):
    path = tmp_path / "bad.csv"
    with open(path, "w", newline="") as file:
        writer = csv.DictWriter(file, fields or list(rows[0]), extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    return path


def _row(**changes):
    a, b = estimate(LOW), estimate(HIGH)
    row = {
        "claim": "4b-vae-beats-kmeans",
        "method": "litl",
        "a": "vae",
        "b": "kmeans",
        "verdict": HOLDS,
        **{f"a_{k}": getattr(a, k) for k in ("mean", "low", "high", "n")},
        **{f"b_{k}": getattr(b, k) for k in ("mean", "low", "high", "n")},
    }
    return row | changes


@pytest.mark.parametrize(
    "rows, fields, message",
    [
        ([_row()], ["claim", "method", "verdict", "a_mean", "a_n"], "lacks the column(s) a_low, a_high"),
        ([_row(claim="4z-made-up")], None, "unknown claim '4z-made-up'"),
        ([_row(a="pca")], None, "the row's a is 'pca'"),
        ([_row(a_mean="twelve")], None, "a_mean is not a number: 'twelve'"),
        ([_row(a_low=-3.0)], None, "is not centred on its mean"),
    ],
)
def test_a_csv_that_cannot_be_rejudged_says_what_is_missing(tmp_path, rows, fields, message):
    with pytest.raises(ClaimsError, match=message.replace("(", r"\(").replace(")", r"\)")):
        rejudge(_csv(tmp_path, rows, fields))


def test_a_rejudged_row_matches_scipys_welch_from_its_interval(tmp_path):
    # The record also names the biped's curve claims, which a claims.csv cannot judge.
    v, *curve_claims = rejudge(_csv(tmp_path, [_row()]))
    assert [c.verdict for c in curve_claims] == [NEEDS_RUNS, NEEDS_RUNS]
    assert v.p == pytest.approx(stats.ttest_ind(LOW, HIGH, equal_var=False).pvalue, rel=1e-9)
    assert v.previous_verdict == HOLDS and v.verdict == HOLDS


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--rejudge", "nowhere/claims.csv"], "no claims.csv at nowhere/claims.csv"),
        (["--scale", "smoke"], "--scale make(s) no sense"),
        (["--episodes", "10", "--jobs", "2"], "--episodes, --jobs make(s) no sense"),
        (["--report-only"], "--report-only make(s) no sense"),
        (["--level", "1.5"], "--level must lie in (0, 1)"),
    ],
)
def test_bad_rejudge_arguments_are_refused(tmp_path, capsys, argv, message):
    path = _csv(tmp_path, [_row()])
    argv = argv if argv[0] == "--rejudge" else ["--rejudge", str(path), *argv]
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--out", str(tmp_path / "out")])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_rejudge_refuses_to_overwrite_its_input(tmp_path, capsys):
    path = _csv(tmp_path, [_row()])
    (tmp_path / "claims.csv").write_bytes(path.read_bytes())
    with pytest.raises(SystemExit):
        main(["--rejudge", str(tmp_path / "claims.csv"), "--out", str(tmp_path)])
    assert "would overwrite the claims.csv being re-judged" in capsys.readouterr().err


def test_each_cell_counts_its_stuck_seeds_skipped_and_stepped_back_iterations():
    import pathlib

    from litl.claims.failures import cell_record, cells_markdown
    from litl.claims.origins import Origin
    from litl.report.runs import Group, Run

    def record(seed, step, loss, skipped=None, stepped_back=False):
        return {"seed": seed, "episode": 0, "iteration": step, "step": step, "task_loss": loss,
                "skipped": skipped, "stepped_back": stepped_back}  # fmt: skip

    # As report.runs reads them: a null float (`skipped` of a kept iteration) becomes NaN.
    records = [record(0, step, -0.1 * step, skipped=float("nan")) for step in range(4)]
    records += [record(1, 0, -0.1), record(1, 1, -0.2, stepped_back=True)]
    records += [record(1, 2, float("nan"), skipped="escaped"), record(1, 3, float("nan"), skipped="escaped")]
    group = Group("biped", "vae", (Run(pathlib.Path("."), {"config": {}}, tuple(records)),))
    cell = cell_record("litl/fig4b/vae", group)
    assert (cell.seeds, cell.stuck, cell.skipped, cell.stepped_back, cell.iterations) == (2, 1, 2, 1, 8)
    gpu = {"platform": "gpu", "device": "NVIDIA H200", "determinism": "off"}
    origins = {"litl/fig4b/vae": Origin("ab" * 20, None, 3.0, gpu)}
    lines = cells_markdown([cell], {"litl/fig4b/vae": 90.0}, origins)
    assert lines[-1] == (
        "| litl/fig4b/vae | 2 | 1 | 2 | 1 | 8 | 1.5 min | abababababab | yields past a stretch of 3 "
        "| NVIDIA H200, determinism off |"
    )
