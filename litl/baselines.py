"""Gradient-free baselines: evolution strategies (evosax) optimizing what litl's gradients do.

    python -m litl baseline=cmaes observer=kmeans seeds=10       # CMA-ES on the biped
    python -m litl baseline=cmaes observer=none +scale=smoke

`run_baseline(robot, config, run_dir)` optimizes the same parameters as litl's loop, the
controller network θ and the design φ (Young's modulus per region, kept in its bounds), with an
evolution strategy from evosax (``cmaes``: CMA-ES, with evosax's defaults but the initial step
size `baseline.sigma`; ``openai_es``: OpenAI-ES with mirrored sampling, standard deviation
`baseline.sigma` and Adam at `baseline.learning_rate` on the mean), one independent strategy
per seed, all seeds and each generation's population simulated at once (vmapped). Its fitness
is the task loss of one forward simulation, the same rollout litl differentiates. The observer
is fixed: an observer that learns (vae, ae, pca) is refused, since no learning phase runs (use
observer=kmeans, whose clusters are fitted at the start, or none).

The run directory is a litl run's: run.json (settings, with the baseline's section), metrics.jsonl
(one record per generation and seed: ``task_loss``, the loss of the strategy's mean, and
``population_best``, ``population_mean``, ``simulations`` and ``simulated_steps`` so far:
a forward step counts 1) and final.json, so `python -m litl.report` draws it beside litl's runs
(labelled by the baseline's name). A generation costs population + 1 forward simulations.
"""

from __future__ import annotations

import json
import math
import pathlib
import time

import jax
import jax.numpy as jnp
import numpy as np

from litl.config import BaselineKind, Config, SettingsError
from litl.loop.algorithm import make_algorithm
from litl.loop.progress import say
from litl.loop.run import RunDirectoryLock, _claim, settings
from litl.robots.robot import Robot


def _strategy(baseline, template):
    """The evosax strategy and its parameters: CMA-ES with its defaults but the initial step size;
    OpenAI-ES with mirrored sampling, a constant standard deviation and Adam on the mean."""
    import optax
    from evosax.algorithms import CMA_ES, Open_ES

    if baseline.kind == BaselineKind.cmaes:
        strategy = CMA_ES(population_size=baseline.population, solution=template)
        params = strategy.default_params
        return strategy, params.replace(std_init=jnp.asarray(baseline.sigma, params.std_init.dtype))
    strategy = Open_ES(
        population_size=baseline.population,
        solution=template,
        optimizer=optax.adam(baseline.learning_rate),
        std_schedule=optax.constant_schedule(baseline.sigma),
    )
    return strategy, strategy.default_params


def run_baseline(
    robot: Robot, config: Config, run_dir, progress: bool = True, config_files: dict[str, str] | None = None
) -> dict:
    """Run `config.baseline` for `config.seeds` seeds; returns {"run_dir", "final": [per seed],
    "records"}. `config_files` ({relative path: text}) are written into the run directory once it
    is claimed (the command line's .hydra/*.yaml)."""
    baseline = config.baseline
    if baseline.kind == BaselineKind.none:
        raise SettingsError("baseline.kind=none: there is no baseline to run (litl's loop runs instead)")
    algorithm = make_algorithm(robot, config)
    if algorithm.observer.learned:
        raise SettingsError(
            f"baseline={baseline.kind.value} optimizes the controller and design on fixed features, "
            f"and observer {config.observer.kind!r} learns; use observer=kmeans or observer=none",
            "observer.kind",
        )
    run_dir = pathlib.Path(run_dir)
    seeds = [config.seed + s for s in range(config.seeds)]
    starts = [algorithm.init(seed) for seed in seeds]
    # The design in units of its range (0: E_min, 1: E_max), so that one step size suits it and
    # the controller's weights alike.
    low, high = robot.design_space.bounds
    normalized = [(s.design - low) / (high - low) for s in starts]
    template = (starts[0].controller, normalized[0])
    strategy, params = _strategy(baseline, template)
    observers = jax.tree.map(lambda *x: jnp.stack(x), *[s.observer for s in starts])
    means = jax.tree.map(
        lambda *x: jnp.stack(x), *[(s.controller, u) for s, u in zip(starts, normalized, strict=True)]
    )

    def fitness(solution, observer):
        controller, design = solution
        loss, _ = algorithm.simulate(controller, low + jnp.clip(design, 0.0, 1.0) * (high - low), observer)
        return jnp.where(jnp.isfinite(loss), loss, jnp.inf)

    @jax.jit
    def generation(key, state, observer):
        ask_key, tell_key = jax.random.split(key)
        population, state = strategy.ask(ask_key, state, params)
        losses = jax.vmap(fitness, in_axes=(0, None))(population, observer)
        mean_loss = fitness(strategy.get_mean(state), observer)
        state, _ = strategy.tell(tell_key, population, losses, state, params)
        return state, mean_loss, jnp.min(losses), jnp.mean(jnp.where(jnp.isfinite(losses), losses, jnp.nan))

    keys = jnp.stack([jax.random.key_data(jax.random.key(seed)) for seed in seeds])
    init = jax.vmap(lambda key, mean: strategy.init(jax.random.wrap_key_data(key), mean, params))
    states = init(keys, means)
    step_all = jax.jit(  # traced once, not at every generation
        jax.vmap(lambda key, state, observer: generation(jax.random.wrap_key_data(key), state, observer))
    )
    # Each generation's keys: every seed's key split, the first half kept.
    advance = jax.jit(
        jax.vmap(lambda k: jax.random.key_data(jax.random.split(jax.random.wrap_key_data(k))[0]))
    )
    wanted = settings(robot, config, algorithm)
    run_dir.mkdir(parents=True, exist_ok=True)
    per_generation = baseline.population + 1
    with RunDirectoryLock(run_dir):
        if (run_dir / "metrics.jsonl").exists():
            raise SettingsError(
                f"{run_dir} already holds a run's metrics; a baseline run does not resume: choose a new run "
                f"directory (hydra.run.dir=...). Nothing was changed.",
                "baseline.kind",
            )
        _claim(run_dir, wanted, config_files or {})
        records = []
        with (run_dir / "metrics.jsonl").open("w") as out:
            start = time.perf_counter()
            for g in range(baseline.generations):
                keys = advance(keys)
                states, mean_loss, best, mean = step_all(keys, states, observers)
                mean_loss, best, mean = (np.asarray(a) for a in (mean_loss, best, mean))
                wall = time.perf_counter() - start
                for s, seed in enumerate(seeds):
                    record = {
                        "seed": seed,
                        "episode": 0,
                        "iteration": g,
                        "step": g,
                        "task_loss": _number(mean_loss[s]),
                        "population_best": _number(best[s]),
                        "population_mean": _number(mean[s]),
                        "simulations": (g + 1) * per_generation,
                        "simulated_steps": (g + 1) * per_generation * algorithm.steps,
                        "wall_s": round(wall, 3),
                    }
                    records.append(record)
                    out.write(json.dumps(record) + "\n")
                out.flush()
                if progress:
                    say(
                        f"litl: {baseline.kind.value} generation {g + 1}/{baseline.generations}, task loss "
                        f"(mean of the strategy) {float(np.nanmean(mean_loss)):.4g}"
                    )
        final = [
            {
                "seed": seed,
                "task_loss": _number(mean_loss[s]),
                "simulations": baseline.generations * per_generation,
            }
            for s, seed in enumerate(seeds)
        ]
        (run_dir / "final.json").write_text(json.dumps(final, indent=1))
    return {"run_dir": run_dir, "final": final, "records": records}


def _number(value) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None
