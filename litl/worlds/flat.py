"""The flat world: the empty box, no terrain (the catalog's scenes, bit for bit)."""

from __future__ import annotations

from litl.robots.robot import Robot


def flat(robot: Robot, settings: None, context: object = None) -> Robot:
    """`robot` as it is: the box's own floor and walls are its world."""
    return robot
