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
from dataclasses import dataclass, field
from typing import Optional, Tuple


class SettingsError(ValueError):
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
    alternating = "alternating"     # Algorithm 1: a learning phase after every episode
    one_shot = "one_shot"           # learn once, from the initial rollout, never again
    simultaneous = "simultaneous"   # one observer step per optimization iteration, no phases


class TaskKind(enum.StrEnum):
    default = "default"             # the robot's own task (see the README's robot table)
    locomotion = "locomotion"       # distance walked
    velocity = "velocity"           # mean forward velocity


class Resolution(enum.StrEnum):
    """Grid spacing when robot.dx is null: paper (1/128 2D, 1/32 3D), demo (1/64, 1/32), smoke
    (1/32, 1/16)."""
    paper = "paper"
    demo = "demo"
    smoke = "smoke"


class Activation(enum.StrEnum):
    elu = "elu"                     # keeps units alive on the mostly empty field
    relu = "relu"                   # the paper's


class GridField(enum.StrEnum):
    velocity = "velocity"            # node momentum / mass, the paper's
    mass_weighted = "mass_weighted"  # node velocity * mass / a full cell's mass (litl.sim.fields)


class FeatureGradient(enum.StrEnum):
    stop = "stop"                   # the task-loss gradient treats the features as constants
    full = "full"                   # the paper's end-to-end backpropagation through them


class LoggerKind(enum.StrEnum):
    """Where a run's live logs go besides metrics.jsonl (`litl.loop.loggers`)."""
    tensorboard = "tensorboard"     # event files in <run dir>/tensorboard/
    wandb = "wandb"                 # Weights & Biases, where the package is installed
    none = "none"


class DType(enum.StrEnum):
    float32 = "float32"
    float64 = "float64"             # needs jax.enable_x64


# The closed-loop controller's clock: the sinusoid baseline's 30 rad/s (about 5 strides a second).
CLOCK_PERIOD = 2 * math.pi / 30.0
# The closed-loop controller's input gain on the observer's features (ControllerConfig.feature_scale).
FEATURE_SCALE = 0.2

RESOLUTIONS = {Resolution.paper: {2: None, 3: None}, Resolution.demo: {2: 1 / 64, 3: 1 / 32},
               Resolution.smoke: {2: 1 / 32, 3: 1 / 16}}


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


class _Checked:
    """Shared by the config dataclasses: `KEY` is their place in the tree (``"loop.learning"``);
    `__post_init__` normalizes lists to tuples and strings to their enums, then `check`s."""

    KEY = ""

    def __post_init__(self):
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            kind = _enum_of(f.type)
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

    def _invalid(self, name: str, text: str):
        raise SettingsError(f"{self._key(name)}={getattr(self, name)!r}: {text}", self._key(name))

    def _positive_ints(self, *names, optional=()):
        for name in names:
            value = getattr(self, name)
            if value is None and name in optional:
                continue
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                self._invalid(name, "must be a positive integer" +
                              (", or null for none" if name in optional else ""))

    def _positive_numbers(self, *names, optional=(), zero=False):
        for name in names:
            value = getattr(self, name)
            if value is None and name in optional:
                continue
            if not (_number(value) and (value >= 0 if zero else value > 0)):
                self._invalid(name, ("must be a number >= 0" if zero else
                                     "must be a positive number") +
                              (", or null for none" if name in optional else ""))

    def replace(self, **changes):
        """A copy with `changes`; a dict for a nested config changes only the keys it names:
        ``config.replace(loop={"episodes": 3}, seeds=2)``."""
        merged = {}
        for name, value in changes.items():
            current = getattr(self, name)
            if isinstance(value, dict) and dataclasses.is_dataclass(current):
                value = current.replace(**value)
            merged[name] = value
        return dataclasses.replace(self, **merged)


def _enum_of(annotation):
    text = str(annotation)
    for kind in (ControllerKind, Schedule, TaskKind, Resolution, Activation, GridField, FeatureGradient,
                 LoggerKind, DType):
        if kind.__name__ in text:
            return kind
    return None


@dataclass(frozen=True)
class MaterialConfig(_Checked):
    """The robot's material from the command line; each null keeps the robot's own value
    (`litl.robots.Material`; the catalog's robots: E = 20 in [15, 30], ν = 0.25, density 1,
    actuator strength 3). The time step follows the stiffest allowed design.

    Attributes:
      youngs_modulus: initial Young's modulus E of every design region.
      bounds: [E_min, E_max], the range co-design keeps each region's E in.
      poisson_ratio, density, actuator_strength: fixed material parameters.
    """

    KEY = "robot.material"
    youngs_modulus: Optional[float] = None
    bounds: Optional[Tuple[float, float]] = None
    poisson_ratio: Optional[float] = None
    density: Optional[float] = None
    actuator_strength: Optional[float] = None

    def check(self):
        self._positive_numbers("youngs_modulus", "density", optional=("youngs_modulus", "density"))
        if self.bounds is not None and not (len(self.bounds) == 2 and all(map(_number, self.bounds))
                                            and 0 < self.bounds[0] <= self.bounds[1]):
            self._invalid("bounds", "must be [E_min, E_max] with 0 < E_min <= E_max")
        if self.poisson_ratio is not None and not (_number(self.poisson_ratio)
                                                   and -1 < self.poisson_ratio < 0.5):
            self._invalid("poisson_ratio", "must lie in (-1, 0.5)")
        if self.actuator_strength is not None and not _number(self.actuator_strength):
            self._invalid("actuator_strength", "must be a finite number")

    def changes(self) -> dict:
        """The `litl.robots.Material` fields this config sets."""
        names = {"bounds": "youngs_modulus_bounds"}
        return {names.get(f.name, f.name): getattr(self, f.name)
                for f in dataclasses.fields(self) if getattr(self, f.name) is not None}


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
    dx: Optional[float] = None
    resolution: Resolution = Resolution.demo
    module: Optional[str] = None
    material: MaterialConfig = field(default_factory=MaterialConfig)


@dataclass(frozen=True)
class TaskConfig(_Checked):
    KEY = "task"
    kind: TaskKind = TaskKind.default


@dataclass(frozen=True)
class ObserverConfig(_Checked):
    """What the controller sees.

    Attributes:
      kind: a registered observer (`litl.loop.observers`): vae (the method), ae (plain
        autoencoder), kmeans (baseline), none (no features: open-loop control), or your own.
      latent_dim: r, latent variables of the (V)AE.
      window: side (domain units) of the grid window a (V)AE sees, centred on the robot's
        particle centroid and rounded up to a multiple of 32 nodes (`litl.models.window`);
        None: the whole grid, as in the paper. The replay buffer stores these windows.
      channels: widths of the five encoder convolutions.
      activation: the (V)AE's activation (`Activation`).
      field: what the (V)AE sees of the grid and the replay buffer stores (`GridField`): the
        node velocities (the paper's), or the velocities weighted by the node's mass relative to
        a full cell (`litl.sim.fields`), which fades the boundary's light nodes whose
        momentum / mass is dominated by numerical noise.
      clusters: k, clusters of the k-means observer.
      module: a module to import first, which registers observers of your own
        (`litl.loop.observers.register`); then kind=<its name>.
    """

    KEY = "observer"
    kind: str = "vae"
    latent_dim: int = 8
    window: Optional[float] = 0.5
    channels: Tuple[int, ...] = (8, 16, 32, 32, 64)
    activation: Activation = Activation.elu
    field: GridField = GridField.mass_weighted
    clusters: int = 6
    module: Optional[str] = None

    def check(self):
        self._positive_ints("latent_dim", "clusters")
        self._positive_numbers("window", optional=("window",))
        if len(self.channels) != 5 or not all(isinstance(c, int) and c >= 1
                                              for c in self.channels):
            self._invalid("channels", "needs 5 positive integer widths")


@dataclass(frozen=True)
class ControllerConfig(_Checked):
    """The controller θ and its optimizer.

    Attributes:
      kind: mlp (closed loop: an MLP of the observer's features) or sinusoid (the open-loop
        baseline `litl.models.open_loop.SinusoidController`; needs observer none).
      widths: hidden layers of the MLP.
      omega: angular frequency (rad/s) of the sinusoid controller.
      period: the MLP also sees (sin, cos) of a clock of this period (s), as DiffTaichi's
        closed-loop walkers see sine waves beside the state; None: features only (the paper's
        controller as described). The default, 2π/30 s, is the sinusoid baseline's frequency.
        Measured on `experiment=biped_compare` (5 seeds, mean of each seed's last 10
        iterations): the clock lifts the VAE arm from 0.200 to 0.307 and k-means from 0.224 to
        0.361 (README, "The biped comparison").
      learning_rate: Adam step size of θ.
      feature_gradient: stop treats the observer's features as constants in the task-loss
        gradient (it reaches θ through the actuation's effect on the motion only); full also
        differentiates the features w.r.t. the simulated grid (the paper's end-to-end
        backpropagation), which explodes with the horizon (`benchmarks/gradient_horizon.py`).
      feature_scale: the features are multiplied by this before they enter the MLP (an input
        gain: with Adam, how fast the features' pathway grows against the clock's). The VAE's
        latents vary with a standard deviation near 1 along a rollout, k-means' positions and
        velocities near 0.2; at gain 1 the trained controllers read the VAE's latents with 3x the
        gain and produce 2-4x rougher actuation. Measured on `experiment=biped_compare` (5 seeds,
        distance averaged over all 100 iterations / over each seed's last 10): VAE 0.212 / 0.239
        at gain 1, 0.291 / 0.315 at 0.2; k-means 0.283 / 0.333 at both (README, "The biped
        comparison").
    """

    KEY = "controller"
    kind: ControllerKind = ControllerKind.mlp
    widths: Tuple[int, ...] = (64, 64)
    omega: float = 30.0
    period: Optional[float] = CLOCK_PERIOD
    learning_rate: float = 0.01
    feature_gradient: FeatureGradient = FeatureGradient.stop
    feature_scale: float = FEATURE_SCALE

    def check(self):
        if not all(isinstance(w, int) and w >= 1 for w in self.widths):
            self._invalid("widths", "every width must be a positive integer")
        self._positive_numbers("omega", "learning_rate", "feature_scale")
        self._positive_numbers("period", optional=("period",))


@dataclass(frozen=True)
class SimSettings(_Checked):
    """Attributes: steps per rollout (None: the robot's episode length); dtype of the run."""

    KEY = "sim"
    steps: Optional[int] = None
    dtype: DType = DType.float32

    def check(self):
        self._positive_ints("steps", optional=("steps",))


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
      max_steps: if set, also stop once this many SGD steps (minibatches) were taken. 320 (ten
        epochs of a full buffer) keeps a phase cheaper than the episode's optimization for 10
        vmapped seeds on CPU (`benchmarks/loop_speed.py`; 400 cost 1.13x); on
        `experiment=biped_compare` (step-back tolerance 0.2) the VAE arm ended at 0.367 ± 0.028
        (worst seed 0.297) with 320 and 0.382 ± 0.022 (0.309) with 400.
      patience_steps: if set, early stopping counts SGD steps instead of epochs: stop once the
        epochs since the best validation loss hold at least this many steps. An epoch is one
        minibatch while the buffer is small and many later, so a patience in epochs stops far too
        early at first (one Adam step) and far too late at the end.
      momentum_weight: weight w of the (V)AE's momentum term: w x the squared error of a linear
        head from the encoder means to the input field's mean over the window (in the
        mass-weighted field, the robot's momentum per node; `vae.loss_terms`). It asks the latents
        to carry the robot's bulk motion linearly, which the per-node loss hardly sees (the
        biped's vertical momentum is under 1% of its field's energy). 0 is the paper's loss.
        Measured on `experiment=biped_compare` (10 seeds, final learning phase): velocity R²
        (x, y) medians 0.90, 0.78 at 0, 0.96, 0.95 at 0.3, 0.98, 0.95 at 1; recon_explained
        0.82, 0.81, 0.78; distance 0.371, 0.377, 0.389 (README, "The momentum head").
    """

    KEY = "loop.learning"
    max_epochs: int = 100
    batch_size: int = 8
    patience: int = 5
    learning_rate: float = 3e-3
    beta: float = 1.0
    max_steps: Optional[int] = 320
    patience_steps: Optional[int] = 100
    momentum_weight: float = 0.3

    def check(self):
        self._positive_ints("max_epochs", "batch_size", "patience", "max_steps", "patience_steps",
                            optional=("max_steps", "patience_steps"))
        self._positive_numbers("learning_rate", "beta", "momentum_weight", zero=True)


@dataclass(frozen=True)
class LoopConfig(_Checked):
    """Algorithm 1's loop: K episodes of M iterations, the replay buffer, the ablation switches.

    Attributes:
      episodes: K, alternations of optimization and learning.
      iterations: M, optimization iterations (simulations with backpropagation) per episode.
      design_learning_rate: Adam step size of the design variables φ (Young's modulus per region).
      gradient_clip: clip θ's and φ's gradients to this global norm before Adam (None: off).
        Gradients through long closed-loop rollouts can spike by orders of magnitude; a spike
        would otherwise swamp Adam's second-moment estimate for many steps.
      snapshot_stride: record the grid velocity every this many steps.
      replay_capacity: B, snapshots kept in the replay buffer (a ring buffer).
      alpha: target step Θ ← α·Θ′ + (1 − α)·Θ after each learning phase (1: no smoothing).
      update_tolerance: after each learning phase (not the bootstrap) Θ takes the target step only
        if the current controller and design, simulated once with the stepped observer, reach a
        task loss at most this fraction of |loss| worse than with the observer before it; else
        Θ is kept for the next episode (`update_accepted` false in learning.jsonl). Costs two
        forward simulations per phase. None: always step (the paper's Algorithm 1). A retrained
        observer moves the controller's inputs; measured on `experiment=biped_compare` (10
        seeds), unchecked steps threw two seeds from 0.26-0.33 to 0.09-0.11 in the last episode.
      step_back_tolerance: an optimization iteration whose task loss is worse than the last
        accepted iterate's by more than this fraction of |its loss| goes back to that iterate
        and retakes its step at half the size (at most 3 halvings in a row; `stepped_back` in
        metrics.jsonl); no simulation is repeated. None: every step is kept (the paper's).
        Closed-loop controllers can lose their gait in one Adam step and not find it again;
        measured on `experiment=biped_compare` (10 seeds, last-10 mean ± 90% CI, worst seed),
        off -> 0.2 (400 SGD steps per learning phase): VAE 0.340 ± 0.056 (0.128) -> 0.382 ±
        0.022 (0.309), k-means 0.293 ± 0.047 (0.156) -> 0.334 ± 0.034 (0.254), sinusoids 0.331
        ± 0.024 (0.271) -> 0.340 ± 0.017 (0.300); 0.2 -> 0.1 (320 steps): VAE 0.367 ± 0.028
        (0.297) -> 0.371 ± 0.033 (0.301), k-means 0.334 -> 0.349 ± 0.027 (0.252), sinusoids
        0.340 -> 0.336 ± 0.020 (0.285), with 59, 86 and 14 of each arm's 1000 iterations
        stepped back at 0.1.
      final_learning_rate_fraction: θ's and φ's Adam step sizes (controller.learning_rate,
        loop.design_learning_rate) follow a cosine over the run's K x M iterations, from their
        configured values at the first to this fraction of them at the last (1: constant, the
        paper's). It multiplies Adam's update, so the optimizer states, and checkpoints, are the
        same for every value. Late in a run, full steps kept throwing walking seeds back (seeds
        that reached 0.30 ended near 0.25, stepping back again and again); measured on
        `experiment=biped_compare` (10 seeds, last-10 mean ± 90% CI, worst seed), 1 -> 0.1:
        VAE 0.377 ± 0.036 (0.250) -> 0.381 ± 0.022 (0.324), k-means 0.349 ± 0.027 (0.252) ->
        0.362 ± 0.018 (0.301), sinusoids 0.336 ± 0.020 (0.285) -> 0.331 ± 0.014 (0.280); steps
        back 87 -> 53, 86 -> 39, 14 -> 11 of each arm's 1000 iterations.
      replay: keep a replay buffer; False keeps only the latest rollout's snapshots.
      schedule: how learning alternates with optimization (`Schedule`).
      codesign: optimize the design φ with the controller; False: control only.
      learning: the learning phase (`LearningConfig`).
    """

    KEY = "loop"
    episodes: int = 10
    iterations: int = 10
    design_learning_rate: float = 0.5
    gradient_clip: Optional[float] = 1.0
    snapshot_stride: int = 20
    replay_capacity: int = 500
    alpha: float = 0.5
    update_tolerance: Optional[float] = 0.1
    step_back_tolerance: Optional[float] = 0.1
    final_learning_rate_fraction: float = 0.1
    replay: bool = True
    schedule: Schedule = Schedule.alternating
    codesign: bool = True
    learning: LearningConfig = field(default_factory=LearningConfig)

    def check(self):
        self._positive_ints("episodes", "iterations", "snapshot_stride", "replay_capacity")
        self._positive_numbers("design_learning_rate")
        self._positive_numbers("gradient_clip", optional=("gradient_clip",))
        self._positive_numbers("update_tolerance", "step_back_tolerance", zero=True,
                               optional=("update_tolerance", "step_back_tolerance"))
        if not (_number(self.alpha) and 0 < self.alpha <= 1):
            self._invalid("alpha", "must lie in (0, 1] (1 = no target smoothing)")
        if not (_number(self.final_learning_rate_fraction)
                and 0 <= self.final_learning_rate_fraction <= 1):
            self._invalid("final_learning_rate_fraction",
                          "must lie in [0, 1] (1 = constant step sizes)")


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

    def check(self):
        self._positive_ints("animation_stride")


@dataclass(frozen=True)
class Config(_Checked):
    """Everything one run needs. `litl.loop.run(robot, config, ...)` reads observer,
    controller, sim, loop, seeds and seed; robot and task say which robot the CLI builds,
    experiment and output what it records and draws.

    Attributes:
      seeds: S, independent runs batched with `jax.vmap` (the paper uses 10).
      seed: base seed; the runs use seed, seed + 1, ..., seed + S - 1.
    """

    robot: RobotConfig = field(default_factory=RobotConfig)
    task: TaskConfig = field(default_factory=TaskConfig)
    observer: ObserverConfig = field(default_factory=ObserverConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    sim: SimSettings = field(default_factory=SimSettings)
    loop: LoopConfig = field(default_factory=LoopConfig)
    experiment: ExperimentConfig = field(default_factory=ExperimentConfig)
    output: OutputConfig = field(default_factory=OutputConfig)
    seeds: int = 1
    seed: int = 0

    def check(self):
        self._positive_ints("seeds")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            self._invalid("seed", "must be an integer >= 0")
        if self.controller.kind == ControllerKind.sinusoid and self.observer.kind != "none":
            raise SettingsError(
                f"observer.kind={self.observer.kind!r}: the sinusoid controller is open loop and "
                f"reads no observer; set observer none (controller=sinusoid on the command line "
                f"does so)", "observer.kind")

    def check_observer_kind(self) -> None:
        """`observer.kind` names a registered observer (imports the registry, hence JAX)."""
        from litl.loop import observers

        if self.observer.kind not in observers.names():
            hint = (f"; observer.module={self.observer.module!r} registered no observer of that "
                    f"name" if self.observer.module else
                    "; an observer of your own: observer.kind=<name> observer.module=<module "
                    "that registers it>")
            raise SettingsError(f"observer.kind={self.observer.kind!r}: unknown observer; choose "
                                f"one of {list(observers.names())}{hint}", "observer.kind")

    def run_settings(self) -> dict:
        """The settings that shape a run's results (recorded in `run.json`; a resumed run must
        match them): observer, controller, sim, loop, seeds, seed."""
        tree = dataclasses.asdict(self)
        return {name: tree[name] for name in ("observer", "controller", "sim", "loop", "seeds",
                                              "seed")}


def from_dict(kind, values: dict):
    """Build the config dataclass `kind` from a nested dict (a composed Hydra config as plain
    containers, or `run.json`); nested dicts become nested configs."""
    fields = {f.name: f for f in dataclasses.fields(kind)}
    unknown = sorted(set(values) - set(fields))
    if unknown:
        prefix = f"{kind.KEY}." if kind.KEY else ""
        raise SettingsError(f"unknown setting(s) {[prefix + u for u in unknown]}")
    built = {}
    for name, value in values.items():
        nested = _dataclass_of(fields[name].type)
        built[name] = from_dict(nested, value) if nested and isinstance(value, dict) else value
    return kind(**built)


def flatten(tree: dict, prefix: str = "") -> dict:
    """A nested dict's leaves by dotted key: ``{"loop.episodes": 10, ...}``."""
    flat = {}
    for key, value in tree.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f"{prefix}{key}."))
        else:
            flat[prefix + key] = value
    return flat


def _dataclass_of(annotation):
    for kind in (RobotConfig, MaterialConfig, TaskConfig, ObserverConfig, ControllerConfig, SimSettings,
                 LoopConfig, LearningConfig, ExperimentConfig, OutputConfig):
        if str(annotation) == kind.__name__:
            return kind
    return None


def register_with_hydra() -> None:
    """Put `Config` in Hydra's ConfigStore as `litl_schema`, which `conf/config.yaml` extends.

    The dataclasses are frozen for the Python API; Hydra merges YAML files and overrides into
    the node, so its read-only flags are lifted (the result is frozen again by `from_dict`)."""
    from hydra.core.config_store import ConfigStore
    from omegaconf import DictConfig, OmegaConf

    def writable(node):
        node._set_flag("readonly", None)
        if isinstance(node, DictConfig):
            for key in node:
                writable(node._get_node(key))

    node = OmegaConf.structured(Config)
    writable(node)
    ConfigStore.instance().store(name="litl_schema", node=node)


def from_hydra(cfg) -> Config:
    """Convert a composed Hydra config (DictConfig) into `Config`, checking every value."""
    from omegaconf import OmegaConf, SCMode

    plain = OmegaConf.to_container(cfg, resolve=True, structured_config_mode=SCMode.DICT)
    plain.pop("hydra", None)
    return from_dict(Config, plain)
