"""Closed-loop gradient norms by horizon, for each observer and each `feature_gradient` setting.

    python benchmarks/gradient_horizon.py                      # biped, demo resolution
    python benchmarks/gradient_horizon.py --json
    python benchmarks/gradient_horizon.py --episodes 1 --iterations 2 --horizons 50 100   # smoke
    python benchmarks/gradient_horizon.py --runs outputs/stability/vae outputs/stability/kmeans

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
import json
import pathlib
import tempfile

import jax
import jax.numpy as jnp
import numpy as np

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def trained_state(observer: str, episodes: int, iterations: int, dx: float):
    """(robot, config, one seed's LoopState) after a short run."""
    import litl.robots
    from litl.config import Config
    from litl.loop import seed_slice
    from litl.loop.run import run

    robot = litl.robots.get("biped", dx=dx)
    config = Config().replace(
        observer={"kind": observer},
        loop={"episodes": episodes, "iterations": iterations, "learning": {"max_epochs": 30, "patience": 5}},
    )
    with tempfile.TemporaryDirectory() as run_dir:
        state = seed_slice(run(robot, config, run_dir, progress=False).state, 0)
    return robot, config, state


def state_of_run(run_dir: pathlib.Path, seed_index: int = 0):
    """(robot, config, LoopState of one seed) at the latest checkpoint of a run directory."""
    import litl.robots
    from litl.config import Config, from_dict
    from litl.loop import make_algorithm, seed_slice, stack_seeds
    from litl.loop.checkpoint import Checkpoints

    saved = json.loads((run_dir / "run.json").read_text())
    config = from_dict(Config, saved["config"])
    robot = litl.robots.get(saved["robot"], dx=saved["dx"])
    algorithm = make_algorithm(robot, config.algorithm)
    template = stack_seeds([algorithm.init(config.seed + s) for s in range(config.seeds)])
    counters = {
        "episodes_done": 0,
        "metrics_lines": 0,
        "learning_lines": 0,
        "loss_before_retrain": np.full(config.seeds, np.nan),
    }
    checkpoints = Checkpoints(run_dir / "checkpoints")
    state, _ = checkpoints.restore(template, counters)
    checkpoints.close()
    return robot, config, seed_slice(state, seed_index)


def measure(robot, config, state, horizons) -> list[dict]:
    from litl.loop import make_algorithm

    observer = config.observer.kind
    state = jax.tree.map(jnp.asarray, state)
    rows = []
    for mode in ("full", "stop"):
        for steps in horizons:
            algorithm = make_algorithm(
                robot,
                config.replace(
                    sim={"steps": steps}, controller={"mlp": {"feature_gradient": mode}}
                ).algorithm,
            )
            _, metrics = jax.jit(algorithm.optimize)(state)
            rows.append(
                {
                    "observer": observer,
                    "feature_gradient": mode,
                    "steps": steps,
                    "controller_grad_norm": float(metrics["controller_grad_norm"]),
                    "design_grad_norm": float(metrics["design_grad_norm"]),
                    "task_loss": float(metrics["task_loss"]),
                    "skipped": int(metrics["skipped"]),
                }
            )
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--observers", nargs="+", default=["vae", "ae", "kmeans"])
    parser.add_argument("--horizons", nargs="+", type=int, default=[100, 300, 640])
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--iterations", type=int, default=5)
    parser.add_argument("--dx", type=float, default=1 / 64)
    parser.add_argument(
        "--runs",
        nargs="+",
        type=pathlib.Path,
        default=None,
        help="measure from the latest checkpoints of these run directories "
        "(seed 0 of each) instead of training",
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.runs:
        trained = [state_of_run(run_dir) for run_dir in args.runs]
        source = "latest checkpoints of " + ", ".join(map(str, args.runs))
    else:
        trained = [
            trained_state(observer, args.episodes, args.iterations, args.dx) for observer in args.observers
        ]
        source = f"biped dx = {args.dx:g}; trained {args.episodes} x {args.iterations} iterations"
    labels = [str(r) for r in args.runs] if args.runs else args.observers
    rows = [
        {"state": label, **row}
        for label, (robot, config, state) in zip(labels, trained, strict=True)
        for row in measure(robot, config, state, args.horizons)
    ]
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print(f"device: {jax.devices()[0].device_kind}; {source}")
    width = max(len(label) for label in labels)
    print(
        f"{'state':{width}s} {'observer':8s} {'gradient':8s} "
        + " ".join(f"{'T=' + str(t):>10s}" for t in args.horizons)
    )
    for label in labels:
        for mode in ("full", "stop"):
            picked = [r for r in rows if r["state"] == label and r["feature_gradient"] == mode]
            print(
                f"{label:{width}s} {picked[0]['observer']:8s} {mode:8s} "
                + " ".join(f"{r['controller_grad_norm']:10.3g}" for r in picked)
            )
    print("(norm of d task loss / d controller parameters, before clipping)")


if __name__ == "__main__":
    main()
