"""The slope world: the ground rises at `angle` degrees, starting `gap` cells past the robot's
front (`litl.worlds.terrain`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from litl.robots.robot import Robot
from litl.settings import number
from litl.worlds.terrain import TerrainSettings, collider, with_terrain


@dataclass(frozen=True)
class SlopeSettings(TerrainSettings):
    """``world.slope``: the terrain's keys (`TerrainSettings`) and

    Attributes:
      angle: the slope's angle, degrees in (0, 45].
    """

    angle: float = 10.0

    def check(self) -> None:
        super().check()
        if not (number(self.angle) and 0 < self.angle <= 45):
            self._invalid("angle", "must lie in (0, 45] degrees")


def slope(robot: Robot, settings: SlopeSettings, context: object = None) -> Robot:
    """`robot` before a slope of `settings.angle` degrees."""

    def rise(robot, settings, start, floor, dx, length):
        return [length], [floor + (length - start) * math.tan(math.radians(settings.angle))]

    return with_terrain(robot, collider(robot, settings, "slope", rise))
