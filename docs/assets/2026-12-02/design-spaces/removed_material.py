"""Where a geometry run's removed material goes: for each seed of a design=all (or geometry) run,
the distance walked by the particles that keep material (density >= 0.5) and by those removed,
and how far the body's front got (the right wall stops a robot that walks far enough).

    python docs/assets/2026-12-02/design-spaces/removed_material.py RUN_DIR [OUT.json]

The task's distance is the mean over every particle, removed ones included; if removed particles
(almost massless) moved much further than the kept body, the distance would overstate the walk.
With OUT.json, also writes the rows there (unrounded) with the wall's face
and the run's commit.
"""

from __future__ import annotations

import json
import pathlib
import sys

import numpy as np

from litl.loop import load_final, seed_slice
from litl.replay import load_run_config
from litl.viz import record_rollout


def main(run_dir: pathlib.Path, out: pathlib.Path | None = None) -> None:
    robot, config = load_run_config(run_dir)
    from litl.loop import make_algorithm

    algorithm = make_algorithm(robot, config.algorithm)
    saved = load_final(run_dir, robot, config)
    space = robot.design_space
    n = robot.layout.n_particles
    start = np.asarray(robot.initial_state().x)[:n, 0]
    wall = robot.config.grid_shape[0] * robot.config.dx - robot.config.boundary.thickness * robot.config.dx
    print(f"the right wall's inner face: x = {wall:.3f}")
    print(
        "| seed | kept particles | kept body walked | removed walked | all (the task's) | front at the end |"
    )
    print("|---|---|---|---|---|---|")
    rows = []
    for index in range(config.seeds):
        one = seed_slice(saved, index)
        shaped = isinstance(one["design"], dict) and "occupancy" in one["design"]
        kept = np.asarray(space.density(one["design"])) >= 0.5 if shaped else np.ones(n, bool)
        positions = record_rollout(
            robot,
            algorithm.policy,
            (one["controller"], one["observer"]),
            algorithm.steps,
            design=space.to_design(one["design"]),
            stride=algorithm.steps,
            field=algorithm.field,
        )[0]
        moved = np.asarray(positions[-1][:n, 0]) - start
        removed = moved[~kept].mean() if (~kept).any() else float("nan")
        print(
            f"| {config.seed + index} | {kept.sum()} of {n} | {moved[kept].mean():.3f} | {removed:.3f} | "
            f"{moved.mean():.3f} | {float(np.max(positions[-1][:n, 0])):.3f} |"
        )
        rows.append(
            {
                "seed": config.seed + index,
                "kept_particles": int(kept.sum()),
                "particles": n,
                "kept_walked": float(moved[kept].mean()),
                "removed_walked": float(removed),
                "all_walked": float(moved.mean()),
                "front": float(np.max(positions[-1][:n, 0])),
            }
        )
    if out is not None:
        run = json.loads((run_dir / "run.json").read_text())
        record = {
            "run_dir": str(run_dir),
            "run_commit": run["provenance"]["commit"],
            "wall_face": wall,
            "rows": rows,
        }
        out.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]) if len(sys.argv) > 2 else None)
