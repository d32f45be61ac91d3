"""Where does the simulator stay finite? Aggressive controllers on the biped, by material and dt.

    python benchmarks/sim_stability.py                                  # the catalog's biped
    python benchmarks/sim_stability.py --youngs 5 15 30 --strength 4    # the old material
    python benchmarks/sim_stability.py --dt-factor 1.28 --controllers 8  # the old time step

For each Young's modulus E (every design region), one batch (vmapped) of rollouts with
backpropagation of the biped's task loss: the trained gait that blew the old biped up (from
`tests/sim/test_stability.py`) and `--controllers` random open-loop sinusoid controllers with
weights up to 4 (nearly bang-bang actuation) and frequencies 10–60 rad/s. Reported per E:

  cfl, strain   the CFL number c dt / dx and the active strain strength / (lambda + 2 mu)
                (`litl.sim.safety`: accepted up to 0.75 and 0.2)
  failed        rollouts that blew up, lost particles or gave a non-finite gradient
  inverted      rollouts in which some particle's det F went below 0
  det_p5        5th percentile over rollouts of the smallest det F reached (crushing)
  distance      median distance travelled
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import pathlib
import sys

import jax
import jax.numpy as jnp
import numpy as np

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def controllers(count: int, seed: int = 0):
    # The trained gait lives with its regression test; the repository root makes it importable.
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))
    from tests.sim.test_stability import TRAINED_BIAS, TRAINED_WEIGHTS

    keys = jax.random.split(jax.random.key(seed), 3)
    amplitude = jnp.linspace(0.5, 4.0, count)[:, None, None]
    weights = jnp.concatenate(
        [jnp.asarray(TRAINED_WEIGHTS)[None], amplitude * jax.random.normal(keys[0], (count, 4, 4))]
    )
    bias = jnp.concatenate([jnp.asarray(TRAINED_BIAS)[None], jax.random.normal(keys[1], (count, 4))])
    omega = jnp.concatenate([jnp.array([30.0]), jax.random.uniform(keys[2], (count,), minval=10, maxval=60)])
    return weights, bias, omega


def measure(robot, youngs: float, strength: float | None, dt_factor: float, params) -> dict:
    from litl.sim import make_rollout
    from litl.sim.safety import wave_speed

    config = dataclasses.replace(robot.config, dt=robot.config.dt * dt_factor)
    steps = int(round(robot.steps / dt_factor))
    design = robot.design_space.to_design(robot.design_space.uniform(youngs))
    if strength is not None:
        design = design.replace(actuator_strength=jnp.full_like(design.actuator_strength, strength))
    scene = robot.scene()

    def policy(p, state, grid_velocity):
        weights, bias, omega = p
        time = state.step.astype(jnp.float32) * config.dt
        phases = omega * time + 2 * math.pi * jnp.arange(4) / 4
        return jnp.tanh(weights @ jnp.sin(phases) + bias)

    def smallest_det(state):
        F = state.F
        return jnp.min(F[:, 0, 0] * F[:, 1, 1] - F[:, 0, 1] * F[:, 1, 0])

    rollout = make_rollout(config, scene.body, policy, steps, observe=smallest_det)
    task_loss = robot.task_loss()

    def loss(p):
        final, trajectory = rollout(p, design, scene.state)
        return task_loss(scene.state, final)[0], trajectory

    (value, trajectory), grad = jax.jit(jax.vmap(jax.value_and_grad(loss, has_aux=True)))(params)
    grad_norm = np.sqrt(
        sum(np.sum(np.asarray(g) ** 2, axis=tuple(range(1, g.ndim))) for g in jax.tree.leaves(grad))
    )
    health = trajectory.health
    failed = (
        (np.asarray(health.first_nonfinite_step) >= 0)
        | (np.asarray(health.first_escape_step) >= 0)
        | ~np.isfinite(grad_norm)
    )
    det = np.asarray(trajectory.observations).min(axis=1)
    mu, lam = (float(np.asarray(p)[0]) for p in design.lame())
    return {
        "youngs": youngs,
        "cfl": wave_speed(scene.body, design) * config.dt / config.dx,
        "strain": float(np.max(np.asarray(design.actuator_strength))) / (lam + 2 * mu),
        "failed": int(failed.sum()),
        "rollouts": len(failed),
        "trained_gait_failed": bool(failed[0]),
        "inverted": int(np.sum(det < 0)),
        "det_p5": float(np.nanpercentile(np.where(failed, np.nan, det), 5)) if (~failed).any() else None,
        "distance": float(np.nanmedian(-np.asarray(value))),
    }


def main():
    import litl.robots

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--youngs", nargs="+", type=float, default=[15.0, 20.0, 30.0])
    parser.add_argument(
        "--strength", type=float, default=None, help="actuator strength (default: the robot's)"
    )
    parser.add_argument("--dt-factor", type=float, default=1.0, help="multiply the robot's dt")
    parser.add_argument("--controllers", type=int, default=32)
    parser.add_argument("--dx", type=float, default=1 / 64)
    args = parser.parse_args()
    robot = litl.robots.get("biped", dx=args.dx)
    params = controllers(args.controllers)
    print(
        f"device: {jax.devices()[0].device_kind}; biped dx = {args.dx:g}, "
        f"dt = {robot.config.dt * args.dt_factor:g}"
    )
    print(
        f"{'E':>5s} {'cfl':>5s} {'strain':>6s} {'failed':>8s} {'gait':>5s} {'inverted':>8s} "
        f"{'det_p5':>7s} {'distance':>8s}"
    )
    for youngs in args.youngs:
        r = measure(robot, youngs, args.strength, args.dt_factor, params)
        det = f"{r['det_p5']:7.3f}" if r["det_p5"] is not None else "    n/a"
        print(
            f"{youngs:5g} {r['cfl']:5.2f} {r['strain']:6.3f} {r['failed']:>3d}/{r['rollouts']:<4d} "
            f"{'FAIL' if r['trained_gait_failed'] else 'ok':>5s} {r['inverted']:8d} {det} "
            f"{r['distance']:8.3f}"
        )


if __name__ == "__main__":
    main()
