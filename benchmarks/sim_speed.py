"""Simulator speed: forward and forward+backward rollouts of reference-sized scenes.

    python benchmarks/sim_speed.py            # human-readable table
    python benchmarks/sim_speed.py --json     # one JSON object (see below)
    python benchmarks/sim_speed.py --scenes walker2d --repeats 3

Scenes:
  walker2d          the reference walker (shared/reference/walker2d.md), float32, 1023 steps
  quadruped3d       ~28k particles on a 64^3 grid, 511 steps, 16 actuators, neo-Hookean
  walker2d_vmap10   the walker with 10 different controllers, vmapped

For each scene: `compile_s` (lowering + XLA compilation of forward+backward), `forward_s` and
`forward_backward_s` (medians over --repeats runs after compilation) and `peak_rss_mb` (peak
resident memory of a fresh process that ran only that scene). Each scene runs in its own process.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time

import numpy as np

SCENES = ("walker2d", "quadruped3d", "walker2d_vmap10")


def _walker(n_policies: int | None, steps: int):
    import jax
    import jax.numpy as jnp

    from litl.robots import walker2d
    from litl.sim import make_rollout

    scene = walker2d.build(jnp.float32)
    rng = np.random.default_rng(0)
    weights = rng.normal(0, 0.3, (walker2d.N_ACTUATORS, 4))
    bias = rng.normal(0, 0.05, walker2d.N_ACTUATORS)
    params = walker2d.params(weights, bias)
    rollout = make_rollout(scene.config, scene.body, walker2d.policy(), steps)

    def loss(p):
        final, trajectory = rollout(p, scene.design, scene.state)
        return walker2d.loss(final), trajectory.health

    if n_policies:
        params = jax.tree.map(
            lambda a: a + jnp.asarray(rng.normal(0, 0.05, (n_policies,) + a.shape), a.dtype), params
        )
        total = lambda p: jnp.sum(jax.vmap(lambda q: loss(q)[0])(p))
        forward = jax.vmap(loss)
        gradient = jax.value_and_grad(total)
    else:
        forward = loss
        gradient = jax.value_and_grad(loss, has_aux=True)
    return forward, gradient, params


def quadruped_scene(dtype=None):
    """A box body on four legs, each leg split into 4 actuated quarters (16 actuators)."""
    import jax.numpy as jnp

    from litl.robots.primitives import sample_box
    from litl.sim import Body, Boundary, Design, SimConfig, SimState, Wall

    dtype = dtype or jnp.float32
    dx = 1.0 / 64
    floor = 3 * dx
    leg_height, leg_size = 0.12, 0.08
    parts = [sample_box([0.2, floor + leg_height, 0.3], [0.4, 0.12, 0.25], dx)]
    actuators = [np.full(len(parts[0]), -1)]
    for leg, (x0, z0) in enumerate([(0.2, 0.3), (0.52, 0.3), (0.2, 0.47), (0.52, 0.47)]):
        points = sample_box([x0, floor, z0], [leg_size, leg_height, leg_size], dx)
        # Quarters around the leg's vertical axis: front/back (x) by left/right (z).
        quarter = 2 * (points[:, 0] > x0 + leg_size / 2) + (points[:, 2] > z0 + leg_size / 2)
        parts.append(points)
        actuators.append(4 * leg + quarter)
    x = np.concatenate(parts)
    actuator = np.concatenate(actuators).astype(np.int32)
    n = len(x)
    youngs, poisson, density = 3000.0, 0.3, 1.0
    design = Design.uniform(n, youngs, poisson, density, [0.3 * youngs] * 16, dtype)
    body = Body(
        volume=jnp.full((n,), (dx / 2) ** 3, dtype),
        actuator=jnp.asarray(actuator),
        fiber=jnp.asarray(np.tile([0.0, 1.0, 0.0], (16, 1)), dtype),
        pinned=jnp.zeros((n,), bool),
    )
    mu, lam = (float(p[0]) for p in design.lame())
    speed = np.sqrt((lam + 2 * mu + 0.3 * youngs) / density)
    config = SimConfig(
        grid_shape=(64, 64, 64), dx=dx, dt=0.5 * dx / speed, gravity=(0.0, -9.8, 0.0),
        boundary=Boundary.box(3, floor=Wall("friction", 0.5), sides="sticky"),
        constitutive_model="neo_hookean",
    )
    return config, body, design, SimState.at_rest(jnp.asarray(x, dtype))


def _quadruped(steps: int):
    import jax
    import jax.numpy as jnp

    from litl.sim import make_rollout

    config, body, design, state = quadruped_scene()

    def policy(params, state, grid_velocity):
        t = state.step.astype(jnp.float32) * config.dt
        return jnp.tanh(params["amplitude"] * jnp.sin(20.0 * t + params["phase"]))

    rng = np.random.default_rng(0)
    params = {
        "amplitude": jnp.asarray(rng.uniform(0.5, 1.0, 16), jnp.float32),
        "phase": jnp.asarray(rng.uniform(0, 2 * np.pi, 16), jnp.float32),
    }
    rollout = make_rollout(config, body, policy, steps)

    def loss(p):
        final, trajectory = rollout(p, design, state)
        return -jnp.mean(final.x[:, 0]), trajectory.health

    return loss, jax.value_and_grad(loss, has_aux=True), params


def run_scene(name: str, repeats: int, steps: int | None) -> dict:
    import jax

    from litl.sim import raise_if_unhealthy

    if name == "walker2d":
        forward, gradient, params = _walker(None, steps or 1023)
    elif name == "walker2d_vmap10":
        forward, gradient, params = _walker(10, steps or 1023)
    elif name == "quadruped3d":
        forward, gradient, params = _quadruped(steps or 511)
    else:
        raise SystemExit(f"unknown scene {name!r}; choose from {SCENES}")

    start = time.perf_counter()
    gradient_compiled = jax.jit(gradient).lower(params).compile()
    compile_s = time.perf_counter() - start
    forward_compiled = jax.jit(forward).lower(params).compile()

    def timed(fn):
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            out = jax.block_until_ready(fn(params))
            times.append(time.perf_counter() - start)
        return statistics.median(times), out

    forward_s, (_, health) = timed(forward_compiled)
    raise_if_unhealthy(health)
    forward_backward_s, _ = timed(gradient_compiled)
    return {
        "forward_s": round(forward_s, 4),
        "forward_backward_s": round(forward_backward_s, 4),
        "compile_s": round(compile_s, 2),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "repeats": repeats,
        "device": str(jax.devices()[0].platform),
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=SCENES)
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per measurement (>= 1)")
    parser.add_argument("--steps", type=int, default=None, help="override the steps (smoke runs)")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # internal: run one scene in-process
    args = parser.parse_args(argv)
    if args.repeats < 1 or (args.steps is not None and args.steps < 1):
        parser.error("--repeats and --steps must be positive")
    if args.one:
        print(json.dumps(run_scene(args.one, args.repeats, args.steps)))
        return
    results = {}
    for name in args.scenes:
        command = [sys.executable, __file__, "--one", name, "--repeats", str(args.repeats)]
        if args.steps:
            command += ["--steps", str(args.steps)]
        done = subprocess.run(command, capture_output=True, text=True, env=os.environ.copy())
        if done.returncode:
            raise SystemExit(f"scene {name} failed:\n{done.stderr[-4000:]}")
        results[name] = json.loads(done.stdout.strip().splitlines()[-1])
    if args.json:
        print(json.dumps(results))
        return
    print(f"{'scene':18s} {'forward_s':>10s} {'fwd+bwd_s':>10s} {'compile_s':>10s} {'peak_MB':>9s}")
    for name, r in results.items():
        print(f"{name:18s} {r['forward_s']:10.3f} {r['forward_backward_s']:10.3f} "
              f"{r['compile_s']:10.1f} {r['peak_rss_mb']:9.0f}")


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    main()
