"""Controllers: what maps the observer's features to actuation, one module each.

The interface (`Controller`, `ControllerContext`) and the registry by name (`register`, `make`,
`names`) are `litl.controllers.interface`; the built-in controllers register themselves here,
each with its own settings dataclass (``controller.<name>``):

* ``mlp`` (`mlp`, `MLPSettings`): the closed-loop MLP on the observer's features and a clock;
* ``sinusoid`` (`sinusoid`, `SinusoidSettings`): the open-loop baseline (observer none).
"""

from litl.controllers.interface import CONTROLLERS, Controller, ControllerContext, make, names, register
from litl.controllers.mlp import MLPSettings, mlp
from litl.controllers.sinusoid import SinusoidSettings, sinusoid

if "mlp" not in CONTROLLERS.names():  # a module reloaded (importlib.reload) registers once
    register("mlp", mlp, MLPSettings)
    register("sinusoid", sinusoid, SinusoidSettings, open_loop=True)

__all__ = ["Controller", "ControllerContext", "make", "names", "register"]
