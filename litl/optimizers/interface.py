"""The optimization methods' registry by name (`litl.settings.registry`): `register`, `names`, `make`.

An optimization method (``optimizer=<name>``) is what changes the controller and the design:
litl's loop (Algorithm 1, `litl.optimizers.loop`), or an evolution strategy or PPO
(`litl.optimizers.evolution`, `litl.optimizers.ppo`), each registered with its own settings
dataclass (its section of the config, ``optimizer.<name>``). Its factory is
``factory(robot, settings, context) -> Optimizer``, `context` the run's `litl.config.RunContext`
(Algorithm 1's settings, the seeds, the output, what run.json records), never the whole config;
an `Optimizer` says what it will spend (`budget`) and runs, or resumes, in a run directory
(`run`), writing a litl run directory there (`litl.loop.run_directory`) that reports, replays
and the claims read alike.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from litl.config import RunContext
from litl.settings import Settings
from litl.settings.registry import Registry, registry

# What a method reads besides its own settings (`litl.config.RunContext`), under the name the
# methods written before it held Algorithm 1's settings apart (they read `context.config`) import.
OptimizerContext = RunContext


@runtime_checkable
class Optimizer(Protocol):
    """One optimization method, built for a robot and a run's settings."""

    name: str

    def budget(self) -> str:
        """What it will spend, for the run's first line (``"10 x 10 iterations"``)."""
        ...

    def run(self, run_dir: Any, progress: bool, config_files: dict[str, str]) -> Any:
        """Run (or resume) in `run_dir`, write the run directory, say the final task losses."""
        ...


Factory = Callable[..., Optimizer]

OPTIMIZERS: Registry = registry("optimizer")


def register(
    name: str,
    factory: Factory,
    settings: type[Settings] | None = None,
    *,
    label: str | None = None,
    replace: bool = False,
) -> None:
    """Make `factory(robot, settings, context) -> Optimizer` selectable as `name` (CLI
    ``optimizer=<name>``), with `settings`, its frozen settings dataclass (CLI
    ``optimizer.<name>.<key>=value``; in run.json as the optimizer's section), or None.

    Args:
      label: how reports name it (default: `name`).
      replace: replace a method already registered under `name` (else that is an error).
    """
    OPTIMIZERS.register(name, factory, settings, label=label, replace=replace)


def names() -> tuple[str, ...]:
    """The registered optimization methods' names."""
    return OPTIMIZERS.names()


def make(name_or_config: Any, robot: Any, context: OptimizerContext) -> Optimizer:
    """The `Optimizer` of `name_or_config` (the config's ``optimizer`` part, or a registered
    name: its defaults) for `robot`."""
    _, optimizer = OPTIMIZERS.build(name_or_config, robot, context, Optimizer)
    return optimizer
