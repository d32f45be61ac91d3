"""The report's PNG plots, in the style of the paper's Fig. 4 (task loss) and Fig. 5 (recon loss).

Figures are built with `matplotlib.figure.Figure` rather than pyplot, so writing a report leaves
no open figures and needs no backend choice (PNG is rendered with Agg).
"""

from __future__ import annotations

import math
import os
import pathlib

import numpy as np
from matplotlib.figure import Figure

from litl.report.runs import Group
from litl.report.stats import Curve

XLABEL = "optimization iteration"
# tab10: one colour per label, the same in every figure of a report.
PALETTE = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
)


def label_colors(labels: list[str]) -> dict[str, str]:
    """A colour per distinct label, in order of first appearance."""
    distinct = list(dict.fromkeys(labels))
    return {label: PALETTE[i % len(PALETTE)] for i, label in enumerate(distinct)}


def plot_panels(
    panels: list[tuple[str, list[tuple[Curve, str, str]]]],
    path: str | os.PathLike[str],
    ylabel: str,
    colors: dict[str, str],
    level: float,
    log: bool = False,
    steps: bool = False,
) -> pathlib.Path:
    """Write one PNG with a panel per entry: lines for the means, shaded confidence bands.

    Args:
      panels: list of (title, lines); lines: list of (curve, linestyle, legend text). The colour
        comes from the curve's label, so a label's train and validation lines match.
      path: the PNG file to write.
      ylabel: the y-axis label.
      colors: {label: colour}, see `label_colors`.
      level: the confidence level of the bands, for the legend title.
      log: use a log y axis where every plotted value is positive.
      steps: draw each value as holding until the next iteration (for quantities that change
        only between episodes, such as the observer's reconstruction loss).
    """
    cols = min(len(panels), 3)
    rows = math.ceil(len(panels) / cols)
    figure = Figure(figsize=(5.2 * cols, 3.8 * rows), layout="constrained")
    axes = figure.subplots(rows, cols, squeeze=False).ravel()
    # strict=False: the grid may have more cells than panels (the last row's are left empty).
    for ax, (title, lines) in zip(axes, panels, strict=False):
        for curve, style, text in lines:
            color = colors.get(curve.label, PALETTE[0])
            # A single iteration would draw no line; a marker keeps it visible.
            marker = "o" if len(curve.steps) == 1 else None
            ax.plot(
                curve.steps,
                curve.mean,
                linestyle=style,
                color=color,
                marker=marker,
                label=text,
                drawstyle="steps-post" if steps else "default",
            )
            if np.any(curve.high > curve.low):
                ax.fill_between(
                    curve.steps,
                    curve.low,
                    curve.high,
                    color=color,
                    alpha=0.2,
                    linewidth=0,
                    step="post" if steps else None,
                )
        values = np.concatenate([np.concatenate([c.low, c.high]) for c, _, _ in lines])
        values = values[np.isfinite(values)]
        if log and values.size and np.all(values > 0):
            ax.set_yscale("log")
        ax.set_title(title)
        ax.set_xlabel(XLABEL)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small", title=f"mean, {level:.0%} CI", title_fontsize="small")
    for ax in axes[len(panels) :]:
        ax.set_visible(False)
    path = pathlib.Path(path)
    figure.savefig(path, dpi=120)
    return path


def plot_task_loss(
    task_curves: list[Curve], path: str | os.PathLike[str], colors: dict[str, str], level: float
) -> pathlib.Path:
    """Task loss vs optimization iteration, a panel per robot, a curve per label (Fig. 4)."""
    robots = list(dict.fromkeys(c.robot for c in task_curves))
    panels = [(robot, [(c, "-", c.label) for c in task_curves if c.robot == robot]) for robot in robots]
    return plot_panels(panels, path, "task loss", colors, level)


def plot_components(
    component_curves: list[Curve], path: str | os.PathLike[str], colors: dict[str, str], level: float
) -> pathlib.Path:
    """Each task term vs optimization iteration, a panel per robot and term."""
    keys = list(dict.fromkeys((c.robot, c.key) for c in component_curves))
    panels = [
        (
            f"{robot}: {key.removeprefix('task/')}",
            [(c, "-", c.label) for c in component_curves if (c.robot, c.key) == (robot, key)],
        )
        for robot, key in keys
    ]
    return plot_panels(panels, path, "task term", colors, level)


def plot_body(
    body_curves: list[Curve], path: str | os.PathLike[str], colors: dict[str, str], level: float
) -> pathlib.Path:
    """The co-designed body's figures (``placement/*``, ``geometry/*``: `litl.designs`) vs
    optimization iteration, a panel per robot and figure: the design's history."""
    keys = list(dict.fromkeys((c.robot, c.key) for c in body_curves))
    panels = [
        (f"{robot}: {key}", [(c, "-", c.label) for c in body_curves if (c.robot, c.key) == (robot, key)])
        for robot, key in keys
    ]
    return plot_panels(panels, path, "body figure", colors, level)


def plot_recon_loss(
    val_curves: list[Curve],
    train_curves: list[Curve],
    path: str | os.PathLike[str],
    colors: dict[str, str],
    level: float,
) -> pathlib.Path:
    """Reconstruction loss of the observer in use vs optimization iteration (Fig. 5).

    Solid lines are the validation loss, dashed ones the training loss, both as recorded by the
    learning phase that produced the observer in use (so they change only between episodes).
    """
    robots = list(dict.fromkeys(c.robot for c in val_curves + train_curves))
    panels = []
    for robot in robots:
        lines = [(c, "-", f"{c.label} (validation)") for c in val_curves if c.robot == robot]
        lines += [(c, "--", f"{c.label} (training)") for c in train_curves if c.robot == robot]
        panels.append((robot, lines))
    return plot_panels(panels, path, "reconstruction loss", colors, level, log=True, steps=True)


def plot_recon_sgd(
    groups: list[Group], path: str | os.PathLike[str], colors: dict[str, str]
) -> pathlib.Path | None:
    """Validation reconstruction loss after every epoch vs optimizer (SGD) step (Fig. 5).

    One thin line per seed, in its label's colour; the steps of successive learning phases are
    counted one after another (phase 0 is the initial training). In the paper's unit, the mean
    reconstruction error per grid node |D(E(v)) - v| (average pixel distance), where the runs
    recorded it (`val_distance_history`, since 2026-12-02); older runs: the mean squared error per
    value of the normalized field. Returns None without data.
    """
    key = (
        "val_distance_history"
        if all("val_distance_history" in r for g in groups for run in g.runs for r in run.learning)
        else "val_recon_history"
    )
    robots = list(dict.fromkeys(g.robot for g in groups))
    figure = Figure(figsize=(6.4, 4.2 * len(robots)))
    drawn = False
    for index, robot in enumerate(robots):
        ax = figure.add_subplot(len(robots), 1, index + 1)
        for group in (g for g in groups if g.robot == robot):
            first = True
            for run in group.runs:
                for seed in sorted({r["seed"] for r in run.learning}):
                    # Phases that learn by SGD steps (an autoencoder's) have a history per epoch.
                    phases = sorted(
                        (r for r in run.learning if r["seed"] == seed and key in r),
                        key=lambda r: r["phase"],
                    )
                    x, y, start = [], [], 0
                    for phase in phases:
                        history = [np.nan if v is None else v for v in phase[key]]
                        x += [start + (e + 1) * phase["steps_per_epoch"] for e in range(len(history))]
                        y += history
                        start = x[-1] if x else start
                    if x:
                        ax.plot(
                            x,
                            y,
                            color=colors[group.label],
                            lw=0.8,
                            alpha=0.8,
                            label=group.label if first else None,
                        )
                        first, drawn = False, True
        ax.set_title(robot)
        ax.set_xlabel("SGD step (learning phases one after another)")
        ax.set_ylabel(
            "validation error per node |D(E(v)) - v|"
            if key == "val_distance_history"
            else "validation reconstruction loss (MSE per value)"
        )
        ax.set_yscale("log")
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize="small")
    if not drawn:
        return None
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    return pathlib.Path(path)
