"""Robots as data: layouts from shapes, images and voxels; the paper's robots; task losses.

import litl.robots
litl.robots.names()                 # the registered robots
robot = litl.robots.get("biped")    # a `Robot`: layout, sim config, materials, task
scene = robot.scene()               # simulator pytrees (config, body, design, state)
litl.robots.register("mine", build, dim=2)   # your own: build(dx) -> Robot
"""

from litl.robots.catalog import get, names, register
from litl.robots.design import DesignSpace
from litl.robots.image import layout_from_pixels, layout_from_png
from litl.robots.layout import Layout, LayoutError
from litl.robots.robot import Material, Robot, Scene, check_fits, place
from litl.robots.shapes import Box, Circle, Ellipse, Extrusion, Part, Polygon, Voxels, sample_parts
from litl.robots.tasks import Locomotion, Position, Push, Reach, Task, make_task_loss

__all__ = [
    "Box",
    "Circle",
    "DesignSpace",
    "Ellipse",
    "Extrusion",
    "Layout",
    "LayoutError",
    "Locomotion",
    "Material",
    "Part",
    "Polygon",
    "Position",
    "Push",
    "Reach",
    "Robot",
    "Scene",
    "Task",
    "Voxels",
    "check_fits",
    "get",
    "layout_from_pixels",
    "layout_from_png",
    "make_task_loss",
    "names",
    "place",
    "register",
    "sample_parts",
]
