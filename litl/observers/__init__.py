"""Observers: what a closed-loop controller sees of the simulation, one module each.

The interface (`Observer`, `Learner`) and the registry by name (`register`, `make`, `names`) are
`litl.observers.interface`; the built-in observers register themselves here:

* ``vae``, ``ae`` (`autoencoder`): the convolutional (variational) autoencoder of the grid
  velocity field, the paper's method;
* ``pca`` (`pca`): a linear projection of the same windowed field, fitted on the replay buffer: the
  baseline that tells whether the autoencoder's nonlinearity matters;
* ``kmeans`` (`kmeans`): the paper's baseline, mean positions and velocities of particle clusters;
* ``none`` (`open_loop`): no features (open-loop control).

A new observer is one module with a factory and a `register` call, and a YAML file in
`litl/conf/observer/` to name it on the command line (the observers guide shows `pca` as the
worked example).
"""

from litl.observers.autoencoder import autoencoder
from litl.observers.interface import Factory, Learner, Observer, check_kind, make, names, register
from litl.observers.kmeans import kmeans
from litl.observers.open_loop import no_observer
from litl.observers.pca import pca

register("vae", autoencoder)
register(
    "ae",
    lambda robot, config, sim_config, dtype: autoencoder(robot, config, sim_config, dtype, variational=False),
)
register("kmeans", kmeans)
register("pca", pca)
register("none", no_observer)

__all__ = ["Factory", "Learner", "Observer", "check_kind", "make", "names", "register"]
