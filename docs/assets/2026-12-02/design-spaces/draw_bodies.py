"""The robot's own body beside the bodies co-design made, for the design-spaces page.

    python docs/assets/2026-12-02/design-spaces/draw_bodies.py RUNS_ROOT OUT.png [SEED]

Draws, for one seed (default 0), the biped as built and the final bodies of RUNS_ROOT/vae/actuators
and RUNS_ROOT/vae/all: each particle in its strongest channel's colour (passive black), the
particles without material (density < 0.5) left out (`BodySpace.placed_layout`).
"""

from __future__ import annotations

import dataclasses
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from litl.loop import load_final, seed_slice  # noqa: E402
from litl.replay import load_run_config  # noqa: E402
from litl.viz import draw  # noqa: E402


def main(root: pathlib.Path, out: pathlib.Path, seed: int = 0) -> None:
    figure, axes = plt.subplots(1, 3, figsize=(14, 4))
    for ax, name in zip(axes, ("own", "actuators", "all"), strict=True):
        run_dir = root / "vae" / ("actuators" if name == "own" else name)
        robot, config = load_run_config(run_dir)
        if name == "own":
            body, title = dataclasses.replace(robot, design=None), "the biped as built"
        else:
            phi = seed_slice(load_final(run_dir, robot, config), seed - config.seed)["design"]
            layout = robot.design_space.placed_layout(phi, robot.layout)
            body = dataclasses.replace(robot, layout=layout, design=None)
            title = (
                f"design={name}, seed {seed}: {layout.n_particles} of {robot.layout.n_particles} particles"
            )
        draw(body, ax=ax, show_targets=False)
        low, high = robot.layout.positions.min(0), robot.layout.positions.max(0)
        ax.set_xlim(low[0] - 0.03, high[0] + 0.03)
        ax.set_ylim(low[1] - 0.03, high[1] + 0.03)
        ax.set_title(title)
    figure.tight_layout()
    figure.savefig(out, dpi=90)


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]), int(sys.argv[3]) if len(sys.argv) > 3 else 0)
