"""What `python -m litl` does with a composed config: build, run Algorithm 1, draw the results.

`run_experiment(settings, run_dir)` is the whole job, callable from notebooks too:

    from litl.app import compose, run_experiment
    result = run_experiment(compose(["robot=arm", "+scale=smoke"]), "outputs/try")
"""

from __future__ import annotations

import dataclasses
import importlib
import pathlib
import sys

import litl.robots
from litl.conf.schema import Settings, register, to_settings
from litl.loop import LearningConfig, LoopConfig, run
from litl.loop.config import LoopConfigError
from litl.loop.run import RunDirectoryLock
from litl.robots.robot import Robot
from litl.robots.tasks import Locomotion, Task

TASKS = ("default", "locomotion", "velocity")
RESOLUTIONS = {"paper": {2: None, 3: None}, "demo": {2: 1 / 64, 3: 1 / 32},
               "smoke": {2: 1 / 32, 3: 1 / 16}}


class SettingsError(ValueError):
    """A config value that the schema's types allow but litl cannot use."""


def normalize_overrides(overrides: list[str]) -> list[str]:
    """Accept `+scale=...`, `+experiment=...` and `+variant=...` as well as the plain form.

    These groups sit in the defaults list as optional entries, so Hydra wants the plain form; the
    `+` form is what users of other Hydra apps type for optional groups.
    """
    optional = ("scale", "experiment", "variant")
    return [o[1:] if o.startswith("+") and o[1:].split("=")[0] in optional else o for o in overrides]


def compose(overrides: list[str] = ()) -> Settings:
    """Compose the config like the CLI does (for notebooks and tests) and convert it."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_module

    register()
    with initialize_config_module("litl.conf", version_base="1.3"):
        cfg = hydra_compose("config", overrides=normalize_overrides(list(overrides)))
    return to_settings(cfg)


def build_robot(settings: Settings) -> Robot:
    """The configured robot at the configured resolution, with the configured task."""
    name, module = settings.robot.name, settings.robot.module
    import_user_module("robot.module", module, "litl.robots.register")
    if name not in litl.robots.names():
        hint = (f"; robot.module={module!r} registered no robot of that name" if module else
                "; a robot of your own: robot.name=<name> robot.module=<module that registers it>")
        raise SettingsError(f"unknown robot {name!r}; choose one of {litl.robots.names()} "
                            f"(robot=<name>){hint}")
    resolution = settings.robot.resolution
    if resolution not in RESOLUTIONS:
        raise SettingsError(f"unknown robot.resolution {resolution!r}; choose one of "
                            f"{sorted(RESOLUTIONS)} or set robot.dx")
    dx = settings.robot.dx
    if dx is None:
        dx = RESOLUTIONS[resolution][litl.robots.catalog.ROBOTS[name].dim]
    robot = litl.robots.get(name, dx=dx)
    kind = settings.task.kind
    if kind not in TASKS:
        raise SettingsError(f"unknown task {kind!r}; choose one of {TASKS} (task=<kind>)")
    if kind != "default":
        measure = "distance" if kind == "locomotion" else "velocity"
        robot = dataclasses.replace(robot, task=Task(Locomotion(measure=measure)))
    return robot


# Where each `LoopConfig` field comes from on the command line (errors name the key as typed).
CLI_KEYS = {
    "episodes": "loop.episodes", "iterations": "loop.iterations", "seeds": "seeds",
    "seed": "seed", "steps": "sim.steps", "observer": "observer.kind",
    "latent_dim": "observer.latent_dim", "window": "observer.window",
    "channels": "observer.channels", "activation": "observer.activation",
    "clusters": "observer.clusters", "controller": "controller.kind",
    "controller_widths": "controller.widths", "controller_omega": "controller.omega",
    "controller_period": "controller.period", "feature_gradient": "controller.feature_gradient",
    "learning_rate": "controller.learning_rate",
    "design_learning_rate": "loop.design_learning_rate", "gradient_clip": "loop.gradient_clip",
    "snapshot_stride": "loop.snapshot_stride", "replay_capacity": "loop.replay_capacity",
    "alpha": "loop.alpha", "one_shot": "loop.one_shot", "dtype": "sim.dtype",
}


def import_user_module(key: str, module: str | None, registers: str) -> None:
    """Import the module a setting names (it registers robots or observers of the user's own)."""
    if not module:
        return
    try:
        importlib.import_module(module)
    except ImportError as error:
        raise SettingsError(f"{key}={module!r} could not be imported ({error}); give a module "
                            f"importable from the working directory or installed, which calls "
                            f"{registers}") from None


def loop_config(settings: Settings) -> LoopConfig:
    """The `LoopConfig` of a composed config (validated there; errors name the CLI key)."""
    import_user_module("observer.module", settings.observer.module, "litl.loop.observers.register")
    try:
        learning = LearningConfig(**dataclasses.asdict(settings.loop.learning))
    except ValueError as error:
        raise LoopConfigError(f"loop.learning.{error}") from None
    try:
        return _loop_config(settings, learning)
    except LoopConfigError as error:
        key = CLI_KEYS.get(error.field)
        if key is None or not str(error).startswith(error.field):
            raise
        raise LoopConfigError(key + str(error)[len(error.field):], error.field) from None


def _loop_config(settings: Settings, learning: LearningConfig) -> LoopConfig:
    loop, observer, controller = settings.loop, settings.observer, settings.controller
    return LoopConfig(
        episodes=loop.episodes, iterations=loop.iterations, seeds=settings.seeds,
        seed=settings.seed, steps=settings.sim.steps, observer=observer.kind,
        latent_dim=observer.latent_dim, window=observer.window,
        channels=tuple(observer.channels),
        activation=observer.activation,
        clusters=observer.clusters, controller=controller.kind,
        controller_omega=controller.omega, controller_widths=tuple(controller.widths),
        controller_period=controller.period, learning_rate=controller.learning_rate,
        feature_gradient=controller.feature_gradient,
        design_learning_rate=loop.design_learning_rate, gradient_clip=loop.gradient_clip,
        snapshot_stride=loop.snapshot_stride,
        replay_capacity=loop.replay_capacity,
        learning=learning,
        alpha=loop.alpha, replay=loop.replay, one_shot=loop.one_shot,
        simultaneous=loop.simultaneous, codesign=loop.codesign, dtype=settings.sim.dtype)


def run_experiment(settings: Settings, run_dir, config_files: dict[str, str] | None = None):
    """Run Algorithm 1 for the settings in `run_dir` (resuming it if it holds a run), then draw.

    `config_files` ({relative path: text}) are written into `run_dir` once it is locked for this
    process and its settings checked (`python -m litl` records Hydra's `.hydra/*.yaml` so, so that
    a second process on the same directory changes nothing). Returns the `litl.loop.RunResult`.
    """
    robot = build_robot(settings)
    config = loop_config(settings)
    run_dir = pathlib.Path(run_dir)
    print(f"litl: {robot.name} ({robot.layout.n_particles} particles, grid "
          f"{robot.config.grid_shape}), observer {config.observer}, {config.seeds} seed(s), "
          f"{config.episodes} x {config.iterations} iterations -> {run_dir}", file=sys.stderr)
    run_dir.mkdir(parents=True, exist_ok=True)
    with RunDirectoryLock(run_dir):        # held through the pictures too
        result = run(robot, config, run_dir, progress=settings.output.progress,
                     config_files=config_files)
        if settings.output.pictures or settings.output.animation:
            from litl.pictures import draw_run

            draw_run(robot, config, result, run_dir, animation=settings.output.animation,
                     pictures=settings.output.pictures, stride=settings.output.animation_stride)
    final = [r["task_loss"] for r in result.metrics[-config.seeds:]]
    shown = ", ".join("n/a" if v is None else f"{v + 0.0:.6g}" for v in final)   # no "-0.0"
    print(f"litl: final task loss per seed [{shown}]; results in {run_dir}", file=sys.stderr)
    return result

