"""claims.md: the claims table (the verdict after Holm first), its footnotes, the cut check and
the rules, for measured runs or for a claims.csv re-judged from its summary statistics."""

from __future__ import annotations

import datetime
import math
from collections.abc import Sequence

from litl.claims.estimates import Estimate, falling
from litl.claims.origins import judging_litl
from litl.claims.rules import ALPHA, NEEDS_RUNS, POWER
from litl.claims.verdicts import CLAIMS, Verdict
from litl.records.formatting import format_number

# The paper's appendix (its hyperparameters) was not available: method=paper is litl's reading of
# the paper's text, so a verdict under it is about that reading (docs/guide/method.md).
PAPER_CAVEAT = (
    "method=paper is litl's reading of the paper's text: the paper's appendix with its "
    "hyperparameters was not available, so a paper-method verdict judges that reading, not the "
    "paper's own runs (docs/guide/method.md)."
)

HEADER = (
    "| claim | method | a | a: mean [CI] | b | b: mean [CI] | verdict (after Holm) | Holm p | p "
    "| unadjusted | difference [95% CI] | detectable | margin δ |"
)

# One sentence per kind of claim: what its detectable difference says.
DETECTABLE = {
    "beats": (
        "“A beats B”: *detectable* = (t_{0.975, df} + t_{0.80, df}) × √(s_a²/n_a + s_b²/n_b), "
        "Welch–Satterthwaite df, is the smallest |a − b| the two-sided Welch test at 0.05 would "
        "have found with 80% power given these seeds' spreads; a row not resolved with its "
        "difference below it (§) says the seeds were too few to tell, not that the two are equal."
    ),
    "competitive": (
        "“A is competitive with B”: the same *detectable*, read against the margin: with δ below "
        "it, these seeds had under 80% power to show non-inferiority even if the two were equal."
    ),
    "converges": (
        "“A converges faster than B”: the same Welch *detectable*, on each seed's mean task loss "
        "over every iteration of its run."
    ),
    "stuck": (
        "“A gets stuck less than B”: *detectable* is the smallest difference of the two "
        "proportions of stuck seeds (true proportions centred on the pooled one) that Fisher's "
        "two-sided exact test at 0.05 finds with 80% power, computed exactly; at 10 seeds a side "
        "it is about 0.6: ten seeds tell little about how often seeds get stuck."
    ),
    "retraining": (
        "Table 1: *detectable* = (t_{0.975, n−1} + t_{0.80, n−1}) × s/√n is the smallest departure "
        "of the mean change from its threshold −δ that the two-sided one-sample test would have "
        "found with 80% power."
    ),
}


def _interval(estimate: Estimate | None) -> str:
    if estimate is None or not math.isfinite(estimate.mean):
        return "—"
    stuck = f", {estimate.stuck} stuck" if estimate.stuck else ""
    if estimate.n < 2:
        return f"{format_number(estimate.mean)} (n={estimate.n}{stuck})"
    return (
        f"{format_number(estimate.mean)} [{format_number(estimate.low)}, "
        f"{format_number(estimate.high)}] (n={estimate.n}{stuck})"
    )


def _difference(v: Verdict) -> str:
    """The difference with its 95% interval, (§) if it is below the detectable difference."""
    if not math.isfinite(v.difference):
        return "—"
    below = " (§)" if v.gap_below_detectable else ""
    if not math.isfinite(v.difference_low):
        return f"{format_number(v.difference)}{below}"
    return (
        f"{format_number(v.difference)} [{format_number(v.difference_low)}, "
        f"{format_number(v.difference_high)}]{below}"
    )


def _previous(v: Verdict) -> str:
    """The verdict a re-judged claims.csv held (and its Holm verdict where it had one)."""
    if v.previous_holm_verdict and v.previous_holm_verdict != v.previous_verdict:
        return f"{v.previous_verdict} (after Holm: {v.previous_holm_verdict})"
    return v.previous_verdict or "—"


def _row(v: Verdict, rejudged: bool) -> str:
    caveat = " (†)" if v.method.startswith("paper") else ""
    flag = " (‡)" if _flagged(v) else ""
    cells = [
        v.claim.statement,
        v.method,
        v.claim.a,
        _interval(v.a),
        v.claim.b or "progress/episode",
        _interval(v.b),
        f"**{v.holm_verdict}**{caveat}{flag}",
        format_number(v.holm_p, ".3g"),
        format_number(v.test_p, ".3g"),
        v.verdict,
        _difference(v),
        format_number(v.detectable),
        format_number(v.margin),
    ]
    if rejudged:
        cells.append(_previous(v))
    return "| " + " | ".join(cells) + " |"


def _intro(
    results: list[Verdict], level: float, command: str, source: str | None, notes: Sequence[str]
) -> list[str]:
    family = sum(math.isfinite(v.test_p) or v.verdict == NEEDS_RUNS for v in results)
    judge = judging_litl()
    written = f"Written {datetime.date.today().isoformat()} by `{command}`, judged by {judge}."
    if source is not None:
        written = (
            f"Re-judged {datetime.date.today().isoformat()} by `{command}` from `{source}` "
            f"(judged by {judge}), by the "
            f"current rules: each side's mean, {level:.0%} interval and n give back its sample "
            f"standard deviation (s = (high − mean) √n / t_{{(1+{level:g})/2, n−1}}), and every "
            f"row is judged again from those. The runs behind the CSV were not kept: a row whose "
            f"rule needs them says **{NEEDS_RUNS}** (a competitive claim's margin needs its "
            f"reference's first-iteration task loss) and counts in the Holm family as p = 1, the "
            f"worst case for the others; *before* is the CSV's own verdict, by the rules it was "
            f"written with."
        )
    return [
        "# The paper's claims, " + ("measured" if source is None else "re-judged"),
        "",
        written,
        "",
        *(line for note in notes for line in (note, "")),
        f"Final task loss = a seed's mean task loss over its last 10 iterations (lower is better); "
        f"the a and b intervals are {level:.0%} Student-t intervals of the mean over seeds, for "
        f"display. Every test is at α = {ALPHA} two-sided (equivalently one-sided at "
        f"{ALPHA / 2:g} in each direction). For Table 1, a is the change of the objective after "
        f"retraining plus one step (negative: progress lost) and b the progress per episode.",
        "",
        f"**verdict (after Holm)** is the primary verdict: the table makes {family} tests at once, "
        f"and a row holds or is contradicted only if its p, Holm–Bonferroni-adjusted over the "
        f"{family} (*Holm p*), is below {ALPHA}. *unadjusted* is the same rule without the "
        f"correction. *p* is the two-sided-scale p-value the verdict rests on: Welch's two-sided p "
        f"for “beats”; for “competitive”, twice the one-sided non-inferiority p (of being worse by "
        f"more than δ for a contradicted row; the smaller of the two for one not resolved); "
        f"Table 1's two-sided one-sample p. *difference* is mean(a) − mean(b) with its 95% Welch "
        f"interval (Table 1: the mean change minus its threshold −δ); *detectable* is the smallest "
        f"difference these seeds could have detected with {POWER:.0%} power in that two-sided test "
        f"at {ALPHA}, from the observed spreads; (§): |difference| is below it. "
        f"*margin δ*: a competitive claim's non-inferiority margin (Table 1: its threshold is −δ).",
        "",
        HEADER + (" before |" if source is not None else ""),
        "|---|---|---|---|---|---|---|---:|---:|---|---|---:|---:|" + ("---|" if source is not None else ""),
    ]


def claims_markdown(
    results: list[Verdict],
    level: float,
    command: str,
    unfinished: list[str],
    timings: dict[str, float],
    source: str | None = None,
    notes: Sequence[str] = (),
) -> str:
    """claims.md for `results`; `source`: the claims.csv they were re-judged from (None: they
    were judged on runs); `notes`: lines said right under the header (which litl and material
    made the runs: `litl.claims.origins.describe`; a departure from a committed plan)."""
    lines = _intro(results, level, command, source, notes)
    lines += [_row(v, source is not None) for v in results]
    lines += _footnotes(results)
    if source is not None:
        lines += [
            "",
            "## Where the runs were cut",
            "",
            "Not checked: the cut check judges each claim again on the runs' first iterations, "
            "and needs the runs, which were not kept (its CSV columns are empty).",
        ]
    lines += _cut_section(results, level)
    lines += ["", "## Rules", ""]
    lines += _rules(results)
    kinds = {v.claim.kind for v in results}
    lines += ["", "What the detectable difference says:", ""]
    lines += [f"- {text}" for kind, text in DETECTABLE.items() if kind in kinds]
    lines += ["", "## Sources", ""]
    lines += [f"- `{c.id}`: {c.source}" for c in CLAIMS if any(v.claim is c for v in results)]
    lines += _unfinished(unfinished) + _time(timings)
    return "\n".join(lines) + "\n"


def _rules(results: list[Verdict]) -> list[str]:
    """One line per claim and rule; a claim whose rule reads differently under each method (a
    margin's value) says which method each is for."""
    methods: dict[tuple[str, str], list[str]] = {}
    for v in results:
        methods.setdefault((v.claim.id, v.rule), []).append(v.method)
    ids = [claim_id for claim_id, _ in methods]
    return [
        f"- `{claim_id}`" + (f" ({', '.join(names)})" if ids.count(claim_id) > 1 else "") + f": {rule}"
        for (claim_id, rule), names in methods.items()
    ]


def _footnotes(results: list[Verdict]) -> list[str]:
    lines = []
    if any(v.method.startswith("paper") for v in results):
        lines += ["", f"(†) {PAPER_CAVEAT}"]
    if any(_flagged(v) for v in results):
        lines += [
            "",
            "(‡) The verdict depends on where the runs were cut: it changes between the cut and "
            "the end, or a compared curve was still falling at the end (see below).",
        ]
    if any(v.gap_below_detectable for v in results):
        lines += [
            "",
            "(§) |difference| is below the detectable difference: a true gap of this size would be "
            "found (p < 0.05) less than 80% of the time with these seeds; a row not resolved with "
            "it says too few seeds, not no difference.",
        ]
    if any(e is not None and e.stuck for v in results for e in (v.a, v.b)):
        lines += [
            "",
            "*k stuck*: k of the n seeds ended stuck at their last good parameters (their last "
            "iterations were skipped); each counts with its last good iterations (its mean over "
            "the 10 iterations up to its last good one).",
        ]
    return lines


def _unfinished(unfinished: list[str]) -> list[str]:
    if not unfinished:
        return []
    return [
        "",
        "## Not finished",
        "",
        "These runs have not finished (run the same command again to resume them); "
        "claims that need them say `no data`:",
        "",
        *(f"- {name}" for name in unfinished),
    ]


def _time(timings: dict[str, float]) -> list[str]:
    if not timings:
        return []
    total = sum(timings.values())
    return [
        "",
        "## Time",
        "",
        f"{len(timings)} runs, {total / 3600:.2f} h in all (wall time of each run's "
        f"last process; see timings.json).",
    ]


def _flagged(v: Verdict) -> bool:
    """Whether a verdict depends on where its runs were cut (`litl.claims.cuts`)."""
    return v.cut is not None and (v.cut.changed(v) or bool(v.cut.still_falling))


def _slope(estimate: Estimate | None) -> str:
    if estimate is None:
        return "—"
    text = _interval(estimate).replace(" (n=", " per iteration (n=")
    return f"**{text}, still falling**" if falling(estimate) else text


def _cut_section(results: list[Verdict], level: float) -> list[str]:
    """The cut check's table: each verdict at the end and at the cut, and the slopes of its
    curves over the last iterations."""
    checked = [v for v in results if v.cut is not None]
    if not checked:
        return []
    fractions = {f"{v.cut.fraction:.0%}" for v in checked if v.cut is not None}
    tails = {v.cut.tail for v in checked if v.cut is not None and v.cut.tail}
    tail = f"its last {tails.pop()} iterations" if len(tails) == 1 else "its last iterations"
    lines = [
        "",
        "## Where the runs were cut",
        "",
        f"Each claim judged again by the same rules on the runs' first {' / '.join(sorted(fractions))} "
        f"of iterations (a seed's final task loss then being its mean over the last 10 before "
        f"the cut; Holm over the cut's tests), and the slope of each compared task-loss curve "
        f"over {tail}: per seed the least-squares slope, then the mean over seeds with its "
        f"{level:.0%} interval. **changed**: the verdict after Holm, or the unadjusted one, differs "
        f"between the cut and the end. **still falling**: the slope's interval lies below 0, so "
        f"the curve had not settled. The cut is the same run at an earlier iteration, not a "
        f"shorter run (under method=litl the step sizes decay over the whole run).",
        "",
        "| claim | method | iterations | verdict after Holm (unadjusted) | at the cut "
        "| verdict at the cut after Holm (unadjusted) | a: slope [CI] | b: slope [CI] | depends on the cut |",
        "|---|---|---:|---|---:|---|---|---|---|",
    ]
    for v in checked:
        cut = v.cut
        assert cut is not None
        flags = (["**changed**"] if cut.changed(v) else []) + [
            f"**{v.claim.a if side == 'a' else v.claim.b} still falling**" for side in cut.still_falling
        ]
        lines.append(
            f"| {v.claim.statement} | {v.method} | {cut.total} | {v.holm_verdict} ({v.verdict}) | "
            f"{cut.iterations} | {cut.holm_verdict} ({cut.verdict}) | {_slope(cut.a_slope)} | "
            f"{_slope(cut.b_slope)} | {', '.join(flags) or 'no'} |"
        )
    return lines
