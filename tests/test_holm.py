"""The claims table's multiple-comparison correction: Holm-Bonferroni on known values, the
verdicts that survive it, the table's columns, and the suite of record's page."""

import csv
import dataclasses
import math
import pathlib
import re

import numpy as np
import pytest
from scipy.stats import ttest_ind

from litl.claims import rules
from litl.claims.markdown import claims_markdown
from litl.claims.tables import write_csv
from litl.claims.verdicts import (
    CLAIMS,
    CONTRADICTED,
    HOLDS,
    NO_DATA,
    NOT_RESOLVED,
    holm,
    judge,
    with_holm,
)
from tests.test_claims import HIGH, LOW, SAME, TIGHT, claim, group

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    "p, adjusted",
    [
        # R: p.adjust(c(0.01, 0.02, 0.03, 0.04, 0.05), "holm")
        ([0.01, 0.02, 0.03, 0.04, 0.05], [0.05, 0.08, 0.09, 0.09, 0.09]),
        # Unsorted input keeps its order; 0.04 * 1 is raised to the 0.06 before it.
        ([0.01, 0.04, 0.03, 0.005], [0.03, 0.06, 0.06, 0.02]),
        # Capped at 1; a NaN (no test) is not in the family and stays NaN.
        ([0.3, math.nan, 0.6], [0.6, math.nan, 0.6]),
        ([0.5, 0.9], [1.0, 1.0]),
        ([], []),
    ],
)
def test_holm_matches_known_values(p, adjusted):
    np.testing.assert_allclose(holm(p), adjusted, rtol=1e-12)


def test_holm_refuses_what_is_not_a_family_of_p_values():
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        holm([0.1, 1.5])
    with pytest.raises(ValueError, match="1-D"):
        holm([[0.1, 0.2]])


def test_each_verdict_rests_on_the_test_that_decided_it():
    # "Beats": one two-sided Welch test decides either way, so p and test_p are the same.
    for a, b, verdict in ((LOW, HIGH, HOLDS), (HIGH, LOW, CONTRADICTED), (SAME, LOW, NOT_RESOLVED)):
        groups = {"vae": group("vae", a), "kmeans": group("k", b)}
        result = judge(claim("4b-vae-beats-kmeans"), "litl", groups)
        assert result.verdict == verdict
        assert result.test_p == result.p == pytest.approx(ttest_ind(a, b, equal_var=False).pvalue, rel=1e-9)
    # "Competitive": p is the doubled non-inferiority p (H0: a - b >= 0.1, the margin); a
    # contradicted row rests on the doubled p of the opposite test (H0: a - b <= 0.1), one not
    # resolved on the smaller of the two.
    competitive = claim("4a-kmeans-competitive")
    shifted = [x + 0.1 for x in TIGHT]  # b moved by the margin: the tests are Welch's against it
    for shift, verdict in ((0.02, HOLDS), (0.3, CONTRADICTED), (0.1, NOT_RESOLVED)):
        a = [x + shift for x in TIGHT]
        result = judge(competitive, "litl", {"kmeans": group("k", a), "vae": group("vae", TIGHT)})
        holding = min(1, 2 * ttest_ind(a, shifted, equal_var=False, alternative="less").pvalue)
        opposite = min(1, 2 * ttest_ind(a, shifted, equal_var=False, alternative="greater").pvalue)
        assert result.verdict == verdict and result.p == pytest.approx(holding, rel=1e-9)
        expected = {HOLDS: holding, CONTRADICTED: opposite, NOT_RESOLVED: min(holding, opposite)}[verdict]
        assert result.test_p == pytest.approx(expected, rel=1e-9)


def test_verdicts_that_do_not_survive_holm_become_not_resolved():
    vae, kmeans = group("vae", LOW), group("kmeans", HIGH)
    beats = judge(claim("4b-vae-beats-kmeans"), "litl", {"vae": vae, "kmeans": kmeans})
    near = group("kmeans", [x + 0.02 for x in TIGHT])
    competitive = judge(claim("4a-kmeans-competitive"), "litl", {"kmeans": near, "vae": group("vae", TIGHT)})
    assert beats.verdict == HOLDS and competitive.verdict == HOLDS
    (alone,) = with_holm([beats])
    assert alone.holm_p == pytest.approx(beats.test_p) and alone.holm_verdict == HOLDS
    # A verdict at p = 0.02 holds alone; among three such tests its adjusted p is 0.06.
    marginal = dataclasses.replace(beats, test_p=0.02)
    assert with_holm([marginal])[0].holm_verdict == HOLDS
    family = with_holm([marginal] * 3)
    assert [v.holm_p for v in family] == pytest.approx([0.06] * 3)
    assert all(v.holm_verdict == NOT_RESOLVED and v.verdict == HOLDS for v in family)
    # A "competitive" claim is a test like the others now: it holds after Holm only if its
    # adjusted p is below 0.05.
    assert with_holm([competitive] * 3)[0].holm_verdict == HOLDS
    weak = dataclasses.replace(competitive, test_p=0.02)
    assert [v.holm_verdict for v in with_holm([weak] * 3)] == [NOT_RESOLVED] * 3
    contradicted = dataclasses.replace(competitive, verdict=CONTRADICTED, test_p=0.04)
    other = dataclasses.replace(beats, test_p=0.03)
    assert [v.holm_verdict for v in with_holm([contradicted, other])] == [NOT_RESOLVED] * 2


def test_the_claims_table_shows_holm_first_and_the_paper_caveat(tmp_path):
    groups = {"vae": group("vae", LOW), "kmeans": group("kmeans", HIGH), "sinusoid": group("s", SAME)}
    results = with_holm(
        [
            judge(c, m, groups)
            for m in ("litl", "paper")
            for c in CLAIMS
            if c.panel == "fig4b" and c.b and not c.comparator
        ]
    )
    text = claims_markdown(results, 0.9, "python -m litl.claims", [], {})
    header = next(line for line in text.splitlines() if line.startswith("| claim |"))
    assert "| verdict (after Holm) | Holm p | p | unadjusted |" in header
    assert header.endswith("| difference [95% CI] | detectable | margin δ |")
    assert f"the table makes {len(results)} tests at once" in text
    assert "is the primary verdict" in text
    rows = [line for line in text.splitlines() if line.startswith("| on the biped")]
    # Four comparisons (final distance, convergence, stuck seeds, open loop) under two methods.
    assert len(rows) == 8
    for row in rows:
        assert ("(†)" in row) == ("| paper |" in row), row
    assert "(†) method=paper is litl's reading of the paper's text" in text
    with open(write_csv(results, tmp_path / "claims.csv")) as file:
        written = list(csv.DictReader(file))
    assert [float(r["holm_p"]) for r in written] == pytest.approx([v.holm_p for v in results])
    assert [r["holm_verdict"] for r in written] == [v.holm_verdict for v in results]
    assert [r["verdict"] for r in written] == [v.verdict for v in results]


def test_the_suite_pages_holm_column_is_holm_of_its_claims_csv():
    """The suite of record's page was corrected by hand from its claims.csv (the runs are not in
    the repository): its Holm column must be Holm of that file's p-values under the rules of its
    day (one-sided tests; `python -m litl.claims --rejudge` judges it by today's)."""
    with open(ROOT / "docs/assets/2026-11-26/suite/claims.csv") as file:
        rows = list(csv.DictReader(file))
    kinds = {c.id: c.kind for c in CLAIMS}
    test_p = []
    for row in rows:
        p = float(row["p"])
        if kinds[row["claim"]] == "competitive" or row["verdict"] == HOLDS:
            test_p.append(p)
        elif row["verdict"] == CONTRADICTED:
            test_p.append(1 - p)
        else:
            test_p.append(min(p, 1 - p))
    adjusted = holm(test_p)
    page = (ROOT / "docs/results/2026-11-26-claims-suite.md").read_text()
    table = [
        line for line in page.split("## The claims table", 1)[1].splitlines() if line.startswith("| on ")
    ]
    assert len(table) == len(rows) == 20
    for line, row, value in zip(table, rows, adjusted, strict=True):
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        assert cells[1] == row["method"] and cells[0] == row["statement"]
        assert float(cells[8]) == pytest.approx(float(f"{value:.3g}"), rel=1e-9), line
        surviving = cells[9].replace("(†)", "").strip()
        verdict = row["verdict"]
        expected = (
            verdict
            if verdict == NOT_RESOLVED or value < 0.05 or kinds[row["claim"]] == "competitive"
            else NOT_RESOLVED
        )
        assert re.sub(r"\*", "", surviving) == expected, line


@pytest.mark.parametrize(
    "verdict, holm_p, survives",
    [
        (HOLDS, 0.049, HOLDS),
        (HOLDS, 0.05, NOT_RESOLVED),
        (CONTRADICTED, 0.01, CONTRADICTED),
        (CONTRADICTED, math.nan, NOT_RESOLVED),
        (NO_DATA, 0.001, NO_DATA),
        (NOT_RESOLVED, 0.001, NOT_RESOLVED),
    ],
)
def test_one_rule_decides_what_survives_holm(verdict, holm_p, survives):
    """The claims tables (`Verdict.holm_verdict`) and the budget comparison (`litl.report.budget`)
    both ask `rules.after_holm`: a holds or contradicted needs its adjusted p below ALPHA."""
    assert rules.after_holm(verdict, holm_p) == survives
