"""Environment steps per second of `litl.envs` for vmapped batches of environments.

    python benchmarks/env_throughput.py                      # the biped at dx 1/32, batches 1, 64, 512
    python benchmarks/env_throughput.py --robot quadruped --dx 0.0625 --batches 1 16

One jitted, vmapped `env.step` (with its automatic reset) per call; `hold` simulation steps per
environment step (8). Compile time apart; the rate is the median over --repeats calls after it,
as environment steps (and simulation steps) per second summed over the batch; peak RSS is the
process's.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import time

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--robot", default="biped")
    parser.add_argument("--dx", type=float, default=1 / 32)
    parser.add_argument("--hold", type=int, default=8)
    parser.add_argument("--batches", type=int, nargs="+", default=[1, 64, 512])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()

    import jax
    import jax.numpy as jnp

    import litl.envs
    import litl.robots

    robot = litl.robots.get(args.robot, dx=args.dx)
    env, params = litl.envs.make(robot, hold=args.hold)
    print(
        f"{robot.name}, {robot.layout.n_particles} particles, hold {args.hold}; {jax.devices()[0].platform}"
    )
    print("| environments | compile (s) | env steps / s | simulation steps / s |")
    print("|---|---|---|---|")
    for batch in args.batches:
        keys = jax.random.split(jax.random.key(0), batch)
        _, state = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
        actions = jnp.full((batch, robot.n_actuators), 0.3)
        step = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))
        start = time.perf_counter()
        compiled = step.lower(keys, state, actions, params).compile()
        compile_s = time.perf_counter() - start
        out = compiled(keys, state, actions, params)
        jax.block_until_ready(out)
        runs = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            out = compiled(keys, out[1], actions, params)
            jax.block_until_ready(out)
            runs.append(time.perf_counter() - start)
        rate = batch / statistics.median(runs)
        print(f"| {batch} | {compile_s:.1f} | {rate:,.0f} | {rate * args.hold:,.0f} |", flush=True)
    print(f"\npeak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    main()
