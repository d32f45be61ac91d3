"""Writing the claims' results: claims.md and claims.csv, Table 1, one figure per paper panel."""

from __future__ import annotations

import csv
import datetime
import math
import os
import pathlib
from collections.abc import Callable, Sequence

import numpy as np

from litl.claims.cuts import CUT, falling, with_cuts
from litl.claims.suite import PANELS, Cell, expected_records, finished_records
from litl.claims.verdicts import ALPHA, CLAIMS, Estimate, Verdict, judge, retraining_effects, with_holm
from litl.config import Config
from litl.formatting import format_number
from litl.report import figures
from litl.report.runs import Group, load_run
from litl.report.stats import curves, table1

CSV_FIELDS = (
    "claim",
    "method",
    "panel",
    "statement",
    "a",
    "a_mean",
    "a_low",
    "a_high",
    "a_n",
    "b",
    "b_mean",
    "b_low",
    "b_high",
    "b_n",
    "p",
    "verdict",
    "rule",
    "source",
    "test_p",
    "holm_p",
    "holm_verdict",
    # Seeds that ended stuck, counted with their last good loss (litl.stuck).
    "a_stuck",
    "b_stuck",
    # The cut check (litl.claims.cuts): the verdict at the cut, and the slopes at the end.
    "iterations",
    "cut_iterations",
    "cut_verdict",
    "cut_holm_verdict",
    "cut_changed",
    "tail_iterations",
    "a_slope",
    "a_slope_low",
    "a_slope_high",
    "a_still_falling",
    "b_slope",
    "b_slope_low",
    "b_slope_high",
    "b_still_falling",
)

# The paper's appendix (its hyperparameters) was not available: method=paper is litl's reading of
# the paper's text, so a verdict under it is about that reading (docs/guide/method.md).
PAPER_CAVEAT = (
    "method=paper is litl's reading of the paper's text: the paper's appendix with its "
    "hyperparameters was not available, so a paper-method verdict judges that reading, not the "
    "paper's own runs (docs/guide/method.md)."
)


# {(method, panel name): {variant name: its runs}}
Groups = dict[tuple[str, str], dict[str, Group]]


def load_groups(
    out: str | os.PathLike[str], suite: list[Cell], config_of: Callable[[Cell], Config]
) -> tuple[Groups, list[str]]:
    """{(method, panel): {variant: Group}} of the finished cells, and the unfinished cells'
    names. `config_of(cell)` gives a cell's composed config (for its expected length)."""
    groups: Groups = {}
    unfinished = []
    for cell in suite:
        run_dir = cell.run_dir(out)
        if finished_records(run_dir) < expected_records(config_of(cell)):
            unfinished.append(cell.name)
            continue
        run = load_run(run_dir)
        groups.setdefault((cell.method, cell.panel.name), {})[cell.variant.name] = Group(
            run.robot, cell.variant.name, (run,)
        )
    return groups, unfinished


def verdicts(
    groups: Groups, methods: Sequence[str], level: float = 0.9, cut: float | None = CUT
) -> list[Verdict]:
    """Every claim whose panel was run, under every method asked for, with Holm-adjusted p over
    all of them (the table's family of tests), and each judged again at the `cut` (a fraction
    of the iterations; None: no cut check) with its curves' slopes at the end
    (`litl.claims.cuts.with_cuts`)."""
    panels = {panel for _, panel in groups}
    results = with_holm(
        [
            judge(claim, method, groups.get((method, claim.panel), {}), level)
            for method in methods
            for claim in CLAIMS
            if claim.panel in panels
            and (not claim.comparator or claim.b in groups.get((method, claim.panel), {}))
        ]
    )
    return results if cut is None else with_cuts(results, groups, level, cut)


def _cells(estimate: Estimate | None) -> list[float | str]:
    if estimate is None:
        return ["", "", "", 0]
    return [estimate.mean, estimate.low, estimate.high, estimate.n]


def _cut_cells(v: Verdict) -> list[float | str | int | bool]:
    """The cut check's CSV cells (empty without one)."""
    if v.cut is None:
        return [""] * 14
    cut = v.cut
    slopes: list[float | str | int | bool] = []
    for side, estimate in (("a", cut.a_slope), ("b", cut.b_slope)):
        slopes += (
            ["", "", "", ""]
            if estimate is None
            else [estimate.mean, estimate.low, estimate.high, side in cut.still_falling]
        )
    return [
        cut.total,
        cut.iterations,
        cut.verdict,
        cut.holm_verdict,
        cut.changed(v),
        cut.tail,
        *slopes,
    ]


def write_csv(results: list[Verdict], path: pathlib.Path) -> pathlib.Path:
    with open(path, "w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(CSV_FIELDS)
        for v in results:
            c = v.claim
            row = [
                c.id,
                v.method,
                c.panel,
                c.statement,
                c.a,
                *_cells(v.a),
                c.b or "",
                *_cells(v.b),
                v.p,
                v.verdict,
                v.rule,
                c.source,
                v.test_p,
                v.holm_p,
                v.holm_verdict,
                "" if v.a is None else v.a.stuck,
                "" if v.b is None else v.b.stuck,
                *_cut_cells(v),
            ]
            writer.writerow(["" if isinstance(x, float) and not math.isfinite(x) else x for x in row])
    return path


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


def claims_markdown(
    results: list[Verdict], level: float, command: str, unfinished: list[str], timings: dict[str, float]
) -> str:
    family = sum(math.isfinite(v.test_p) for v in results)
    lines = [
        "# The paper's claims, measured",
        "",
        f"Written {datetime.date.today().isoformat()} by `{command}`.",
        "",
        f"Final task loss = a seed's mean task loss over its last 10 iterations (lower is "
        f"better); intervals are {level:.0%} Student-t intervals of the mean over seeds; p is "
        f"the one-sided Welch p-value of the test that makes the claim hold (α = {ALPHA}). "
        f"For Table 1, a is the change of the objective after retraining plus one step "
        f"(negative: progress lost) and b the progress per episode.",
        "",
        f"The table makes {family} one-sided tests at once, one per row with a p: the test its "
        f"verdict rests on (p's own for a row that holds; the opposite one-sided test, p-value "
        f"1 − p, for a contradicted row; the smaller of the two for a row not resolved; a "
        f"'competitive' row's p is already its one test, of a being worse, and its holding rests "
        f"on a margin). Holm p is that test's p-value, Holm–Bonferroni-adjusted over the "
        f"{family}; *after Holm* is the verdict that survives the correction (a verdict whose "
        f"adjusted p is not below {ALPHA} becomes not resolved).",
        "",
        "| claim | method | a | a: mean [CI] | b | b: mean [CI] | p | verdict | Holm p | after Holm |",
        "|---|---|---|---|---|---|---:|---|---:|---|",
    ]
    for v in results:
        caveat = " (†)" if v.method == "paper" else ""
        flag = " (‡)" if _flagged(v) else ""
        lines.append(
            f"| {v.claim.statement} | {v.method} | {v.claim.a} | {_interval(v.a)} | "
            f"{v.claim.b or 'progress/episode'} | {_interval(v.b)} | "
            f"{format_number(v.p, '.3g')} | **{v.verdict}**{caveat}{flag} | "
            f"{format_number(v.holm_p, '.3g')} | {v.holm_verdict}{caveat} |"
        )
    if any(v.method == "paper" for v in results):
        lines += ["", f"(†) {PAPER_CAVEAT}"]
    if any(_flagged(v) for v in results):
        lines += [
            "",
            "(‡) The verdict depends on where the runs were cut: it changes between the cut and "
            "the end, or a compared curve was still falling at the end (see below).",
        ]
    if any(e is not None and e.stuck for v in results for e in (v.a, v.b)):
        lines += [
            "",
            "*k stuck*: k of the n seeds ended stuck at their last good parameters (their last "
            "iterations were skipped); each counts with its last good iterations (its mean over "
            "the 10 iterations up to its last good one).",
        ]
    lines += _cut_section(results, level)
    lines += ["", "## Rules", ""]
    for claim_id, rule in dict.fromkeys((v.claim.id, v.rule) for v in results):
        lines.append(f"- `{claim_id}`: {rule}")
    lines += ["", "## Sources", ""]
    lines += [f"- `{c.id}`: {c.source}" for c in CLAIMS if any(v.claim is c for v in results)]
    if unfinished:
        lines += [
            "",
            "## Not finished",
            "",
            "These runs have not finished (run the same command again to resume them); "
            "claims that need them say `no data`:",
            "",
        ]
        lines += [f"- {name}" for name in unfinished]
    if timings:
        total = sum(timings.values())
        lines += [
            "",
            "## Time",
            "",
            f"{len(timings)} runs, {total / 3600:.2f} h in all (wall time of each run's "
            f"last process; see timings.json).",
        ]
    return "\n".join(lines) + "\n"


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
        f"{level:.0%} interval. **changed**: the verdict, or the verdict after Holm, differs "
        f"between the cut and the end. **still falling**: the slope's interval lies below 0, so "
        f"the curve had not settled. The cut is the same run at an earlier iteration, not a "
        f"shorter run (under method=litl the step sizes decay over the whole run).",
        "",
        "| claim | method | iterations | verdict (after Holm) | at the cut | verdict at the cut (after Holm) "
        "| a: slope [CI] | b: slope [CI] | depends on the cut |",
        "|---|---|---:|---|---:|---|---|---|---|",
    ]
    for v in checked:
        cut = v.cut
        assert cut is not None
        flags = (["**changed**"] if cut.changed(v) else []) + [
            f"**{v.claim.a if side == 'a' else v.claim.b} still falling**" for side in cut.still_falling
        ]
        lines.append(
            f"| {v.claim.statement} | {v.method} | {cut.total} | {v.verdict} ({v.holm_verdict}) | "
            f"{cut.iterations} | {cut.verdict} ({cut.holm_verdict}) | {_slope(cut.a_slope)} | "
            f"{_slope(cut.b_slope)} | {', '.join(flags) or 'no'} |"
        )
    return lines


def table1_markdown(groups: Groups, methods: Sequence[str]) -> str:
    """Table 1 per method from the biped's VAE runs: what retraining cost alone, and what
    remained after one step, per retraining (mean ± std over seeds), beside the paper's."""
    lines = [
        "# Table 1 at demo size",
        "",
        "Per retraining: `retrain_effect` (task objective before retraining minus right "
        "after it) and `retrain_change` (minus after it plus one optimization step), mean "
        "and sample std over seeds. Negative: progress lost. The biped's task loss is minus "
        "the distance walked, so these are changes of distance, as in the paper.",
        "",
    ]
    for method in methods:
        group = groups.get((method, "fig4b"), {}).get("vae")
        if group is None:
            continue
        effect = {r["retrain"]: r for r in table1([group], "retrain_effect")}
        change = {r["retrain"]: r for r in table1([group], "retrain_change")}
        lines += [
            f"## method={method}",
            "",
            "| retrain | retraining alone: mean | std | after one step: mean | std | n |",
            "|---:|---:|---:|---:|---:|---:|",
        ]
        for retrain in sorted(set(effect) | set(change)):
            e, c = effect.get(retrain, {}), change.get(retrain, {})
            lines.append(
                f"| {retrain} | {format_number(e.get('mean'), '.3e')} | "
                f"{format_number(e.get('std'), '.3e')} | {format_number(c.get('mean'), '.3e')} | "
                f"{format_number(c.get('std'), '.3e')} | {c.get('n', e.get('n', 0))} |"
            )
        changes, progress = retraining_effects(group)
        lines += [
            "",
            f"Over all retrainings: after one step {format_number(np.nanmean(changes), '.3e')}"
            f" per retraining; progress per episode {format_number(np.nanmean(progress), '.3e')}.",
            "",
        ]
    lines += [
        "The paper (dx 1/128, 15 retrainings): means between -1.86e-2 and +3.56e-2, "
        "standard deviations 4.3e-3 to 8.4e-2."
    ]
    return "\n".join(lines) + "\n"


def plot_panels(
    groups: Groups, methods: Sequence[str], out: pathlib.Path, level: float
) -> list[pathlib.Path]:
    """One PNG per paper panel: task loss vs iteration with bands, a subplot per method."""
    written = []
    for panel in PANELS:
        runs = [
            (method, groups[(method, panel.name)]) for method in methods if (method, panel.name) in groups
        ]
        if not runs:
            continue
        # The panel's variants, then any optional comparator that was run (`--comparators`).
        names = list(dict.fromkeys([v.name for v in panel.variants] + [n for _, by in runs for n in by]))
        colors = figures.label_colors(names)
        subplots = [
            (
                f"{panel.title}\nmethod={method}",
                [
                    (curve, "-", curve.label)
                    for curve in curves(
                        [by_variant[name] for name in names if name in by_variant],
                        "task_loss",
                        level,
                    )
                ],
            )
            for method, by_variant in runs
        ]
        path = out / f"{panel.name}.png"
        figures.plot_panels(subplots, path, "task loss", colors, level)
        written.append(path)
    return written
