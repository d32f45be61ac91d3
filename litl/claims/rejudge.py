"""Re-judging a published claims.csv by the current rules, from its summary statistics alone.

A claims.csv gives each side of a claim its mean over seeds, its Student-t interval at the
table's level (90% by default: `litl.report.stats.confidence_band`) and its seed count n. The
interval's upper end is mean + t_{(1+level)/2, n-1} s / sqrt(n), so it gives back the side's
sample standard deviation s exactly (`litl.claims.stats.sd_from_interval`), and (mean, s, n) is
all the rules of `litl.claims.rules` need for a "beats" claim and for Table 1's (whose b is the
progress per episode). A "competitive" claim's margin needs its reference's task loss at the
first iteration, which a claims.csv does not hold: its row says NEEDS_RUNS, with the verdict the
CSV held, and counts in the Holm family as p = 1 (`litl.claims.verdicts.with_holm`). Nothing is
invented: the cut check needs the runs too, and is left out.

    python -m litl.claims --rejudge docs/assets/2026-11-26/suite/claims.csv --out rejudged
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
import pathlib

from litl.claims import rules
from litl.claims.estimates import Estimate, proportion
from litl.claims.rules import NEEDS_RUNS
from litl.claims.stats import Summary, sd_from_interval, welch
from litl.claims.suite import ClaimsError
from litl.claims.verdicts import CLAIMS, Claim, Verdict, compare, from_judgement, with_holm
from litl.records.formatting import format_number

# The columns re-judging reads (a claims.csv of 2026-11-26 or later has them all).
REQUIRED = (
    *("claim", "method", "verdict"),
    *("a_mean", "a_low", "a_high", "a_n"),
    *("b_mean", "b_low", "b_high", "b_n"),
)


def read_claims_csv(path: str | os.PathLike[str]) -> list[dict[str, str]]:
    """The rows of a claims.csv written by `python -m litl.claims`.

    Raises:
      ClaimsError: no such file, or it lacks a column of REQUIRED, or has no rows.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        raise ClaimsError(
            f"--rejudge: no claims.csv at {path} (give a claims.csv that python -m litl.claims wrote)"
        )
    with open(path, newline="") as file:
        reader = csv.DictReader(file)
        rows = list(reader)
        columns = reader.fieldnames or []
    missing = [name for name in REQUIRED if name not in columns]
    if missing:
        raise ClaimsError(
            f"--rejudge: {path} lacks the column(s) {', '.join(missing)}: re-judging needs each "
            f"side's mean, interval and seed count (a claims.csv that python -m litl.claims wrote)"
        )
    if not rows:
        raise ClaimsError(f"--rejudge: {path} has no rows to re-judge")
    return rows


def _number(row: dict[str, str], column: str, where: str) -> float:
    """A numeric cell; an empty one (no estimate) is NaN."""
    text = (row.get(column) or "").strip()
    if not text:
        return math.nan
    try:
        return float(text)
    except ValueError:
        raise ClaimsError(f"--rejudge: {where}: {column} is not a number: {text!r}") from None


def _side(row: dict[str, str], side: str, level: float, where: str) -> tuple[Estimate | None, Summary]:
    """A side's interval as the CSV has it, and its (mean, sd, n) recovered from that interval.

    Raises:
      ClaimsError: the interval is not one around the mean (so not a Student-t one).
    """
    mean, low, high = (_number(row, f"{side}_{name}", where) for name in ("mean", "low", "high"))
    n_value = _number(row, f"{side}_n", where)
    n = 0 if math.isnan(n_value) else int(n_value)
    if n == 0 or not math.isfinite(mean):
        return None, Summary(math.nan, math.nan, 0)
    if n >= 2 and not math.isclose(high - mean, mean - low, rel_tol=1e-6, abs_tol=1e-12 * abs(mean)):
        raise ClaimsError(
            f"--rejudge: {where}: {side}'s interval [{low}, {high}] is not centred on its mean "
            f"{mean}, so it is not a Student-t interval of the mean and gives no standard deviation"
        )
    stuck = _number(row, f"{side}_stuck", where)
    # A claims.csv older than the stuck count does not say: unknown, not 0.
    estimate = Estimate(mean, low, high, n, None if math.isnan(stuck) else int(stuck))
    return estimate, Summary(mean, sd_from_interval(mean, high, n, level), n)


def _claim(row: dict[str, str], where: str) -> Claim:
    """The claim a row judged, checked against the variants the row names."""
    claim = next((c for c in CLAIMS if c.id == row["claim"]), None)
    if claim is None:
        known = ", ".join(c.id for c in CLAIMS)
        raise ClaimsError(f"--rejudge: {where}: unknown claim {row['claim']!r} (litl's: {known})")
    for side, name in (("a", claim.a), ("b", claim.b or "")):
        if row.get(side) is not None and row[side] != name:
            raise ClaimsError(
                f"--rejudge: {where}: claim {claim.id} compares {claim.a} with {claim.b}, but the "
                f"row's {side} is {row[side]!r}"
            )
    return claim


def _needs_runs(claim: Claim, a: Summary, b: Summary) -> rules.Judgement:
    """A "competitive" row: its difference, interval and detectable difference are measured; its
    verdict needs the margin, which needs the runs. The rule says for which margins it would
    hold (unadjusted), so a reader who knows the reference's progress can judge it."""
    assert claim.b is not None  # a comparison names both sides
    if (missing := rules.too_few(a, b)) is not None:
        return missing
    difference = welch(a, b)
    low, high = difference.interval(rules.ALPHA)
    rule = (
        f"needs the runs: the margin δ = {rules.MARGIN:.0%} of {claim.b}'s progress needs its task "
        f"loss at the first iteration, which the CSV does not hold, and the runs were not kept"
    )
    if math.isfinite(high):
        # Non-inferiority holds when the interval's upper end is below delta = MARGIN x progress.
        rule += (
            f"; unadjusted, it would hold if {claim.b}'s progress exceeded "
            f"{format_number(high / rules.MARGIN, '.3g')}"
        )
        if low > 0:
            rule += f" and be contradicted if it were below {format_number(low / rules.MARGIN, '.3g')}"
    return rules.Judgement(
        math.nan,
        NEEDS_RUNS,
        rule,
        math.nan,
        difference.estimate,
        low,
        high,
        detectable=difference.detectable(rules.ALPHA, rules.POWER),
    )


def rejudge_row(row: dict[str, str], level: float, where: str) -> Verdict:
    """One claims.csv row judged again by the current rules (Holm not yet applied)."""
    claim = _claim(row, where)
    if claim.kind == "stuck":
        return _rejudge_stuck(row, claim, level, where)
    a_estimate, a = _side(row, "a", level, where)
    b_estimate, b = _side(row, "b", level, where)
    previous = row["verdict"]
    if claim.kind == "retraining":
        judgement = rules.retraining(a, b)  # a: the change per retraining; b: progress per episode
    elif claim.kind == "competitive":
        judgement = _needs_runs(claim, a, b)
    else:
        judgement = compare(claim, a, b)
    verdict = from_judgement(claim, row["method"], a_estimate, b_estimate, judgement)
    return dataclasses.replace(
        verdict, previous_verdict=previous, previous_holm_verdict=row.get("holm_verdict") or ""
    )


def _rejudge_stuck(row: dict[str, str], claim: Claim, level: float, where: str) -> Verdict:
    """A "stuck" row: each side's proportion of stuck seeds and seed count give back the counts
    that Fisher's test reads (the threshold that made them is the record's own)."""
    assert claim.b is not None  # a comparison names both sides
    counts = []
    for side in ("a", "b"):
        rate, n = _number(row, f"{side}_mean", where), _number(row, f"{side}_n", where)
        n_seeds = 0 if math.isnan(n) else int(n)
        count = round(rate * n_seeds) if math.isfinite(rate) else 0
        if n_seeds and not math.isclose(count, rate * n_seeds, abs_tol=1e-6):
            raise ClaimsError(
                f"--rejudge: {where}: {side}'s proportion {rate} of {n_seeds} seeds is no count"
            )
        counts.append((count, n_seeds))
    (a_count, a_n), (b_count, b_n) = counts
    judgement = rules.stuck(a_count, a_n, b_count, b_n, claim.a, claim.b, threshold=None)
    verdict = from_judgement(
        claim, row["method"], proportion(a_count, a_n, level), proportion(b_count, b_n, level), judgement
    )
    return dataclasses.replace(
        verdict, previous_verdict=row["verdict"], previous_holm_verdict=row.get("holm_verdict") or ""
    )


def rejudge(path: str | os.PathLike[str], level: float = 0.9) -> list[Verdict]:
    """Every row of a claims.csv judged again by the current rules, with Holm's correction over
    the re-judged family.

    Args:
      path: a claims.csv written by `python -m litl.claims`.
      level: the confidence level of its intervals (the suite's default, 0.9).

    Raises:
      ClaimsError: the file is missing, lacks a needed column, or holds a row that is not a
        claim litl knows or whose numbers cannot be read.
    """
    rows = read_claims_csv(path)
    judged = [rejudge_row(row, level, f"{path}, line {i}") for i, row in enumerate(rows, start=2)]
    return with_holm(judged + needs_per_seed_records(judged, path))


PER_SEED_KINDS = ("converges", "stuck")


def needs_per_seed_records(judged: list[Verdict], path: str | os.PathLike[str]) -> list[Verdict]:
    """The claims whose rules read each seed's curve (`PER_SEED_KINDS`: convergence, stuck seeds)
    that the table's cells could be judged on but a claims.csv cannot: one NEEDS_RUNS row per
    such claim and method whose two variants the table compared, saying what the record lacks."""
    compared = {(v.method, v.claim.panel, name) for v in judged for name in (v.claim.a, v.claim.b) if name}
    lacking = (
        f"needs the runs: {path} holds each variant's mean, interval and seed count, not each "
        f"seed's task loss per iteration, which this rule reads (the runs' metrics.jsonl were not kept)"
    )
    methods = sorted({v.method for v in judged})
    return [
        Verdict(claim, method, None, None, math.nan, NEEDS_RUNS, lacking)
        for claim in CLAIMS
        if claim.kind in PER_SEED_KINDS and claim.b is not None
        for method in methods
        if {(method, claim.panel, claim.a), (method, claim.panel, claim.b)} <= compared
        and not any(v.claim is claim and v.method == method for v in judged)
    ]
