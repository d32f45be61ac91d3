"""Design spaces: what co-design changes about the robot's body (``design=<name>``), one module
each, behind one registry (`litl.designs.interface`):

* ``modulus`` (`modulus`, the default): one Young's modulus per design region (the paper's);
* ``actuators`` (`actuators`): where the muscles are, per particle, a softmax over the robot's
  actuators and a passive channel (``design.actuators.modulus=true`` co-designs the modulus too).

A design space of one's own registers like a world (`register`, ``design.module=<module>``).
"""

from litl.designs.actuators import ActuatorsSettings, PlacementSpace, actuators
from litl.designs.interface import DESIGNS, apply, names, register
from litl.designs.modulus import modulus

if "modulus" not in DESIGNS.names():  # a module reloaded (importlib.reload) registers once
    register("modulus", modulus)
    register("actuators", actuators, ActuatorsSettings)

__all__ = ["ActuatorsSettings", "PlacementSpace", "apply", "names", "register"]
