"""The open-loop sinusoid baseline (`sinusoid`, `litl.models.open_loop`): reads no features."""

from __future__ import annotations

from dataclasses import dataclass

from litl.controllers.interface import Controller, ControllerContext
from litl.models.open_loop import SinusoidController
from litl.settings import Settings


@dataclass(frozen=True)
class SinusoidSettings(Settings):
    """The open-loop baseline (`controller=sinusoid`, `litl.models.open_loop`). Attributes:
    omega, the sinusoids' angular frequency (rad/s)."""

    omega: float = 30.0

    def check(self) -> None:
        self._positive_numbers("omega")


def sinusoid(robot, settings: SinusoidSettings, context: ControllerContext) -> Controller:
    """Phase-shifted sinusoids of `settings.omega` mixed per actuator."""
    return Controller(SinusoidController(robot.n_actuators, omega=settings.omega))
