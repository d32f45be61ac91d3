"""Controllers: what maps the observer's features to actuation, one module each.

The interface (`Controller`, `ControllerContext`) and the registry by name (`register`, `make`,
`names`) are `litl.controllers.interface`; the built-in controllers register themselves here,
each with its own settings dataclass (``controller.<name>``):

* ``mlp`` (`mlp`, `MLPSettings`): the closed-loop MLP on the observer's features and a clock;
* ``sinusoid`` (`sinusoid`, `SinusoidSettings`): the open-loop baseline (observer none);
* ``latent_mpc``, ``latent_ilqr``, ``latent_lqr`` (`litl.controllers.latent`; `MPCSettings`,
  `ILQRSettings`, `LQRSettings`): the
  planners in a trained run's latent space, run by ``python -m litl.latent.control`` (a training
  run is refused: the loop does not train them).
"""

from litl.controllers.interface import CONTROLLERS, Controller, ControllerContext, make, names, register
from litl.controllers.latent import latent_ilqr, latent_lqr, latent_mpc
from litl.controllers.mlp import MLPSettings, mlp
from litl.controllers.sinusoid import SinusoidSettings, sinusoid
from litl.latent.planning import ILQRSettings, LQRSettings, MPCSettings

if "mlp" not in CONTROLLERS.names():  # a module reloaded (importlib.reload) registers once
    register("mlp", mlp, MLPSettings)
    register("sinusoid", sinusoid, SinusoidSettings, open_loop=True)
    register("latent_mpc", latent_mpc, MPCSettings, plans=True)
    register("latent_ilqr", latent_ilqr, ILQRSettings, plans=True)
    register("latent_lqr", latent_lqr, LQRSettings, plans=True)

__all__ = ["Controller", "ControllerContext", "make", "names", "register"]
