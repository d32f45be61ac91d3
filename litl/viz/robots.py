"""Pictures of robots: particles coloured by actuator, design region, actuation or stiffness.

In the style of the paper's Fig. 4 insets: particles drawn as small squares, passive material in
light grey, each actuator in its own colour, pinned particles dark grey, particle groups that must
reach a target marked with a black X at their centroid, targets as green circles, and the walls as
grey bands of ``boundary.thickness * dx``.

What is drawn can be given as

* a `litl.robots.robot.Robot` (layout, config and task come from it), or
* a `litl.robots.layout.Layout` with optional keywords ``config=`` (for the domain and walls;
  without it the view fits the particles) and ``task=`` (for reach targets).

The artists carry ``gid``s so that callers (and tests) can find and restyle them:
``"particles"`` (the scatter of particles), ``"wall"`` (one patch per closed wall),
``"pinned_box"`` (grid regions pinned by the boundary), ``"target"`` (one per reach target) and
``"reach_group"`` (one X per group that must reach a target).

Actuation colours: ``RdBu`` over the fixed range [-1, 1]. A positive actuation adds tension along
the fiber, so the material contracts (blue); a negative one makes it expand (red). Stiffness
colours (a design φ: Young's modulus per region): ``viridis`` over the design bounds.
"""

from __future__ import annotations

from typing import Any

import matplotlib.colors as mcolors
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import to_rgba
from matplotlib.patches import Circle, Rectangle

from litl.errors import UserError
from litl.robots.layout import Layout

PASSIVE_COLOR = "#bdbdbd"
PINNED_COLOR = "#404040"
WALL_COLOR = "#8c8c8c"
# The scenery's bodies (`Robot.scenery`) by name: sand, water; anything else in a clay colour.
SCENERY_COLORS = {"sand": "#d8c078", "water": "#7fb2e5"}
TARGET_COLOR = "#1a9641"
# tab10 without green (targets) and grey (passive material, walls).
ACTUATOR_PALETTE = ("#1f77b4", "#ff7f0e", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#bcbd22", "#17becf")
ACTUATION_CMAP = "RdBu"
ACTUATION_NORM = mcolors.Normalize(vmin=-1.0, vmax=1.0)
ACTUATION_LABEL = "actuation (+1 contracts, -1 expands)"
STIFFNESS_CMAP = "viridis"
STIFFNESS_LABEL = "Young's modulus E of the region"


class VizError(UserError, ValueError):
    """Something cannot be drawn as asked; the message says what and how to fix it."""


# ---------------------------------------------------------------------------- inputs


def resolve(robot, config=None, task=None):
    """Normalize a drawable into ``(name, layout, config or None, targets)``.

    Args:
      robot: a `Robot`, or a `Layout` (then `config` and `task` may be given).
      config: `SimConfig` for a bare layout; must be None for a `Robot`.
      task: `Task` for a bare layout; must be None for a `Robot`.

    Returns:
      name: a label for messages; layout; config (None for a bare layout without one);
      targets: {group name: (d,) target point} of the task's reach terms.
    """
    if isinstance(robot, Layout):
        name, layout = "layout", robot
    elif hasattr(robot, "layout") and hasattr(robot, "config"):
        if config is not None or task is not None:
            raise VizError("config= and task= are for a bare Layout; a Robot brings its own")
        name, layout, config, task = robot.name, robot.layout, robot.config, robot.task
    else:
        raise VizError(f"expected a Robot or a Layout, got {type(robot).__name__}")
    if config is not None and config.dim != layout.dim:
        raise VizError(f"the layout is {layout.dim}D but the config's grid is {config.dim}D")
    targets = (
        {}
        if task is None
        else {group: np.asarray(point, np.float64) for group, point in task.targets.items()}
    )
    for group in targets:
        layout.group_mask(group)  # clear error for an unknown group
    return name, layout, config, targets


def check_positions(name: str, layout: Layout, positions) -> np.ndarray:
    """(n, d) float positions; the layout's rest positions when `positions` is None."""
    if positions is None:
        return layout.positions
    positions = np.asarray(positions, np.float64)
    want = (layout.n_particles, layout.dim)
    if positions.shape != want:
        raise VizError(
            f"positions for {name!r} must have shape (n_particles, dim) = {want}, got {positions.shape}"
        )
    return positions


def check_actuation(name: str, layout: Layout, actuation) -> np.ndarray | None:
    """(m,) float actuation, or None."""
    if actuation is None:
        return None
    actuation = np.asarray(actuation, np.float64)
    if actuation.shape != (layout.n_actuators,):
        raise VizError(
            f"actuation for {name!r} must have shape (n_actuators,) = "
            f"({layout.n_actuators},), got {actuation.shape}"
        )
    return actuation


def _check_dim(name: str, layout: Layout, dim: int):
    if layout.dim != dim:
        other = "draw_robot_3d" if layout.dim == 3 else "draw_robot"
        raise VizError(f"{name!r} is {layout.dim}D; use {other} to draw it")


# ---------------------------------------------------------------------------- colours


def actuator_colors(n_actuators: int) -> np.ndarray:
    """(m, 4) RGBA: a distinct colour per actuator (palette first, evenly spaced hues beyond it)."""
    if n_actuators <= len(ACTUATOR_PALETTE):
        return mcolors.to_rgba_array(ACTUATOR_PALETTE[:n_actuators]).reshape(-1, 4)
    return plt.get_cmap("hsv")(np.arange(n_actuators) / n_actuators)


def stiffness_norm(stiffness, stiffness_range=None) -> mcolors.Normalize:
    """The colour scale of a design: `stiffness_range` (E_min, E_max), or the values' range."""
    low, high = (
        stiffness_range
        if stiffness_range is not None
        else (float(np.min(stiffness)), float(np.max(stiffness)))
    )
    return mcolors.Normalize(vmin=low, vmax=high if high > low else low + 1.0)


def particle_colors(
    layout: Layout,
    actuation=None,
    show_regions: bool = False,
    stiffness=None,
    stiffness_range=None,
    opacity=None,
) -> np.ndarray:
    """(n, 4) RGBA colour of every particle.

    Args:
      layout: the particles' labels.
      actuation: (m,) actuation per actuator, or None. Given, every actuated particle takes its
        actuator's value on the ``RdBu`` colormap over [-1, 1]; passive particles stay light grey.
        Without it, each actuator gets its own colour.
      show_regions: colour by design region instead (cannot be combined with `actuation`).
      stiffness: (R,) Young's modulus per design region (a design φ): colour every particle by
        its region's value on ``viridis`` over `stiffness_range` (default: the values' range);
        cannot be combined with `actuation` or `show_regions`.
      opacity: (n,) each particle's opacity in [0, 1] (a co-designed body's material, `litl.
        designs.BodySpace.density`), in every mode; None: opaque.

    Pinned particles are dark grey in every mode: they do not move, whatever their labels say.
    """
    if sum((show_regions, actuation is not None, stiffness is not None)) > 1:
        raise VizError("show_regions, actuation and stiffness each pick the colours; pass only one")
    n = layout.n_particles
    colors = np.tile(mcolors.to_rgba(PASSIVE_COLOR), (n, 1))
    actuated = layout.actuator >= 0
    if stiffness is not None:
        stiffness = np.asarray(stiffness, np.float64)
        if stiffness.shape != (layout.n_regions,):
            raise VizError(
                f"stiffness must have one value per design region, shape "
                f"({layout.n_regions},), got {stiffness.shape}"
            )
        norm = stiffness_norm(stiffness, stiffness_range)
        colors = plt.get_cmap(STIFFNESS_CMAP)(norm(stiffness[layout.region]))
    elif show_regions:
        # Set3 rather than tab10, whose first colours are those of actuators 0, 1, ...
        cmap = plt.get_cmap("Set3" if layout.n_regions <= 12 else "tab20")
        colors = cmap(layout.region % cmap.N)
    elif actuation is not None:
        actuation = np.asarray(actuation, np.float64)
        values = ACTUATION_NORM(actuation[layout.actuator[actuated]])
        colors[actuated] = plt.get_cmap(ACTUATION_CMAP)(values)
    else:
        colors[actuated] = actuator_colors(layout.n_actuators)[layout.actuator[actuated]]
    colors[layout.pinned] = mcolors.to_rgba(PINNED_COLOR)
    if opacity is not None:
        opacity = np.asarray(opacity, np.float64)
        if opacity.shape != (n,):
            raise VizError(f"opacity must have one value per particle, shape ({n},), got {opacity.shape}")
        colors[:, 3] = np.clip(opacity, 0.0, 1.0)
    return colors


# ---------------------------------------------------------------------------- 2D


def particle_side(layout: Layout) -> float:
    """Edge length of one particle's cell (domain units): the typical volume's d-th root."""
    return float(np.median(layout.volume)) ** (1.0 / layout.dim)


def _marker_size(ax, side: float) -> float:
    """Scatter size (points²) of a square of edge `side` in data units, for the current view."""
    ax.apply_aspect()  # the equal-aspect box is only settled here
    width_px = ax.get_window_extent().width
    x0, x1 = ax.get_xlim()
    points_per_unit = width_px / abs(x1 - x0) * 72.0 / ax.figure.dpi
    return max((side * points_per_unit) ** 2, 0.25)


def _wall_rectangles(config) -> list[tuple[tuple[float, float], float, float]]:
    """(corner, width, height) of the band of each closed wall in 2D."""
    thickness = config.boundary.thickness * config.dx
    size = config.domain_size
    bands = []
    for face, wall in enumerate(config.boundary.walls):
        if wall.kind == "open":
            continue
        axis, high = divmod(face, 2)
        lower = [0.0, 0.0]
        extent = list(size)
        lower[axis] = size[axis] - thickness if high else 0.0
        extent[axis] = thickness
        bands.append(((lower[0], lower[1]), extent[0], extent[1]))
    return bands


def draw_collider(ax, collider, config, time: float = 0.0, resolution: int = 256):
    """A 2D collider's solid (signed distance < 0) where it is at `time`, filled in the walls'
    colour; the drawn artist (None in 3D, or where the solid is outside the domain)."""
    if config.dim != 2:
        return None
    width, height = config.domain_size
    xs, ys = np.linspace(0, width, resolution), np.linspace(0, height, resolution)
    grid = np.stack(np.meshgrid(xs, ys, indexing="xy"), axis=-1)
    phi, _ = collider.distance(grid, time)
    if phi.min() >= 0:
        return None
    filled = ax.contourf(xs, ys, phi, levels=[phi.min() - 1.0, 0.0], colors=[WALL_COLOR], zorder=1)
    filled.set_gid("moving_collider" if collider.moving else "collider")
    return filled


def _view_limits(layout: Layout, positions: np.ndarray, config, targets):
    """Per-axis (low, high) limits: the domain, or the particles and targets with a margin."""
    if config is not None:
        return [(0.0, s) for s in config.domain_size]
    points = np.concatenate([positions, *[t[None] for t in targets.values()]])
    low, high = points.min(axis=0), points.max(axis=0)
    margin = 0.1 * np.max(high - low) + particle_side(layout)
    return list(zip(low - margin, high + margin, strict=True))


def _scatter_particles(ax, positions, colors, side: float, zorder: float, gid: str) -> None:
    """Particles as squares of their own size on the Axes as it is now."""
    ax.scatter(
        positions[:, 0],
        positions[:, 1],
        s=_marker_size(ax, side),
        c=colors,
        marker="s",
        linewidths=0,
        zorder=zorder,
        gid=gid,
    )


def draw_robot(
    robot,
    ax=None,
    positions=None,
    actuation=None,
    show_targets: bool = True,
    show_regions: bool = False,
    *,
    config=None,
    task=None,
    colorbar: bool = False,
    stiffness=None,
    stiffness_range=None,
    scenery=None,
    time: float = 0.0,
    opacity=None,
):
    """Draw a 2D robot (rest pose or any state) on a matplotlib Axes.

    Args:
      robot: a 2D `Robot`, or a `Layout` (see `config` and `task`).
      ax: Axes to draw on; None: a new figure (pyplot) of a size that suits the domain.
      positions: (n, 2) particle positions to draw; None: the layout's rest positions.
      actuation: (m,) actuation of each actuator; colours actuated particles on ``RdBu`` over
        [-1, 1] (blue contracts, red expands). None: one colour per actuator.
      show_targets: draw reach targets (green circles) and X's at the reaching groups' centroids.
      show_regions: colour particles by design region instead of by actuator.
      config: with a bare `Layout`, the `SimConfig` whose domain and walls to draw; without one
        the view fits the particles and no walls are drawn.
      task: with a bare `Layout`, the `Task` whose reach targets to draw.
      colorbar: with `actuation` or `stiffness`, add a colour bar of its scale.
      stiffness, stiffness_range: colour by a design's Young's modulus per region instead (see
        `particle_colors`).
      scenery: (k, 2) positions of the robot's scenery (`Robot.scenery`: a sand bed, a pool);
        None: its rest positions. Drawn under the robot, one colour per body.
      time: seconds since the rollout's start: where moving colliders (`Collider.velocity`)
        are drawn.
      opacity: (n,) each particle's opacity in [0, 1] (see `particle_colors`); None: opaque.

    Returns:
      The Axes. Equal aspect, limits the domain. Particle marker sizes follow the Axes' size at the
      time of drawing (resize the figure first, then draw).

    Raises:
      VizError: a 3D robot (use `draw_robot_3d`), a 3D Axes, or positions/actuation of the wrong
        shape.
    """
    name, layout, config, targets = resolve(robot, config, task)
    _check_dim(name, layout, 2)
    positions = check_positions(name, layout, positions)
    actuation = check_actuation(name, layout, actuation)
    colors = particle_colors(layout, actuation, show_regions, stiffness, stiffness_range, opacity)
    limits = _view_limits(layout, positions, config, targets)
    if ax is None:
        aspect = (limits[1][1] - limits[1][0]) / (limits[0][1] - limits[0][0])
        _, ax = plt.subplots(figsize=(5.0, float(np.clip(5.0 * aspect, 1.5, 8.0))))
    elif getattr(ax, "name", "") == "3d":
        raise VizError("draw_robot needs a 2D Axes; use draw_robot_3d for 3D Axes")

    ax.set_xlim(*limits[0])
    ax.set_ylim(*limits[1])
    ax.set_aspect("equal")
    if config is not None:
        for corner, width, height in _wall_rectangles(config):
            ax.add_patch(
                Rectangle(corner, width, height, facecolor=WALL_COLOR, edgecolor="none", zorder=1, gid="wall")
            )
        for collider in config.boundary.colliders:
            draw_collider(ax, collider, config, time)
        for lo, hi in config.boundary.pinned_boxes:
            ax.add_patch(
                Rectangle(
                    lo,
                    hi[0] - lo[0],
                    hi[1] - lo[1],
                    facecolor=PINNED_COLOR,
                    alpha=0.3,
                    hatch="//",
                    edgecolor=PINNED_COLOR,
                    zorder=1,
                    gid="pinned_box",
                )
            )
    bodies = getattr(robot, "scenery", ())
    if bodies:
        rest = np.concatenate([body.positions for body in bodies])
        where = rest if scenery is None else np.asarray(scenery, np.float64)
        colours = np.concatenate(
            [np.tile(to_rgba(SCENERY_COLORS.get(b.name, "#b0a080")), (b.n_particles, 1)) for b in bodies]
        )
        _scatter_particles(ax, where, colours, particle_side(layout), zorder=1.5, gid="scenery")
        task = getattr(robot, "task", None)
        pushes = {} if task is None or not show_targets else task.push_targets
        for target in pushes.values():  # where a pushed body is to go (push_box): a green ring
            radius = 2.0 * (config.dx if config is not None else particle_side(layout))
            ring = Circle(tuple(target[:2]), radius, fill=False, edgecolor=TARGET_COLOR, lw=2, zorder=3)
            ring.set_gid("push_target")
            ax.add_patch(ring)
    if colorbar:  # first: it shrinks the Axes, which sets the marker size
        _add_colorbar(ax, actuation, stiffness, stiffness_range)
    _scatter_particles(ax, positions, colors, particle_side(layout), zorder=2, gid="particles")
    if show_targets:
        radius = 2.0 * (config.dx if config is not None else particle_side(layout))
        for group, target in targets.items():
            ax.add_patch(
                Circle(
                    tuple(target),
                    radius,
                    facecolor=TARGET_COLOR,
                    alpha=0.6,
                    edgecolor=TARGET_COLOR,
                    zorder=3,
                    gid="target",
                )
            )
            center = positions[layout.groups[group]].mean(axis=0)
            ax.plot(
                *center,
                marker="x",
                color="black",
                markersize=9,
                markeredgewidth=2,
                linestyle="none",
                zorder=4,
                gid="reach_group",
            )
    ax.set_xlabel("x")
    ax.set_ylabel("y (up)")
    return ax


def add_actuation_colorbar(ax, **kwargs):
    """A colour bar of the actuation scale ([-1, 1], ``RdBu``) beside `ax`; returns it."""
    mappable = plt.cm.ScalarMappable(norm=ACTUATION_NORM, cmap=ACTUATION_CMAP)
    kwargs = {"shrink": 0.8, "label": ACTUATION_LABEL, **kwargs}
    return ax.figure.colorbar(mappable, ax=ax, **kwargs)


def add_stiffness_colorbar(ax, stiffness, stiffness_range=None, **kwargs):
    """A colour bar of the stiffness scale (``viridis``) beside `ax`; returns it."""
    mappable = plt.cm.ScalarMappable(norm=stiffness_norm(stiffness, stiffness_range), cmap=STIFFNESS_CMAP)
    kwargs = {"shrink": 0.8, "label": STIFFNESS_LABEL, **kwargs}
    return ax.figure.colorbar(mappable, ax=ax, **kwargs)


def _add_colorbar(ax, actuation, stiffness, stiffness_range, **kwargs):
    if stiffness is not None:
        add_stiffness_colorbar(ax, stiffness, stiffness_range, **kwargs)
    elif actuation is not None:
        add_actuation_colorbar(ax, **kwargs)


# ---------------------------------------------------------------------------- 3D


def to_plot_3d(points: np.ndarray) -> np.ndarray:
    """Simulation (x, up, depth) to mplot3d (x, depth, up): mplot3d draws its z axis upwards."""
    return np.asarray(points)[..., [0, 2, 1]]


def draw_robot_3d(
    robot,
    ax=None,
    positions=None,
    actuation=None,
    show_targets: bool = True,
    show_regions: bool = False,
    *,
    config=None,
    task=None,
    colorbar: bool = False,
    stiffness=None,
    stiffness_range=None,
    elev: float = 20.0,
    azim: float = -65.0,
    limits=None,
    opacity=None,
):
    """Draw a 3D robot as a scatter on a mplot3d Axes (same colour rules as `draw_robot`).

    The simulation's axis 1 ("up") is drawn vertically and axis 2 (depth) into the picture; the
    floor wall is a grey plane at its thickness; limits are the domain, with a box aspect
    proportional to it; the view is from the front side (`elev`, `azim` in degrees).

    Args:
      robot: a 3D `Robot`, or a `Layout` (see `draw_robot` for `config` and `task`).
      ax: a 3D Axes (``fig.add_subplot(projection="3d")``); None: a new figure.
      positions: (n, 3) particle positions; None: the rest positions.
      actuation: (m,) actuation of each actuator (see `draw_robot`).
      show_targets, show_regions, config, task, colorbar, stiffness, stiffness_range: as in
        `draw_robot`.
      elev, azim: camera angles passed to ``ax.view_init``.
      limits: (3, 2) low and high view limits per simulation axis (x, up, depth), e.g. a
        rollout's bounding box (`rollout_limits`); None: the domain.
      opacity: (n,) each particle's opacity in [0, 1] (see `particle_colors`); None: opaque.

    Returns:
      The 3D Axes.

    Raises:
      VizError: a 2D robot (use `draw_robot`), a 2D Axes, or inputs of the wrong shape.
    """
    name, layout, config, targets = resolve(robot, config, task)
    _check_dim(name, layout, 3)
    positions = check_positions(name, layout, positions)
    actuation = check_actuation(name, layout, actuation)
    colors = particle_colors(layout, actuation, show_regions, stiffness, stiffness_range, opacity)
    if ax is None:
        ax = plt.figure(figsize=(6.0, 5.0)).add_subplot(projection="3d")
    elif getattr(ax, "name", "") != "3d":
        raise VizError("draw_robot_3d needs a 3D Axes: fig.add_subplot(projection='3d')")

    if limits is None:
        limits = _view_limits(layout, positions, config, targets)
    elif np.shape(limits) != (3, 2):
        raise VizError(f"limits must be (3, 2) low/high per axis, got shape {np.shape(limits)}")
    limits = np.asarray(limits, float)[[0, 2, 1]]
    ax.set_xlim(*limits[0])
    ax.set_ylim(*limits[1])
    ax.set_zlim(*limits[2])
    ax.set_box_aspect(limits[:, 1] - limits[:, 0])
    ax.view_init(elev=elev, azim=azim)
    # Draw in zorder (floor, body, markers): by depth, mplot3d would hide the X inside the body.
    ax.computed_zorder = False
    if config is not None and config.boundary.walls[2].kind != "open":
        _draw_floor(ax, config, limits)
    plotted = to_plot_3d(positions)
    # Marker area from the particle cell relative to the domain; the projection shrinks it, so
    # this only approximates the cell, which is all a 3D scatter can do.
    extent = float(np.max(limits[:, 1] - limits[:, 0]))
    width_points = ax.figure.get_figwidth() * 72.0 * 0.6
    size = max((particle_side(layout) / extent * width_points) ** 2, 0.5)
    ax.scatter(
        plotted[:, 0],
        plotted[:, 1],
        plotted[:, 2],
        s=size,
        c=colors,
        marker="s",
        linewidths=0,
        depthshade=True,
        zorder=2,
        gid="particles",
    )
    if show_targets:
        for group, target in targets.items():
            point = to_plot_3d(target)
            ax.scatter(*point, s=120, color=TARGET_COLOR, alpha=0.7, marker="o", zorder=3, gid="target")
            center = to_plot_3d(positions[layout.groups[group]].mean(axis=0))
            ax.scatter(*center, s=80, color="black", marker="x", linewidths=2, zorder=4, gid="reach_group")
    if colorbar:
        _add_colorbar(ax, actuation, stiffness, stiffness_range, shrink=0.6, pad=0.12)
    ax.set_xlabel("x")
    ax.set_ylabel("depth")
    ax.set_zlabel("up")
    return ax


def rollout_limits(positions, config=None, margin: float = 0.1, targets=()) -> np.ndarray:
    """(3, 2) view limits around a 3D rollout: its particles' bounding box over all frames (and
    any `targets` points), `margin` wider on every side and down to the floor, clipped to the
    domain (with `config`)."""
    points = np.concatenate(
        [np.asarray(positions, float).reshape(-1, 3), np.asarray(list(targets), float).reshape(-1, 3)]
    )
    limits = np.stack([points.min(0) - margin, points.max(0) + margin], axis=1)
    limits[1, 0] = 0.0
    if config is not None:
        limits[:, 0] = np.maximum(limits[:, 0], 0.0)
        limits[:, 1] = np.minimum(limits[:, 1], np.asarray(config.domain_size, float))
    return limits


def _draw_floor(ax, config, limits):
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    (x0, x1), (z0, z1) = limits[0], limits[1]  # plot axes: x, depth
    height = config.boundary.thickness * config.dx
    corners = [(x0, z0, height), (x1, z0, height), (x1, z1, height), (x0, z1, height)]
    ax.add_collection3d(
        Poly3DCollection(
            [corners], facecolor=WALL_COLOR, alpha=0.35, edgecolor=WALL_COLOR, zorder=1, gid="wall"
        )
    )


def draw(robot, ax=None, **kwargs: Any):
    """`draw_robot` or `draw_robot_3d`, whichever fits the robot's dimension."""
    layout = resolve(robot, kwargs.get("config"), kwargs.get("task"))[1]
    return (draw_robot_3d if layout.dim == 3 else draw_robot)(robot, ax, **kwargs)
