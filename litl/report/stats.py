"""Statistics over seeds: Student-t confidence bands, learning curves and the paper's Table 1."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

# scipy comes with jax (one of its requirements), so it costs litl no extra dependency.
from scipy.special import stdtrit

from litl.records.stuck import SeedEnd, seed_end
from litl.report.runs import Group


def t_quantile(probability: float, dof: ArrayLike) -> np.ndarray:
    """The `probability` quantile of Student's t distribution with `dof` degrees of freedom.

    Args:
      probability: in (0, 1), e.g. 0.95 for a two-sided 90% interval.
      dof: degrees of freedom (> 0), a number or an array.
    """
    return np.asarray(stdtrit(np.asarray(dof, np.float64), probability))


def _check_level(level: float) -> None:
    if not (isinstance(level, (int, float)) and 0 < level < 1):
        raise ValueError(f"the confidence level must lie in (0, 1), e.g. 0.9; got {level!r}")


def confidence_band(values: ArrayLike, level: float = 0.9) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean over seeds with a two-sided Student-t confidence interval for it.

    The interval is mean ± t_{(1+level)/2, n-1} · s / √n with s the sample standard deviation
    (n - 1 in the denominator) of the n finite values. NaN values (missing or non-finite data)
    are left out; where fewer than two remain the band collapses to the mean (no interval).

    Args:
      values: (seeds, ...) e.g. (seeds, iterations); the first axis is reduced.
      level: confidence level, e.g. 0.9 for the paper's 90% bands.

    Returns:
      (mean, low, high), each of shape values.shape[1:]; NaN where no value is finite.
    """
    _check_level(level)
    values = np.asarray(values, np.float64)
    finite = np.isfinite(values)
    n = finite.sum(axis=0)
    safe = np.where(finite, values, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n > 0, safe.sum(axis=0) / n, np.nan)
        squares = np.where(finite, (values - mean) ** 2, 0.0).sum(axis=0)
        sem = np.sqrt(squares / np.maximum(n - 1, 1) / np.maximum(n, 1))
        half = np.where(n > 1, t_quantile((1 + level) / 2, np.maximum(n - 1, 1)) * sem, 0.0)
    return mean, mean - half, mean + half


def _value(record: dict[str, Any], key: str) -> float:
    value = record.get(key)
    return float(value) if isinstance(value, (int, float)) else math.nan


def series(group: Group, key: str = "task_loss") -> tuple[np.ndarray, np.ndarray]:
    """The values of one metric for every seed of a group, on the union of their steps.

    Args:
      group: runs pooled under one label.
      key: a metrics field, e.g. ``"task_loss"``, ``"task/distance"``, ``"recon_loss_val"``.

    Returns:
      steps: (T,) global optimization iterations, ascending.
      values: (n_series, T) with NaN where a seed lacks the step or the value, or skipped the
        iteration (a failed rollout measures nothing); one row per (run, seed) pair, so equal
        seed numbers in separate runs count separately.
    """
    rows: dict[tuple[int, int], dict[int, float]] = {}
    for index, run in enumerate(group.runs):
        for record in run.records:
            value = np.nan if isinstance(record.get("skipped"), str) else _value(record, key)
            rows.setdefault((index, int(record["seed"])), {})[int(record["step"])] = value
    steps = np.array(sorted({step for row in rows.values() for step in row}), np.int64)
    column = {int(step): t for t, step in enumerate(steps)}
    values = np.full((len(rows), len(steps)), np.nan)
    for r, row in enumerate(rows[k] for k in sorted(rows)):
        for step, value in row.items():
            values[r, column[step]] = value
    return steps, values


def series_ends(group: Group) -> list[tuple[int, SeedEnd]]:
    """How each seed of a group ended (`litl.records.stuck.SeedEnd`: stuck or not, its last good
    iteration) with the index of its run in `group.runs`, one per row of `series`, in its order."""
    rows: dict[tuple[int, int], list[dict[str, Any]]] = {}
    for index, run in enumerate(group.runs):
        for record in run.records:
            rows.setdefault((index, int(record["seed"])), []).append(record)
    return [
        (index, seed_end(seed, sorted(rows[(index, seed)], key=lambda r: int(r["step"]))))
        for index, seed in sorted(rows)
    ]


def final_values(group: Group, key: str = "task_loss") -> np.ndarray:
    """(n_series,) each seed's value at its last recorded step (NaN if missing there); for a
    seed that ended stuck (`litl.records.stuck`: its last iterations skipped), at its last good step.

    Rows are ordered as in `series`.
    """
    values: dict[tuple[int, int], dict[int, float]] = {}
    for index, run in enumerate(group.runs):
        for record in run.records:
            values.setdefault((index, int(record["seed"])), {})[int(record["step"])] = _value(record, key)
    final = []
    for series_key, (_, end) in zip(sorted(values), series_ends(group), strict=True):
        at = values[series_key]
        step = (end.last_good_step if end.stuck else max(at)) if at else None
        final.append(math.nan if step is None else at[step])
    return np.array(final, np.float64)


def final_window_values(group: Group, key: str = "task_loss", last: int = 10) -> np.ndarray:
    """(n_series,) each seed's mean over its last `last` iterations (skipped ones left out); for
    a seed that ended stuck (`litl.records.stuck`), over the `last` iterations up to its last good one.

    Less noisy than the last iteration alone; NaN for a seed with no finite value there. Rows
    are ordered as in `series`.
    """
    if isinstance(last, bool) or not isinstance(last, int) or last < 1:
        raise ValueError(f"last must be a positive number of iterations, got {last!r}")
    steps, values = series(group, key)
    tail = values[:, -last:]
    column = {int(step): t for t, step in enumerate(steps)}
    for row, (_, end) in enumerate(series_ends(group)):
        if end.stuck:
            # The window ends at its last good iteration (all NaN if it never had one).
            stop = column[end.last_good_step] + 1 if end.last_good_step is not None else 0
            window = values[row, max(0, stop - last) : stop].copy()
            tail[row] = np.nan
            tail[row, : len(window)] = window
    finite = np.isfinite(tail)
    with np.errstate(invalid="ignore"):
        return np.where(
            finite.any(axis=1),
            np.where(finite, tail, 0.0).sum(axis=1) / np.maximum(finite.sum(axis=1), 1),
            np.nan,
        )


@dataclasses.dataclass(frozen=True)
class Curve:
    """One label's learning curve: mean over seeds with a confidence band.

    Attributes:
      robot: the robot's name.
      label: the group's label.
      key: the metric, e.g. ``"task_loss"``.
      steps: (T,) global optimization iterations.
      mean, low, high: (T,) mean and confidence band (equal to the mean where n < 2).
      n: (T,) seeds with a finite value at each step.
    """

    robot: str
    label: str
    key: str
    steps: np.ndarray
    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    n: np.ndarray


def curves(groups: list[Group], key: str = "task_loss", level: float = 0.9) -> list[Curve]:
    """A `Curve` of `key` per group that has any finite value of it."""
    result = []
    for group in groups:
        steps, values = series(group, key)
        n = np.isfinite(values).sum(axis=0)
        if not n.any():
            continue
        mean, low, high = confidence_band(values, level)
        result.append(Curve(group.robot, group.label, key, steps, mean, low, high, n))
    return result


def components(group: Group) -> list[str]:
    """The ``task/<term>`` metric names recorded by a group, sorted."""
    return sorted(
        {key for run in group.runs for record in run.records for key in record if key.startswith("task/")}
    )


BODY_FIGURES = ("placement/", "geometry/")


def body_figures(group: Group) -> list[str]:
    """The figures of a co-designed body a group recorded (``placement/*``, ``geometry/*``), sorted."""
    return sorted(
        {
            key
            for run in group.runs
            for record in run.records
            for key in record
            if key.startswith(BODY_FIGURES)
        }
    )


def table1(groups: list[Group], key: str = "retrain_change") -> list[dict[str, Any]]:
    """The paper's Table 1: `retrain_change` per retraining, mean and standard deviation.

    `key` = ``"retrain_effect"`` gives the same for retraining alone (before any step).

    Retraining e is the learning phase after episode e - 1, measured on iteration 1 of episode e
    (see `litl.loop.run`). The standard deviation is the sample one (n - 1; NaN for one seed).

    Returns:
      One row per group and retraining with data: {robot, label, retrain, mean, std, n}.
    """
    rows = []
    for group in groups:
        by_retrain: dict[int, list[float]] = {}
        for run in group.runs:
            for record in run.records:
                change = _value(record, key)
                if math.isfinite(change):
                    by_retrain.setdefault(int(record.get("episode", 0)), []).append(change)
        for retrain in sorted(by_retrain):
            changes = np.asarray(by_retrain[retrain])
            rows.append(
                {
                    "robot": group.robot,
                    "label": group.label,
                    "retrain": retrain,
                    "mean": float(changes.mean()),
                    "std": float(changes.std(ddof=1)) if len(changes) > 1 else math.nan,
                    "n": len(changes),
                }
            )
    return rows
