"""Worlds: the ground a robot walks on and what shares it, one module each.

The registry (`register`, `names`, `put`, `brings_task`) is `litl.worlds.interface`; the built-in
worlds register themselves here, each with its own settings (``world.<name>`` in the config):

* ``flat`` (`flat`): the empty box (the catalog's scenes, bit for bit);
* ``slope``, ``steps``, ``bumps`` (`slope`, `steps`, `bumps`; what they share is
  `litl.worlds.terrain`): terrain ahead of the robot, as a collider (`litl.sim.colliders`);
* ``sand``, ``water`` (`sand`, `water`; `litl.worlds.bed`): a second body under the robot;
* ``push_box`` (`push_box`): a box ahead of the robot, and the task of pushing it.

A world of one's own is a module with a settings dataclass, a factory and a `register` call,
chosen with ``world=<name> world.module=<module>`` (docs/guide/robots.md shows one).
"""

from litl.worlds.bumps import BumpsSettings, bumps
from litl.worlds.flat import flat
from litl.worlds.interface import WORLDS, brings_task, names, put, register, task_note, task_record
from litl.worlds.push_box import PushBoxSettings, push_box
from litl.worlds.sand import SandSettings, sand
from litl.worlds.slope import SlopeSettings, slope
from litl.worlds.steps import StepsSettings, steps
from litl.worlds.water import WaterSettings, water

if "flat" not in WORLDS.names():  # a module reloaded (importlib.reload) registers once
    register("flat", flat)
    register("slope", slope, SlopeSettings)
    register("steps", steps, StepsSettings)
    register("bumps", bumps, BumpsSettings)
    register("sand", sand, SandSettings)
    register("water", water, WaterSettings)
    register("push_box", push_box, PushBoxSettings, task=True)

__all__ = ["brings_task", "names", "put", "register", "task_note", "task_record"]
