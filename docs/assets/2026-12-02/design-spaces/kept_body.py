"""Does the kept body walk? For each seed of a design=all (or actuators) run, the body co-design
made, with its removed material (density < 0.5) taken away and each particle's strongest channel as its one
actuator (`BodySpace.placed_layout`: what the replay's drawing holds), simulated under the seed's
final controller, observer and Young's moduli.

    python docs/assets/2026-12-02/design-spaces/kept_body.py RUN_DIR

Prints minus the task loss (for a walker, the distance walked) of the run's own body and of the
kept body alone: if the removed material (1% of the mass and stiffness left, rho_min) carried the
gait, the kept body would walk much less.
"""

from __future__ import annotations

import dataclasses
import pathlib
import sys

from litl.loop import load_final, make_algorithm, seed_slice
from litl.replay import load_run_config
from litl.robots import LayoutError


def main(run_dir: pathlib.Path) -> None:
    robot, config = load_run_config(run_dir)
    own = make_algorithm(robot, config.algorithm)
    saved = load_final(run_dir, robot, config)
    # Minus the task loss: for a walker the distance walked (the bunny's adds its hands' reach).
    print(
        "| seed | particles kept | minus task loss, the run's body | minus task loss, the kept body alone |"
    )
    print("|---|---|---|---|")
    for index in range(config.seeds):
        one = seed_slice(saved, index)
        phi = one["design"]
        try:
            layout = robot.design_space.placed_layout(phi, robot.layout)
        except LayoutError as error:  # the kept body lost a part the robot needs
            print(f"| {config.seed + index} | not a robot: {error} | | |")
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


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]))
