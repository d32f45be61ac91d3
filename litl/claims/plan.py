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
      first_seed: the planned seeds are first_seed, ..., first_seed + seeds - 1.
    """

    episodes: int
    iterations: int
    seeds: int
    page: str
    first_seed: int = 0

    def describe(self) -> str:
        last = self.first_seed + self.seeds - 1
        return f"{self.episodes} x {self.iterations}, seeds {self.first_seed}-{last}; {self.page}"


# The paper-resolution runs' plan, committed before any cell finished (issue #46).
PAPER_PLAN = CommittedPlan(10, 10, 10, "docs/results/2026-11-27-paper-scale-plan.md")
# Fig. 4b at dx 1/128 under the paper's second reading (issue #65): seeds 0-9 (planned 2026-12-02),
# then its second stage, seeds 10-29 of the VAE and k-means cells (the plan amended in 075461c,
# before those runs).
READING_PLAN = CommittedPlan(10, 10, 10, "docs/results/2026-12-02-paper-reading-plan.md")
STAGE2_PLAN = CommittedPlan(10, 10, 20, "docs/results/2026-12-02-paper-reading-plan.md", first_seed=10)
COMMITTED_PLANS = (PAPER_PLAN, READING_PLAN, STAGE2_PLAN)


def departure_from_plan(config: Config, plans: Sequence[CommittedPlan] = COMMITTED_PLANS) -> str | None:
    """What a results page must say when a run's size and seeds match none of the committed `plans`
    (None: it follows one). Allowed, never refused: a longer or shorter run is a measurement too,
    but not the one a plan fixed in advance."""
    found = (config.loop.episodes, config.loop.iterations, config.seeds, config.seed)
    if any(found == (p.episodes, p.iterations, p.seeds, p.first_seed) for p in plans):
        return None
    listed = " or ".join(f"({plan.describe()})" for plan in plans)
    return (
        f"These runs ({found[0]} episodes x {found[1]} iterations, seeds {found[3]}-"
        f"{found[3] + found[2] - 1}) depart from the committed plans {listed}: their horizon and "
        f"seeds were not fixed before their results."
    )
