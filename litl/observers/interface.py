"""The observer interface: what a closed-loop controller sees, as a small bundle of pure functions.

An `Observer` is to Algorithm 1 what an optax `GradientTransformation` is to an optimizer loop: a
frozen bundle of functions that the algorithm calls without knowing which observer it is.

    observer = litl.observers.make(config.observer, robot, context)  # or make("vae", ...)
    params = observer.init(key, seed)                          # Θ
    features = observer.features(params, state, grid_velocity)  # (observer.n_features,)

A learned observer also has a `Learner`: the grid window its snapshots are cropped to, its learning
phase (returning its statistics: a mapping of named values), how those statistics are written,
its single SGD step (the simultaneous ablation) and, where it has one, its reconstruction. Any
observer may draw its own pictures of a finished run (`Observer.pictures`). Observers are made by
factories registered by name with their own settings dataclass (`register`; `litl.settings.registry`);
`observer.kind` (`litl.config.ObserverConfig`, the CLI's `observer=`) picks one, and
`observer.<name>.<key>` sets its settings. A factory is called as `factory(robot, settings,
context)`: its settings section and an `ObserverContext` (the simulator's config, the dtype and
the learning phase's settings), never the whole config. Each built-in observer is one module of
`litl.observers`.
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from litl.settings import Settings
from litl.settings.registry import Registry, registry

if TYPE_CHECKING:
    import jax

    from litl.config import LearningConfig
    from litl.models.window import Window
    from litl.sim import SimConfig


class GridField(enum.StrEnum):
    """What an observer reads of the grid, and its snapshots record (`Observer.field`)."""

    velocity = "velocity"  # node momentum / mass, the paper's
    mass_weighted = "mass_weighted"  # node velocity * mass / a full cell's mass (litl.sim.fields)


@dataclasses.dataclass(frozen=True)
class ObserverContext:
    """What an observer's factory is given besides its own settings.

    Attributes:
      sim: the robot's simulator config (`litl.sim.SimConfig`: grid, dx, dim).
      dtype: the run's float dtype.
      learning: the learning phase's settings (`loop.learning`), for observers that learn.
    """

    sim: SimConfig
    dtype: Any
    learning: LearningConfig


def every_value(statistics: Mapping[str, Any]) -> tuple[dict, dict]:
    """`Learner.records`'s default: every named value, in learning.jsonl and in metrics.jsonl."""
    return dict(statistics), dict(statistics)


@dataclasses.dataclass(frozen=True)
class LatentCodec:
    """An observer's latent space, between its snapshots and its features (`Learner.latent`).

    Attributes:
      encode: ``encode(params, fields) -> (B, r)``: snapshots as the replay buffer stores them
        (B, *window, d) to the latents the controller reads of them (`Observer.features` of the
        same field).
      decode: ``decode(params, latents) -> (B, *window, d)``: latents back to fields, in the
        snapshots' units (decode(encode(x)) is the observer's reconstruction of x).
    """

    encode: Callable[[Any, Any], Any]
    decode: Callable[[Any, Any], Any]


@dataclasses.dataclass(frozen=True)
class Learner:
    """How a learned observer learns from grid velocity snapshots.

    Attributes:
      window: the grid window (around the particle centroid) the snapshots are cropped to; the
        replay buffer stores snapshots of `window.shape`.
      phase: ``phase(params, buffer, key) -> (params', statistics)``, one learning phase on a
        copy of the parameters (pure, vmappable over seeds); statistics: a mapping of names to
        arrays with the keys of `empty_statistics` (the loop adds ``update_accepted``).
      step: ``step(params, opt_state, snapshots, key) -> (params, opt_state, losses)``, one SGD step
        on a rollout's snapshots (the simultaneous ablation; losses has "recon"); None: the
        observer learns in phases only (`loop.schedule=simultaneous` is refused).
      optimizer_init: ``optimizer_init(params) -> opt_state`` for `step`.
      empty_statistics: ``empty_statistics(dtype, dim) -> {name: array}``, the statistics before
        the first phase (NaN where nothing was measured yet).
      records: ``records(statistics) -> (phase_record, iteration_record)``: from one seed's
        statistics (numpy values, ``update_accepted`` included), what learning.jsonl records of
        the phase and what every metrics.jsonl record repeats of it; default: every value in both.
      reconstruct: ``reconstruct(params, fields) -> fields`` (B, *window, d) for the live log's
        snapshot strip; None if it has none.
      model: the network, if any (for pictures of the representation).
      latent: its latent space (`LatentCodec`): what a latent dynamics model is learned in
        (`loop.dynamics`); None: its features are not a latent space that decodes.
    """

    window: Window
    phase: Callable[[Any, Any, jax.Array], tuple[Any, Mapping[str, Any]]]
    step: Callable | None
    optimizer_init: Callable[[Any], Any]
    empty_statistics: Callable[[Any, int], dict[str, Any]]
    records: Callable[[Mapping[str, Any]], tuple[dict, dict]] = every_value
    reconstruct: Callable[[Any, Any], Any] | None = None
    model: Any = None
    latent: LatentCodec | None = None

    def reporting_epochs(self, on_epoch) -> Learner:
        """This learner with a phase that calls `on_epoch(epoch, validation_loss)` after every
        epoch (from inside the compiled phase), where the phase is a dataclass with an
        `on_epoch` field (as the autoencoder's is); any other phase is kept as it is."""
        phase = self.phase
        if not dataclasses.is_dataclass(phase) or "on_epoch" not in {
            f.name for f in dataclasses.fields(phase)
        }:
            return self
        return dataclasses.replace(self, phase=dataclasses.replace(self.phase, on_epoch=on_epoch))


@dataclasses.dataclass(frozen=True)
class BodyFollower:
    """How an observer follows a body that co-design changes (`design=geometry`, `all`, ...).

    Attributes:
      refit: ``refit(params, design) -> (params', statistics)``: at every learning phase, before
        the observer's own (if it learns), the observer's parameters refitted to the body's
        current `litl.sim.Design` (pure, vmappable over seeds); statistics: a mapping of names to
        arrays with the keys of `empty_statistics`, written out as a learning phase's.
      empty_statistics: ``empty_statistics(dtype) -> {name: array}``, before the first refit.
    """

    refit: Callable[[Any, Any], tuple[Any, Mapping[str, Any]]]
    empty_statistics: Callable[[Any], dict[str, Any]]


@dataclasses.dataclass(frozen=True)
class Observer:
    """An observer's pure functions (see the module docstring).

    Attributes:
      n_features: length of the feature vector.
      init: ``init(key, seed) -> params`` (Θ; a pytree the loop checkpoints and vmaps over seeds).
      features: ``features(params, state, grid_velocity) -> (n_features,)``, jittable, used at
        every simulation step.
      learner: how it learns from snapshots; None for an observer fixed at init.
      settings: the section of the config it reads (``"vae"`` for ``observer.vae.*``), or None;
        `make` sets it from the registration.
      field: the grid field its features read and its snapshots record (`GridField`:
        plain node velocities, or mass-weighted ones, `litl.sim.fields`); None: it reads no grid
        field (the loop hands it plain velocities, and no learner needs snapshots of them).
      pictures: ``pictures(robot, algorithm, state, run_dir, stride) -> [paths]``: the pictures
        of its representation for one seed's final `LoopState` (`litl.viz.run_pictures` calls it); None:
        no pictures.
      follower: how it follows the body as co-design changes it (`BodyFollower`); None: it
        keeps what it was given at init, whatever the design becomes.
    """

    n_features: int
    init: Callable[[jax.Array, int], Any]
    features: Callable[[Any, Any, jax.Array], jax.Array]
    learner: Learner | None = None
    settings: str | None = None
    pictures: Callable[..., list] | None = None
    field: GridField | None = None
    follower: BodyFollower | None = None

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


# factory(robot, settings, context) -> Observer; settings: its own section (or None)
Factory = Callable[..., Observer]
OBSERVERS: Registry = registry("observer")


def register(
    name: str,
    factory: Factory,
    settings: type[Settings] | None = None,
    *,
    section: str | None = None,
    label: str | None = None,
    replace: bool = False,
) -> None:
    """Make `factory(robot, settings, context) -> Observer` selectable as `name` (CLI
    `observer=<name>` or `observer.kind=<name>`), with `settings`, its frozen settings dataclass
    (CLI `observer.<name>.<key>=value`; in run.json as the observer's section), or None.

    Args:
      section: read another observer's section instead of its own (``ae`` reads ``vae``'s).
      label: how reports name it (default: `name`); reports list observers in registration order.
      replace: replace an observer already registered under `name` (else that is an error).
    """
    OBSERVERS.register(name, factory, settings, section=section, label=label, replace=replace)


def names() -> tuple[str, ...]:
    """The registered observers' names."""
    return OBSERVERS.names()


def make(name_or_config, robot, context: ObserverContext) -> Observer:
    """The observer for `robot`: `name_or_config` is an `litl.config.ObserverConfig` (its kind
    with its section) or a registered name (with its settings' defaults)."""
    entry, observer = OBSERVERS.build(name_or_config, robot, context, Observer)
    if observer.settings is None and entry.settings is not None:
        observer = dataclasses.replace(observer, settings=entry.section)
    return observer


def check_kind(config) -> None:
    """Raise `SettingsError` unless `config.observer.kind` names a registered observer."""
    config.observer.check()
