"""Gaits: which particles are a robot's feet, when each is off the floor, and whether it slips.

A distance per rollout does not say *how* a robot got there: stepping, hopping, sliding on its
belly. `measure_gait` answers from recorded positions (`record_rollout`) alone, for any walker in
2D or 3D; `draw_gait` draws the side view, each foot's height and each foot's travel.

    positions, actuation = record_rollout(robot, policy, params, steps, stride=5)
    gait = measure_gait(positions, robot.layout, frame_dt=5 * robot.config.dt)
    draw_gait(robot, positions, frame_dt=5 * robot.config.dt, path="gait.png")

Feet are the particles within one particle spacing of the lowest rest height, split into the
pieces that touch (one per leg). A foot is *lifted* in a frame when its lowest particle is more
than one particle spacing above the lowest any foot reaches in the whole rollout (the floor as the
particles feel it). A foot's *slip* is the share of its horizontal travel made while it is down:
about 0 for stepping (a foot moves only in the air) and about 1 for sliding.
"""

from __future__ import annotations

import numpy as np

from litl.robots.layout import Layout
from litl.viz.robots import VizError, particle_side, resolve


def find_feet(layout: Layout) -> list[np.ndarray]:
    """Index arrays of a robot's feet at rest, ordered by position (x, then depth in 3D).

    Args:
      layout: the robot's particle layout (`robot.layout`).

    Returns:
      One (k_i,) int array per foot: particles within one spacing of the lowest rest height,
      grouped into pieces whose neighbours lie within 1.5 spacings of each other.
    """
    rest = np.asarray(layout.positions, np.float64)
    spacing = particle_side(layout)
    low = np.flatnonzero(rest[:, 1] <= rest[:, 1].min() + spacing)
    across = np.delete(rest[low], 1, axis=1)  # the horizontal coordinates
    near = np.linalg.norm(across[:, None] - across[None], axis=-1) <= 1.5 * spacing
    label = np.arange(len(low))
    while True:  # connected pieces: every particle takes the smallest label of its neighbours
        merged = np.where(near, label[None, :], len(low)).min(axis=1)
        if np.array_equal(merged, label):
            break
        label = merged
    feet = [low[label == value] for value in np.unique(label)]
    return sorted(feet, key=lambda foot: tuple(np.delete(rest[foot].mean(axis=0), 1)))


def _foot_tracks(positions: np.ndarray, layout: Layout):
    """(feet, heights, xs): `find_feet`, each foot's lowest height and mean x per frame, (T, feet)."""
    feet = find_feet(layout)
    heights = np.stack([positions[:, foot, 1].min(axis=1) for foot in feet], axis=1)
    xs = np.stack([positions[:, foot, 0].mean(axis=1) for foot in feet], axis=1)
    return feet, heights, xs


def measure_gait(positions, layout: Layout, frame_dt: float) -> dict:
    """Numbers of a recorded gait.

    Args:
      positions: (T, n, d) particle positions, one frame every `frame_dt` seconds (T >= 2).
      layout: the robot's layout (its rest positions define the feet).
      frame_dt: seconds between frames (> 0).

    Returns:
      A dict: ``centroid_travel`` (x, domain units), ``duration`` (s), ``late_speed`` (the
      centroid's x travel per second over the recording's second half: a gait keeps its pace, a
      lunge or a body stretching forward does not), ``stance_change`` (how much longer the
      stance, the front foot's x minus the back foot's, is at the end than at the start: a body
      that stretches or collapses between its feet shows it here, a gait keeps it near 0), and
      ``feet``, one dict per foot (`find_feet` order) with ``rest_x``, ``travel`` (x),
      ``lifted_fraction`` (of frames), ``liftoffs`` (times it left the floor), ``max_height``
      above the floor, and ``slip`` (share of its |x| travel made while down; None if it did
      not move).
    """
    positions = np.asarray(positions, np.float64)
    if positions.ndim != 3 or positions.shape[1:] != (layout.n_particles, layout.dim) or len(positions) < 2:
        raise VizError(
            f"positions must have shape (T, n_particles, dim) = (T, {layout.n_particles}"
            f", {layout.dim}) with T >= 2 frames, got {positions.shape}"
        )
    if not (np.isfinite(frame_dt) and frame_dt > 0):
        raise VizError(f"frame_dt must be a positive number of seconds, got {frame_dt}")
    spacing = particle_side(layout)
    feet, heights, xs = _foot_tracks(positions, layout)
    floor = heights.min()
    down = heights - floor <= spacing
    moves = np.abs(np.diff(xs, axis=0))
    grounded_moves = np.where(down[1:] & down[:-1], moves, 0.0)
    rest = np.asarray(layout.positions, np.float64)
    summary = []
    for i, foot in enumerate(feet):
        total = moves[:, i].sum()
        summary.append(
            {
                "rest_x": float(rest[foot, 0].mean()),
                "travel": float(xs[-1, i] - xs[0, i]),
                "lifted_fraction": float(1.0 - down[:, i].mean()),
                "liftoffs": int(np.sum(down[:-1, i] & ~down[1:, i])),
                "max_height": float(heights[:, i].max() - floor),
                "slip": float(grounded_moves[:, i].sum() / total) if total > 1e-9 else None,
            }
        )
    centroid = positions[:, :, 0].mean(axis=1)
    half = (len(positions) - 1) // 2
    late_speed = (centroid[-1] - centroid[half]) / ((len(positions) - 1 - half) * frame_dt)
    stance = xs[:, -1] - xs[:, 0]  # feet are ordered back to front
    return {
        "centroid_travel": float(centroid[-1] - centroid[0]),
        "duration": float((len(positions) - 1) * frame_dt),
        "late_speed": float(late_speed),
        "stance_change": float(stance[-1] - stance[0]),
        "feet": summary,
    }


def draw_gait(robot, positions, frame_dt: float, path=None, frames: int = 8):
    """Side view of `frames` moments, each foot's height and each foot's x travel over time.

    Args:
      robot: the `Robot` (or anything `litl.viz.robots.resolve` accepts) that made `positions`.
      positions: (T, n, d) positions, one frame every `frame_dt` seconds.
      frame_dt: seconds between frames.
      path: save the figure here (PNG/PDF) and close it; None: return it open.
      frames: how many moments the side view overlays (>= 1).

    Returns:
      (figure, `measure_gait`'s dict).
    """
    import matplotlib.pyplot as plt

    name, layout, config, _ = resolve(robot)
    gait = measure_gait(positions, layout, frame_dt)
    if not isinstance(frames, int) or frames < 1:
        raise VizError(f"frames must be a positive integer, got {frames!r}")
    positions = np.asarray(positions, np.float64)
    _, lows, xs = _foot_tracks(positions, layout)
    time = np.arange(len(positions)) * frame_dt
    fig, (side, height, travel) = plt.subplots(
        3, 1, figsize=(8, 8), gridspec_kw={"height_ratios": [1.3, 1, 1]}
    )
    for k, t in enumerate(np.linspace(0, len(positions) - 1, frames).round().astype(int)):
        side.scatter(
            positions[t, :, 0],
            positions[t, :, 1],
            s=2,
            linewidths=0,
            color=plt.cm.viridis(k / max(frames - 1, 1)),
        )
    if config is not None:
        side.axhline(config.boundary.thickness * config.dx, color="k", lw=0.8)
    side.set_aspect("equal")
    side.set_title(f"{name}: side view at {frames} moments (dark: early, light: late)")
    for i, foot in enumerate(gait["feet"]):
        label = f"foot {i} (rest x {foot['rest_x']:.2f})"
        height.plot(time, lows[:, i] - lows.min(), label=label)
        travel.plot(time, xs[:, i] - xs[0, i], label=label)
    height.axhline(particle_side(layout), color="grey", ls=":", lw=0.8)
    height.set_ylabel("foot height above floor")
    height.legend(fontsize=7, ncol=3)
    centroid = positions[:, :, 0].mean(axis=1)
    travel.plot(time, centroid - centroid[0], "k--", label="centroid")
    travel.set_ylabel("x travel")
    travel.set_xlabel("time (s)")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=90)
        plt.close(fig)
    return fig, gait
