"""What `python -m litl` does with a composed config: build, run Algorithm 1, draw the results.

`run_experiment(config, run_dir)` is the whole job, callable from notebooks too:

    from litl.app import compose, run_experiment
    result = run_experiment(compose(["robot=arm", "+scale=smoke"]), "outputs/try")

`compose` takes the command line's overrides and returns the checked `litl.config.Config`.
"""

from __future__ import annotations

import dataclasses
import pathlib
from collections.abc import Sequence
from typing import Literal

import litl.backend
import litl.robots
import litl.worlds
from litl.config import (
    RESOLUTIONS,
    BaselineKind,
    Config,
    MaterialConfig,
    SettingsError,
    TaskKind,
)
from litl.hydra_schema import from_hydra, register_with_hydra
from litl.loop import run
from litl.loop.progress import say
from litl.loop.run_directory import RunDirectoryLock
from litl.old_settings import translate_overrides, world_key, world_moved_message
from litl.registry import import_module
from litl.robots.robot import Robot
from litl.robots.tasks import Locomotion, Task
from litl.stuck import seed_ends, shown


def compose(overrides: Sequence[str] = ()) -> Config:
    """Compose the config like the CLI does (for notebooks and tests): `Config`, checked.

    Raises:
      SettingsError: an override Hydra refuses (an unknown key, group option or value, with
        the message `python -m litl` prints) or a value `Config` refuses.
    """
    import warnings

    from hydra import compose as hydra_compose
    from hydra import initialize_config_module
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    overrides, messages = translate_overrides(overrides)
    refuse_old_world_keys(overrides)
    for message in messages:
        warnings.warn(message, FutureWarning, stacklevel=2)
    import_named_modules(overrides)
    register_with_hydra()
    try:
        with initialize_config_module("litl.conf", version_base="1.3"):
            cfg = hydra_compose("config", overrides=overrides)
    except HydraException as error:
        # As Hydra's command line words it: its message, then the OmegaConf error behind it
        # (``Key 'episods' not in 'LoopConfig'``).
        cause = error.__cause__
        detail = f"\n{cause}" if isinstance(cause, OmegaConfBaseException) else ""
        raise SettingsError(f"{error}{detail}{section_keys(cause)}") from error
    return from_hydra(cfg)


def refuse_old_world_keys(overrides: Sequence[str]) -> None:
    """An old world key (``world.angle``) left by `translate_overrides`: one the chosen world
    does not read; say which worlds do."""
    kind = "flat"
    for override in overrides:
        key, _, value = override.lstrip("+~").partition("=")
        if key in ("world", "world.kind"):
            kind = value
    for override in overrides:
        key = override.lstrip("+~").partition("=")[0]
        if key.partition(".")[0] == "world" and world_key(key, kind) is None:
            raise SettingsError(world_moved_message(key, kind), key)


def import_named_modules(overrides: Sequence[str]) -> None:
    """Import the modules that `observer.module=`, `controller.module=` and `world.module=`
    overrides name (each value of a sweep's list), so the parts they register are known when the
    config is composed."""
    for override in overrides:
        key, _, value = override.lstrip("+~").partition("=")
        if key in ("observer.module", "controller.module", "world.module") and value not in ("", "null"):
            for module in value.split(","):
                part = key.split(".")[0]
                import_module(key, module.strip(), f"litl.{part}s.register")


def section_keys(cause: BaseException | None) -> str:
    """For a key Hydra refused under an observer's or controller's section: which observer it
    is and its valid keys (Hydra names only the settings class)."""
    from litl.registry import registry

    key = str(getattr(cause, "full_key", "") or "")
    part, _, rest = key.partition(".")
    section = rest.partition(".")[0]
    if part not in ("observer", "controller") or not section:
        return ""
    settings = registry(part).sections().get(section)
    if settings is None:
        return ""
    readers = [n for n in registry(part).names() if registry(part).get(n).section == section]
    valid = [f.name for f in dataclasses.fields(settings)]
    return f"\n{part} {', '.join(readers)}: the keys of {part}.{section} are {valid}"


def build_robot(config: Config) -> Robot:
    """The configured robot at the configured resolution, with the configured task, in the
    configured world."""
    name, module = config.robot.name, config.robot.module
    import_user_module("robot.module", module, "litl.robots.register")
    if name not in litl.robots.names():
        hint = (
            f"; robot.module={module!r} registered no robot of that name"
            if module
            else "; a robot of your own: robot.name=<name> robot.module=<module that registers it>"
        )
        raise SettingsError(
            f"unknown robot {name!r}; choose one of {litl.robots.names()} (robot=<name>){hint}", "robot.name"
        )
    dx = config.robot.dx
    if dx is None:
        dx = RESOLUTIONS[config.robot.resolution][litl.robots.catalog.ROBOTS[name].dim]
    robot = litl.robots.get(name, dx=dx)
    if config.robot.material.changes():
        robot = _with_material(robot, config.robot.material)
    kind = config.task.kind
    if kind != TaskKind.default and litl.worlds.brings_task(config.world):
        raise SettingsError(
            f"task={kind.value} with world={config.world.kind}: that world brings its own task, so "
            f"task={kind.value} would be set aside; leave task at its default (task=default) or "
            f"choose another world",
            "task.kind",
        )
    if kind != TaskKind.default:
        measure: Literal["distance", "velocity"] = "distance" if kind == TaskKind.locomotion else "velocity"
        robot = dataclasses.replace(robot, task=Task(Locomotion(measure=measure)))
    return litl.worlds.put(robot, config.world)


def _with_material(robot: Robot, material: MaterialConfig) -> Robot:
    """The robot with the command line's material changes, its dt following the stiffest
    allowed design (errors name the robot.material keys as typed)."""
    from litl.sim import SimConfigError

    given = ", ".join(
        f"robot.material.{f.name}={getattr(material, f.name)}"
        for f in dataclasses.fields(material)
        if getattr(material, f.name) is not None
    )
    try:
        return robot.with_material(dataclasses.replace(robot.material, **material.changes()))
    except SimConfigError as error:
        raise SettingsError(
            f"{given}: {error} ({robot.name}'s own material: {robot.material})", "robot.material"
        ) from None


# The module a setting names (it registers robots, observers or controllers of the user's own).
import_user_module = import_module


def check_observer(config: Config) -> None:
    """Check that `observer.kind` is registered (building the config imported `observer.module`)."""
    config.observer.check()


def _as_made(robot: Robot, config: Config, run_dir: pathlib.Path) -> Robot:
    """The robot with the strain limit an older `method=paper` run in `run_dir` was made with.

    `method=paper` simulated litl's strain limit (yield past a stretch of 3) from 2026-11-26 until
    2026-11-27, when it became the paper's elastic material. A paper-method run from that day (its
    run.json records a limit and no provenance) resumes as it was made, with a word; every other
    difference is the resume check's to refuse (`litl.loop.run`).
    """
    path = run_dir / "run.json"
    if not path.exists():
        return robot
    import json

    saved = json.loads(path.read_text())
    limit = saved.get("max_stretch")
    made_before = "provenance" not in saved and saved.get("config", {}).get("method") == "paper"
    if not made_before or limit is None or robot.config.max_stretch is not None or config.method != "paper":
        return robot
    say(
        f"litl: {run_dir} is a method=paper run made before 2026-11-27 with the strain limit "
        f"(max_stretch {limit}); it resumes with it (method=paper now simulates the elastic material)"
    )
    return robot.with_material(dataclasses.replace(robot.material, max_stretch=limit))


def run_experiment(config: Config, run_dir, config_files: dict[str, str] | None = None):
    """Run Algorithm 1 for `config` in `run_dir` (resuming it if it holds a run), then draw.

    `config_files` ({relative path: text}) are written into `run_dir` once it is locked for this
    process and its settings checked (`python -m litl` records Hydra's `.hydra/*.yaml` so that
    a second process on the same directory changes nothing). Returns the `litl.loop.RunResult`.
    """
    run_dir = pathlib.Path(run_dir)
    robot = _as_made(build_robot(config), config, run_dir)
    check_observer(config)
    baseline = config.baseline
    if baseline.kind == BaselineKind.none:
        budget = f"{config.loop.episodes} x {config.loop.iterations} iterations"
    elif baseline.kind == BaselineKind.ppo:
        budget = f"ppo, {baseline.ppo.timesteps} environment steps of {baseline.ppo.hold} simulation steps"
    else:
        budget = f"{baseline.kind.value}, {baseline.generations} generations of {baseline.population}"
    say(
        f"litl: {robot.name} ({robot.layout.n_particles} particles, grid "
        f"{robot.config.grid_shape}), observer {config.observer.kind}, {config.seeds} seed(s), "
        f"{budget} -> {run_dir}"
    )
    note = litl.backend.speed_note()
    if note:
        say(note)
    run_dir.mkdir(parents=True, exist_ok=True)
    if config.baseline.kind != BaselineKind.none:  # a gradient-free baseline instead of the loop
        from litl.baselines import run_baseline

        done = run_baseline(robot, config, run_dir, config.output.progress, config_files)
        losses = ", ".join(
            "n/a" if f["task_loss"] is None else f"{f['task_loss']:.6g}" for f in done["final"]
        )
        say(f"litl: {config.baseline.kind.value}: final task loss per seed [{losses}]; results in {run_dir}")
        return done
    with RunDirectoryLock(run_dir):  # held through the pictures too
        result = run(robot, config, run_dir, progress=config.output.progress, config_files=config_files)
        if config.output.pictures or config.output.animation:
            from litl.pictures import draw_run

            draw_run(
                robot,
                config,
                result,
                run_dir,
                animation=config.output.animation,
                pictures=config.output.pictures,
                stride=config.output.animation_stride,
                progress=config.output.progress,
            )
    # A seed whose last iterations were skipped reports its last good loss, marked (litl.stuck).
    ends = seed_ends(result.metrics)
    seeds = [config.seed + s for s in range(config.seeds)]
    shown_losses = ", ".join(shown(ends[seed]) if seed in ends else "n/a" for seed in seeds)
    say(f"litl: final task loss per seed [{shown_losses}]; results in {run_dir}")
    for seed in seeds:
        end = ends.get(seed)
        if end is not None and end.stuck:
            last = (
                "it never had a finite task loss"
                if end.last_good_step is None
                else f"its loss is that of iteration {end.last_good_step}, its last good one"
            )
            say(
                f"litl: seed {seed} ended stuck at its last good parameters (its last "
                f"{end.skipped_at_end} iteration(s) were skipped); {last}"
            )
    return result
