"""The bumps world: a random piecewise-linear ground, heights in [0, `amplitude`] above the
floor every `wavelength` / 2, drawn from `seed`, starting `gap` cells past the robot's front
(`litl.worlds.terrain`). The amplitude must be at least one grid cell: a lower bump holds no
node the floor wall does not."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from litl.robots.robot import Robot
from litl.sim.config import SimConfigError
from litl.worlds.terrain import TerrainSettings, collider, with_terrain


@dataclass(frozen=True)
class BumpsSettings(TerrainSettings):
    """``world.bumps``: the terrain's keys (`TerrainSettings`) and

    Attributes:
      amplitude: the bumps' largest height above the floor (domain units; at least one grid
        cell, or no bump reaches past the floor wall).
      wavelength: their spacing (domain units).
      seed: the random profile (an integer >= 0).
    """

    amplitude: float = 0.05
    wavelength: float = 0.1
    seed: int = 0

    def check(self) -> None:
        super().check()
        self._positive_numbers("amplitude", "wavelength")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            self._invalid("seed", "must be an integer >= 0")


def bumps(robot: Robot, settings: BumpsSettings, context: object = None) -> Robot:
    """`robot` before random bumps."""

    def profile(robot, settings, start, floor, dx, length):
        if settings.amplitude < dx:
            # A bump acts on the nodes within one cell of its surface: one lower than a cell above
            # the floor holds no node the floor wall does not already hold.
            raise SimConfigError(
                f"world.bumps.amplitude={settings.amplitude:g} is below one grid cell (dx = {dx:g}): "
                f"bumps that low hold no grid node above the floor wall, so the robot would walk on "
                f"the flat box; use world.bumps.amplitude >= {dx:g}"
            )
        rng = np.random.default_rng(settings.seed)
        xs, heights = [], []
        x = start
        while x < length:
            x = min(x + settings.wavelength / 2, length)
            xs.append(x)
            heights.append(floor + settings.amplitude * float(rng.uniform()))
        return xs, heights

    return with_terrain(robot, collider(robot, settings, "bumps", profile))
