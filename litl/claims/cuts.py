"""Verdicts that do not depend on where a run was cut.

A verdict judged at the end of a run could be another one had the run been stopped earlier, or
had it gone on. Two checks say how much a verdict rests on the run's length:

- *At a cut*: every claim is judged again, by the same rules, on the runs' records up to an
  earlier iteration (CUT = 60% of the iterations by default): a seed's final task loss is then
  the mean of its last 10 iterations before the cut, and Holm's correction is taken over the
  cut's family of tests. A verdict after Holm (the primary one), or the unadjusted one, that
  differs between the cut and the end is *changed*. The cut is the same run seen at an earlier
  iteration, not a shorter run: under `method=litl` the step sizes decay over the whole run's
  length. A "competitive" claim's margin at the cut is from its reference's progress up to the cut.
- *Still falling*: per seed, the least-squares slope of the task loss against the iteration over
  the last TAIL = 20% of the iterations (at least 2; skipped iterations left out, and a seed with
  fewer than 2 values there left out); then the mean slope over seeds with its Student-t
  interval at the table's level. A curve is *still falling* when that interval lies below 0
  (the task loss is minimized): it had not settled, and more iterations could change the
  verdict that rests on it. With one seed there is no interval and no flag.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from litl.claims.estimates import CutCheck, Estimate, estimate
from litl.claims.verdicts import Verdict, judge, with_holm
from litl.report.runs import Group
from litl.report.stats import series

CUT = 0.6
TAIL = 0.2

# {(method, panel name): {variant name: its runs}}, as `litl.claims.tables.Groups`.
Groups = Mapping[tuple[str, str], Mapping[str, Group]]


def iterations(group: Group) -> int:
    """The iterations of a group's longest run (its last step + 1; 0 without records)."""
    return max((int(r["step"]) + 1 for run in group.runs for r in run.records), default=0)


def kept(fraction: float, total: int) -> int:
    """How many of `total` iterations a cut at `fraction` keeps (rounded, at least 1)."""
    return max(1, math.floor(fraction * total + 0.5))


def cut_group(group: Group, keep: int) -> Group:
    """`group` with only its first `keep` iterations' records (steps 0 .. keep - 1)."""
    runs = tuple(
        dataclasses.replace(run, records=tuple(r for r in run.records if int(r["step"]) < keep))
        for run in group.runs
    )
    return dataclasses.replace(group, runs=runs)


def tail_slopes(group: Group, tail: float = TAIL) -> tuple[int, np.ndarray]:
    """(window, (n_series,) slopes): each seed's least-squares task-loss slope per iteration
    over the last `window` = `tail` of the group's iterations (at least 2); NaN for a seed with
    fewer than 2 values there. Rows are ordered as in `litl.report.stats.series`."""
    steps, values = series(group, "task_loss")
    window = max(2, kept(tail, iterations(group)))
    inside = steps >= iterations(group) - window
    x, y = steps[inside].astype(np.float64), values[:, inside]
    slopes = np.full(len(values), math.nan)
    for row, losses in enumerate(y):
        finite = np.isfinite(losses)
        if finite.sum() < 2:
            continue
        dx = x[finite] - x[finite].mean()
        slopes[row] = float(np.sum(dx * (losses[finite] - losses[finite].mean())) / np.sum(dx * dx))
    return window, slopes


def slope(group: Group, level: float = 0.9, tail: float = TAIL) -> tuple[int, Estimate]:
    """(window, the mean slope over seeds with its interval at `level`): see `tail_slopes`."""
    window, slopes = tail_slopes(group, tail)
    return window, estimate(slopes, level)


def with_cuts(
    results: Sequence[Verdict],
    groups: Groups,
    level: float = 0.9,
    fraction: float = CUT,
    tail: float = TAIL,
) -> list[Verdict]:
    """`results` (one per claim and method, as `litl.claims.tables.verdicts` gives them) with
    their `cut` set: each claim judged on the first `fraction` of its runs' iterations (Holm over
    the cut's family), and its curves' slopes over the last `tail` of them.

    Raises:
      ValueError: `fraction` or `tail` not in (0, 1).
    """
    for name, value in (("cut", fraction), ("tail", tail)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < 1:
            raise ValueError(f"the {name} must be a fraction of the iterations in (0, 1), got {value!r}")
    # Each group cut at its own length (a panel's variants share one, but need not).
    cut_groups = {
        key: {name: cut_group(group, kept(fraction, iterations(group))) for name, group in by_variant.items()}
        for key, by_variant in groups.items()
    }
    at_cut = with_holm(
        [judge(v.claim, v.method, cut_groups.get((v.method, v.claim.panel), {}), level) for v in results]
    )
    checked = []
    for end, cut in zip(results, at_cut, strict=True):
        by_variant = groups.get((end.method, end.claim.panel), {})
        compared = [by_variant.get(end.claim.a), by_variant.get(end.claim.b) if end.claim.b else None]
        total = max((iterations(g) for g in compared if g is not None), default=0)
        window = 0
        slopes: list[Estimate | None] = [None, None]
        for side, group in enumerate(compared):
            if group is not None:
                window, slopes[side] = slope(group, level, tail)
        check = CutCheck(
            fraction=fraction,
            iterations=kept(fraction, total) if total else 0,
            total=total,
            verdict=cut.verdict,
            holm_verdict=cut.holm_verdict,
            tail=window,
            a_slope=slopes[0],
            b_slope=slopes[1],
        )
        checked.append(dataclasses.replace(end, cut=check))
    return checked
