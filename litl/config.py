"""litl's config model: the sections the core owns, and the parts that registries fill.

The tree mirrors the command line: `Config.loop.episodes` is `loop.episodes=...`,
`Config.observer.kind` is `observer=...` / `observer.kind=...`. The defaults here and in each
observer's and controller's settings dataclass are the only ones (the YAML files under
`litl/conf` select groups and set what a choice changes); every value is checked once, when its
section is built (`litl.settings.Settings`), and an error names the key as typed:

    from litl.config import Config
    config = Config().replace(observer={"kind": "kmeans", "kmeans": {"clusters": 4}}, seeds=10)
    result = litl.loop.run(litl.robots.get("biped"), config, "outputs/biped")

The core's sections are robot, task, sim, loop, experiment and output. `observer` and `controller`
are *parts*: a `kind` chosen among registered names, an optional `module` that registers a user's
own, and one section per registered settings dataclass (``observer.vae``, ``observer.mine``),
which each observer or controller declares with its registration (`litl.observers.register`,
`litl.controllers.register`; `litl.settings.registry`; the parts' machinery is `litl.settings.parts`).
`litl.conf.schema` builds the Hydra schema from the same classes, so a typo, a wrong type or an
unknown choice fails when the config is composed.

Importing this module imports no JAX; building a `Config` imports the observers and controllers
(their settings classes live with them).
"""

from __future__ import annotations

import dataclasses
import enum
import json
from dataclasses import dataclass, field
from typing import Any

from litl.settings import Settings, SettingsError, from_dict, json_safe, number
from litl.settings.dynamics import DynamicsConfig
from litl.settings.parts import ControllerConfig, DesignConfig, ObserverConfig, OptimizerConfig, WorldConfig
from litl.settings.registry import registry
from litl.settings.trees import flatten, unflatten

__all__ = [
    "Config",
    "ControllerConfig",
    "ExperimentConfig",
    "LearningConfig",
    "LoopConfig",
    "MaterialConfig",
    "ObserverConfig",
    "OutputConfig",
    "RobotConfig",
    "RolloutConfig",
    "SafeguardsConfig",
    "Settings",
    "SettingsError",
    "TaskConfig",
    "OptimizerConfig",
    "WorldConfig",
    "flatten",
    "from_dict",
    "json_safe",
    "unflatten",
]

# For code written before the schema moved to `litl.settings`.
_Checked = Settings
_number = number


class Schedule(enum.StrEnum):
    """How the observer's learning alternates with optimization (the paper's ablations)."""

    alternating = "alternating"  # Algorithm 1: a learning phase after every episode
    one_shot = "one_shot"  # learn once, from the initial rollout, never again
    simultaneous = "simultaneous"  # one observer step per optimization iteration, no phases


class TaskKind(enum.StrEnum):
    default = "default"  # the robot's own task (docs/guide/robots.md)
    locomotion = "locomotion"  # distance walked
    velocity = "velocity"  # mean forward velocity
    position = "position"  # walk to a coordinate (task.target) and end there


class Resolution(enum.StrEnum):
    """Grid spacing when robot.dx is null: paper (1/128 2D, 1/32 3D), demo (1/64, 1/32), smoke
    (1/32, 1/16)."""

    paper = "paper"
    demo = "demo"
    smoke = "smoke"


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
    # The reading of the paper used until 2026-12-01 (its first learning phase collapses in most
    # seeds at dx 1/128): kept to compare runs with, `litl/conf/method/paper_first_reading.yaml`.
    paper_first_reading = "paper_first_reading"


class DType(enum.StrEnum):
    float32 = "float32"
    float64 = "float64"  # needs jax.enable_x64


RESOLUTIONS: dict[Resolution, dict[int, float | None]] = {
    Resolution.paper: {2: None, 3: None},
    Resolution.demo: {2: 1 / 64, 3: 1 / 32},
    Resolution.smoke: {2: 1 / 32, 3: 1 / 16},
}


@dataclass(frozen=True)
class MaterialConfig(Settings):
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
            len(self.bounds) == 2 and all(map(number, self.bounds)) and 0 < self.bounds[0] <= self.bounds[1]
        ):
            self._invalid("bounds", "must be [E_min, E_max] with 0 < E_min <= E_max")
        if self.poisson_ratio is not None and not (
            number(self.poisson_ratio) and -1 < self.poisson_ratio < 0.5
        ):
            self._invalid("poisson_ratio", "must lie in (-1, 0.5)")
        if self.actuator_strength is not None and not number(self.actuator_strength):
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
class RobotConfig(Settings):
    """Which robot the CLI builds (`litl.app.build_robot`); the Python API passes a `Robot`.

    Attributes:
      name: a registered robot (`litl.robots.names()`).
      dx: grid spacing; None: the `resolution`'s.
      resolution: grid spacing used when dx is None (`Resolution`).
      module: a module to import first, which registers robots of your own
        (`litl.robots.register`); then name=<its name>.
      material: changes to the robot's material and design bounds (`MaterialConfig`).
      image: a 2D robot drawn as a PNG instead of a registered one (`litl.robots.catalog.
        from_image`: its legend beside it, ``<image>.json``, or litl's palette); a co-designed
        robot's drawing (`python -m litl.replay` writes one) loads back so.
      width: the drawn robot's length along x (None: the legend's note ``_width``).
      shift: move the robot this far along x (domain units) from where its definition places it,
        its reach targets with it (`Robot.shifted`): e.g. 0.3 starts the biped mid-domain.
    """

    KEY = "robot"
    name: str = "biped"
    dx: float | None = None
    resolution: Resolution = Resolution.demo
    module: str | None = None
    material: MaterialConfig = field(default_factory=MaterialConfig)
    image: str | None = None
    width: float | None = None
    shift: float = 0.0

    def check(self) -> None:
        if self.width is not None and not (number(self.width) and self.width > 0):
            self._invalid("width", "must be a length > 0 (of the unit domain), e.g. 0.3")
        if not number(self.shift):
            self._invalid("shift", "must be a finite length along x (of the unit domain), e.g. 0.3")


@dataclass(frozen=True)
class TaskConfig(Settings):
    """The objective (the `task.*` keys).

    Attributes:
      kind: default (the robot's own task), locomotion (the centroid's displacement), velocity
        (its mean velocity at the end) or position (its squared distance to `target` at the end).
      direction: +1 or -1, the way locomotion and velocity count (-1: walk the other way).
      target: position's coordinate along `axis`, inside the domain [0, grid size * dx].
      axis: the axis locomotion, velocity and position count along (0: x).
      group: position: the particle group whose centroid ends at `target` (the arm's ``tip``);
        None: the whole body's.
    """

    KEY = "task"
    kind: TaskKind = TaskKind.default
    direction: float = 1.0
    target: float | None = None
    axis: int = 0
    group: str | None = None

    def check(self) -> None:
        kind = TaskKind(self.kind)
        if self.direction not in (1, -1):
            self._invalid("direction", "must be 1 or -1 (the way task=locomotion or velocity counts)")
        if self.direction != 1 and kind not in (TaskKind.locomotion, TaskKind.velocity):
            self._invalid("direction", f"applies to task=locomotion or velocity, not task={kind.value}")
        if kind == TaskKind.position and not number(self.target):
            self._invalid("target", "task=position needs the coordinate to end at: task.target=<number>")
        if kind != TaskKind.position and self.target is not None:
            self._invalid("target", f"applies to task=position, not task={kind.value}")
        if isinstance(self.axis, bool) or not isinstance(self.axis, int) or self.axis < 0:
            self._invalid("axis", "must be an axis index, 0 (x), 1 (y) or 2 (z, in 3D)")
        if self.axis != 0 and kind == TaskKind.default:
            self._invalid("axis", "applies to task=locomotion, velocity or position, not task=default")
        if self.group is not None and kind != TaskKind.position:
            self._invalid("group", f"applies to task=position, not task={kind.value}")
        if self.group is not None and (not isinstance(self.group, str) or not self.group):
            self._invalid("group", "must name one of the robot's particle groups, e.g. tip")


# The simulator's particle-to-grid sums (`litl.sim.config.PARTICLE_TO_GRID`, spelled again here:
# this module stays free of JAX, and tests/sim/test_rollout.py checks that the two agree).
PARTICLE_TO_GRID = ("scatter", "fixed_point")


@dataclass(frozen=True)
class RolloutConfig(Settings):
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
      particle_to_grid: how particle-to-grid sums (`litl.sim.SimConfig.particle_to_grid`):
        "scatter" (a float scatter-add, the default) or "fixed_point" (integer sums,
        deterministic by construction on any backend; agrees with the scatter to float32
        rounding; on a 2-core CPU the reference walker's forward+backward costs 3.4x the
        scatter's: an option for GPUs, where it is not measured yet).
    """

    KEY = "sim"
    steps: int | None = None
    dtype: DType = DType.float32
    checkpoint_every: int | str | None = "auto"
    memory_budget: float | None = None
    particle_to_grid: str = "scatter"

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
        if self.particle_to_grid not in PARTICLE_TO_GRID:
            self._invalid("particle_to_grid", f"must be one of {', '.join(PARTICLE_TO_GRID)}")

    def budget_bytes(self, rollouts: int) -> int | None:
        """The budget of one of `rollouts` vmapped rollouts, in bytes (None: the default's)."""
        if self.memory_budget is None:
            return None
        return int(self.memory_budget * 2**30 / rollouts)


# The name before issue 39 (it read like the simulator's `SimConfig`): kept, the API documented it.
SimSettings = RolloutConfig


@dataclass(frozen=True)
class LearningConfig(Settings):
    """Hyperparameters of one learning phase.

    Attributes:
      max_epochs: N, the most passes over the training half.
      batch_size: b, snapshots per minibatch.
      patience: q, epochs without a lower validation loss before stopping (used when
        patience_steps is None).
      learning_rate: Adam step size (0 is allowed: nothing is learned).
      max_steps: if set, also stop after this many SGD steps (minibatches); None: epochs only
        (the paper's). Bounds a phase's cost as the buffer grows.
      patience_steps: if set, early stopping counts SGD steps instead of epochs (stop once the
        epochs since the best validation loss hold this many steps); None: `patience` epochs
        (the paper's). An epoch is one minibatch early in a run and many later.

    The VAE's own loss weights (the KL term's, the momentum head's) are its settings
    (``observer.vae.beta``, ``observer.vae.momentum_weight``; here until 2026-12-02).
    """

    KEY = "loop.learning"
    max_epochs: int = 100
    batch_size: int = 8
    patience: int = 5
    learning_rate: float = 3e-3
    max_steps: int | None = 320
    patience_steps: int | None = 100

    def check(self) -> None:
        self._positive_ints(
            "max_epochs",
            "batch_size",
            "patience",
            "max_steps",
            "patience_steps",
            optional=("max_steps", "patience_steps"),
        )
        self._positive_numbers("learning_rate", zero=True)


@dataclass(frozen=True)
class SafeguardsConfig(Settings):
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
        if not (number(self.final_learning_rate_fraction) and 0 <= self.final_learning_rate_fraction <= 1):
            self._invalid("final_learning_rate_fraction", "must lie in [0, 1] (1 = constant step sizes)")


@dataclass(frozen=True)
class LoopConfig(Settings):
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
      dynamics: a latent dynamics model measured at every learning phase (`DynamicsConfig`;
        off by default).
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
    dynamics: DynamicsConfig = field(default_factory=DynamicsConfig)
    learning_seeds_at_once: int | None = None

    def check(self) -> None:
        self._positive_ints("episodes", "iterations", "snapshot_stride", "buffer_capacity")
        self._positive_ints("learning_seeds_at_once", optional=("learning_seeds_at_once",))
        self._positive_numbers("design_learning_rate")
        if not (number(self.alpha) and 0 < self.alpha <= 1):
            self._invalid("alpha", "must lie in (0, 1] (1 = no target smoothing)")


@dataclass(frozen=True)
class ExperimentConfig(Settings):
    """A preset's name (it names the run directory), what it is, and what the paper ran."""

    KEY = "experiment"
    name: str = "demo"
    description: str = ""
    paper_scale: str = ""


@dataclass(frozen=True)
class OutputConfig(Settings):
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
class AlgorithmSettings:
    """The sections of the config that Algorithm 1's functions read (`litl.loop.make_algorithm`):
    the observer, the controller, the simulation, the loop and the number of seeds run at once.
    A compiled program depends on these and on the robot, nothing else (`litl.loop.programs`).
    ``config.algorithm`` gives them."""

    observer: ObserverConfig = field(default_factory=ObserverConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    sim: RolloutConfig = field(default_factory=RolloutConfig)
    loop: LoopConfig = field(default_factory=LoopConfig)
    seeds: int = 1


@dataclass(frozen=True)
class RunContext:
    """What an optimization method reads besides its own settings (``config.context()``):

    Attributes:
      algorithm: Algorithm 1's settings, which every method optimizes through (the ES and PPO
        use its simulation, controller and fixed observer; litl's loop all of it).
      seed: the first seed; the runs use seed, ..., seed + algorithm.seeds - 1 (`seed_ids`).
      output: what the run draws, logs and shows.
      record: the settings `run.json` records (`Config.run_settings`, JSON-safe): what a resumed
        run must match and the reports read.
    """

    algorithm: AlgorithmSettings
    seed: int = 0
    output: OutputConfig = field(default_factory=OutputConfig)
    record: dict[str, Any] = field(default_factory=dict)

    @property
    def seed_ids(self) -> list[int]:
        """The seeds of the run, in order."""
        return [self.seed + s for s in range(self.algorithm.seeds)]


@dataclass(frozen=True)
class Config(Settings):
    """Everything one run needs: the run's entry (`litl.app.run_experiment`, or
    `litl.loop.run(robot, config, ...)`) hands each piece its own sections: Algorithm 1 its
    `algorithm` (observer, controller, sim, loop, seeds), an optimization method its own section
    and the run's `context()`; robot, world and task say which robot the CLI builds, experiment
    and output what it records and draws.

    Attributes:
      method: the method the settings started from (`Method`: `method=paper|litl`, or
        `Config.for_method`); later changes to single keys win. Reports name it.
      seeds: S, independent runs batched with `jax.vmap` (the paper uses 10).
      seed: base seed; the runs use seed, seed + 1, ..., seed + S - 1.
    """

    method: Method = Method.litl
    robot: RobotConfig = field(default_factory=RobotConfig)
    world: WorldConfig = field(default_factory=WorldConfig)
    design: DesignConfig = field(default_factory=DesignConfig)
    task: TaskConfig = field(default_factory=TaskConfig)
    observer: ObserverConfig = field(default_factory=ObserverConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    sim: RolloutConfig = field(default_factory=RolloutConfig)
    loop: LoopConfig = field(default_factory=LoopConfig)
    optimizer: OptimizerConfig = field(default_factory=OptimizerConfig)
    experiment: ExperimentConfig = field(default_factory=ExperimentConfig)
    output: OutputConfig = field(default_factory=OutputConfig)
    seeds: int = 1
    seed: int = 0

    def check(self) -> None:
        self._positive_ints("seeds")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            self._invalid("seed", "must be an integer >= 0")
        traits = registry("controller").get(self.controller.kind).traits
        if traits.get("plans", False):
            from litl.controllers.latent import refusal

            raise refusal(self.controller.kind)
        open_loop = traits.get("open_loop", False)
        if open_loop and self.observer.kind != "none":
            raise SettingsError(
                f"observer.kind={self.observer.kind!r}: the {self.controller.kind} controller is open "
                f"loop and reads no observer; set observer none (controller={self.controller.kind} on "
                f"the command line does so)",
                "observer.kind",
            )

    @property
    def algorithm(self) -> AlgorithmSettings:
        """The sections Algorithm 1 reads (`AlgorithmSettings`)."""
        return AlgorithmSettings(self.observer, self.controller, self.sim, self.loop, self.seeds)

    def context(self) -> RunContext:
        """What an optimization method reads besides its own section (`RunContext`)."""
        record = json.loads(json.dumps(self.run_settings()))
        return RunContext(self.algorithm, self.seed, self.output, record)

    @classmethod
    def for_method(cls, method: str | Method) -> Config:
        """The defaults of `method` (``"paper"`` or ``"litl"``), as `method=<name>` on the
        command line gives them: ``Config.for_method("paper").replace(seeds=10)``."""
        return cls().replace(**method_changes(method))

    def run_settings(self) -> dict[str, Any]:
        """The settings that shape a run's results (recorded in `run.json`; a resumed run must
        match them): method, observer, controller, sim, loop, seeds, seed, the world where it
        is not flat (runs before worlds existed were flat and recorded none) and the optimization
        method where it is not litl's loop (its own section only)."""
        tree = self.to_tree()
        tree["observer"], tree["controller"] = self.observer.record(), self.controller.record()
        for section, keys in EXECUTION_KEYS.items():  # they change memory and time only
            for key in keys:
                tree[section].pop(key)
        names = ("method", "observer", "controller", "sim", "loop", "seeds", "seed")
        # The default world and method are left out: runs from before either existed recorded none.
        world = ("world",) if self.world.kind != WorldConfig().kind else ()
        tree["world"] = self.world.record()
        optimizer = ("optimizer",) if self.optimizer.kind != OptimizerConfig().kind else ()
        tree["optimizer"] = self.optimizer.record()
        design = ("design",) if self.design.kind != DesignConfig().kind else ()
        tree["design"] = self.design.record()
        return {name: tree[name] for name in names + world + optimizer + design}


# Settings that change how much memory and time a run takes, not what it computes (at most its
# rounding): not in `run.json`, so a run can be resumed with others.
EXECUTION_KEYS = {"sim": ("checkpoint_every", "memory_budget"), "loop": ("learning_seeds_at_once",)}


def seeds_at_once(loop: LoopConfig, seeds: int) -> int:
    """How many of `seeds` seeds' learning phases run together (`loop.learning_seeds_at_once`)."""
    setting = loop.learning_seeds_at_once
    return seeds if setting is None else min(setting, seeds)


def read_sections_only(tree: dict[str, Any]) -> dict[str, Any]:
    """Of the observer's and the controller's sections, only the one the chosen kind reads, as
    run.json records them since 2026-11-27 (earlier runs recorded every built-in's); a kind not
    registered (a user's module not imported) keeps them all."""
    flat = flatten(tree)
    for part, default in (
        ("observer", "vae"),
        ("controller", "mlp"),
        ("world", "flat"),
        ("optimizer", "litl"),
    ):
        entry = registry(part).find(str(flat.get(f"{part}.kind", default)))
        if entry is None:
            continue
        flat = {
            key: value
            for key, value in flat.items()
            if not key.startswith(f"{part}.")
            or key.count(".") == 1
            or key.startswith(f"{part}.{entry.section}.")
        }
    return unflatten(flat)


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


# Names that lived here before observers and controllers owned their settings (2026-11-27), and
# the old-spelling tables, which moved next to their readers (`litl.settings.old`).
_MOVED_NAMES = {
    "hydra_schema": ("litl.conf.schema", "hydra_schema"),
    "register_with_hydra": ("litl.conf.schema", "register_with_hydra"),
    "from_hydra": ("litl.conf.schema", "from_hydra"),
    "AutoencoderConfig": ("litl.observers.autoencoder", "AutoencoderSettings"),
    "KMeansConfig": ("litl.observers.kmeans", "KMeansSettings"),
    "PCAConfig": ("litl.observers.pca", "PCASettings"),
    "GridField": ("litl.observers.interface", "GridField"),
    "Activation": ("litl.observers.autoencoder", "Activation"),
    "MLPConfig": ("litl.controllers.mlp", "MLPSettings"),
    "SinusoidConfig": ("litl.controllers.sinusoid", "SinusoidSettings"),
    "FeatureGradient": ("litl.controllers.mlp", "FeatureGradient"),
    "CLOCK_PERIOD": ("litl.controllers.mlp", "CLOCK_PERIOD"),
    "FEATURE_SCALE": ("litl.controllers.mlp", "FEATURE_SCALE"),
    "MOVED_KEYS": ("litl.settings.old", "MOVED_KEYS"),
    "ContactKind": ("litl.worlds.terrain", "ContactKind"),
    "ObservedPart": ("litl.worlds.bodies", "ObservedPart"),
    "FLAT_RUN_KEYS": ("litl.settings.old", "FLAT_RUN_KEYS"),
    "current_key": ("litl.settings.old", "current_key"),
    "recorded_settings": ("litl.settings.old", "recorded_settings"),
    "translate_overrides": ("litl.settings.old", "translate_overrides"),
    "upgrade": ("litl.settings.old", "upgrade"),
    "moved_message": ("litl.settings.old", "moved_message"),
}


def __getattr__(name: str) -> Any:
    if name in _MOVED_NAMES:
        import importlib

        module, attribute = _MOVED_NAMES[name]
        return getattr(importlib.import_module(module), attribute)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
