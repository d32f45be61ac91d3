"""The design spaces' registry by name (`litl.settings.registry`): `register`, `names`, `apply`.

A design space says what co-design changes about a robot's body: its factory is
``factory(robot, settings, context) -> DesignSpace-like`` (the object `Robot.design_space`
returns: `initial`, `uniform`, `project`, `to_design`, `bounds`, `modulus`, `summary`), and
`apply` gives the robot that space. Its settings dataclass is its section of the config
(``design.<name>``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from litl.robots.robot import Robot
from litl.settings import Settings
from litl.settings.registry import Registry, registry

Factory = Callable[..., Any]

DESIGNS: Registry = registry("design")


def register(
    name: str,
    factory: Factory,
    settings: type[Settings] | None = None,
    *,
    label: str | None = None,
    replace: bool = False,
) -> None:
    """Make `factory(robot, settings, context) -> design space` selectable as `name`
    (``design=<name>`` on the command line), with `settings`, its frozen settings dataclass
    (``design.<name>.<key>=value``; in run.json as the design's section), or None."""
    DESIGNS.register(name, factory, settings, label=label, replace=replace)


def names() -> tuple[str, ...]:
    """The registered design spaces' names."""
    return DESIGNS.names()


def apply(robot: Robot, design: Any) -> Robot:
    """`robot` with the design space of `design` (a `litl.config.DesignConfig`, or a registered
    name: its defaults); the robot's own space (`modulus`) leaves it unchanged."""
    _, space = DESIGNS.build(design, dataclasses.replace(robot, design=None), None, object)
    return robot if space is None else dataclasses.replace(robot, design=space)
