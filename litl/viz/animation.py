"""Animations of rollouts: particles coloured by actuation, written to GIF or MP4.

    positions, actuation = record_rollout(robot, policy, params, steps=400, stride=4)
    animate_rollout(robot, positions, actuation, "out/walker.gif", fps=25)

`record_rollout` runs the simulation (jitted) and returns numpy arrays; `animate_rollout` draws them
with the colour rules of `litl.viz.robots` (each actuated particle takes its actuator's value on
``RdBu`` over [-1, 1], passive particles stay grey), 2D or 3D by the robot's dimension.
"""

from __future__ import annotations

import os
import uuid
from pathlib import Path

import jax
import matplotlib.animation as manimation
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from litl.viz.robots import (
    VizError,
    draw_collider,
    draw_robot,
    draw_robot_3d,
    particle_colors,
    resolve,
    rollout_limits,
    to_plot_3d,
)

SUFFIXES = (".gif", ".mp4")


def _check_rollout(name, layout, positions, actuation):
    positions = np.asarray(positions, np.float64)
    actuation = np.asarray(actuation, np.float64)
    n, d, m = layout.n_particles, layout.dim, layout.n_actuators
    if positions.ndim != 3 or positions.shape[1:] != (n, d) or len(positions) == 0:
        raise VizError(
            f"positions for {name!r} must have shape (T, n_particles, dim) = "
            f"(T, {n}, {d}) with T >= 1, got {positions.shape}"
        )
    if actuation.shape != (len(positions), m):
        raise VizError(
            f"actuation for {name!r} must have shape (T, n_actuators) = "
            f"({len(positions)}, {m}) to match the positions, got {actuation.shape}"
        )
    return positions, actuation


def animation_writer(suffix: str, fps: float):
    """The matplotlib writer for an animation file of `suffix` (.gif or .mp4) at `fps` frames a second."""
    # matplotlib's stubs say int; its writers take any positive number of frames per second.
    if suffix == ".gif":
        return manimation.PillowWriter(fps=fps)  # type: ignore[arg-type]
    if not manimation.writers.is_available("ffmpeg"):
        raise VizError(
            "writing .mp4 needs ffmpeg, which matplotlib cannot find: install it "
            "(e.g. `apt-get install ffmpeg` or `conda install ffmpeg`) or write a .gif"
        )
    return manimation.FFMpegWriter(fps=fps)  # type: ignore[arg-type]


def animate_rollout(
    robot,
    positions,
    actuation,
    path,
    fps: float = 30,
    stride: int = 1,
    dpi: int = 80,
    show_targets: bool = True,
    colorbar: bool = True,
    stiffness=None,
    stiffness_range=None,
    scenery=None,
    frame_seconds: float | None = None,
) -> Path:
    """Write an animation of a rollout to `path` (``.gif`` always, ``.mp4`` with ffmpeg).

    Frame k shows ``positions[k * stride]`` with particles coloured by ``actuation[k * stride]``.
    The file is written under a temporary name in the same folder and renamed at the end, so a
    failure leaves no half-written file at `path`.

    Args:
      robot: a `Robot` (2D or 3D; its dimension picks the drawing).
      positions: (T, n, d) particle positions per frame, e.g. from `record_rollout`.
      actuation: (T, m) actuation per frame.
      path: output file; its suffix picks the format (.gif or .mp4). Parent folders are created.
      fps: frames per second of the animation.
      stride: draw every `stride`-th frame.
      dpi: resolution (dots per inch; the figure is 5-6 inches wide).
      show_targets: draw reach targets and X's at the reaching groups' centroids.
      colorbar: add a colour bar of the colour scale.
      stiffness: (R,) Young's modulus per design region (a design φ): colour the particles by
        it (``viridis`` over `stiffness_range`, default the values' range) instead of by
        actuation.
      scenery: (T, k, d) positions of the robot's scenery per frame (`record_rollout(...,
        scenery=True)`), drawn under it (2D); None: none drawn.
      frame_seconds: simulated seconds between consecutive `positions` (the time step times
        `record_rollout`'s stride); frame k is at (k + 1) x that. Moving colliders
        (`Collider.velocity`, 2D) are drawn where they are at each frame; None: the time step,
        as `record_rollout` records with its default stride 1.

    Returns:
      The path written.

    Raises:
      VizError: an unknown suffix, .mp4 without ffmpeg, or positions/actuation of the wrong shape.
    """
    name, layout, config, targets = resolve(robot)
    positions, actuation = _check_rollout(name, layout, positions, actuation)
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise VizError(f"cannot write an animation to {str(path)!r}: use a .gif or .mp4 file name")
    if not isinstance(stride, int) or stride < 1:
        raise VizError(f"stride must be a positive integer, got {stride!r}")
    if not fps > 0:
        raise VizError(f"fps must be positive, got {fps!r}")
    if frame_seconds is not None and not frame_seconds > 0:
        raise VizError(f"frame_seconds must be positive, got {frame_seconds!r}")
    moving = (
        [c for c in config.boundary.colliders if c.moving] if config is not None and layout.dim == 2 else []
    )
    frame_seconds = frame_seconds or (config.dt if config is not None else 0.0)
    writer = animation_writer(suffix, fps)
    frames = range(0, len(positions), stride)

    # A bare Figure (not pyplot's): nothing pops up in interactive sessions and nothing leaks.
    fig = Figure(figsize=(6.0, 5.0) if layout.dim == 3 else (6.0, 4.5), dpi=dpi)
    FigureCanvasAgg(fig)
    coloring = {"stiffness": stiffness, "stiffness_range": stiffness_range} if stiffness is not None else {}
    first_actuation = None if stiffness is not None else actuation[0]
    if layout.dim == 3:
        # Framed on the robot's path rather than the whole domain, where a walker is a speck.
        ax = draw_robot_3d(
            robot,
            fig.add_subplot(projection="3d"),
            positions[0],
            first_actuation,
            show_targets,
            colorbar=colorbar,
            limits=rollout_limits(positions, config, targets=targets.values()),
            **coloring,
        )
    else:
        ax = draw_robot(
            robot,
            fig.add_subplot(),
            positions[0],
            first_actuation,
            show_targets,
            colorbar=colorbar,
            scenery=None if scenery is None else scenery[0],
            time=frame_seconds,
            **coloring,
        )
    terrain = next((a for a in ax.get_children() if a.get_gid() == "scenery"), None)
    fixed = (
        particle_colors(layout, stiffness=stiffness, stiffness_range=stiffness_range)
        if stiffness is not None
        else None
    )
    particles = next(a for a in ax.get_children() if a.get_gid() == "particles")
    crosses = [a for a in ax.get_children() if a.get_gid() == "reach_group"]
    groups = [layout.groups[g] for g in resolve(robot)[3]] if show_targets else []
    title = ax.set_title("")
    drawn = [a for a in ax.get_children() if a.get_gid() == "moving_collider"]

    def update(frame):
        x = positions[frame]
        colors = fixed if fixed is not None else particle_colors(layout, actuation[frame])
        if layout.dim == 3:
            particles._offsets3d = tuple(to_plot_3d(x).T)
            for cross, group in zip(crosses, groups, strict=True):
                cross._offsets3d = tuple(to_plot_3d(x[group].mean(axis=0))[:, None])
        else:
            particles.set_offsets(x)
            if terrain is not None and scenery is not None:
                terrain.set_offsets(scenery[frame])
            for cross, group in zip(crosses, groups, strict=True):
                cross.set_data(*x[group].mean(axis=0)[:, None])
            if moving:  # redrawn where they are at this frame's time
                for artist in drawn:
                    artist.remove()
                drawn[:] = [
                    a
                    for c in moving
                    if (a := draw_collider(ax, c, config, (frame + 1) * frame_seconds)) is not None
                ]
        particles.set_facecolor(colors)
        title.set_text(f"{name}: frame {frame + 1} / {len(positions)}")
        return [particles, *crosses, title]

    animation = manimation.FuncAnimation(fig, update, frames=frames, blit=False)
    save_animation(animation, path, writer, dpi)
    return path


def save_animation(animation, path: Path, writer, dpi: int) -> None:
    """Write `animation` to `path` under a temporary name, renamed when complete.

    Same folder (an atomic rename), same suffix (the writers pick the container from it): a
    failure leaves no half-written file at `path`.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.stem}.{uuid.uuid4().hex[:8]}.partial{path.suffix}")
    try:
        animation.save(temporary, writer=writer, dpi=dpi)
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)


def record_rollout(
    robot,
    policy,
    policy_params,
    steps: int,
    design=None,
    stride: int = 1,
    check: bool = True,
    field=None,
    scenery: bool = False,
):
    """Simulate `robot` under `policy` and return what `animate_rollout` draws.

    Runs `litl.sim.make_rollout` (jitted) from the robot's rest state, recording every particle's
    position after each step (memory: steps * n * d floats).

    Args:
      robot: a `Robot`.
      policy: ``policy(params, state, grid_velocity) -> (m,) actuation``.
      policy_params: the policy's parameters.
      steps: number of simulation steps.
      design: a `litl.sim.Design`; None: the robot's initial design
        (`robot.design_space.to_design()`).
      stride: keep the state after steps stride, 2 stride, ... (every `stride`-th step).
      check: raise `litl.sim.SimulationError` if the rollout blew up or lost particles (set False
        to look at a failure).
      field: what the policy reads of the grid (`litl.sim.fields`; a run's `algorithm.field`);
        None: the node velocities.

      scenery: also return the scenery's positions (`Robot.scenery`: a sand bed, a pool).

    Returns:
      positions: (steps // stride, n, d) numpy positions of the robot's particles after steps
        stride, 2 stride, ...
      actuation: (steps // stride, m) numpy actuation applied in those steps.
      (with `scenery`) (steps // stride, k, d) the scenery's particles' positions.
    """
    from litl.sim import make_rollout, raise_if_unhealthy

    if not isinstance(stride, int) or not 0 < stride <= steps:
        raise VizError(f"stride must be an integer in [1, steps={steps}], got {stride!r}")
    from litl.sim.fields import grid_velocity

    rollout = jax.jit(
        make_rollout(
            robot.config,
            robot.body(),
            policy,
            steps,
            observe=lambda state: state.x,  # the whole scene: the robot's particles, then its scenery's
            remat=False,
            field=field or grid_velocity,
        )
    )
    design = robot.design_space.to_design() if design is None else design
    _, trajectory = rollout(policy_params, design, robot.initial_state())
    if check:
        raise_if_unhealthy(trajectory.health, steps)
    keep = slice(stride - 1, None, stride)
    everything = np.asarray(trajectory.observations)[keep]
    own = robot.layout.n_particles
    recorded = (everything[:, :own], np.asarray(trajectory.actuation)[keep])
    return (*recorded, everything[:, own:]) if scenery else recorded
