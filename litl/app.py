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
import litl.designs
import litl.robots
import litl.worlds
from litl.conf.schema import from_hydra, register_with_hydra
from litl.config import (
    RESOLUTIONS,
    Config,
    MaterialConfig,
    SettingsError,
    TaskConfig,
    TaskKind,
)
from litl.loop.progress import say
from litl.robots.robot import Robot
from litl.robots.tasks import Locomotion, Position, Task
from litl.settings.old import chosen_kinds, sectioned_key, sectioned_message, translate_overrides
from litl.settings.registry import import_module


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
    refuse_old_section_keys(overrides)
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


def refuse_old_section_keys(overrides: Sequence[str]) -> None:
    """An old key of a section that held every kind's keys (``world.angle``,
    ``baseline.population``) left by `translate_overrides`: one the chosen kind does not read;
    say which kinds do."""
    kinds = chosen_kinds(overrides)
    for override in overrides:
        key = override.lstrip("+~").partition("=")[0]
        head = key.partition(".")[0]
        if head in kinds and sectioned_key(key, kinds[head]) is None:
            raise SettingsError(sectioned_message(key, kinds[head]), key)


PART_MODULES = ("observer.module", "controller.module", "world.module", "optimizer.module", "design.module")


def import_named_modules(overrides: Sequence[str]) -> None:
    """Import the modules that a part's `<part>.module=` override names (`PART_MODULES`; each
    value of a sweep's list), so the parts they register are known when the config is composed."""
    for override in overrides:
        key, _, value = override.lstrip("+~").partition("=")
        if key in PART_MODULES and value not in ("", "null"):
            for module in value.split(","):
                part = key.split(".")[0]
                import_module(key, module.strip(), f"litl.{part}s.register")


def section_keys(cause: BaseException | None) -> str:
    """For a key Hydra refused under an observer's or controller's section: which observer it
    is and its valid keys (Hydra names only the settings class)."""
    from litl.settings.registry import registry

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
    if config.robot.image is not None:
        return _placed(_drawn_robot(config), config)
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
    return _placed(litl.robots.get(name, dx=dx), config)


def _drawn_robot(config: Config) -> Robot:
    """The robot in `robot.image`: a 2D drawing, or a 3D robot's voxels (.npz;
    `litl.robots.catalog.from_image`)."""
    dim = 3 if str(config.robot.image).endswith(".npz") else 2
    dx = config.robot.dx if config.robot.dx is not None else RESOLUTIONS[config.robot.resolution][dim]
    dx = litl.robots.catalog.PAPER_DX[dim] if dx is None else dx  # resolution=paper
    try:
        return litl.robots.catalog.from_image(config.robot.image, dx, width=config.robot.width)
    except litl.robots.LayoutError as error:
        raise SettingsError(f"robot.image={config.robot.image}: {error}", "robot.image") from None


def _placed(robot: Robot, config: Config) -> Robot:
    """`robot` with the configured shift, material, task, world and design space."""
    if config.robot.shift:
        from litl.sim import SimConfigError

        try:
            robot = robot.shifted(float(config.robot.shift))
        except SimConfigError as error:
            raise SettingsError(f"robot.shift={config.robot.shift}: {error}", "robot.shift") from None
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
        robot = dataclasses.replace(robot, task=Task(_task_term(robot, config.task)))
    return litl.designs.apply(litl.worlds.put(robot, config.world), config.design)


def _task_term(robot: Robot, task: TaskConfig):
    """The one term of `task=locomotion|velocity|position`, its axis and target checked against
    the robot's domain."""
    dim = robot.config.dim
    if task.axis >= dim:
        raise SettingsError(
            f"task.axis={task.axis}: {robot.name} is {dim}D (axes 0 to {dim - 1})", "task.axis"
        )
    if task.kind == TaskKind.position:
        assert task.target is not None  # TaskConfig.check refuses task=position without one
        size = robot.config.grid_shape[task.axis] * robot.config.dx
        if not 0 < task.target < size:
            raise SettingsError(
                f"task.target={task.target}: outside the domain along axis {task.axis}, (0, {size:g})",
                "task.target",
            )
        groups = robot.layout.groups
        if task.group is not None and task.group not in groups:
            raise SettingsError(
                f"task.group={task.group}: {robot.name} has no such particle group "
                f"(its groups: {sorted(groups) or 'none'})",
                "task.group",
            )
        return Position(target=float(task.target), axis=task.axis, group=task.group)
    measure: Literal["distance", "velocity"] = "distance" if task.kind == TaskKind.locomotion else "velocity"
    return Locomotion(axis=task.axis, measure=measure, direction=float(task.direction))


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
    """Run the configured optimization method (`config.optimizer`: litl's loop, Algorithm 1, by
    default) in `run_dir`, resuming it if it holds a run; litl's loop then draws.

    `config_files` ({relative path: text}) are written into `run_dir` once it is locked for this
    process and its settings checked (`python -m litl` records Hydra's `.hydra/*.yaml` so that
    a second process on the same directory changes nothing). Returns what the method returns
    (litl's loop: the `litl.loop.RunResult`).
    """
    from litl.optimizers import make

    run_dir = pathlib.Path(run_dir)
    robot = _as_made(build_robot(config), config, run_dir)
    check_observer(config)
    optimizer = make(config.optimizer, robot, config.context())
    say(
        f"litl: {robot.name} ({robot.layout.n_particles} particles, grid "
        f"{robot.config.grid_shape}), observer {config.observer.kind}, {config.seeds} seed(s), "
        f"{optimizer.budget()} -> {run_dir}"
    )
    note = litl.worlds.task_note(config.world, robot)
    if note:
        say(note)
    note = litl.backend.speed_note()
    if note:
        say(note)
    run_dir.mkdir(parents=True, exist_ok=True)
    return optimizer.run(run_dir, config.output.progress, config_files or {})
