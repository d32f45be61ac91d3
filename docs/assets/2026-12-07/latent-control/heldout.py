"""The seventh round's model check: how well each latent model predicts the task point's motion
under actions it was not fitted on.

    python docs/assets/2026-12-07/latent-control/heldout.py RUN_DIR OUT.json [ROLLOUTS]

Per seed of a trained run (vmapped, one program): the latent models of `python -m
litl.latent.control` fitted on 32 exploratory episodes, and where its observer has a latent
codec also on the run's buffer and on both (`litl.latent.exploration`, the command's defaults
and key); then 16 more exploratory episodes under another key, held out from every fit. On
them, for h = 1, 5, 10, 20 control steps from every start (the seventh round's records: 1, 5,
20): the RMS error of the predicted displacement of the task point along x, Σ Δ v(ẑ) against
Σ Δ v (the recorded velocities), in domain units, beside
the zero-motion prediction's; and the model's latent RMS error beside the constant latent's.
ROLLOUTS (e.g. ``1,3,5``): also fit the exploratory model with `loop.dynamics.mlp.rollout` K for
each K other than 1 (sources ``explored-rollout<K>``), the multi-step training's check.
"""

from __future__ import annotations

import json
import pathlib
import sys

import jax
import jax.numpy as jnp
import numpy as np

import litl  # noqa: F401  (before JAX starts: litl.backend)

HORIZONS = (1, 5, 10, 20)
HELD_OUT = 16


def displacement_errors(model, data, h: int):
    """(model RMS, zero-motion RMS) of the h-step displacement along x over usable starts."""
    dt = model.control_dt
    count = data.latents.shape[0] - h
    window = jnp.stack([data.links[j : j + count] for j in range(1, h + 1)])
    usable = jnp.all(window, axis=0)
    true = sum(dt * data.velocities[j : j + count, 0] for j in range(1, h + 1))

    def rolled(t):
        z = data.latents[t]
        total = jnp.zeros((), z.dtype)
        for j in range(1, h + 1):
            z = model.step(z, data.actions[t + j])
            total = total + dt * model.velocity(z)[0]
        return total

    predicted = jax.vmap(rolled)(jnp.arange(count))
    n = jnp.maximum(jnp.sum(usable), 1)
    rms = lambda e: jnp.sqrt(jnp.sum(jnp.where(usable, e**2, 0)) / n)  # noqa: E731
    return rms(predicted - true), rms(true)


def main(run_dir: str, out: str, rollouts: str = "1") -> None:
    import dataclasses

    from litl.envs import make
    from litl.latent.control import Episode, load
    from litl.latent.exploration import Exploration, explore, join
    from litl.latent.model import buffer_sequence, fit_sequence
    from litl.latent.planning import Goal
    from litl.latent.prediction import prediction_error

    run_dir = pathlib.Path(run_dir)
    robot, config, algorithm, seeds, state = load(run_dir, latent=False, features=True)
    codec = algorithm.observer.learner.latent if algorithm.observer.learner else None
    episode = Episode(robot, config, algorithm, Goal("walk", 1.0), "latent_mpc", None)
    dtype = jnp.dtype(config.sim.dtype.value)
    first = jax.tree.map(lambda leaf: leaf[0], state.observer)
    env, env_params = make(
        robot, episode.stride, None, "observer", dtype, observer=algorithm.observer, observer_params=first
    )
    control_dt = episode.stride * robot.config.dt
    steps = episode.control_steps
    sources = ["buffer", "explored", "both"] if codec is not None else ["explored"]
    steps_of = {source: 1 for source in sources}
    for k in (int(k) for k in rollouts.split(",")):
        if k != 1:
            sources.append(f"explored-rollout{k}")
            steps_of[sources[-1]] = k

    def one(observer, buffer, design, key):
        params = env_params.replace(design=robot.design_space.to_design(design, dtype), observer=observer)
        explored = explore(env, params, jax.random.fold_in(key, 1), Exploration(), steps)
        held = explore(env, params, jax.random.fold_in(key, 2), Exploration(episodes=HELD_OUT), steps)
        parts = {"explored": explored}
        if codec is not None:
            parts["buffer"] = buffer_sequence(codec, observer, buffer)
            parts["both"] = join(parts["buffer"], explored)
        result = {}
        for source in sources:
            mlp = dataclasses.replace(config.loop.dynamics.mlp, rollout=steps_of[source])
            settings = dataclasses.replace(config.loop.dynamics, mlp=mlp)
            data = parts[source.partition("-")[0]]
            model, _ = fit_sequence(data, key, settings, control_dt, "mlp")
            error = prediction_error(model.step, held.latents, held.actions, held.links, HORIZONS)
            moves = [displacement_errors(model, held, h) for h in HORIZONS]
            result[source] = {
                "latent": error.model,
                "constant_latent": error.constant,
                "displacement": jnp.stack([m[0] for m in moves]),
                "zero_motion": jnp.stack([m[1] for m in moves]),
            }
        return result

    keys = jax.vmap(lambda s: jax.random.fold_in(jax.random.key(s), 78))(jnp.asarray(seeds))
    results = jax.jit(jax.vmap(one))(state.observer, state.buffer, state.design, keys)
    summary = {
        "run_dir": run_dir.name,
        "observer": config.observer.kind,
        "horizons": HORIZONS,
        "held_out_episodes": HELD_OUT,
        "seeds": seeds,
        "sources": {
            source: {name: np.asarray(values, float).round(6).tolist() for name, values in parts.items()}
            for source, parts in results.items()
        },
    }
    pathlib.Path(out).write_text(json.dumps(summary, indent=1))
    for source, parts in summary["sources"].items():
        moved = np.mean(parts["displacement"], axis=0)
        still = np.mean(parts["zero_motion"], axis=0)
        print(source, "displacement RMS", moved.round(4), "zero motion", still.round(4))


if __name__ == "__main__":
    main(*sys.argv[1:])
