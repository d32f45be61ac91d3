"""What the sand and water worlds share: a layer `depth` deep on the whole floor, a second body
under the robot (`litl.worlds.bodies`), the robot lifted onto it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from litl.robots.robot import Robot
from litl.robots.scenery import Scenery
from litl.settings import Settings
from litl.sim.config import SimConfigError
from litl.sim.sampling import sample_box
from litl.worlds.bodies import ObservedPart, with_body


@dataclass(frozen=True)
class BedSettings(Settings):
    """The keys of a bed under the robot (``world.sand.depth`` and so on).

    Attributes:
      depth: the layer's depth (domain units, at least one grid cell); the robot starts on top.
      density: the layer's density, relative to the robot's.
      observe: what the robot's observers see: ``robot`` (the grid field at the nodes the
        robot's particles reach) or ``scene`` (the whole field, the layer included).
    """

    depth: float = 0.04
    density: float = 1.5
    observe: ObservedPart = ObservedPart.robot

    def check(self) -> None:
        self._positive_numbers("depth", "density")


def on_bed(
    robot: Robot, settings: BedSettings, name: str, material: object, nu: float, stiffness: float
) -> Robot:
    """`robot` on a layer of `material` `settings.depth` deep on the whole floor (2 particles per
    cell per axis), `settings.density` times the robot's density. Its Young's modulus is set so
    that its P-wave speed equals the robot's fastest (`Material.max_wave_speed`; `stiffness` is
    (λ + 2μ) / E at Poisson ratio `nu`): the robot's time step holds for it unchanged."""
    if robot.scenery:
        return robot
    config = robot.config
    assert config.boundary is not None  # SimConfig sets the default box
    dx, dim = config.dx, config.dim
    wall = config.boundary.thickness * dx
    low, high = robot.layout.bounds()
    room = config.domain_size[1] - 2 * wall - (high[1] - low[1])
    if settings.depth >= room - 2 * dx:
        raise SimConfigError(
            f"world.{name}.depth={settings.depth:g}: a {name} layer that deep leaves the robot no room "
            f"under the ceiling (at most {max(room - 2 * dx, 0):.3g} here); use a smaller world.{name}.depth"
        )
    if settings.depth < dx:
        raise SimConfigError(
            f"world.{name}.depth={settings.depth:g} is thinner than one grid cell (dx = {dx:g}); "
            f"use world.{name}.depth >= {dx:g}"
        )
    lower = [wall] * dim
    size = [length - 2 * wall for length in config.domain_size]
    size[1] = settings.depth
    positions = sample_box(lower, size, dx, per_cell=2)
    density = settings.density * robot.material.density
    speed = robot.material.max_wave_speed()
    layer = Scenery(
        name=name,
        positions=positions,
        # The layer's volume shared by its particles: a depth that is not a whole number of cells
        # spaces the rows further apart than (dx / 2), and the density must still be the stated one.
        volume=float(np.prod(size)) / len(positions),
        material=material,
        youngs_modulus=density * speed * speed / stiffness,
        poisson_ratio=nu,
        density=density,
    )
    return with_body(robot, layer, settings.observe, lift=settings.depth)
