"""Observers: what a closed-loop controller sees, as a small interface of pure functions.

An `Observer` is to Algorithm 1 what an optax `GradientTransformation` is to an optimizer loop: a
frozen bundle of pure functions that the algorithm calls without knowing which observer it is.

    observer = litl.loop.observers.make("vae", robot, config, sim_config, dtype)
    params = observer.init(key, seed)                          # Θ
    features = observer.features(params, state, grid_velocity)  # (observer.n_features,)

A learned observer also has a `Learner`: the grid window its snapshots are cropped to, its learning
phase and its single SGD step (the simultaneous ablation). Observers are made by factories
registered by name (`register`); `observer.kind` (`litl.config.ObserverConfig`, the CLI's
`observer=`) picks one:

* ``vae``, ``ae``: the convolutional (variational) autoencoder of the grid velocity field (the
  paper's method; features are the encoder means);
* ``kmeans``: the paper's baseline, mean positions and velocities of k particle clusters;
* ``none``: no features (open-loop control).

A fourth observer takes one factory and one `register` call in a module of your own; the CLI
reaches it with `observer.kind=<name> observer.module=<module>` (a YAML file in `conf/observer/`
would make it `observer=<name>`). `tests/loop/test_observers.py` adds a fixed random projection
of the grid so.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import optax

from litl.config import SettingsError
from litl.loop.learning import LearningPhase, LearningStats, make_learning_phase
from litl.models import vae
from litl.models.kmeans import fit_kmeans, kmeans_features
from litl.models.window import Window


@dataclasses.dataclass(frozen=True)
class Learner:
    """How a learned observer learns from grid velocity snapshots.

    Attributes:
      window: the grid window (around the particle centroid) the snapshots are cropped to; the
        replay buffer stores snapshots of `window.shape`.
      phase: ``phase(params, buffer, key) -> (params', LearningStats)``, one learning phase on a
        copy of the parameters (pure, vmappable over seeds).
      step: ``step(params, opt_state, snapshots, key) -> (params, opt_state, losses)``, one SGD step
        on a rollout's snapshots (the simultaneous ablation; losses has "recon").
      optimizer_init: ``optimizer_init(params) -> opt_state`` for `step`.
      model: the network (pictures of the representation read it).
    """

    window: Window
    phase: Callable[[Any, Any, jax.Array], tuple[Any, LearningStats]]
    step: Callable
    optimizer_init: Callable[[Any], Any]
    model: Any

    def reporting_epochs(self, on_epoch) -> Learner:
        """This learner with a phase that calls `on_epoch(epoch, validation_loss)` after every
        epoch (from inside the compiled phase); a phase of your own that is not a
        `LearningPhase` is kept as it is."""
        if not isinstance(self.phase, LearningPhase):
            return self
        return dataclasses.replace(self, phase=dataclasses.replace(self.phase, on_epoch=on_epoch))


@dataclasses.dataclass(frozen=True)
class Observer:
    """An observer's pure functions (see the module docstring).

    Attributes:
      n_features: length of the feature vector.
      init: ``init(key, seed) -> params`` (Θ; a pytree the loop checkpoints and vmaps over seeds).
      features: ``features(params, state, grid_velocity) -> (n_features,)``, jittable, used at
        every simulation step.
      learner: how it learns from snapshots; None for an observer fixed at init.
      settings: the section of `litl.config.ObserverConfig` it reads (``"vae"`` for
        ``observer.vae.*``), or None.
    """

    n_features: int
    init: Callable[[jax.Array, int], Any]
    features: Callable[[Any, Any, jax.Array], jax.Array]
    learner: Learner | None = None
    settings: str | None = None

    @property
    def learned(self) -> bool:
        return self.learner is not None

    @property
    def reads(self) -> tuple[str, ...]:
        """The settings it depends on, as sections of `litl.config.Config`: its own section
        and, if it learns, the learning phase (``("observer.vae", "loop.learning")``). Every key
        in them counts: reports pool two runs only where all of them agree."""
        return ((f"observer.{self.settings}",) if self.settings else ()) + (
            ("loop.learning",) if self.learned else ()
        )


# factory(robot, config, sim_config, dtype) -> Observer; config: the run's `litl.config.Config`
Factory = Callable[..., Observer]
_FACTORIES: dict[str, Factory] = {}


def register(name: str, factory: Factory, replace: bool = False) -> None:
    """Make `factory(robot, config, sim_config, dtype) -> Observer` selectable as `name`
    (`Config.observer.kind`, CLI `observer=<name>` or `observer.kind=<name>`)."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"an observer's name must be a non-empty string, got {name!r}")
    if name in _FACTORIES and not replace:
        raise ValueError(f"an observer named {name!r} is already registered; pass replace=True")
    if not callable(factory):
        raise ValueError(f"factory must be callable, got {factory!r}")
    _FACTORIES[name] = factory


def names() -> tuple[str, ...]:
    """The registered observers' names."""
    return tuple(_FACTORIES)


def make(name: str, robot, config, sim_config, dtype) -> Observer:
    """The observer `name` for `robot` under the loop `config`."""
    if name not in _FACTORIES:
        raise ValueError(f"unknown observer {name!r}; choose one of {names()}")
    return _FACTORIES[name](robot, config, sim_config, dtype)


def check_kind(config) -> None:
    """Raise `SettingsError` unless `config.observer.kind` names a registered observer."""
    kind, module = config.observer.kind, config.observer.module
    if kind not in _FACTORIES:
        hint = (
            f"; observer.module={module!r} registered no observer of that name"
            if module
            else "; an observer of your own: observer.kind=<name> observer.module=<module that registers it>"
        )
        raise SettingsError(
            f"observer.kind={kind!r}: unknown observer; choose one of {list(names())}{hint}", "observer.kind"
        )


def autoencoder(robot, config, sim_config, dtype, variational: bool = True) -> Observer:
    """The (variational) autoencoder observer (`vae`, `ae`): a window around the robot."""
    settings, learning = config.observer.vae, config.loop.learning
    window = Window.around(sim_config.grid_shape, sim_config.dx, settings.window)
    model = vae.ConvAutoencoder(
        window.shape,
        latent_dim=settings.latent_dim,
        channels=settings.channels,
        activation=settings.activation.value,
        variational=variational,
    )
    adam = optax.adam(learning.learning_rate)
    learner = Learner(
        window=window,
        phase=make_learning_phase(model, learning),
        step=vae.make_train_step(model, adam, learning.beta, learning.momentum_weight),
        optimizer_init=lambda params: adam.init(params.network),
        model=model,
    )
    return Observer(
        n_features=settings.latent_dim,
        init=lambda key, seed: vae.init_autoencoder(model, key, dtype),
        features=vae.make_observer(model, window),
        learner=learner,
        settings="vae",
    )


def kmeans(robot, config, sim_config, dtype) -> Observer:
    """The k-means baseline: clusters of the rest configuration, fitted once per seed."""
    clusters = config.observer.kmeans.clusters
    if clusters > robot.layout.n_particles:
        raise SettingsError(
            f"observer.kmeans.clusters={clusters} exceeds the robot's {robot.layout.n_particles} particles",
            "observer.kmeans.clusters",
        )
    rest = robot.initial_state(dtype).x
    return Observer(
        n_features=2 * clusters * sim_config.dim,
        init=lambda key, seed: fit_kmeans(rest, clusters, seed=seed),
        features=kmeans_features,
        settings="kmeans",
    )


def no_observer(robot, config, sim_config, dtype) -> Observer:
    """No features: the controller runs open loop (on the clock, or sinusoids)."""
    return Observer(
        n_features=0,
        init=lambda key, seed: jnp.zeros((), dtype),  # a placeholder
        features=lambda params, state, grid_velocity: jnp.zeros((0,), dtype),
    )


register("vae", autoencoder)
register(
    "ae",
    lambda robot, config, sim_config, dtype: autoencoder(robot, config, sim_config, dtype, variational=False),
)
register("kmeans", kmeans)
register("none", no_observer)
