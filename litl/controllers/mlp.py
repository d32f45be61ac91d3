"""The closed-loop MLP controller (`mlp`): the observer's features and a clock to actuation."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from litl.controllers.interface import Controller, ControllerContext
from litl.models.controller import MLPController
from litl.settings import Settings

# The closed-loop controller's clock: the sinusoid baseline's 30 rad/s (about 5 strides a second).
CLOCK_PERIOD = 2 * math.pi / 30.0
# The closed-loop controller's input gain on the observer's features (MLPSettings.feature_scale).
FEATURE_SCALE = 0.2


class FeatureGradient(enum.StrEnum):
    stop = "stop"  # the task-loss gradient treats the features as constants
    full = "full"  # the paper's end-to-end backpropagation through them


@dataclass(frozen=True)
class MLPSettings(Settings):
    """The closed-loop MLP controller (`controller=mlp`).

    Attributes:
      widths: hidden layers.
      period: the MLP also reads (sin, cos) of a clock of this period (s), as DiffTaichi's
        closed-loop walkers read sine waves beside the state; None: features only (the
        paper's). litl's default is the sinusoid baseline's 30 rad/s.
      feature_scale: an input gain on the observer's features (1: the paper's); how fast, under
        Adam, the features' pathway grows against the clock's.
      feature_gradient: whether the task-loss gradient also flows through the features into the
        simulated grid (`FeatureGradient`; full is the paper's end-to-end backpropagation).
    """

    widths: tuple[int, ...] = (64, 64)
    period: float | None = CLOCK_PERIOD
    feature_scale: float = FEATURE_SCALE
    feature_gradient: FeatureGradient = FeatureGradient.stop

    def check(self) -> None:
        if not all(isinstance(w, int) and w >= 1 for w in self.widths):
            self._invalid("widths", "every width must be a positive integer")
        self._positive_numbers("feature_scale")
        self._positive_numbers("period", optional=("period",))


def mlp(robot, settings: MLPSettings, context: ControllerContext) -> Controller:
    """An MLP of `settings.widths` from the features (and the clock) to the robot's actuators."""
    module = MLPController(
        robot.n_actuators, settings.widths, period=settings.period, feature_scale=settings.feature_scale
    )
    return Controller(module, feature_gradient=settings.feature_gradient == FeatureGradient.full)
