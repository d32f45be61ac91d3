"""The push_box world: an elastic box on the floor ahead of the robot, and the task of pushing
it: the squared distance of its centroid to a target `push` ahead of its start, at the end
(`litl.robots.tasks.Push`). The world brings its own task in place of the robot's: the run says
so and records it in run.json ("task")."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from litl.robots.robot import Robot
from litl.robots.scenery import Scenery
from litl.robots.tasks import Push, Task
from litl.settings import Settings
from litl.sim.config import SimConfigError
from litl.sim.sampling import sample_box
from litl.worlds.bodies import ObservedPart, elastic_wave_stiffness, with_body


@dataclass(frozen=True)
class PushBoxSettings(Settings):
    """``world.push_box``.

    Attributes:
      box_size: the box's side (domain units, at least two grid cells).
      push: how far the box is to be pushed: its target lies `push` ahead of its start (along x).
      gap: cells between the robot's front and the box (>= 0).
      density: the box's density, relative to the robot's.
      observe: what the robot's observers see: ``robot`` or ``scene`` (the box included).
    """

    box_size: float = 0.08
    push: float = 0.1
    gap: float = 2.0
    density: float = 1.5
    observe: ObservedPart = ObservedPart.robot

    def check(self) -> None:
        self._positive_numbers("box_size", "push", "density")
        self._positive_numbers("gap", zero=True)


def push_box(robot: Robot, settings: PushBoxSettings, context: object = None) -> Robot:
    """`robot` before a box to push: a cube (square in 2D) of side `box_size`, `gap` cells past
    the robot's front (centred on it in z), 2 particles per cell per axis, as stiff as the
    robot's stiffest design allows (its P-wave speed the robot's fastest: dt unchanged), of the
    robot's elastic material (one material in the scene: the simulator's single-material step)."""
    if robot.scenery:
        return robot
    config = robot.config
    assert config.boundary is not None  # SimConfig sets the default box
    dx, dim = config.dx, config.dim
    side = settings.box_size
    low, high = robot.layout.bounds()
    lower = np.array(low, np.float64)
    lower[0] = high[0] + settings.gap * dx + dx
    lower[1] = config.boundary.thickness * dx
    if dim == 3:
        lower[2] = (low[2] + high[2] - side) / 2
    room = config.domain_size[0] - config.boundary.thickness * dx - 2 * dx
    if lower[0] + side > room or side < 2 * dx:
        raise SimConfigError(
            f"world.push_box.box_size={side:g}, world.push_box.gap={settings.gap:g}: the box must be at "
            f"least two cells wide ({2 * dx:g}) and fit between the robot's front ({high[0]:.3g}) and "
            f"the wall ({room:.3g}); choose a smaller box or gap"
        )
    if lower[0] + side + settings.push > room:
        raise SimConfigError(
            f"world.push_box.push={settings.push:g}: the target lies beyond the wall (the box would end "
            f"at {lower[0] + side + settings.push:.3g}, the wall is at {room:.3g}); push it less far"
        )
    positions = sample_box(lower, np.full(dim, float(side)), dx, per_cell=2)
    density = settings.density * robot.material.density
    speed, nu = robot.material.max_wave_speed(), 0.3
    body = Scenery(
        name="box",
        positions=positions,
        volume=float(side**dim) / len(positions),
        material=config.own_material,  # the robot's
        youngs_modulus=density * speed * speed / elastic_wave_stiffness(nu),
        poisson_ratio=nu,
        density=density,
    )
    target = positions.mean(axis=0)
    target[0] += settings.push
    return with_body(robot, body, settings.observe, task=Task(Push("box", tuple(target))))
