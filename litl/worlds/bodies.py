"""What the worlds with a second body (sand, water, push_box) share: what the robot's observers
see of a scene with another body in it, and how the body joins the robot's scene
(`litl.robots.scenery`)."""

from __future__ import annotations

import dataclasses
import enum

import numpy as np

from litl.robots.robot import Robot
from litl.robots.scenery import Scenery
from litl.robots.tasks import Task


class ObservedPart(enum.StrEnum):
    """What the observers of a robot among other bodies see."""

    robot = "robot"  # the grid field at the nodes the robot's particles reach
    scene = "scene"  # the whole field, the other body included


def elastic_wave_stiffness(nu: float) -> float:
    """(λ + 2μ) / E of an elastic material of Poisson ratio `nu`: a body whose P-wave speed is
    the robot's fastest has E = density · speed² / this (the robot's time step holds for it)."""
    return (1 - nu) / ((1 + nu) * (1 - 2 * nu))


def with_body(
    robot: Robot,
    body: Scenery,
    observe: ObservedPart,
    *,
    lift: float = 0.0,
    task: Task | None = None,
) -> Robot:
    """`robot` with `body` in its scene (its material after the robot's own, unless it is the
    robot's elastic material), lifted by `lift` onto it, with `task` in place of its own where
    given; a robot that already has a second body is returned as it is (putting a robot in a
    world twice changes nothing)."""
    if robot.scenery:
        return robot
    config = robot.config
    own = config.own_material
    materials = (own,) if body.material == own else (own, body.material)
    shift = np.zeros(robot.dim)
    shift[1] = lift
    return dataclasses.replace(
        robot,
        config=dataclasses.replace(config, materials=materials),
        scenery=(body,),
        observe_scenery=str(observe) == ObservedPart.scene,
        layout=robot.layout.translated(shift) if lift else robot.layout,
        task=task if task is not None else robot.task,
    )
