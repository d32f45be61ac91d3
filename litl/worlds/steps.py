"""The steps world: stairs of `step_height` risers every `step_length` (each riser one cell
wide), starting `gap` cells past the robot's front (`litl.worlds.terrain`)."""

from __future__ import annotations

from dataclasses import dataclass

from litl.robots.robot import Robot
from litl.worlds.terrain import TerrainSettings, collider, with_terrain


@dataclass(frozen=True)
class StepsSettings(TerrainSettings):
    """``world.steps``: the terrain's keys (`TerrainSettings`) and

    Attributes:
      step_height, step_length: the stairs' risers and treads (domain units, > 0).
    """

    step_height: float = 0.02
    step_length: float = 0.1

    def check(self) -> None:
        super().check()
        self._positive_numbers("step_height", "step_length")


def steps(robot: Robot, settings: StepsSettings, context: object = None) -> Robot:
    """`robot` before stairs."""

    def stairs(robot, settings, start, floor, dx, length):
        xs, heights = [], []
        x, height = start, floor
        while x + dx < length:
            height += settings.step_height
            xs.append(x + dx)
            heights.append(height)
            x += settings.step_length
            xs.append(min(x, length))
            heights.append(height)
        return xs, heights

    return with_terrain(robot, collider(robot, settings, "steps", stairs))
