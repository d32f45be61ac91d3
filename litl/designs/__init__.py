"""Design spaces: what co-design changes about the robot's body (``design=<name>``), behind one
registry (`litl.designs.interface`):

* ``modulus`` (`modulus`, the default): one Young's modulus per design region (the paper's);
* ``actuators`` (`body`): where the muscles are, per particle, a softmax over the robot's
  actuators and a passive channel (``design.actuators.modulus=true`` co-designs the modulus too);
* ``geometry`` (`body`): where the material is, per particle, filtered, projected and
  interpolated as topology optimization does, with a volume constraint;
* ``all`` (`body`): actuators, geometry and the modulus together.

A design space of one's own registers like a world (`register`, ``design.module=<module>``).
"""

from litl.designs.body import (
    ActuatorsSettings,
    AllSettings,
    BodySpace,
    GeometrySettings,
    actuators,
    everything,
    geometry,
)
from litl.designs.interface import DESIGNS, apply, names, register
from litl.designs.modulus import modulus

if "modulus" not in DESIGNS.names():  # a module reloaded (importlib.reload) registers once
    register("modulus", modulus)
    register("actuators", actuators, ActuatorsSettings)
    register("geometry", geometry, GeometrySettings)
    register("all", everything, AllSettings)

__all__ = ["ActuatorsSettings", "AllSettings", "BodySpace", "GeometrySettings", "apply", "names", "register"]
