"""The page's body pictures, drawn by litl (`litl.viz.bodies.draw_body`, a run's body.png).

    python docs/assets/2026-12-02/design-spaces/draw_bodies.py RUN_DIR OUT.png [SEED]

Draws seed SEED's (default 0) final body of RUN_DIR (a design=actuators or design=all run with
its `final/` checkpoint) beside the biped as built.
"""

from __future__ import annotations

import pathlib
import sys

from litl.loop import load_final, seed_slice
from litl.replay import load_run_config
from litl.viz.bodies import draw_body


def main(run_dir: pathlib.Path, out: pathlib.Path, seed: int = 0) -> None:
    robot, config = load_run_config(run_dir)
    phi = seed_slice(load_final(run_dir, robot, config), seed - config.seed)["design"]
    draw_body(robot, phi, path=out, title=f"{robot.name}, design={config.design.kind}, seed {seed}")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]), int(sys.argv[3]) if len(sys.argv) > 3 else 0)
