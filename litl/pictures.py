"""The pictures a finished run leaves in its directory (`python -m litl` calls `draw_run`).

* the report of the run (`litl.report`): task_loss.png, recon_loss.png, recon_sgd.png,
  table1.md/csv, summary.md;
* robot.png (the robot with its actuators and targets) and robot.gif (seed 0's final controller
  and design, particles coloured by actuation);
* for a learned observer: snapshots.png (Fig. 1: velocity snapshots, latents, reconstructions),
  latent_sweeps.png (Fig. 8) and saliency.gif; for k-means: clusters.png (Fig. 7).
"""

from __future__ import annotations

import pathlib

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from litl.loop import make_algorithm, seed_slice  # noqa: E402
from litl.report import write_report  # noqa: E402
from litl.viz import animate_rollout, draw, record_rollout  # noqa: E402
from litl.viz.latent import draw_clusters, draw_latent_sweeps, draw_snapshots  # noqa: E402
from litl.viz.saliency import animate_saliency  # noqa: E402

SNAPSHOTS = 6


def draw_run(robot, config, result, run_dir, animation: bool = True, pictures: bool = True,
             stride: int = 10) -> list[pathlib.Path]:
    """Write the run's pictures into `run_dir`; return the files written."""
    run_dir = pathlib.Path(run_dir)
    written = []
    algorithm = make_algorithm(robot, config)
    seed0 = seed_slice(result.state, 0)
    if pictures:
        written += write_report(run_dir).files
        figure = draw(robot).figure
        figure.savefig(run_dir / "robot.png", dpi=100)
        plt.close(figure)
        written.append(run_dir / "robot.png")
        written += _representation(robot, algorithm, seed0, run_dir)
    if animation:
        steps = algorithm.steps
        positions, actuation = record_rollout(
            robot, algorithm.policy, (seed0.controller, seed0.observer), steps,
            design=robot.design(seed0.design), stride=min(stride, steps), check=False)
        written.append(animate_rollout(robot, positions, actuation, run_dir / "robot.gif",
                                       fps=20))
    return written


def _representation(robot, algorithm, state, run_dir: pathlib.Path) -> list[pathlib.Path]:
    if algorithm.model is None:
        figure = plt.figure(figsize=(6, 5))
        ax = figure.add_subplot(111, projection="3d" if robot.dim == 3 else None)
        draw_clusters(robot, state.observer, ax=ax)
        figure.savefig(run_dir / "clusters.png", dpi=100)
        plt.close(figure)
        return [run_dir / "clusters.png"]
    count = int(state.buffer.count)
    if count == 0:
        return []
    # The newest snapshots sit just before the ring buffer's cursor.
    newest = (int(state.buffer.cursor) - 1 - np.arange(min(count, SNAPSHOTS))[::-1]) % count
    snapshots = np.asarray(state.buffer.fields)[newest]
    written = []
    for name, make in (
        ("snapshots.png", lambda path: draw_snapshots(algorithm.model, state.observer, snapshots, path)),
        ("latent_sweeps.png", lambda path: draw_latent_sweeps(algorithm.model, state.observer,
                                                              path=path)),
    ):
        figure = make(run_dir / name)
        plt.close(figure)
        written.append(run_dir / name)
    written.append(animate_saliency(algorithm.model, state.observer, algorithm.controller,
                                    state.controller, snapshots, run_dir / "saliency.gif"))
    return written
