"""Closed-loop gradient norms by horizon, for each observer and each `feature_gradient` setting.

    python benchmarks/gradient_horizon.py                      # biped, demo resolution
    python benchmarks/gradient_horizon.py --json
    python benchmarks/gradient_horizon.py --episodes 1 --iterations 2 --horizons 50 100   # smoke

For each observer (vae, ae, kmeans) a short learning-in-the-loop run (default 3 episodes x 5
iterations, `feature_gradient="stop"`, one seed) brings controller and observer to a trained
state, as in a real run. From that state, for each horizon T and each `feature_gradient`
setting, one optimization iteration of T steps reports the norm of the task loss's gradient
w.r.t. the controller parameters θ (before clipping).

Reading it: an exploding gradient (orders of magnitude above the open-loop or k-means norms, and
growing with T) is useless to Adam even when clipped: its direction is dominated by the chaotic
sensitivity of late steps to early ones.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile

import jax
import jax.numpy as jnp


def measure(observer: str, horizons, episodes: int, iterations: int, dx: float) -> list[dict]:
    import litl.robots
    from litl.loop import LearningConfig, LoopConfig, make_algorithm, seed_slice
    from litl.loop.run import run

    robot = litl.robots.get("biped", dx=dx)
    config = LoopConfig(episodes=episodes, iterations=iterations, observer=observer,
                        snapshot_stride=20, replay_capacity=500,
                        learning=LearningConfig(max_epochs=30, patience=5))
    with tempfile.TemporaryDirectory() as run_dir:
        state = seed_slice(run(robot, config, run_dir, progress=False).state, 0)
    state = jax.tree.map(jnp.asarray, state)
    rows = []
    for mode in ("full", "stop"):
        for steps in horizons:
            algorithm = make_algorithm(robot, dataclasses.replace(
                config, steps=steps, feature_gradient=mode))
            _, metrics = jax.jit(algorithm.optimize)(state)
            rows.append({"observer": observer, "feature_gradient": mode, "steps": steps,
                         "controller_grad_norm": float(metrics["controller_grad_norm"]),
                         "design_grad_norm": float(metrics["design_grad_norm"]),
                         "task_loss": float(metrics["task_loss"]),
                         "skipped": int(metrics["skipped"])})
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--observers", nargs="+", default=["vae", "ae", "kmeans"])
    parser.add_argument("--horizons", nargs="+", type=int, default=[100, 300, 500])
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--iterations", type=int, default=5)
    parser.add_argument("--dx", type=float, default=1 / 64)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rows = [row for observer in args.observers
            for row in measure(observer, args.horizons, args.episodes, args.iterations, args.dx)]
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print(f"device: {jax.devices()[0].device_kind}; biped dx = {args.dx:g}; trained "
          f"{args.episodes} episodes x {args.iterations} iterations")
    print(f"{'observer':8s} {'gradient':8s} " + " ".join(f"{'T=' + str(t):>10s}" for t in args.horizons))
    for observer in args.observers:
        for mode in ("full", "stop"):
            norms = [r["controller_grad_norm"] for r in rows
                     if r["observer"] == observer and r["feature_gradient"] == mode]
            print(f"{observer:8s} {mode:8s} " + " ".join(f"{n:10.3g}" for n in norms))
    print("(norm of d task loss / d controller parameters, before clipping)")


if __name__ == "__main__":
    main()
