"""Simulator speed: forward and forward+backward rollouts of reference-sized scenes.

    python benchmarks/sim_speed.py            # human-readable table
    python benchmarks/sim_speed.py --json     # one JSON object (see below)
    python benchmarks/sim_speed.py --scenes walker2d --repeats 3
    python benchmarks/sim_speed.py --scenes block3d_1m --steps 2 --particles 4000   # smoke
    python benchmarks/sim_speed.py --scenes walker2d quadruped3d --max-stretch 3  # strain limit's cost

Scenes:
  walker2d          the reference walker (tests/sim/data/walker2d.md), float32, 1023 steps
  quadruped3d       ~28k particles on a 64^3 grid, 511 steps, 16 actuators, neo-Hookean
  walker2d_vmap10   the walker with 10 different controllers, vmapped
  block3d_1m        throughput: an elastic block of 51^3 cells x 8 = 1,061,208 particles (or
                    --particles, rounded up to a cube of cells) on a 128^3 grid, 128 steps, the
                    gradient taken for every particle's Young's modulus; its backward pass keeps
                    ~13 GB of states. Run by default except on a CPU, where by the other scenes'
                    rates it would take tens of minutes on 2 cores.

For each scene: `compile_s` (lowering + XLA compilation of forward+backward), `forward_s` and
`forward_backward_s` (medians over --repeats runs after compilation), the same as particle-steps
per second (`forward_particle_steps_per_s`, `forward_backward_particle_steps_per_s`: particles x
steps x batch / time), `peak_rss_mb` (peak resident memory of a fresh process that ran only that
scene; on a GPU, `peak_device_mb` from the device's allocator where it reports one) and `device`
(platform and kind of `jax.devices()[0]`). `--max-stretch S` runs the scenes with the strain limit
`SimConfig.max_stretch` = S (the catalog robots' is 3; the scenes' own have none), to measure its
cost. Each scene runs in its own process, so that the
parent never starts the accelerator (JAX would reserve most of a GPU's memory for it).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import time

import numpy as np

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)

SCENES = ("walker2d", "quadruped3d", "walker2d_vmap10", "block3d_1m")
# Run on a CPU when --scenes is not given (elsewhere: all), leaving out the throughput scene.
CPU_SCENES = ("walker2d", "quadruped3d", "walker2d_vmap10")
BLOCK_PARTICLES = 1_048_576


def _walker(n_policies: int | None, steps: int, max_stretch: float | None = None, p2g: str = "scatter"):
    import dataclasses

    import jax
    import jax.numpy as jnp

    from litl.robots import walker2d
    from litl.sim import make_rollout

    scene = walker2d.build(jnp.float32)
    own = dataclasses.replace(scene.config.own_material, max_stretch=max_stretch)
    config = dataclasses.replace(scene.config.with_own_material(own), particle_to_grid=p2g)
    scene = dataclasses.replace(scene, config=config)
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
    return forward, gradient, params, (n_policies or 1) * scene.body.n_particles


def quadruped_scene(dtype=None):
    """A box body on four legs, each leg split into 4 actuated quarters (16 actuators)."""
    import jax.numpy as jnp

    from litl.robots.primitives import sample_box
    from litl.sim import Body, Boundary, Design, Elastic, SimConfig, SimState, Wall

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
        grid_shape=(64, 64, 64),
        dx=dx,
        dt=0.5 * dx / speed,
        gravity=(0.0, -9.8, 0.0),
        boundary=Boundary.box(3, floor=Wall("friction", 0.5), sides="sticky"),
        materials=(Elastic("neo_hookean"),),
    )
    return config, body, design, SimState.at_rest(jnp.asarray(x, dtype))


def _quadruped(steps: int, max_stretch: float | None = None, p2g: str = "scatter"):
    import dataclasses

    import jax
    import jax.numpy as jnp

    from litl.sim import make_rollout

    config, body, design, state = quadruped_scene()
    config = config.with_own_material(dataclasses.replace(config.own_material, max_stretch=max_stretch))
    config = dataclasses.replace(config, particle_to_grid=p2g)

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

    return loss, jax.value_and_grad(loss, has_aux=True), params, body.n_particles


def block_scene(particles: int = BLOCK_PARTICLES, n_grid: int = 128, dtype=None):
    """An elastic cube of at least `particles` particles (8 per cell) on an `n_grid`^3 grid, on the
    floor, its lower half one actuator (fibers up): the throughput scene, where particle-to-grid
    scatters to 27 nodes per particle with 8 particles per cell."""
    import jax.numpy as jnp

    from litl.robots.primitives import sample_box
    from litl.sim import Body, Boundary, Design, SimConfig, SimState

    dtype = dtype or jnp.float32
    dx = 1.0 / n_grid
    cells = math.ceil((particles / 8) ** (1 / 3) - 1e-9)  # cells per side, 2^3 particles each
    if not 0 < cells <= n_grid - 16:
        raise SystemExit(
            f"--particles {particles} does not fit a {n_grid}^3 grid (1 to "
            f"{8 * (n_grid - 16) ** 3} particles)"
        )
    # Half a cell more than `cells` so that sample_box's int(size / dx) is `cells`, not one less.
    size = (cells + 0.5) * dx
    x = sample_box([(n_grid - cells) / 2 * dx, 4 * dx, (n_grid - cells) / 2 * dx], [size] * 3, dx)
    n = len(x)
    youngs, poisson, density = 3000.0, 0.3, 1.0
    strength = 0.2 * youngs  # an active strain of 0.15 (safety's bound: 0.2)
    design = Design.uniform(n, youngs, poisson, density, [strength], dtype)
    body = Body(
        volume=jnp.full((n,), (dx / 2) ** 3, dtype),
        actuator=jnp.asarray(np.where(x[:, 1] < 4 * dx + size / 2, 0, -1), jnp.int32),
        fiber=jnp.asarray([[0.0, 1.0, 0.0]], dtype),
        pinned=jnp.zeros((n,), bool),
    )
    mu, lam = (float(p[0]) for p in design.lame())
    speed = math.sqrt((lam + 2 * mu + strength) / density)
    config = SimConfig(
        grid_shape=(n_grid,) * 3,
        dx=dx,
        dt=0.4 * dx / speed,
        gravity=(0.0, -9.8, 0.0),
        boundary=Boundary.box(3, floor="sticky", sides="sticky"),
    )
    return config, body, design, SimState.at_rest(jnp.asarray(x, dtype))


def block_problem(steps: int, particles: int, n_grid: int = 128, checkpoint_every: int | None = None):
    """`block_scene`'s loss (mean final x), its value_and_grad for every particle's Young's
    modulus, that (n,) modulus and n (`benchmarks/memory_scale.py` uses it too)."""
    import jax
    import jax.numpy as jnp

    from litl.sim import make_rollout

    config, body, design, state = block_scene(particles, n_grid)

    def pulse(params, state, grid_velocity):
        # One contraction per 128 steps, the default length.
        return jnp.sin(state.step.astype(jnp.float32) * (2 * math.pi / 128))[None]

    rollout = make_rollout(config, body, pulse, steps, checkpoint_every=checkpoint_every)

    def loss(youngs):
        final, trajectory = rollout(None, design.replace(youngs_modulus=youngs), state)
        return jnp.mean(final.x[:, 0]), trajectory.health

    return loss, jax.value_and_grad(loss, has_aux=True), design.youngs_modulus, body.n_particles


def device_info() -> dict:
    """Platform ("cpu", "gpu", ...) and kind ("NVIDIA H100 80GB HBM3", ...) of the first device."""
    import jax

    device = jax.devices()[0]
    return {
        "platform": device.platform,
        "device_kind": device.device_kind,
        "device_count": jax.device_count(),
        "determinism": litl.backend.mode(),
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
    }


def _peak_device_mb():
    import jax

    stats = jax.devices()[0].memory_stats() or {}  # None on CPU
    peak = stats.get("peak_bytes_in_use")
    return None if peak is None else round(peak / 2**20, 1)


def run_scene(
    name: str,
    repeats: int,
    steps: int | None,
    particles: int = BLOCK_PARTICLES,
    max_stretch: float | None = None,
    p2g: str = "scatter",
) -> dict:
    import jax

    from litl.sim import raise_if_unhealthy

    # batch_particles: particles simulated per step, over all vmapped rollouts.
    if name == "walker2d":
        steps = steps or 1023
        forward, gradient, params, batch_particles = _walker(None, steps, max_stretch, p2g)
    elif name == "walker2d_vmap10":
        steps = steps or 1023
        forward, gradient, params, batch_particles = _walker(10, steps, max_stretch, p2g)
    elif name == "quadruped3d":
        steps = steps or 511
        forward, gradient, params, batch_particles = _quadruped(steps, max_stretch, p2g)
    elif name == "block3d_1m":
        if max_stretch is not None or p2g != "scatter":
            raise SystemExit("--max-stretch and --particle-to-grid apply to the walker and quadruped scenes")
        steps = steps or 128
        forward, gradient, params, batch_particles = block_problem(steps, particles)
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
    particle_steps = batch_particles * steps
    return {
        "forward_s": round(forward_s, 4),
        "forward_backward_s": round(forward_backward_s, 4),
        "compile_s": round(compile_s, 2),
        "particles": batch_particles,
        "steps": steps,
        "forward_particle_steps_per_s": float(f"{particle_steps / forward_s:.4g}"),
        "forward_backward_particle_steps_per_s": float(f"{particle_steps / forward_backward_s:.4g}"),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "peak_device_mb": _peak_device_mb(),
        "repeats": repeats,
        "device": device_info(),
    }


def _child(arguments: list[str]) -> dict:
    """Run this script with `arguments` in a fresh process; its last stdout line, as JSON."""
    command = [sys.executable, __file__, *arguments]
    done = subprocess.run(command, capture_output=True, text=True, env=os.environ.copy())
    if done.returncode:
        raise SystemExit(f"{' '.join(arguments)} failed:\n{done.stderr[-4000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None):
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--scenes",
        nargs="+",
        default=None,
        choices=SCENES,
        help=f"default: {' '.join(CPU_SCENES)} on a CPU, all scenes elsewhere",
    )
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per measurement (>= 1)")
    parser.add_argument("--steps", type=int, default=None, help="override the steps (smoke runs)")
    parser.add_argument(
        "--particles",
        type=int,
        default=BLOCK_PARTICLES,
        help="at least this many particles in block3d_1m (smoke runs: e.g. 4000)",
    )
    parser.add_argument(
        "--max-stretch",
        type=float,
        default=None,
        help="run the scenes with this strain limit (SimConfig.max_stretch; default: none)",
    )
    parser.add_argument(
        "--particle-to-grid",
        choices=("scatter", "fixed_point"),
        default="scatter",
        help="how particle-to-grid sums (SimConfig.particle_to_grid; default: scatter)",
    )
    parser.add_argument("--one", help=argparse.SUPPRESS)  # internal: run one scene in-process
    parser.add_argument("--device-info", action="store_true", help=argparse.SUPPRESS)  # internal
    args = parser.parse_args(argv)
    if args.repeats < 1 or (args.steps is not None and args.steps < 1) or args.particles < 1:
        parser.error("--repeats, --steps and --particles must be positive")
    if args.device_info:
        print(json.dumps(device_info()))
        return
    if args.one:
        measured = run_scene(
            args.one, args.repeats, args.steps, args.particles, args.max_stretch, args.particle_to_grid
        )
        print(json.dumps(measured))
        return
    device = _child(["--device-info"])
    scenes = args.scenes or (CPU_SCENES if device["platform"] == "cpu" else SCENES)
    results = {}
    for name in scenes:
        command = ["--one", name, "--repeats", str(args.repeats), "--particles", str(args.particles)]
        if args.steps:
            command += ["--steps", str(args.steps)]
        if args.max_stretch is not None:
            command += ["--max-stretch", str(args.max_stretch)]
        command += ["--particle-to-grid", args.particle_to_grid]
        results[name] = _child(command)
    if args.json:
        print(json.dumps(results))
        return
    print(
        f"device: {device['device_kind']} ({device['platform']}, {device['device_count']} "
        f"device{'s' if device['device_count'] > 1 else ''}; the first one is used)"
    )
    print(
        f"{'scene':18s} {'forward_s':>10s} {'fwd+bwd_s':>10s} {'compile_s':>10s} {'peak_MB':>9s} "
        f"{'fwd_Mps/s':>10s} {'f+b_Mps/s':>10s}"
    )
    for name, r in results.items():
        peak = r["peak_device_mb"] if r["peak_device_mb"] is not None else r["peak_rss_mb"]
        print(
            f"{name:18s} {r['forward_s']:10.3f} {r['forward_backward_s']:10.3f} "
            f"{r['compile_s']:10.1f} {peak:9.0f} "
            f"{r['forward_particle_steps_per_s'] / 1e6:10.2f} "
            f"{r['forward_backward_particle_steps_per_s'] / 1e6:10.2f}"
        )
    print(
        "Mps/s: million particle-steps per second; peak_MB: the device's peak where it reports "
        "one, else the process's peak resident memory"
    )


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    main()
