"""The sand world: a bed of Drucker-Prager sand (`litl.sim.materials.Sand`) under the robot
(`litl.worlds.bed`). Sand as stiff as the robot's stiffest design is strained by its own weight
by about 1.5% on the biped, the range `litl.sim.validation` found robust."""

from __future__ import annotations

from dataclasses import dataclass

from litl.robots.robot import Robot
from litl.settings import number
from litl.sim.materials import Sand
from litl.worlds.bed import BedSettings, on_bed
from litl.worlds.bodies import elastic_wave_stiffness


@dataclass(frozen=True)
class SandSettings(BedSettings):
    """``world.sand``: the bed's keys (`BedSettings`) and

    Attributes:
      friction_angle: the sand's friction angle, degrees in (0, 90).
    """

    friction_angle: float = 30.0

    def check(self) -> None:
        super().check()
        if not (number(self.friction_angle) and 0 < self.friction_angle < 90):
            self._invalid("friction_angle", "must lie in (0, 90) degrees")


def sand(robot: Robot, settings: SandSettings, context: object = None) -> Robot:
    """`robot` on a bed of sand."""
    nu = 0.3
    return on_bed(robot, settings, "sand", Sand(settings.friction_angle), nu, elastic_wave_stiffness(nu))
