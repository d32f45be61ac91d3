"""litl's one config model: frozen dataclasses shared by the Python API and the Hydra CLI.

The tree mirrors the command line: `Config.loop.episodes` is `loop.episodes=...`,
`Config.observer.kind` is `observer=...` / `observer.kind=...`. The defaults here are the only
ones (the YAML files under `litl/conf` select groups and set what a choice changes); every value
is checked once, when its dataclass is built, and an error names the key as typed on the command
line:

    from litl.config import Config
    config = Config().replace(observer={"kind": "kmeans"}, loop={"episodes": 3}, seeds=10)
    result = litl.loop.run(litl.robots.get("biped"), config, "outputs/biped")

`register_with_hydra` puts the same classes in Hydra's ConfigStore, where they type every key:
a typo, a wrong type or an unknown kind (`controller.kind=mpl`) fails when the config is
composed, naming the choices. Observer kinds are the one open set (observers of your own register
by name, `litl.loop.observers.register`), so `observer.kind` is checked against that registry.

This module imports no JAX, so that `litl.report` can read the defaults without it.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import typing
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, NoReturn, Self, TypeVar

from litl.errors import UserError


class SettingsError(UserError, ValueError):
    """A setting litl cannot use; the message names its key (as typed on the command line) and
    says how to fix it.

    Attributes:
      key: the dotted key at fault (``"loop.episodes"``), or None when several are.
    """

    def __init__(self, message: str, key: str | None = None):
        super().__init__(message)
        self.key = key


class ControllerKind(enum.StrEnum):
    """What maps features to actuation: an MLP (closed loop) or the open-loop sinusoid baseline."""

    mlp = "mlp"
    sinusoid = "sinusoid"


class Schedule(enum.StrEnum):
    """How the observer's learning alternates with optimization (the paper's ablations)."""

    alternating = "alternating"  # Algorithm 1: a learning phase after every episode
    one_shot = "one_shot"  # learn once, from the initial rollout, never again
    simultaneous = "simultaneous"  # one observer step per optimization iteration, no phases


class TaskKind(enum.StrEnum):
    default = "default"  # the robot's own task (docs/guide/robots.md)
    locomotion = "locomotion"  # distance walked
    velocity = "velocity"  # mean forward velocity


class Resolution(enum.StrEnum):
    """Grid spacing when robot.dx is null: paper (1/128 2D, 1/32 3D), demo (1/64, 1/32), smoke
    (1/32, 1/16)."""

    paper = "paper"
    demo = "demo"
    smoke = "smoke"


class Activation(enum.StrEnum):
    elu = "elu"  # keeps units alive on the mostly empty field
    relu = "relu"  # the paper's


class GridField(enum.StrEnum):
    velocity = "velocity"  # node momentum / mass, the paper's
    mass_weighted = "mass_weighted"  # node velocity * mass / a full cell's mass (litl.sim.fields)


class FeatureGradient(enum.StrEnum):
    stop = "stop"  # the task-loss gradient treats the features as constants
    full = "full"  # the paper's end-to-end backpropagation through them


class LoggerKind(enum.StrEnum):
    """Where a run's live logs go besides metrics.jsonl (`litl.loop.loggers`)."""

    tensorboard = "tensorboard"  # event files in <run dir>/tensorboard/
    wandb = "wandb"  # Weights & Biases, where the package is installed
    none = "none"


class Method(enum.StrEnum):
    """Which defaults a run starts from (`method=` on the command line, `Config.for_method`):
    the paper's Algorithm 1 as described, or litl's (the paper's plus its measured additions).
    The keys a method sets are in `litl/conf/method/<name>.yaml`."""

    litl = "litl"
    paper = "paper"


class DType(enum.StrEnum):
    float32 = "float32"
    float64 = "float64"  # needs jax.enable_x64


# The closed-loop controller's clock: the sinusoid baseline's 30 rad/s (about 5 strides a second).
CLOCK_PERIOD = 2 * math.pi / 30.0
# The closed-loop controller's input gain on the observer's features (ControllerConfig.feature_scale).
FEATURE_SCALE = 0.2

RESOLUTIONS: dict[Resolution, dict[int, float | None]] = {
    Resolution.paper: {2: None, 3: None},
    Resolution.demo: {2: 1 / 64, 3: 1 / 32},
    Resolution.smoke: {2: 1 / 32, 3: 1 / 16},
}


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


class _Checked:
    """Shared by the config dataclasses: `KEY` is their place in the tree (``"loop.learning"``);
    `__post_init__` normalizes lists to tuples and strings to their enums, then `check`s."""

    KEY = ""
    if TYPE_CHECKING:  # every subclass is a dataclass
        __dataclass_fields__: ClassVar[dict[str, dataclasses.Field[Any]]]

    def __post_init__(self) -> None:
        types = _field_types(type(self))
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            kind = _enum_of(types[f.name])
            if kind is not None and value is not None and not isinstance(value, kind):
                try:
                    value = kind(value)
                except ValueError:
                    self._invalid(f.name, f"choose one of {[k.value for k in kind]}")
            if isinstance(value, list):
                value = tuple(value)
            object.__setattr__(self, f.name, value)
        self.check()

    def check(self) -> None:
        """Raise `SettingsError` for a value that cannot be used."""

    def _key(self, name: str) -> str:
        return f"{self.KEY}.{name}" if self.KEY else name

    def _invalid(self, name: str, text: str) -> NoReturn:
        raise SettingsError(f"{self._key(name)}={getattr(self, name)!r}: {text}", self._key(name))

    def _positive_ints(self, *names: str, optional: tuple[str, ...] = ()) -> None:
        for name in names:
            value = getattr(self, name)
            if value is None and name in optional:
                continue
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                self._invalid(
                    name, "must be a positive integer" + (", or null for none" if name in optional else "")
                )

    def _positive_numbers(self, *names: str, optional: tuple[str, ...] = (), zero: bool = False) -> None:
        for name in names:
            value = getattr(self, name)
            if value is None and name in optional:
                continue
            if not (_number(value) and (value >= 0 if zero else value > 0)):
                self._invalid(
                    name,
                    ("must be a number >= 0" if zero else "must be a positive number")
                    + (", or null for none" if name in optional else ""),
                )

    def replace(self, **changes: Any) -> Self:
        """A copy with `changes`; a dict for a nested config changes only the keys it names:
        ``config.replace(loop={"episodes": 3}, seeds=2)``."""
        merged = {}
        for name, value in _moved_changes(self.KEY, changes).items():
            current = getattr(self, name)
            if isinstance(value, dict) and isinstance(current, _Checked):
                value = current.replace(**value)
            merged[name] = value
        return dataclasses.replace(self, **merged)


_C = TypeVar("_C", bound=_Checked)


def _moved_changes(section: str, changes: dict[str, Any]) -> dict[str, Any]:
    """`changes` to the config at `section` with moved keys renamed (a warning each): at the
    top, ``loop={"replay": False}`` becomes ``loop={"replay_buffer": False}``."""
    import warnings

    prefix = f"{section}." if section else ""
    flat = flatten(changes, prefix)
    if not any(key in MOVED_KEYS for key in flat):
        return changes
    for key in flat:
        if key in MOVED_KEYS:
            warnings.warn(moved_message(key), FutureWarning, stacklevel=4)
    return unflatten({MOVED_KEYS.get(key, key)[len(prefix) :]: value for key, value in flat.items()})


def _field_types(kind: type) -> dict[str, Any]:
    """`kind`'s field annotations resolved to types (this module's are strings)."""
    return typing.get_type_hints(kind)


def _classes(annotation: object) -> tuple[type, ...]:
    """The classes an annotation admits: ``X`` and ``X | None`` give (X,)."""
    return tuple(a for a in typing.get_args(annotation) or (annotation,) if isinstance(a, type))


def _enum_of(annotation: object) -> type[enum.Enum] | None:
    """The enum a field's annotation names (its closed set of values), or None."""
    return next((a for a in _classes(annotation) if issubclass(a, enum.Enum)), None)


def _dataclass_of(annotation: object) -> type[_Checked] | None:
    """The config dataclass a field's annotation names (a nested section), or None."""
    return next((a for a in _classes(annotation) if issubclass(a, _Checked)), None)


@dataclass(frozen=True)
class MaterialConfig(_Checked):
    """The robot's material from the command line; each null keeps the robot's own value
    (`litl.robots.Material`; the catalog's robots: E = 20 in [15, 30], ν = 0.25, density 1,
    actuator strength 3, yield past a stretch of 3). The time step follows the stiffest allowed
    design.

    Attributes:
      youngs_modulus: initial Young's modulus E of every design region.
      bounds: [E_min, E_max], the range co-design keeps each region's E in.
      poisson_ratio, density, actuator_strength: fixed material parameters.
      max_stretch: the principal stretch past which the material yields (the strain limit,
        `litl.sim.SimConfig.max_stretch`); inf: purely elastic, as ChainQueen. Checked where the
        robot's material is built (`litl.robots.Material`, the one check of a limit).
    """

    KEY = "robot.material"
    youngs_modulus: float | None = None
    bounds: tuple[float, float] | None = None
    poisson_ratio: float | None = None
    density: float | None = None
    actuator_strength: float | None = None
    max_stretch: float | None = None

    def check(self) -> None:
        self._positive_numbers("youngs_modulus", "density", optional=("youngs_modulus", "density"))
        if self.bounds is not None and not (
            len(self.bounds) == 2 and all(map(_number, self.bounds)) and 0 < self.bounds[0] <= self.bounds[1]
        ):
            self._invalid("bounds", "must be [E_min, E_max] with 0 < E_min <= E_max")
        if self.poisson_ratio is not None and not (
            _number(self.poisson_ratio) and -1 < self.poisson_ratio < 0.5
        ):
            self._invalid("poisson_ratio", "must lie in (-1, 0.5)")
        if self.actuator_strength is not None and not _number(self.actuator_strength):
            self._invalid("actuator_strength", "must be a finite number")

    def changes(self) -> dict[str, Any]:
        """The `litl.robots.Material` fields this config sets."""
        names = {"bounds": "youngs_modulus_bounds"}
        return {
            names.get(f.name, f.name): getattr(self, f.name)
            for f in dataclasses.fields(self)
            if getattr(self, f.name) is not None
        }


@dataclass(frozen=True)
class RobotConfig(_Checked):
    """Which robot the CLI builds (`litl.app.build_robot`); the Python API passes a `Robot`.

    Attributes:
      name: a registered robot (`litl.robots.names()`).
      dx: grid spacing; None: the `resolution`'s.
      resolution: grid spacing used when dx is None (`Resolution`).
      module: a module to import first, which registers robots of your own
        (`litl.robots.register`); then name=<its name>.
      material: changes to the robot's material and design bounds (`MaterialConfig`).
    """

    KEY = "robot"
    name: str = "biped"
    dx: float | None = None
    resolution: Resolution = Resolution.demo
    module: str | None = None
    material: MaterialConfig = field(default_factory=MaterialConfig)


@dataclass(frozen=True)
class TaskConfig(_Checked):
    KEY = "task"
    kind: TaskKind = TaskKind.default


@dataclass(frozen=True)
class AutoencoderConfig(_Checked):
    """The (V)AE observers' network and what it sees (`observer=vae` and `observer=ae`).

    Attributes:
      latent_dim: r, latent variables (the controller's features).
      window: side (domain units) of the grid window it sees, centred on the robot's particle
        centroid and rounded up to a multiple of 32 nodes (`litl.models.window`); None: the
        whole grid (the paper's).
      channels: widths of the five encoder convolutions.
      activation: the network's activation (`Activation`; the paper's: relu).
      field: what it sees of the grid and the replay buffer stores (`GridField`): node
        velocities (the paper's), or velocities weighted by the node's mass relative to a full
        cell, which fades the light boundary nodes whose velocity is mostly numerical noise.
    """

    KEY = "observer.vae"
    latent_dim: int = 8
    window: float | None = 0.5
    channels: tuple[int, ...] = (8, 16, 32, 32, 64)
    activation: Activation = Activation.elu
    field: GridField = GridField.mass_weighted

    def check(self) -> None:
        self._positive_ints("latent_dim")
        self._positive_numbers("window", optional=("window",))
        if len(self.channels) != 5 or not all(isinstance(c, int) and c >= 1 for c in self.channels):
            self._invalid("channels", "needs 5 positive integer widths")


@dataclass(frozen=True)
class KMeansConfig(_Checked):
    """The k-means baseline (`observer=kmeans`). Attributes: clusters, k clusters of the rest
    shape (features: each cluster's mean position and velocity)."""

    KEY = "observer.kmeans"
    clusters: int = 6

    def check(self) -> None:
        self._positive_ints("clusters")


@dataclass(frozen=True)
class PCAConfig(_Checked):
    """The PCA observer (`observer=pca`): a linear projection of the windowed grid field, fitted
    on the replay buffer in every learning phase (`litl.observers.pca`).

    Attributes:
      components: r, principal components (the controller's features).
      window: side (domain units) of the grid window it sees, as `observer.vae.window`.
      field: what it sees of the grid and the replay buffer stores (`GridField`), as
        `observer.vae.field` (runs from before this key read the VAE's).
    """

    KEY = "observer.pca"
    components: int = 8
    window: float | None = 0.5
    field: GridField = GridField.mass_weighted

    def check(self) -> None:
        self._positive_ints("components")
        self._positive_numbers("window", optional=("window",))


@dataclass(frozen=True)
class ObserverConfig(_Checked):
    """What the controller sees. Each observer reads its own section (`vae` for vae and ae,
    `kmeans`), so two runs differ in their observer exactly when that section differs.

    Attributes:
      kind: a registered observer (`litl.loop.observers`): vae (the method), ae (plain
        autoencoder), kmeans (baseline), none (no features: open-loop control), or your own.
      module: a module to import first, which registers observers of your own
        (`litl.loop.observers.register`); then kind=<its name>.
      vae: settings of the (V)AE observers (`AutoencoderConfig`).
      kmeans: settings of the k-means observer (`KMeansConfig`).
      pca: settings of the PCA observer (`PCAConfig`).
    """

    KEY = "observer"
    kind: str = "vae"
    module: str | None = None
    vae: AutoencoderConfig = field(default_factory=AutoencoderConfig)
    kmeans: KMeansConfig = field(default_factory=KMeansConfig)
    pca: PCAConfig = field(default_factory=PCAConfig)


@dataclass(frozen=True)
class MLPConfig(_Checked):
    """The closed-loop MLP controller (`controller=mlp`).

    Attributes:
      widths: hidden layers.
      period: the MLP also reads (sin, cos) of a clock of this period (s), as DiffTaichi's
        closed-loop walkers read sine waves beside the state; None: features only (the
        paper's). litl's default is the sinusoid baseline's 30 rad/s.
      feature_scale: an input gain on the observer's features (1: the paper's); how fast, under
        Adam, the features' pathway grows against the clock's.
      feature_gradient: whether the task-loss gradient also flows through the features into the
        simulated grid (`FeatureGradient`; full is the paper's end-to-end backpropagation).
    """

    KEY = "controller.mlp"
    widths: tuple[int, ...] = (64, 64)
    period: float | None = CLOCK_PERIOD
    feature_scale: float = FEATURE_SCALE
    feature_gradient: FeatureGradient = FeatureGradient.stop

    def check(self) -> None:
        if not all(isinstance(w, int) and w >= 1 for w in self.widths):
            self._invalid("widths", "every width must be a positive integer")
        self._positive_numbers("feature_scale")
        self._positive_numbers("period", optional=("period",))


@dataclass(frozen=True)
class SinusoidConfig(_Checked):
    """The open-loop baseline (`controller=sinusoid`, `litl.models.open_loop`). Attributes:
    omega, the sinusoids' angular frequency (rad/s)."""

    KEY = "controller.sinusoid"
    omega: float = 30.0

    def check(self) -> None:
        self._positive_numbers("omega")


@dataclass(frozen=True)
class ControllerConfig(_Checked):
    """The controller θ and its optimizer.

    Attributes:
      kind: mlp (closed loop on the observer's features) or sinusoid (open loop; needs observer
        none).
      learning_rate: Adam step size of θ.
      mlp: settings of the MLP (`MLPConfig`).
      sinusoid: settings of the sinusoid baseline (`SinusoidConfig`).
    """

    KEY = "controller"
    kind: ControllerKind = ControllerKind.mlp
    learning_rate: float = 0.01
    mlp: MLPConfig = field(default_factory=MLPConfig)
    sinusoid: SinusoidConfig = field(default_factory=SinusoidConfig)

    def check(self) -> None:
        self._positive_numbers("learning_rate")


@dataclass(frozen=True)
class RolloutConfig(_Checked):
    """The rollouts' length, float type and memory: the `sim.*` keys. (The simulator's own
    configuration, grid, dt, gravity and walls, is `litl.sim.SimConfig`, which a robot brings.)

    Attributes:
      steps: steps per rollout (None: the robot's own rollout length, `Robot.steps`).
      dtype: float type of the run (float64 needs `jax.enable_x64`).
      checkpoint_every: "auto" (segment checkpointing only where the backward pass would not
        fit `memory_budget`, with segments of about √steps steps), K (always, K steps), or None
        (never). It changes memory and time, never results.
      memory_budget: GiB the rollouts' backward passes may keep on a device, all vmapped seeds
        together; None: half the device's memory (a GPU's own, or the RAM).
    """

    KEY = "sim"
    steps: int | None = None
    dtype: DType = DType.float32
    checkpoint_every: int | str | None = "auto"
    memory_budget: float | None = None

    def check(self) -> None:
        self._positive_ints("steps", optional=("steps",))
        every = self.checkpoint_every
        if (
            every != "auto"
            and every is not None
            and (isinstance(every, bool) or not isinstance(every, int) or every < 1)
        ):
            self._invalid("checkpoint_every", "must be auto, a positive number of steps, or null for never")
        self._positive_numbers("memory_budget", optional=("memory_budget",))

    def budget_bytes(self, rollouts: int) -> int | None:
        """The budget of one of `rollouts` vmapped rollouts, in bytes (None: the default's)."""
        if self.memory_budget is None:
            return None
        return int(self.memory_budget * 2**30 / rollouts)


# The name before issue 39 (it read like the simulator's `SimConfig`): kept, the API documented it.
SimSettings = RolloutConfig


@dataclass(frozen=True)
class LearningConfig(_Checked):
    """Hyperparameters of one learning phase.

    Attributes:
      max_epochs: N, the most passes over the training half.
      batch_size: b, snapshots per minibatch.
      patience: q, epochs without a lower validation loss before stopping (used when
        patience_steps is None).
      learning_rate: Adam step size (0 is allowed: nothing is learned).
      beta: weight of the KL term in the VAE loss.
      max_steps: if set, also stop after this many SGD steps (minibatches); None: epochs only
        (the paper's). Bounds a phase's cost as the buffer grows.
      patience_steps: if set, early stopping counts SGD steps instead of epochs (stop once the
        epochs since the best validation loss hold this many steps); None: `patience` epochs
        (the paper's). An epoch is one minibatch early in a run and many later.
      momentum_weight: weight of a linear head from the encoder means to the field's mean over
        the window (the robot's momentum), trained with the reconstruction (`vae.loss_terms`),
        so the latents carry the bulk motion linearly; 0: the paper's loss.
    """

    KEY = "loop.learning"
    max_epochs: int = 100
    batch_size: int = 8
    patience: int = 5
    learning_rate: float = 3e-3
    beta: float = 1.0
    max_steps: int | None = 320
    patience_steps: int | None = 100
    momentum_weight: float = 0.3

    def check(self) -> None:
        self._positive_ints(
            "max_epochs",
            "batch_size",
            "patience",
            "max_steps",
            "patience_steps",
            optional=("max_steps", "patience_steps"),
        )
        self._positive_numbers("learning_rate", "beta", "momentum_weight", zero=True)


@dataclass(frozen=True)
class SafeguardsConfig(_Checked):
    """litl's additions to Algorithm 1 that keep an optimization from losing what it found; the
    paper has none of them (`method=paper`: null, null, null, 1). Measured in the docs' results.

    Attributes:
      gradient_clip: clip θ's and φ's gradients to this global norm before Adam (None: off); a
        spike from a long closed-loop rollout would otherwise swamp Adam's second moments.
      update_tolerance: after each learning phase (not the bootstrap) Θ takes its target step
        only if the current controller and design, simulated once with the stepped observer,
        do at most this fraction of |loss| worse than before (two forward simulations;
        `update_accepted` in learning.jsonl); None: always step.
      step_back_tolerance: an iteration whose task loss is worse than the last accepted
        iterate's by more than this fraction of |its loss| returns to that iterate and retakes
        its step at half the size (at most 3 halvings in a row; `stepped_back` in
        metrics.jsonl); None: every step is kept.
      final_learning_rate_fraction: θ's and φ's Adam steps follow a cosine over the run's K x M
        iterations down to this fraction at the last (1: constant). It scales Adam's update, so
        optimizer states and checkpoints are the same for every value.
    """

    KEY = "loop.safeguards"
    gradient_clip: float | None = 1.0
    update_tolerance: float | None = 0.1
    step_back_tolerance: float | None = 0.1
    final_learning_rate_fraction: float = 0.1

    def check(self) -> None:
        self._positive_numbers("gradient_clip", optional=("gradient_clip",))
        self._positive_numbers(
            "update_tolerance",
            "step_back_tolerance",
            zero=True,
            optional=("update_tolerance", "step_back_tolerance"),
        )
        if not (_number(self.final_learning_rate_fraction) and 0 <= self.final_learning_rate_fraction <= 1):
            self._invalid("final_learning_rate_fraction", "must lie in [0, 1] (1 = constant step sizes)")


@dataclass(frozen=True)
class LoopConfig(_Checked):
    """Algorithm 1's loop: K episodes, each M optimization iterations (one simulation with
    backpropagation each) followed by a learning phase; the replay buffer; the ablation switches.

    Attributes:
      episodes: K, alternations of optimization and learning.
      iterations: M, optimization iterations per episode.
      design_learning_rate: Adam step size of the design variables φ (Young's modulus per region).
      snapshot_stride: record the grid velocity every this many simulation steps.
      buffer_capacity: B, snapshots kept in the replay buffer (a ring buffer).
      alpha: target step Θ ← α·Θ′ + (1 − α)·Θ after each learning phase (1: no smoothing).
      replay_buffer: keep a replay buffer; False keeps only the latest rollout's snapshots (the
        no-replay ablation).
      schedule: how learning alternates with optimization (`Schedule`).
      codesign: optimize the design φ with the controller; False: control only.
      safeguards: litl's stabilizers of the optimization (`SafeguardsConfig`).
      learning: the learning phase (`LearningConfig`).
      learning_seeds_at_once: None (the default): every seed's learning phase vmapped, as the
        optimization; N: N seeds' phases vmapped together, the groups one after another. A
        vmapped phase runs until its slowest seed stops; 1 stops each at its own epoch, which on
        the CPU made epoch-bounded phases (`method=paper`) 1.1-1.4x faster
        (`benchmarks/loop_speed.py`, docs/results/benchmarks.md). A different grouping rounds
        differently, and early stopping can turn that into another epoch count, so a run is
        another sample of the same method, not the same numbers; it is not recorded in run.json.
    """

    KEY = "loop"
    episodes: int = 10
    iterations: int = 10
    design_learning_rate: float = 0.5
    snapshot_stride: int = 20
    buffer_capacity: int = 500
    alpha: float = 0.5
    replay_buffer: bool = True
    schedule: Schedule = Schedule.alternating
    codesign: bool = True
    safeguards: SafeguardsConfig = field(default_factory=SafeguardsConfig)
    learning: LearningConfig = field(default_factory=LearningConfig)
    learning_seeds_at_once: int | None = None

    def check(self) -> None:
        self._positive_ints("episodes", "iterations", "snapshot_stride", "buffer_capacity")
        self._positive_ints("learning_seeds_at_once", optional=("learning_seeds_at_once",))
        self._positive_numbers("design_learning_rate")
        if not (_number(self.alpha) and 0 < self.alpha <= 1):
            self._invalid("alpha", "must lie in (0, 1] (1 = no target smoothing)")


@dataclass(frozen=True)
class ExperimentConfig(_Checked):
    """A preset's name (it names the run directory), what it is, and what the paper ran."""

    KEY = "experiment"
    name: str = "demo"
    description: str = ""
    paper_scale: str = ""


@dataclass(frozen=True)
class OutputConfig(_Checked):
    """Attributes: progress bar on stderr; GIF of the final robot (seed 0); the loss plot, robot
    drawing and latent/cluster pictures; simulation steps per animation frame; the live logger
    (`LoggerKind`: tensorboard, wandb or none)."""

    KEY = "output"
    progress: bool = True
    animation: bool = True
    pictures: bool = True
    animation_stride: int = 10
    logger: LoggerKind = LoggerKind.tensorboard

    def check(self) -> None:
        self._positive_ints("animation_stride")


@dataclass(frozen=True)
class Config(_Checked):
    """Everything one run needs. `litl.loop.run(robot, config, ...)` reads observer,
    controller, sim, loop, seeds and seed; robot and task say which robot the CLI builds,
    experiment and output what it records and draws.

    Attributes:
      method: the method the settings started from (`Method`: `method=paper|litl`, or
        `Config.for_method`); later changes to single keys win. Reports name it.
      seeds: S, independent runs batched with `jax.vmap` (the paper uses 10).
      seed: base seed; the runs use seed, seed + 1, ..., seed + S - 1.
    """

    method: Method = Method.litl
    robot: RobotConfig = field(default_factory=RobotConfig)
    task: TaskConfig = field(default_factory=TaskConfig)
    observer: ObserverConfig = field(default_factory=ObserverConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    sim: RolloutConfig = field(default_factory=RolloutConfig)
    loop: LoopConfig = field(default_factory=LoopConfig)
    experiment: ExperimentConfig = field(default_factory=ExperimentConfig)
    output: OutputConfig = field(default_factory=OutputConfig)
    seeds: int = 1
    seed: int = 0

    def check(self) -> None:
        self._positive_ints("seeds")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            self._invalid("seed", "must be an integer >= 0")
        if self.controller.kind == ControllerKind.sinusoid and self.observer.kind != "none":
            raise SettingsError(
                f"observer.kind={self.observer.kind!r}: the sinusoid controller is open loop and "
                f"reads no observer; set observer none (controller=sinusoid on the command line "
                f"does so)",
                "observer.kind",
            )

    @classmethod
    def for_method(cls, method: str | Method) -> Config:
        """The defaults of `method` (``"paper"`` or ``"litl"``), as `method=<name>` on the
        command line gives them: ``Config.for_method("paper").replace(seeds=10)``."""
        return cls().replace(**method_changes(method))

    def run_settings(self) -> dict[str, Any]:
        """The settings that shape a run's results (recorded in `run.json`; a resumed run must
        match them): method, observer, controller, sim, loop, seeds, seed."""
        tree = json_safe(dataclasses.asdict(self))
        for section, keys in EXECUTION_KEYS.items():  # they change memory and time only
            for key in keys:
                tree[section].pop(key)
        return {
            name: tree[name] for name in ("method", "observer", "controller", "sim", "loop", "seeds", "seed")
        }


# Settings that change how much memory and time a run takes, not what it computes (at most its
# rounding): not in `run.json`, so a run can be resumed with others.
EXECUTION_KEYS = {"sim": ("checkpoint_every", "memory_budget"), "loop": ("learning_seeds_at_once",)}


def seeds_at_once(loop: LoopConfig, seeds: int) -> int:
    """How many of `seeds` seeds' learning phases run together (`loop.learning_seeds_at_once`)."""
    setting = loop.learning_seeds_at_once
    return seeds if setting is None else min(setting, seeds)


def json_safe(tree: Any) -> Any:
    """Enums as their values, tuples as lists: the tree as `json.dumps` / YAML write it."""
    if isinstance(tree, dict):
        return {key: json_safe(value) for key, value in tree.items()}
    if isinstance(tree, (list, tuple)):
        return [json_safe(value) for value in tree]
    return tree.value if isinstance(tree, enum.Enum) else tree


def method_changes(method: str | Method) -> dict[str, Any]:
    """The nested changes `method` makes to `Config()` (read from litl/conf/method/<name>.yaml,
    the files the command line's `method=` group uses)."""
    from importlib import resources

    import yaml

    try:
        method = Method(method)
    except ValueError:
        raise SettingsError(
            f"method={method!r}: choose one of {[m.value for m in Method]}", "method"
        ) from None
    text = (resources.files("litl.conf") / "method" / f"{method.value}.yaml").read_text()
    return yaml.safe_load(text) or {}


# The old spellings of settings, in two tables because they are two namespaces: dotted keys that
# moved since this module was written, and the flat layout of run.json files from before it.
#
# Keys that moved, by their old dotted name. The old spellings are still accepted, with a
# warning, on the command line (`translate_overrides`), in `Config.replace` and in older
# run.json files (`upgrade`, `recorded_settings`).
MOVED_KEYS = {
    "observer.latent_dim": "observer.vae.latent_dim",
    "observer.window": "observer.vae.window",
    "observer.channels": "observer.vae.channels",
    "observer.activation": "observer.vae.activation",
    "observer.field": "observer.vae.field",
    "observer.clusters": "observer.kmeans.clusters",
    "controller.widths": "controller.mlp.widths",
    "controller.period": "controller.mlp.period",
    "controller.feature_scale": "controller.mlp.feature_scale",
    "controller.feature_gradient": "controller.mlp.feature_gradient",
    "controller.omega": "controller.sinusoid.omega",
    "loop.gradient_clip": "loop.safeguards.gradient_clip",
    "loop.update_tolerance": "loop.safeguards.update_tolerance",
    "loop.step_back_tolerance": "loop.safeguards.step_back_tolerance",
    "loop.final_learning_rate_fraction": "loop.safeguards.final_learning_rate_fraction",
    "loop.replay": "loop.replay_buffer",
    "loop.replay_capacity": "loop.buffer_capacity",
}


# run.json files written before this module (before 2026-11-23) kept the run's settings in one
# flat "loop" object; where each of its keys lives now. They are no keys of today's command line
# (`observer=` there picks a group, not `observer.kind`), so only `recorded_settings` reads them.
FLAT_RUN_KEYS = {
    "episodes": "loop.episodes",
    "iterations": "loop.iterations",
    "steps": "sim.steps",
    "dtype": "sim.dtype",
    "observer": "observer.kind",
    "latent_dim": "observer.vae.latent_dim",
    "window": "observer.vae.window",
    "channels": "observer.vae.channels",
    "activation": "observer.vae.activation",
    "clusters": "observer.kmeans.clusters",
    "controller": "controller.kind",
    "controller_widths": "controller.mlp.widths",
    "controller_omega": "controller.sinusoid.omega",
    "controller_period": "controller.mlp.period",
    "feature_gradient": "controller.mlp.feature_gradient",
    "learning_rate": "controller.learning_rate",
    "design_learning_rate": "loop.design_learning_rate",
    "gradient_clip": "loop.safeguards.gradient_clip",
    "snapshot_stride": "loop.snapshot_stride",
    "replay_capacity": "loop.buffer_capacity",
    "alpha": "loop.alpha",
    "replay": "loop.replay_buffer",
    "codesign": "loop.codesign",
    "learning": "loop.learning",
    "seeds": "seeds",
    "seed": "seed",
}


def current_key(key: str) -> str:
    """Where a setting lives now, under any spelling a run.json may hold: a moved dotted key
    (`MOVED_KEYS`), a key of the flat layout (`FLAT_RUN_KEYS`) or today's."""
    return FLAT_RUN_KEYS.get(key) or MOVED_KEYS.get(key, key)


def recorded_settings(saved: dict[str, Any]) -> dict[str, Any]:
    """A parsed run.json's settings by today's dotted key (``"loop.alpha"``), as
    `Config.run_settings` names them; older layouts translated, and a run recorded before
    methods were named started from litl's."""
    if isinstance(saved.get("config"), dict):
        flat = flatten(saved["config"])
    else:
        legacy: dict[str, Any] = dict(saved.get("loop", {}))
        one_shot = legacy.pop("one_shot", False)
        simultaneous = legacy.pop("simultaneous", False)
        schedule = "one_shot" if one_shot else "simultaneous" if simultaneous else "alternating"
        moved = {FLAT_RUN_KEYS.get(key, key): value for key, value in legacy.items()}
        flat = {**flatten(moved), "loop.schedule": schedule}
    flat = {MOVED_KEYS.get(key, key): value for key, value in flat.items()}
    flat.setdefault("method", Method.litl.value)
    # The PCA observer read the VAE's field until it had its own (2026-11-27).
    flat.setdefault("observer.pca.field", flat.get("observer.vae.field", GridField.mass_weighted.value))
    return flat


def moved_message(old: str) -> str:
    return f"{old} is now {MOVED_KEYS[old]}; the old spelling still works for now, but will not for ever"


def translate_overrides(overrides: Iterable[str]) -> tuple[list[str], list[str]]:
    """Command-line overrides with moved keys renamed (`MOVED_KEYS`), and a message for each:
    ``["loop.replay=false"] -> (["loop.replay_buffer=false"], ["loop.replay is now ..."])``."""
    translated, messages = [], []
    for override in overrides:
        prefix = override[:1] if override[:1] in "+~" else ""
        key, equals, value = override[len(prefix) :].partition("=")
        if key in MOVED_KEYS:
            messages.append(moved_message(key))
            override = f"{prefix}{MOVED_KEYS[key]}{equals}{value}"
        translated.append(override)
    return translated, messages


def upgrade(tree: dict[str, Any]) -> dict[str, Any]:
    """A run's nested settings (`run.json`'s "config") with moved keys renamed; a run recorded
    before methods were named started from litl's; one recorded before a section was added ran
    with its defaults."""
    flat = flatten(tree)
    flat = {MOVED_KEYS.get(key, key): value for key, value in flat.items()}
    flat.setdefault("method", Method.litl.value)
    # The PCA observer read the VAE's field until it had its own (2026-11-27).
    flat.setdefault("observer.pca.field", flat.get("observer.vae.field", GridField.mass_weighted.value))
    # observer.pca is read only by the PCA observer, which came with it.
    for key, value in flatten({"observer": {"pca": json_safe(dataclasses.asdict(PCAConfig()))}}).items():
        flat.setdefault(key, value)
    return unflatten(flat)


def unflatten(flat: dict[str, Any]) -> dict[str, Any]:
    """The nested dict of a dotted-key dict (`flatten`'s inverse)."""
    tree: dict[str, Any] = {}
    for key, value in flat.items():
        *parents, leaf = key.split(".")
        node = tree
        for parent in parents:
            node = node.setdefault(parent, {})
        node[leaf] = value
    return tree


def from_dict(kind: type[_C], values: dict[Any, Any]) -> _C:
    """Build the config dataclass `kind` from a nested dict (a composed Hydra config as plain
    containers, or `run.json`); nested dicts become nested configs."""
    fields = {f.name: f for f in dataclasses.fields(kind)}
    unknown = sorted(set(values) - set(fields))
    if unknown:
        prefix = f"{kind.KEY}." if kind.KEY else ""
        raise SettingsError(f"unknown setting(s) {[prefix + u for u in unknown]}")
    built = {}
    for name, value in values.items():
        nested = _dataclass_of(_field_types(kind)[name])
        built[name] = from_dict(nested, value) if nested and isinstance(value, dict) else value
    return kind(**built)


def flatten(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """A nested dict's leaves by dotted key: ``{"loop.episodes": 10, ...}``."""
    flat = {}
    for key, value in tree.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f"{prefix}{key}."))
        else:
            flat[prefix + key] = value
    return flat


def register_with_hydra() -> None:
    """Put `Config` in Hydra's ConfigStore as `litl_schema`, which `conf/config.yaml` extends.

    The dataclasses are frozen for the Python API; Hydra merges YAML files and overrides into
    the node, so its read-only flags are lifted (the result is frozen again by `from_dict`)."""
    from hydra.core.config_store import ConfigStore
    from omegaconf import DictConfig, OmegaConf

    def writable(node: Any) -> None:
        node._set_flag("readonly", None)
        if isinstance(node, DictConfig):
            for key in node:
                writable(node._get_node(key))

    node = OmegaConf.structured(Config)
    writable(node)
    ConfigStore.instance().store(name="litl_schema", node=node)


def from_hydra(cfg: Any) -> Config:
    """Convert a composed Hydra config (DictConfig) into `Config`, checking every value."""
    from omegaconf import OmegaConf, SCMode

    plain = OmegaConf.to_container(cfg, resolve=True, structured_config_mode=SCMode.DICT)
    assert isinstance(plain, dict)  # a DictConfig converts to a dict
    plain.pop("hydra", None)
    return from_dict(Config, plain)
