"""The controller interface: what maps the observer's features to actuation, registered by name.

A controller is made by a factory registered with its own settings dataclass (`register`;
`litl.settings.registry`), called as `factory(robot, settings, context)`; `controller.kind` (the CLI's
`controller=`) picks one and `controller.<name>.<key>` sets its settings. It returns a
`Controller`: a Flax module (``init(key, features, time=...)``, ``apply(params, features,
time=...)`` -> (n_actuators,) in [-1, 1]) and whether the task loss's gradient flows through the
features it reads.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from litl.settings import Settings
from litl.settings.registry import Registry, registry


@dataclasses.dataclass(frozen=True)
class ControllerContext:
    """What a controller's factory is given besides its own settings: the run's float dtype."""

    dtype: Any


@dataclasses.dataclass(frozen=True)
class Controller:
    """A controller's module and how the loop differentiates through it.

    Attributes:
      module: ``module.init(key, features, time=t)`` and ``module.apply(params, features,
        time=t)`` -> actuation (n_actuators,) in [-1, 1] (a `flax.linen.Module`).
      feature_gradient: whether the task loss's gradient flows through the features into the
        simulated grid (the paper's end-to-end backpropagation); False: the features are
        constants to it.
    """

    module: Any
    feature_gradient: bool = False


CONTROLLERS: Registry = registry("controller")


def register(
    name: str,
    factory,
    settings: type[Settings] | None = None,
    *,
    open_loop: bool = False,
    plans: bool = False,
    label: str | None = None,
    replace: bool = False,
) -> None:
    """Make `factory(robot, settings, context) -> Controller` selectable as `name` (CLI
    `controller=<name>`), with `settings` its frozen settings dataclass (CLI
    `controller.<name>.<key>=value`) or None; `open_loop`: it reads no features (the run must
    use observer none); `plans`: it plans with a trained run's latent model and is not trained
    by the loop (a training run with it is refused; `litl.controllers.latent`)."""
    CONTROLLERS.register(
        name, factory, settings, label=label, replace=replace, open_loop=open_loop, plans=plans
    )


def names() -> tuple[str, ...]:
    """The registered controllers' names."""
    return CONTROLLERS.names()


def make(name_or_config, robot, context: ControllerContext) -> Controller:
    """The controller for `robot`: `name_or_config` is an `litl.config.ControllerConfig` (its
    kind with its section) or a registered name (with its settings' defaults)."""
    return CONTROLLERS.build(name_or_config, robot, context, Controller)[1]
