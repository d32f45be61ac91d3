"""The worlds' registry by name (`litl.settings.registry`): `register`, `names`, `put`.

A world is a factory ``factory(robot, settings, context) -> Robot``: the robot in that world
(terrain added to its scene's colliders, or a second body beside it), which returns a robot
already in it unchanged. Its settings dataclass is its section of the config (``world.<name>``).
A world that brings its own task in place of the robot's registers with ``task=True``; runs in it
say so and record the task in run.json.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from typing import Any

from litl.robots.robot import Robot
from litl.robots.tasks import Task
from litl.settings import Settings
from litl.settings.registry import Registry, registry

Factory = Callable[..., Robot]

WORLDS: Registry = registry("world")


def register(
    name: str,
    factory: Factory,
    settings: type[Settings] | None = None,
    *,
    task: bool = False,
    label: str | None = None,
    replace: bool = False,
) -> None:
    """Make `factory(robot, settings, context) -> Robot` selectable as `name` (``world=<name>``
    on the command line), with `settings`, its frozen settings dataclass (``world.<name>.<key>=
    value``; in run.json as the world's section), or None.

    Args:
      task: the world brings its own task in place of the robot's (push_box).
      label: how reports name it (default: `name`).
      replace: replace a world already registered under `name` (else that is an error).
    """
    WORLDS.register(name, factory, settings, label=label, replace=replace, task=task)


def names() -> tuple[str, ...]:
    """The registered worlds' names."""
    return WORLDS.names()


def put(robot: Robot, world: Any) -> Robot:
    """`robot` in `world` (a `litl.config.WorldConfig`, or a registered name: its defaults).
    Putting a robot in the same world twice changes nothing."""
    _, placed = WORLDS.build(world, robot, None, Robot)
    return placed


def brings_task(world: Any) -> bool:
    """Whether `world` (its config or its name) brings its own task in place of the robot's."""
    name = world if isinstance(world, str) else world.kind
    return bool(WORLDS.get(name).traits.get("task", False))


def task_note(world: Any, placed: Robot) -> str | None:
    """What a run says when `world` brings its own task (`placed`: the robot put in it), or None."""
    if not brings_task(world):
        return None
    kind = world if isinstance(world, str) else world.kind
    return (
        f"litl: world={kind} brings its own task, in place of the robot's: "
        f"{task_record(placed.task)} (run.json records it as 'task')"
    )


def task_record(task: Task | None) -> list[dict[str, Any]]:
    """`task` as run.json records it: each term's kind and fields (none: no task)."""
    terms = task.terms if task is not None else ()
    return [
        {"term": type(term).__name__, **json.loads(json.dumps(dataclasses.asdict(term)))} for term in terms
    ]
