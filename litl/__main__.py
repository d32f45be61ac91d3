"""`python -m litl`: a small, quick demo run on CPU.

Until the Hydra CLI lands, the default job optimizes the open-loop controller of the reference
walker (shared/reference/walker2d.md) with Adam through whole differentiable simulations and
writes the per-iteration losses to `<out>/metrics.jsonl`.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m litl", description=__doc__)
    parser.add_argument("--iterations", type=int, default=6, help="Adam steps (default 6)")
    parser.add_argument("--steps", type=int, default=1023, help="simulation steps per rollout")
    parser.add_argument("--learning-rate", type=float, default=0.05)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="outputs/walker2d", help="run directory")
    args = parser.parse_args(argv)
    if args.iterations < 1 or args.steps < 1 or not args.learning_rate > 0:
        parser.error("--iterations, --steps and --learning-rate must be positive")

    import jax
    import numpy as np
    import optax

    from litl.robots import walker2d
    from litl.sim import check_time_step, make_rollout, raise_if_unhealthy, validate

    scene = walker2d.build()
    validate(scene.config, scene.body, scene.design, scene.state)
    check_time_step(scene.config, scene.body, scene.design)
    rng = np.random.default_rng(args.seed)
    params = walker2d.params(rng.normal(0, 0.3, (walker2d.N_ACTUATORS, 4)),
                             rng.normal(0, 0.05, walker2d.N_ACTUATORS))
    rollout = make_rollout(scene.config, scene.body, walker2d.policy(), args.steps)

    def loss(p):
        final, trajectory = rollout(p, scene.design, scene.state)
        return walker2d.loss(final), trajectory.health

    optimizer = optax.adam(args.learning_rate)

    @jax.jit
    def update(p, opt_state):
        (value, health), grads = jax.value_and_grad(loss, has_aux=True)(p)
        updates, opt_state = optimizer.update(grads, opt_state, p)
        return optax.apply_updates(p, updates), opt_state, value, health

    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    opt_state = optimizer.init(params)
    start = time.perf_counter()
    with open(out / "metrics.jsonl", "w") as metrics:
        for iteration in range(args.iterations):
            params, opt_state, value, health = update(params, opt_state)
            raise_if_unhealthy(health, args.steps)
            record = {"iteration": iteration, "task_loss": float(value),
                      "distance": float(-value) - float(scene.state.x[:, 0].mean()),
                      "wall_s": round(time.perf_counter() - start, 3)}
            metrics.write(json.dumps(record) + "\n")
            metrics.flush()
            print(f"iteration {iteration}: loss {record['task_loss']:.5f} "
                  f"(walked {record['distance']:+.4f}) [{record['wall_s']:.1f} s]")
    print(f"metrics written to {out / 'metrics.jsonl'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
