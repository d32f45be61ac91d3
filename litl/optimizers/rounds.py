"""The impure side of an optimization method that runs in rounds (the evolution strategies and
PPO): the run directory (lock, run.json, metrics.jsonl, final.json), checkpoints and resuming,
progress.

A method (`Method`) is pure: `init()` gives every seed's state (batched), `advance(state, r)` runs
round r (an ES generation, a stretch of PPO updates and an evaluation) and gives the new state
and each seed's figures. The runner writes one metrics record per round and seed (``task_loss``,
``simulations`` and ``simulated_steps`` so far, ``wall_s``, and the method's own figures) and saves
a checkpoint (orbax, `litl.loop.checkpoint`) at least every `CHECKPOINT_SECONDS` and at the end, so
a run killed or paused resumes where its last checkpoint left it, with the same results.
"""

from __future__ import annotations

import json
import math
import pathlib
import time
from dataclasses import dataclass
from typing import Any, Protocol

import jax
import jax.numpy as jnp
import numpy as np

from litl.config import SettingsError
from litl.loop.checkpoint import Checkpoints
from litl.loop.progress import say
from litl.loop.run_directory import RunDirectoryLock, claim, read_metrics

CHECKPOINT_SECONDS = 120.0


@dataclass(frozen=True)
class Cost:
    """What one round simulates per seed: `simulated_steps` (a forward step counts 1) and
    `simulations` (the same in whole rollouts of the robot)."""

    simulated_steps: int
    simulations: float


def seed_keys(seeds: list[int]) -> jax.Array:
    """(seeds, key data) each seed's PRNG key as raw data, to vmap over (`jax.random.wrap_key_data`)."""
    return jnp.stack([jax.random.key_data(jax.random.key(seed)) for seed in seeds])


class Method(Protocol):
    name: str
    rounds: int
    seeds: list[int]
    algorithm: Any  # the `litl.loop.algorithm.Algorithm` whose controller and design it optimizes

    def init(self) -> Any: ...

    def advance(self, state: Any, round_index: int) -> tuple[Any, dict[str, Any]]: ...

    def cost(self, round_index: int) -> Cost: ...


def run_rounds(
    method: Method,
    seeds: list[int],
    run_dir: pathlib.Path,
    wanted: dict,
    config_files: dict[str, str],
    progress: bool,
) -> dict:
    """Run (or resume) `method` in `run_dir`; returns {"run_dir", "final", "records"}."""
    run_dir.mkdir(parents=True, exist_ok=True)
    with RunDirectoryLock(run_dir):
        checkpoints = Checkpoints(run_dir / "checkpoints")
        try:
            return _run_locked(method, seeds, run_dir, wanted, config_files, progress, checkpoints)
        finally:
            checkpoints.close()


def _run_locked(method, seeds, run_dir, wanted, config_files, progress, checkpoints) -> dict:
    metrics = run_dir / "metrics.jsonl"
    if metrics.exists() and checkpoints.latest() is None:
        raise SettingsError(
            f"{run_dir} already holds a run's metrics but no checkpoint to resume it from; choose a new "
            f"run directory (hydra.run.dir=...). Nothing was changed.",
            "optimizer.kind",
        )
    claim(run_dir, wanted, config_files)
    state = method.init()
    done, records, elapsed = 0, [], 0.0
    if checkpoints.latest() is not None:
        counters = {
            "rounds_done": np.zeros((), np.int64),
            "lines": np.zeros((), np.int64),
            "wall_s": np.zeros((), np.float64),
        }
        state, found = checkpoints.restore(state, counters)
        done, elapsed = int(found["rounds_done"]), float(found["wall_s"])
        records = read_metrics(metrics, int(found["lines"]))
        if progress:
            say(f"litl: {method.name}: resuming {run_dir} after round {done} of {method.rounds}")
    steps = sum(method.cost(r).simulated_steps for r in range(done))
    simulations = sum(method.cost(r).simulations for r in range(done))
    with metrics.open("w") as out:  # the records the checkpoint covers, then the new ones
        for record in records:
            out.write(json.dumps(record) + "\n")
        start, saved = time.perf_counter() - elapsed, time.perf_counter()
        for r in range(done, method.rounds):
            state, figures = method.advance(state, r)
            figures = jax.tree.map(np.asarray, figures)
            cost = method.cost(r)
            steps, simulations = steps + cost.simulated_steps, simulations + cost.simulations
            wall = time.perf_counter() - start
            for s, seed in enumerate(seeds):
                record = {"seed": seed, "episode": 0, "iteration": r, "step": r}
                record.update({name: _number(values[s]) for name, values in figures.items()})
                record.update(simulations=round(simulations, 3), simulated_steps=steps, wall_s=round(wall, 3))
                records.append(record)
                out.write(json.dumps(record) + "\n")
            out.flush()
            if progress:
                losses = np.asarray(figures["task_loss"], np.float64)
                say(f"litl: {method.name} round {r + 1}/{method.rounds}, task loss {np.nanmean(losses):.4g}")
            last = r + 1 == method.rounds
            if last or time.perf_counter() - saved >= CHECKPOINT_SECONDS:
                saving: dict[str, Any] = {"rounds_done": r + 1, "lines": len(records), "wall_s": wall}
                checkpoints.save(r + 1, state, saving)
                saved = time.perf_counter()
    last_of = {record["seed"]: record for record in records}
    final = [
        {"seed": seed, "task_loss": last_of[seed]["task_loss"], "simulations": last_of[seed]["simulations"]}
        for seed in seeds
    ]
    (run_dir / "final.json").write_text(json.dumps(final, indent=1))
    return {"run_dir": run_dir, "final": final, "records": records}


def _number(value) -> float | int | None:
    value = np.asarray(value)
    if value.dtype == bool or np.issubdtype(value.dtype, np.integer):
        return int(value)
    value = float(value)
    return value if math.isfinite(value) else None


class RoundsOptimizer:
    """A `Method` as a `litl.optimizers.Optimizer`: runs its rounds in a run directory and says
    the final task loss per seed."""

    def __init__(self, method: Method, robot: Any, record: dict, budget: str):
        """`record`: the settings run.json records (`litl.config.RunContext.record`)."""
        self.method, self.robot, self.record, self._budget = method, robot, record, budget
        self.name = method.name

    def budget(self) -> str:
        return self._budget

    def run(self, run_dir: Any, progress: bool, config_files: dict[str, str]) -> dict:
        from litl.loop.run import settings

        wanted = settings(self.robot, self.record, self.method.algorithm)
        method = self.method
        done = run_rounds(method, method.seeds, pathlib.Path(run_dir), wanted, config_files, progress)
        losses = ", ".join(
            "n/a" if f["task_loss"] is None else f"{f['task_loss']:.6g}" for f in done["final"]
        )
        say(f"litl: {self.name}: final task loss per seed [{losses}]; results in {run_dir}")
        return done
