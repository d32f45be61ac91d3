"""A run's compiled programs, shared by the runs of one process that need the same ones.

`jax.jit` keeps what it traced, lowered and compiled per function object. A run builds its
functions anew (`make_algorithm`), so a second run of the same robot under the same settings in
one process (resuming a run in a notebook, running a cell again, a sweep's jobs in one process,
a suite of runs, the tests) would trace and lower every program again: seconds for a small run,
a minute for a large one, most of a short run's time. JAX's persistent compilation cache saves
only the last step, XLA's compilation.

`programs(robot, config.algorithm, reports_epochs, seeds_at_once)` returns the same `Programs` (the
algorithm and its jit-of-vmap functions) for the same content: the robot's (every particle,
material value and setting, compared by value: two robots built alike share), the settings
`make_algorithm` reads (`AlgorithmSettings`: observer, controller, sim, loop but `loop.episodes`,
which `optimize` takes as a value, and seeds), the registered
observer's and controller's factories, and JAX's 64-bit mode. A key that cannot be made (an
object litl cannot compare by value, such as a user's task holding an open file) builds afresh.

The cache holds `LITL_PROGRAM_CACHE` entries (default 4; 0 turns sharing off), the least
recently used dropped first: each holds the compiled programs and the robot's arrays they were
traced with. A change to litl's own code within a running process (a module reloaded, a function
patched) is not part of the key: call `clear()` after one, or set LITL_PROGRAM_CACHE=0.
"""

from __future__ import annotations

import collections
import dataclasses
import enum
import functools
import hashlib
import os
import types
from collections.abc import Callable
from typing import Any

import jax
import numpy as np

from litl.config import AlgorithmSettings
from litl.loop.algorithm import make_algorithm
from litl.robots.robot import Robot
from litl.settings.registry import registry

SWITCH = "LITL_PROGRAM_CACHE"
DEFAULT_SIZE = 4


class _Unkeyable(Exception):
    """A value litl cannot compare by value; its run builds its programs afresh."""


def content_key(value: Any) -> Any:
    """A hashable key equal for values equal in content: dataclasses field by field, arrays by
    dtype, shape and bytes, containers item by item, functions and classes by identity.

    Raises:
      _Unkeyable: for any other object (its equality says nothing about its content)."""
    if value is None or isinstance(value, (bool, int, str, bytes)):
        return (type(value).__name__, value)
    if isinstance(value, float):
        return ("float", repr(value))  # nan equals nan here: the same setting
    if isinstance(value, enum.Enum):
        return (type(value), value.value)
    if isinstance(value, (np.ndarray, np.generic, jax.Array)):
        array = np.ascontiguousarray(np.asarray(value))
        return ("array", array.dtype.str, array.shape, hashlib.sha1(array.tobytes()).hexdigest())
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return (type(value),) + tuple(
            (f.name, content_key(getattr(value, f.name))) for f in dataclasses.fields(value)
        )
    if isinstance(value, (tuple, list)):
        return (type(value).__name__,) + tuple(content_key(item) for item in value)
    if isinstance(value, dict):
        return ("dict",) + tuple(sorted((repr(k), content_key(v)) for k, v in value.items()))
    if isinstance(value, (types.FunctionType, types.BuiltinFunctionType, type, types.ModuleType)):
        return ("identity", value)
    if isinstance(value, functools.partial):
        return ("partial", content_key(value.func), content_key(value.args), content_key(value.keywords))
    raise _Unkeyable(type(value).__name__)


class EpochReports:
    """The learning phases' per-epoch callback, compiled into the programs once: it forwards to
    the current run's progress display (`to`), which the next run sharing them replaces."""

    def __init__(self):
        self.to: Callable[[Any, Any], None] | None = None

    def __call__(self, epoch, validation) -> None:
        if self.to is not None:
            self.to(epoch, validation)


@dataclasses.dataclass(frozen=True)
class Programs:
    """One run's pure functions (`algorithm`) and the jitted, seed-batched ones the run shell
    calls: `optimize(states, iterations_in_run)`, `learn(states, first)`, `bootstrap`,
    `evaluate`; `reconstruct` (the learned observer's reconstruction of a few snapshots, for the
    pictures) is jitted on first use; `epochs` forwards the learning phases' epoch reports."""

    algorithm: Any
    optimize: Callable
    learn: Callable
    bootstrap: Callable
    evaluate: Callable
    epochs: EpochReports
    _reconstruct: dict = dataclasses.field(default_factory=dict)

    @property
    def reconstruct(self) -> Callable:
        if "jit" not in self._reconstruct:
            self._reconstruct["jit"] = jax.jit(self.algorithm.observer.learner.reconstruct)
        return self._reconstruct["jit"]


def _build(robot: Robot, settings: AlgorithmSettings, reports_epochs: bool, seeds_at_once: int) -> Programs:
    epochs = EpochReports()
    algorithm = make_algorithm(robot, settings, on_epoch=epochs if reports_epochs else None)
    batched = lambda f: jax.jit(jax.vmap(f))
    learn = jax.jit(functools.partial(algorithm.learn_seeds, at_once=seeds_at_once))
    if algorithm.retrains:
        # The bootstrap's learning phase is the later phases' program, `first` passed as a value,
        # not a second compilation of it.
        fill = batched(algorithm.fill)
        bootstrap = lambda states: learn(fill(states), first=True)
    else:
        bootstrap = batched(algorithm.bootstrap)
    # The run's length (the step sizes' cosine) is an argument shared by the seeds.
    optimize = jax.jit(jax.vmap(algorithm.optimize, in_axes=(0, None)))
    evaluate = batched(algorithm.evaluate)
    return Programs(algorithm, optimize, learn, bootstrap, evaluate, epochs)


_cache: collections.OrderedDict[Any, Programs] = collections.OrderedDict()


def cache_size() -> int:
    """How many sets of programs a process keeps (`LITL_PROGRAM_CACHE`, default 4)."""
    text = os.environ.get(SWITCH, "").strip()
    if not text:
        return DEFAULT_SIZE
    try:
        size = int(text)
    except ValueError:
        size = -1
    if size < 0:
        from litl.errors import UserError

        raise UserError(f"{SWITCH}={text!r}: must be a whole number >= 0 (0 turns sharing off)")
    return size


def _key(robot: Robot, settings: AlgorithmSettings, reports_epochs: bool, seeds_at_once: int) -> Any:
    # What `make_algorithm` reads, and only that: its settings, but the number of episodes (the
    # run passes its length to `optimize` as a value), and the registered factories they name.
    read = dataclasses.replace(settings, loop=dataclasses.replace(settings.loop, episodes=1))
    factories = (
        registry("observer").get(settings.observer.kind).factory,
        registry("controller").get(settings.controller.kind).factory,
    )
    return content_key(
        (robot, read, factories, reports_epochs, seeds_at_once, bool(jax.config.jax_enable_x64))  # type: ignore[attr-defined]
    )


def programs(robot: Robot, settings: AlgorithmSettings, reports_epochs: bool, seeds_at_once: int) -> Programs:
    """The programs of a run of `robot` under Algorithm 1's `settings` (see the module docstring): built, or
    shared with an earlier run of this process that needed the same ones."""
    size = cache_size()
    try:
        key = _key(robot, settings, reports_epochs, seeds_at_once) if size else None
    except _Unkeyable:
        key = None
    found = _cache.get(key) if key is not None else None
    if found is None:
        found = _build(robot, settings, reports_epochs, seeds_at_once)
        if key is not None:
            _cache[key] = found
    else:
        _cache.move_to_end(key)
    while len(_cache) > size:  # the size may have changed since the last call
        _cache.popitem(last=False)
    return found


def clear() -> None:
    """Forget every shared program (their memory is freed once no run holds them)."""
    _cache.clear()
