"""The claims suite's plan: each cell's estimated time and memory, from a measured iteration.

Before a suite runs, one optimization iteration of each panel's first variant is compiled and
timed (all its seeds, vmapped, on the device the runs will use), with the program's device memory
from XLA's memory analysis. A cell's estimate is its iterations times its panel's iteration, plus
one compilation; the other variants of a panel (k-means, sinusoids) are cheaper than its VAE, so
the estimate is an upper bound for them. Cells run `jobs` at a time, in the suite's order
(each starting when a job is free), as `litl.claims.suite.run_suite` runs them.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Sequence

from litl.claims.suite import Cell, ClaimsError, expected_records, finished_records
from litl.config import Config


@dataclasses.dataclass(frozen=True)
class Measurement:
    """One optimization iteration of a cell's program.

    Attributes:
      compile_s: lowering and compilation, seconds.
      iteration_s: one iteration after compilation (all seeds), seconds.
      device_bytes: the program's device memory (arguments, outputs and temporaries; XLA's
        memory analysis), or None where the backend does not report it.
    """

    compile_s: float
    iteration_s: float
    device_bytes: int | None


@dataclasses.dataclass(frozen=True)
class PlannedCell:
    cell: Cell
    records_left: int
    seconds: float
    device_bytes: int | None


def measure(config: Config) -> Measurement:
    """Compile and time one vmapped optimization iteration of `config` (its seeds, its robot)."""
    import jax

    from litl.app import build_robot
    from litl.loop import make_algorithm, stack_seeds

    robot = build_robot(config)
    algorithm = make_algorithm(robot, config.algorithm)
    state = stack_seeds([algorithm.init(seed) for seed in range(config.seeds)])
    start = time.perf_counter()
    compiled = jax.jit(jax.vmap(algorithm.optimize)).lower(state).compile()
    compile_s = time.perf_counter() - start
    jax.block_until_ready(compiled(state))
    start = time.perf_counter()
    jax.block_until_ready(compiled(state))
    iteration_s = time.perf_counter() - start
    analysis = compiled.memory_analysis()
    device_bytes = None
    if analysis is not None:
        device_bytes = int(
            analysis.argument_size_in_bytes + analysis.output_size_in_bytes + analysis.temp_size_in_bytes
        )
    jax.clear_caches()
    return Measurement(compile_s, iteration_s, device_bytes)


def plan(
    out: str | os.PathLike[str],
    suite: Sequence[Cell],
    config_of: Callable[[Cell], Config],
    measure_one: Callable[[Config], Measurement] = measure,
) -> list[PlannedCell]:
    """Each unfinished cell of `suite` with its estimated time and memory (finished cells are
    left out): one measurement per panel, on its first unfinished cell."""
    measured: dict[str, Measurement] = {}
    planned = []
    for cell in suite:
        config = config_of(cell)
        left = expected_records(config) - finished_records(cell.run_dir(out))
        if left <= 0:
            continue
        key = cell.panel.name
        if key not in measured:
            measured[key] = measure_one(config)
        m = measured[key]
        iterations = left // max(config.seeds, 1)
        planned.append(PlannedCell(cell, left, m.compile_s + iterations * m.iteration_s, m.device_bytes))
    return planned


def check_jobs(planned: Sequence[PlannedCell], jobs: int, device_bytes: int | None) -> None:
    """Refuse (`ClaimsError`) fewer than one job, or more jobs than the device's memory holds
    at once by the plan's largest cells."""
    if jobs < 1:
        raise ClaimsError(f"--jobs must be at least 1; got {jobs}")
    sizes = sorted((p.device_bytes for p in planned if p.device_bytes), reverse=True)
    if device_bytes is None or not sizes:
        return
    needed = sum(sizes[:jobs])
    if needed > 0.9 * device_bytes:
        fits = max(1, sum(1 for k in range(1, len(sizes) + 1) if sum(sizes[:k]) <= 0.9 * device_bytes))
        raise ClaimsError(
            f"--jobs {jobs}: the {min(jobs, len(sizes))} largest cells need {needed / 2**30:.1f} GiB "
            f"at once, over 90% of the device's {device_bytes / 2**30:.1f} GiB; use --jobs {fits} or fewer"
        )


def wall_time(planned: Sequence[PlannedCell], jobs: int) -> float:
    """The suite's estimated wall time with `jobs` cells at once, each started in the suite's
    order when a job is free (as `run_suite` does)."""
    lanes = [0.0] * max(jobs, 1)
    for cell in planned:
        lanes[lanes.index(min(lanes))] += cell.seconds
    return max(lanes, default=0.0)


def describe(planned: Sequence[PlannedCell], jobs: int) -> list[str]:
    """The plan as lines for people: each cell's estimate and memory, then the total."""
    lines = []
    for p in planned:
        memory = "" if p.device_bytes is None else f", {p.device_bytes / 2**20:,.0f} MiB"
        lines.append(f"  {p.cell.name}: {p.records_left} records left, ~{duration(p.seconds)}{memory}")
    total = sum(p.seconds for p in planned)
    lines.append(
        f"  {len(planned)} cells, ~{duration(total)} one at a time; ~{duration(wall_time(planned, jobs))} "
        f"with {jobs} at once (estimates from one measured iteration per panel)"
    )
    return lines


def duration(seconds: float) -> str:
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


@dataclasses.dataclass(frozen=True)
class CommittedPlan:
    """An experiment's horizon and seeds as committed before its runs (a results page cites it).

    Attributes:
      episodes, iterations, seeds: the planned run size.
      page: the committed plan, relative to the repository's root.
    """

    episodes: int
    iterations: int
    seeds: int
    page: str


# The paper-resolution runs' plan, committed before any cell finished (issue #46).
PAPER_PLAN = CommittedPlan(10, 10, 10, "docs/results/2026-11-27-paper-scale-plan.md")


def departure_from_plan(config: Config, plan: CommittedPlan = PAPER_PLAN) -> str | None:
    """What a results page must say when a run's size differs from the committed `plan`'s
    (None: it follows the plan). Allowed, never refused: a longer or shorter run is a
    measurement too, but not the one the plan fixed in advance."""
    found = (config.loop.episodes, config.loop.iterations, config.seeds)
    if found == (plan.episodes, plan.iterations, plan.seeds):
        return None
    return (
        f"These runs ({found[0]} episodes x {found[1]} iterations, {found[2]} seeds) depart from the "
        f"committed plan ({plan.episodes} x {plan.iterations}, {plan.seeds} seeds; {plan.page}): "
        f"their horizon was not fixed before their results."
    )
