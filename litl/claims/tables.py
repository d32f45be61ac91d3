"""Writing the claims' results: claims.csv, Table 1, one figure per paper panel (claims.md:
`litl.claims.markdown`)."""

from __future__ import annotations

import csv
import math
import os
import pathlib
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from litl.claims.cuts import CUT, with_cuts
from litl.claims.estimates import Estimate
from litl.claims.origins import Origin, material
from litl.claims.slices import lacking, read_cell
from litl.claims.suite import PANELS, Cell
from litl.claims.verdicts import CLAIMS, Verdict, judge, retraining_effects, with_holm
from litl.config import Config
from litl.records.formatting import format_number
from litl.report import figures
from litl.report.runs import Group
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
    # mean(a) - mean(b) with its 95% interval, the non-inferiority margin, and the smallest
    # difference the seeds could have detected (80% power, two-sided 0.05): litl.claims.rules.
    "difference",
    "difference_low",
    "difference_high",
    "margin",
    "detectable",
    "gap_below_detectable",
    # Seeds that ended stuck, counted with their last good loss (litl.records.stuck).
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
    # Re-judged from a claims.csv (python -m litl.claims --rejudge): the verdicts it held.
    "previous_verdict",
    "previous_holm_verdict",
    # Which litl (commit) and which material made the compared cells ("a | b" where they differ).
    "commit",
    "material",
)

# {(method, panel name): {variant name: its runs}}
Groups = dict[tuple[str, str], dict[str, Group]]


def load_groups(
    out: str | os.PathLike[str],
    suite: list[Cell],
    config_of: Callable[[Cell], Config],
    first_seed: int = 0,
) -> tuple[Groups, dict[str, str]]:
    """{(method, panel): {variant: Group}} of the cells whose every seed has finished (a cell
    run whole, or the union of its slices: `litl.claims.slices`), and {cell name: what it still
    lacks} of the others. `config_of(cell)` gives a cell's composed config (its seeds and size);
    the cell's seeds are ``first_seed, ..., first_seed + seeds - 1``."""
    groups: Groups = {}
    unfinished: dict[str, str] = {}
    for cell in suite:
        config = config_of(cell)
        seeds = range(first_seed, first_seed + config.seeds)
        found = read_cell(cell.run_dir(out), seeds, config.loop.episodes, config.loop.iterations)
        if not found.complete:
            unfinished[cell.name] = lacking(found, seeds)
            continue
        groups.setdefault((cell.method, cell.panel.name), {})[cell.variant.name] = Group(
            found.runs[0].robot, cell.variant.name, found.runs
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


def write_csv(
    results: list[Verdict], path: pathlib.Path, found: Mapping[str, Origin] | None = None
) -> pathlib.Path:
    """claims.csv; `found`: {cell name: its origin} (`litl.claims.origins.origins`) for the
    commit and material columns (empty without)."""
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
                v.difference,
                v.difference_low,
                v.difference_high,
                v.margin,
                v.detectable,
                "" if v.gap_below_detectable is None else v.gap_below_detectable,
                "" if v.a is None or v.a.stuck is None else v.a.stuck,
                "" if v.b is None or v.b.stuck is None else v.b.stuck,
                *_cut_cells(v),
                v.previous_verdict,
                v.previous_holm_verdict,
                *_origin_cells(v, found or {}),
            ]
            writer.writerow(["" if isinstance(x, float) and not math.isfinite(x) else x for x in row])
    return path


def _origin_cells(v: Verdict, found: Mapping[str, Origin]) -> list[str]:
    """The commit and material of the cells a verdict compares ("a | b" where they differ)."""
    cells = [found.get(f"{v.method}/{v.claim.panel}/{name}") for name in (v.claim.a, v.claim.b) if name]
    known = [o for o in cells if o is not None]
    commits = dict.fromkeys(o.commit or "" for o in known)
    materials = dict.fromkeys(material(o.max_stretch) for o in known)
    return [" | ".join(commits), " | ".join(materials)]


def table1_markdown(groups: Groups, methods: Sequence[str], scale: str = "demo scale") -> str:
    """Table 1 per method from the biped's VAE runs: what retraining cost alone, and what
    remained after one step, per retraining (mean ± std over seeds), beside the paper's.
    `scale` names the runs' size in the title (a `Scale.label`, e.g. ``paper scale``)."""
    lines = [
        f"# Table 1 at {scale}",
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
