"""Where does the simulator stay finite? Aggressive controllers on the biped, by material and dt.

    python benchmarks/sim_stability.py                                  # the catalog's biped
    python benchmarks/sim_stability.py --youngs 5 15 30 --strength 4    # the old material
    python benchmarks/sim_stability.py --dt-factor 1.28 --controllers 8  # the old time step
    python benchmarks/sim_stability.py --dx 0.0078125 --controllers 512 --forward-only \
        --max-stretch none 3 2.5                                        # the strain limit

For each Young's modulus E (every design region), one batch (vmapped) of rollouts with
backpropagation of the biped's task loss: the trained gait that blew the old biped up (from
`tests/sim/test_stability.py`) and `--controllers` random open-loop sinusoid controllers with
weights up to 4 (nearly bang-bang actuation) and frequencies 10–60 rad/s. Reported per E:

  cfl, strain   the CFL number c dt / dx and the active strain strength / (lambda + 2 mu)
                (`litl.sim.safety`: accepted up to 0.75 and 0.2)
  failed        rollouts that blew up, lost particles or gave a non-finite gradient
  inverted      rollouts in which some particle's det F went below 0
  det_p5        5th percentile over rollouts of the smallest det F reached (crushing)
  stretch       largest singular value of F reached per rollout (before any failure): median and
                90th percentile over the healthy rollouts
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


def measure(
    robot, youngs: float, strength: float | None, dt_factor: float, params, max_stretch, forward_only=False
) -> dict:
    from litl.sim import linalg, make_rollout
    from litl.sim.safety import wave_speed
    from litl.sim.stretch import largest_stretch

    config = dataclasses.replace(robot.config, dt=robot.config.dt * dt_factor)
    config = config.with_own_material(dataclasses.replace(config.own_material, max_stretch=max_stretch))
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

    def deformation(state):
        F = linalg.split_mat(state.F)
        return jnp.stack([jnp.min(linalg.det(F)), jnp.max(largest_stretch(F))])

    rollout = make_rollout(config, scene.body, policy, steps, observe=deformation)
    task_loss = robot.task_loss()

    def loss(p):
        final, trajectory = rollout(p, design, scene.state)
        return task_loss(scene.state, final)[0], trajectory

    if forward_only:
        value, trajectory = jax.jit(jax.vmap(loss))(params)
        grad_norm = np.zeros(len(value))
    else:
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
    observed = np.asarray(trajectory.observations)
    det = observed[:, :, 0].min(axis=1)
    # The largest stretch before a failure (after it, F holds whatever the blow-up left).
    escape = np.asarray(health.first_escape_step)
    stretch = np.array(
        [o[: e if e >= 0 else None, 1].max(initial=1.0) for o, e in zip(observed, escape, strict=True)]
    )
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
        "stretch": np.percentile(stretch[~failed], [50, 90]) if (~failed).any() else None,
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
    parser.add_argument(
        "--max-stretch",
        nargs="+",
        default=["robot"],
        help="strain limits to compare (SimConfig.max_stretch): numbers, 'none' (no limit) or "
        "'robot' (the robot's own, the default)",
    )
    parser.add_argument(
        "--forward-only", action="store_true", help="no backpropagation (failures of the rollout only)"
    )
    args = parser.parse_args()
    robot = litl.robots.get("biped", dx=args.dx)
    params = controllers(args.controllers)
    print(
        f"device: {jax.devices()[0].device_kind}; biped dx = {args.dx:g}, "
        f"dt = {robot.config.dt * args.dt_factor:g}"
        + ("; forward only" if args.forward_only else "; with backpropagation")
    )
    print(
        f"{'limit':>5s} {'E':>5s} {'cfl':>5s} {'strain':>6s} {'failed':>8s} {'gait':>5s} {'inverted':>8s} "
        f"{'det_p5':>7s} {'distance':>8s} {'stretch p50 p90':>15s}"
    )
    for limit in args.max_stretch:
        max_stretch = {"robot": robot.config.max_stretch, "none": None}.get(limit.lower())
        if limit.lower() not in ("robot", "none"):
            max_stretch = float(limit)
        for youngs in args.youngs:
            r = measure(robot, youngs, args.strength, args.dt_factor, params, max_stretch, args.forward_only)
            det = f"{r['det_p5']:7.3f}" if r["det_p5"] is not None else "    n/a"
            stretch = "n/a" if r["stretch"] is None else "{:7.2f} {:7.2f}".format(*r["stretch"])
            print(
                f"{max_stretch or 'none':>5} {youngs:5g} {r['cfl']:5.2f} {r['strain']:6.3f} "
                f"{r['failed']:>3d}/{r['rollouts']:<4d} {'FAIL' if r['trained_gait_failed'] else 'ok':>5s} "
                f"{r['inverted']:8d} {det} {r['distance']:8.3f} {stretch:>15s}",
                flush=True,
            )


if __name__ == "__main__":
    main()
