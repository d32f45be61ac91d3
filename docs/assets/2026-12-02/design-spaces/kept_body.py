"""Does the kept body walk? For each seed of a design=all (or actuators) run, the body co-design
made, with its removed material (density < 0.5) taken away and each particle's strongest channel as its one
actuator (`BodySpace.placed_layout`: what the replay's drawing holds), simulated under the seed's
final controller, observer and Young's moduli.

    python docs/assets/2026-12-02/design-spaces/kept_body.py RUN_DIR [OUT.json]

Prints minus the task loss (for a walker, the distance walked) of the run's own body and of the
kept body alone: if the removed material (1% of the mass and stiffness left, rho_min) carried the
gait, the kept body would walk much less. With OUT.json, also writes the rows there (each seed's
particles kept and both distances, unrounded) with the run's commit.
"""

from __future__ import annotations

import dataclasses
import json
import pathlib
import sys

from litl.loop import load_final, make_algorithm, seed_slice
from litl.replay import load_run_config
from litl.robots import LayoutError


def main(run_dir: pathlib.Path, out: pathlib.Path | None = None) -> None:
    robot, config = load_run_config(run_dir)
    own = make_algorithm(robot, config.algorithm)
    saved = load_final(run_dir, robot, config)
    # Minus the task loss: for a walker the distance walked (the bunny's adds its hands' reach).
    print(
        "| seed | particles kept | minus task loss, the run's body | minus task loss, the kept body alone |"
    )
    print("|---|---|---|---|")
    rows = []
    for index in range(config.seeds):
        one = seed_slice(saved, index)
        phi = one["design"]
        try:
            layout = robot.design_space.placed_layout(phi, robot.layout)
        except LayoutError as error:  # the kept body lost a part the robot needs
            print(f"| {config.seed + index} | not a robot: {error} | | |")
            rows.append({"seed": config.seed + index, "not_a_robot": str(error)})
            continue
        kept = dataclasses.replace(robot, layout=layout, design=None)
        alone = make_algorithm(kept, config.algorithm)
        run_loss = float(own.simulate(one["controller"], phi, one["observer"])[0])
        kept_loss = float(
            alone.simulate(one["controller"], robot.design_space.modulus(phi), one["observer"])[0]
        )
        print(
            f"| {config.seed + index} | {layout.n_particles} of {robot.layout.n_particles} | "
            f"{-run_loss:.3f} | {-kept_loss:.3f} |"
        )
        rows.append(
            {
                "seed": config.seed + index,
                "particles_kept": layout.n_particles,
                "particles": robot.layout.n_particles,
                "run_body": -run_loss,
                "kept_body": -kept_loss,
            }
        )
    if out is not None:
        run = json.loads((run_dir / "run.json").read_text())
        record = {"run_dir": str(run_dir), "run_commit": run["provenance"]["commit"], "rows": rows}
        out.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]) if len(sys.argv) > 2 else None)
