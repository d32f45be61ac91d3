"""What the terrain worlds (slope, steps, bumps) share: their settings' common keys and how a
height profile ahead of the robot becomes a collider of its scene (`litl.sim.colliders`).

The profile starts `gap` cells past the robot's front (its largest x), so the robot starts on
the flat floor as in the empty box and meets the terrain when it walks. Its flat part lies under
the box's floor wall (it holds the same grid nodes), so only the terrain ahead adds contact. In
3D the profile is the same for every z. The robot keeps its own task (distance along x, which on
a slope is the distance along it times cos θ).
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from litl.robots.robot import Robot
from litl.settings import Settings
from litl.sim.colliders import Collider, HeightField
from litl.sim.config import SimConfigError, Wall


class ContactKind(enum.StrEnum):
    """How the terrain holds the robot (`litl.sim.colliders.apply_contact`)."""

    sticky = "sticky"  # as the floor
    slip = "slip"
    friction = "friction"  # Coulomb, with coefficient `friction`


@dataclass(frozen=True)
class TerrainSettings(Settings):
    """The keys every terrain world has (``world.<name>.gap`` and so on).

    Attributes:
      gap: cells between the robot's front and the terrain's start (>= 0).
      contact: how the terrain holds the robot: sticky (as the floor), slip or friction.
      friction: the Coulomb coefficient of a friction contact (>= 0).
    """

    gap: float = 2.0
    contact: ContactKind = ContactKind.sticky
    friction: float = 0.5

    def check(self) -> None:
        self._positive_numbers("friction", "gap", zero=True)


# A profile: (the robot, its terrain's settings, x where it starts, the floor's height, dx,
# the domain's length) -> (xs, heights) of the terrain ahead, after the start.
Profile = Callable[[Robot, TerrainSettings, float, float, float, float], tuple[list[float], list[float]]]


def collider(robot: Robot, settings: TerrainSettings, name: str, profile: Profile) -> Collider:
    """The collider of a terrain world called `name` in front of `robot`: the floor up to
    `settings.gap` cells past its front, then `profile`'s points."""
    config = robot.config
    assert config.boundary is not None  # SimConfig sets the default box
    dx, length = config.dx, config.domain_size[0]
    floor = (config.boundary.thickness - 2) * dx  # with a one-cell band: the floor wall's nodes
    start = float(robot.layout.bounds()[1][0]) + settings.gap * dx
    if start >= length - 4 * dx:
        raise SimConfigError(
            f"world={name}: the robot's front is at x = {start - settings.gap * dx:.3g}, which leaves no "
            f"room for terrain in a domain {length:.3g} long; use a smaller world.{name}.gap or another robot"
        )
    xs, heights = profile(robot, settings, start, floor, dx, length)
    xs, heights = [0.0, start, *xs], [floor, floor, *heights]
    top = config.domain_size[1] - (config.boundary.thickness + 2) * dx
    if max(heights) > top:
        raise SimConfigError(
            f"world={name}: its terrain reaches y = {max(heights):.3g}, above the room under the "
            f"ceiling ({top:.3g}); make world={name}'s terrain lower (its height settings)"
        )
    kind: Any = settings.contact  # a ContactKind is the str Wall takes
    contact = Wall(kind, settings.friction if settings.contact == "friction" else 0.0)
    return Collider(HeightField(tuple(xs), tuple(heights), dim=robot.dim), contact)


def with_terrain(robot: Robot, ground: Collider) -> Robot:
    """`robot` with `ground` added to its scene's colliders (after its own); a robot that already
    has it is returned as it is (putting a robot in a world twice changes nothing)."""
    boundary = robot.config.boundary
    assert boundary is not None  # SimConfig sets the default box
    if boundary.colliders[-1:] == (ground,):
        return robot
    boundary = dataclasses.replace(boundary, colliders=boundary.colliders + (ground,))
    return dataclasses.replace(robot, config=dataclasses.replace(robot.config, boundary=boundary))
