"""Colliders: a block on a slope against g (sin θ - μ cos θ), and what a world costs a rollout.

    python benchmarks/colliders.py                  # both tables
    python benchmarks/colliders.py --only incline   # the physics check only
    python benchmarks/colliders.py --only cost --repeats 5

Incline: a 2D elastic block (0.15 wide, E 2000, ν 0.3, dx 1/32) on a `HalfPlane` slope with
Coulomb friction μ; its acceleration down the slope is fitted (a quadratic in time) to its
centroid over 0.025-0.25 s, for the collider's contact band of 0 and 1 cell, and for the box's
friction floor wall under gravity tilted by θ (the walls' own contact). Theory: g (sin θ - μ cos θ),
0 when tan θ < μ.

Cost: the biped at dx 1/64 (its 1 s rollout, float32) forward and forward+backward through the
whole rollout, in the flat world and in `world=slope` / `steps` / `bumps` / `sand` / `water` (the last two: a
second body of 456 particles under the robot's 581), and the flat world with a moving slip paddle
behind the robot (a moving collider: its distance evaluated at every node and step): compile time apart,
medians of --repeats runs after compiling. The peak resident memory is the process's.
"""

from __future__ import annotations

import argparse
import math
import resource
import statistics
import time

import numpy as np

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def incline(theta_deg: float, mu: float, band: float | None, n_grid: int = 32) -> float:
    """The block's fitted acceleration down the slope (band None: the floor wall, gravity tilted)."""
    import jax
    import jax.numpy as jnp

    from litl.robots.primitives import sample_box
    from litl.sim import Body, Boundary, Design, SimConfig, SimState, Wall, make_rollout
    from litl.sim.colliders import Collider, HalfPlane

    theta, dx, size, seconds = math.radians(theta_deg), 1.0 / n_grid, 0.15, 0.25
    contact = Wall("friction", mu) if mu else Wall("slip")
    x = sample_box([0.0, 0.0], [size, size], dx, per_cell=2)
    down = np.array([-math.cos(theta), -math.sin(theta)])
    if band is None:  # the floor wall; gravity tilted instead of the ground
        x = x + np.array([0.45, 3.6 * dx])
        gravity = (-9.8 * math.sin(theta), -9.8 * math.cos(theta))
        boundary = Boundary.box(2, floor=contact, sides="slip")
        down = np.array([-1.0, 0.0])
    else:
        rotation = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
        normal = np.array([-math.sin(theta), math.cos(theta)])
        x = (x - [size / 2, 0.0]) @ rotation.T + np.array([0.55, 0.35]) + 0.6 * dx * normal
        gravity = (0.0, -9.8)
        boundary = Boundary.box(
            2, colliders=[Collider(HalfPlane((0.55, 0.35), tuple(normal)), contact, band)]
        )
    n = len(x)
    design = Design.uniform(n, 2000.0, 0.3, 1.0, [], jnp.float32)
    body = Body(
        volume=jnp.full((n,), (dx / 2) ** 2),
        actuator=jnp.full((n,), -1, jnp.int32),
        fiber=jnp.zeros((0, 2)),
        pinned=jnp.zeros((n,), bool),
    )
    mu_, lam = (float(p[0]) for p in design.lame())
    dt = 0.4 * dx / math.sqrt(lam + 2 * mu_)
    config = SimConfig((n_grid, n_grid), dx, dt, gravity, boundary=boundary)
    steps = int(seconds / dt)
    rollout = jax.jit(make_rollout(config, body, lambda p, s, g: jnp.zeros((0,)), steps))
    _, trajectory = rollout(None, design, SimState.at_rest(jnp.asarray(x, jnp.float32)))
    along = np.asarray(trajectory.observations) @ down
    t = np.arange(1, steps + 1) * dt
    window = t > 0.1 * seconds
    fit = np.stack([np.ones(window.sum()), t[window], 0.5 * t[window] ** 2], axis=1)
    return float(np.linalg.lstsq(fit, along[window], rcond=None)[0][2])


def incline_table() -> None:
    print("| θ | μ | theory (m/s²) | collider, band 1 | collider, band 0 | floor wall, gravity tilted |")
    print("|---|---|---|---|---|---|")
    for theta, mu in ((30, 0.0), (30, 0.2), (30, 0.4), (30, 0.8), (20, 0.2), (20, 0.5)):
        expected = max(9.8 * (math.sin(math.radians(theta)) - mu * math.cos(math.radians(theta))), 0.0)
        measured = [incline(theta, mu, band) for band in (1.0, 0.0, None)]
        print(
            f"| {theta}° | {mu} | {expected:.3f} | " + " | ".join(f"{a:.3f}" for a in measured) + " |",
            flush=True,
        )


def _with_paddle(robot):
    """The robot with a slip paddle behind it moving right at 0.05: what a moving collider (its
    distance evaluated at every node and step) costs beside the static ones."""
    import dataclasses

    from litl.sim import Wall
    from litl.sim.colliders import Box, Collider

    config = robot.config
    low = (config.boundary.thickness + 1) * config.dx
    back = float(robot.layout.positions[:, 0].min()) - 2 * config.dx
    paddle = Collider(Box((low, low), (back, 0.3)), Wall("slip"), velocity=(0.05, 0.0))
    boundary = dataclasses.replace(config.boundary, colliders=(*config.boundary.colliders, paddle))
    return dataclasses.replace(robot, config=dataclasses.replace(config, boundary=boundary))


def world_cost(repeats: int) -> None:
    import jax

    from litl.app import build_robot, compose

    print("| world | compile (s) | forward (s) | forward+backward (s) |")
    print("|---|---|---|---|")
    for world in ("flat", "slope", "steps", "bumps", "sand", "water", "flat + moving paddle"):
        robot = build_robot(compose([f"world={world.split()[0]}"]))
        if "paddle" in world:
            robot = _with_paddle(robot)
        scene = robot.scene()
        from litl.sim import make_rollout

        n = robot.n_actuators
        rollout = make_rollout(scene.config, scene.body, lambda p, s, g: jax.numpy.tanh(p), robot.steps)

        def loss(p, rollout=rollout, scene=scene, robot=robot):
            final, _ = rollout(p, scene.design, scene.state)
            return jax.numpy.mean(robot.own(final).x[:, 0])  # the robot's particles, not its bed's

        forward, gradient = jax.jit(loss), jax.jit(jax.grad(loss))
        params = jax.numpy.full((n,), 0.3)
        start = time.perf_counter()
        forward.lower(params).compile()
        gradient.lower(params).compile()
        compile_s = time.perf_counter() - start
        times = {}
        for name, fn in (("forward", forward), ("gradient", gradient)):
            jax.block_until_ready(fn(params))
            runs = []
            for _ in range(repeats):
                start = time.perf_counter()
                jax.block_until_ready(fn(params))
                runs.append(time.perf_counter() - start)
            times[name] = statistics.median(runs)
        print(f"| {world} | {compile_s:.1f} | {times['forward']:.3f} | {times['gradient']:.3f} |", flush=True)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak RSS {peak:.0f} MB; {jax.devices()[0].platform}, {jax.devices()[0].device_kind}")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--only", choices=("incline", "cost"))
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    if args.only in (None, "incline"):
        incline_table()
    if args.only in (None, "cost"):
        world_cost(args.repeats)


if __name__ == "__main__":
    main()
