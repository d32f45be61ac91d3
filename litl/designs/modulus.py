"""``design=modulus`` (the default): one Young's modulus per design region, in its bounds
(`litl.robots.design.DesignSpace`), the paper's co-design."""

from __future__ import annotations

from litl.robots.robot import Robot


def modulus(robot: Robot, settings: None, context: object = None) -> None:
    """The robot's own design space (None: `Robot.design_space` builds it)."""
    return None
