"""Observers: what a closed-loop controller sees of the simulation, one module each.

The interface (`Observer`, `Learner`, `ObserverContext`) and the registry by name (`register`,
`make`, `names`) are `litl.observers.interface`; the built-in observers register themselves
here, each with its own settings dataclass (its section of the config, ``observer.<name>``):

* ``vae``, ``ae`` (`autoencoder`, `AutoencoderSettings`; ``ae`` reads ``observer.vae``): the
  convolutional (variational) autoencoder of the grid velocity field, the paper's method;
* ``pca`` (`pca`, `PCASettings`): a linear projection of the same windowed field, fitted on the
  replay buffer: the baseline that tells whether the autoencoder's nonlinearity matters;
* ``kmeans`` (`kmeans`, `KMeansSettings`): the paper's baseline, mean positions and velocities of
  particle clusters;
* ``none`` (`open_loop`): no features (open-loop control).

A new observer is one module with a settings dataclass, a factory and a `register` call; a YAML
file in `litl/conf/observer/` is only needed for a built-in one's help comment (the observers
guide shows an example with a setting of its own).
"""

from litl.observers.autoencoder import AutoencoderSettings, autoencoder, plain_autoencoder
from litl.observers.interface import (
    OBSERVERS,
    BodyFollower,
    Factory,
    GridField,
    Learner,
    Observer,
    ObserverContext,
    check_kind,
    make,
    names,
    register,
)
from litl.observers.kmeans import KMeansSettings, kmeans
from litl.observers.open_loop import no_observer
from litl.observers.pca import PCASettings, pca

if "vae" not in OBSERVERS.names():  # a module reloaded (importlib.reload) registers once
    register("vae", autoencoder, AutoencoderSettings)
    register("ae", plain_autoencoder, AutoencoderSettings, section="vae")
    register("pca", pca, PCASettings)
    register("kmeans", kmeans, KMeansSettings)
    register("none", no_observer)

__all__ = [
    "BodyFollower",
    "Factory",
    "GridField",
    "Learner",
    "Observer",
    "ObserverContext",
    "check_kind",
    "make",
    "names",
    "register",
]
