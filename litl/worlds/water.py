"""The water world: a pool of weakly compressible fluid (`litl.sim.materials.Fluid`) under the
robot (`litl.worlds.bed`); its sound speed is then about 10x the robots' walking speeds. At
density 1 (the default) the robot is neutrally buoyant."""

from __future__ import annotations

from dataclasses import dataclass

from litl.robots.robot import Robot
from litl.sim.materials import Fluid
from litl.worlds.bed import BedSettings, on_bed


@dataclass(frozen=True)
class WaterSettings(BedSettings):
    """``world.water``: the bed's keys (`BedSettings`), its density the robot's by default."""

    density: float = 1.0


def water(robot: Robot, settings: WaterSettings, context: object = None) -> Robot:
    """`robot` on a pool of water."""
    return on_bed(robot, settings, "water", Fluid(), 0.0, 1.0)
