"""Where the `stop` candidate's non-finite controller gradient comes from (seed 100, episode 2).

    python probe.py RUN_DIR grad STEPS...   # task loss and gradient norms, float32 and float64,
                                            # for rollouts cut at each of STEPS
    python probe.py RUN_DIR where           # float32 forward, jit alone and jit of vmap (as the
                                            # loop runs it): first non-finite / escaped step

RUN_DIR: a run of `python -m litl experiment=fig4b_biped variant=vae method=paper seeds=1
controller.mlp.feature_gradient=stop seed=100 loop.episodes=3` (commit 1af005e) whose newest
checkpoint is the one after 2 episodes (move checkpoints/3 aside): the parameters at which every
iteration of episode 2 was skipped for a non-finite gradient.
"""

import json
import pathlib
import sys

import jax
import jax.numpy as jnp
import numpy as np
import optax

from litl.app import build_robot
from litl.config import DType
from litl.loop import make_algorithm, stack_seeds
from litl.loop.checkpoint import Checkpoints
from litl.replay import load_run_config


def newest_checkpoint(run: pathlib.Path):
    robot, config = load_run_config(run)
    algorithm = make_algorithm(robot, config.algorithm)
    checkpoints = Checkpoints(run / "checkpoints")
    counters = {
        "episodes_done": 0,
        "metrics_lines": 0,
        "learning_lines": 0,
        "loss_before_retrain": np.zeros(1),
    }
    print("checkpoint after episodes:", checkpoints.latest(), flush=True)
    state, _ = checkpoints.restore(stack_seeds([algorithm.init(config.seed)]), counters)
    checkpoints.close()
    one = jax.tree.map(lambda a: np.asarray(a)[0], state)
    return robot, config, (one.controller, one.design, one.observer)


def grad(run: pathlib.Path, steps_list: list[int]) -> None:
    _, config, params = newest_checkpoint(run)
    for dtype in (DType.float32, DType.float64):
        for steps in steps_list:
            with jax.enable_x64(dtype == DType.float64):
                cfg = config.replace(sim={"dtype": dtype, "steps": steps})
                algorithm = make_algorithm(build_robot(cfg), cfg.algorithm)
                f = jnp.float64 if dtype == DType.float64 else jnp.float32
                p = jax.tree.map(
                    lambda a, f=f: (
                        jnp.asarray(a, f) if np.issubdtype(np.asarray(a).dtype, np.floating) else a
                    ),
                    params,
                )
                loss = lambda c, d, o, algorithm=algorithm: algorithm.simulate(c, d, o)[0]  # noqa: E731
                value, (gc, gd) = jax.jit(jax.value_and_grad(loss, argnums=(0, 1)))(*p)
            print(
                json.dumps(
                    {
                        "dtype": dtype.value,
                        "steps": steps,
                        "loss": float(value),
                        "controller_grad_norm": float(optax.tree.norm(gc)),
                        "design_grad_norm": float(optax.tree.norm(gd)),
                    }
                ),
                flush=True,
            )


def where(run: pathlib.Path) -> None:
    robot, config, params = newest_checkpoint(run)
    algorithm = make_algorithm(robot, config.algorithm)
    simulate = lambda c, d, o: algorithm.simulate(c, d, o)  # noqa: E731
    for name, fn, args in [
        ("jit", jax.jit(simulate), params),
        ("jit of vmap", jax.jit(jax.vmap(simulate)), jax.tree.map(lambda a: jnp.asarray(a)[None], params)),
    ]:
        total, (_, trajectory) = fn(*args)
        health = jax.tree.map(lambda a: np.asarray(a).reshape(-1)[0].item(), trajectory.health)
        print(
            json.dumps(
                {
                    "forward": name,
                    "loss": float(np.asarray(total).reshape(-1)[0]),
                    "first_nonfinite_step": health.first_nonfinite_step,
                    "first_escape_step": health.first_escape_step,
                }
            ),
            flush=True,
        )


if __name__ == "__main__":
    run_dir = pathlib.Path(sys.argv[1])
    if sys.argv[2] == "grad":
        grad(run_dir, [int(s) for s in sys.argv[3:]])
    else:
        where(run_dir)
