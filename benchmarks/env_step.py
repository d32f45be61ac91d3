"""What a differentiated `litl.envs` step costs: the oracle planner's inner loop.

    python benchmarks/env_step.py            # biped at dx 1/64 (the demo run's), hold 20, horizon 5
    python benchmarks/env_step.py --robot quadruped --dx 0.0625 --hold 8 --horizon 2

Times, per simulation step, a plan of `--horizon` environment steps (each action held for
`--hold` simulation steps) run forward, and run with its gradient with respect to the actions
(`jax.value_and_grad`, what `litl.latent.planning.true_plan_cost` asks of the environment).
Beside them, the same simulation steps scanned through the public packed step
(`litl.sim.make_step`, which unpacks and packs the (n, d) arrays every step, as `litl.envs` did
before 2026-12-07): the reference the environment's component-carrying step is measured against.
Medians of --repeats calls after compiling; compile time apart; peak RSS at the end.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import time

import jax
import jax.numpy as jnp

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def _time(function, arguments, repeats: int) -> dict:
    started = time.perf_counter()
    compiled = jax.jit(function).lower(*arguments).compile()
    compile_s = time.perf_counter() - started
    calls = []
    for _ in range(repeats):
        started = time.perf_counter()
        jax.block_until_ready(compiled(*arguments))
        calls.append(time.perf_counter() - started)
    return {"compile_s": round(compile_s, 2), "median_s": statistics.median(calls)}


def main() -> None:
    from litl.envs import make
    from litl.sim import make_step

    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--robot", default="biped")
    parser.add_argument("--dx", type=float, default=1 / 64)
    parser.add_argument("--hold", type=int, default=20)
    parser.add_argument("--horizon", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    env, params = make(args.robot, hold=args.hold, dx=args.dx)
    key = jax.random.key(0)
    _, start = env.reset(key, params)
    actions = jnp.full((args.horizon, env.num_actions), 0.3, env.dtype)

    def env_cost(actions):
        def forward(state, action):
            state = env.step_env(key, state, action, params)[1]
            return state, jnp.mean(state.sim.x[:, 0])

        _, positions = jax.lax.scan(forward, start, actions)
        return jnp.mean(positions)

    packed_step = make_step(env._scene.config, env._scene.body)

    def packed_cost(actions):
        def forward(sim, action):
            def one(sim, _):
                return packed_step(sim, action, params.design)[0], None

            sim, _ = jax.lax.scan(one, sim, None, length=args.hold)
            return sim, jnp.mean(sim.x[:, 0])

        _, positions = jax.lax.scan(forward, start.sim, actions)
        return jnp.mean(positions)

    steps = args.horizon * args.hold
    rows = {}
    for name, function in (
        ("env forward", env_cost),
        ("env value_and_grad", jax.value_and_grad(env_cost)),
        ("packed step forward", packed_cost),
        ("packed step value_and_grad", jax.value_and_grad(packed_cost)),
    ):
        row = _time(function, (actions,), args.repeats)
        row["ms_per_sim_step"] = round(1e3 * row.pop("median_s") / steps, 3)
        rows[name] = row
        print(name, row, flush=True)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    report = {
        "robot": args.robot,
        "dx": args.dx,
        "particles": int(start.sim.x.shape[0]),
        "hold": args.hold,
        "horizon": args.horizon,
        "backend": jax.default_backend(),
        "rows": rows,
        "peak_rss_mb": round(peak_mb),
    }
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
