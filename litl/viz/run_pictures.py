"""The pictures a finished run leaves in its directory (`python -m litl` calls `draw_run`).

* the report of the run (`litl.report`): task_loss.png, recon_loss.png, recon_sgd.png,
  table1.md/csv, summary.md;
* robot.png (the robot with its actuators and targets) and robot.gif (the final controller and
  design of the first seed whose rollout stays finite, particles coloured by actuation; seeds that
  blew up are skipped and named on stderr);
* body.png, where the design space shapes the body (``design=actuators|geometry|all``): that
  seed's final body beside the body as built (`litl.viz.bodies.draw_body`: each particle's
  strongest channel with a legend, its material as opacity, the modulus where it is co-designed);
  with several seeds, every seed's final body too, as ``bodies/seed<S>.png`` (seeds differ in
  where their muscles and material went);
* the observer's own pictures (`Observer.pictures`): for the autoencoder snapshots.png (Fig. 1:
  velocity snapshots, latents, reconstructions), latent_sweeps.png (Fig. 8) and saliency.gif; for
  k-means clusters.png (Fig. 7); for PCA its components and reconstructions.
"""

from __future__ import annotations

import pathlib

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from litl.loop import make_algorithm, seed_slice  # noqa: E402
from litl.loop.progress import say  # noqa: E402
from litl.report import write_report  # noqa: E402
from litl.sim import SimulationError  # noqa: E402
from litl.viz import animate_rollout, draw, record_rollout  # noqa: E402
from litl.viz.bodies import draw_body  # noqa: E402


def draw_run(
    robot,
    context,
    result,
    run_dir,
    animation: bool = True,
    pictures: bool = True,
    stride: int = 10,
    progress: bool = False,
) -> list[pathlib.Path]:
    """Write the run's pictures into `run_dir`; return the files written. `context` is the run's
    (`litl.config.RunContext`: ``config.context()``). With `progress`, say on stderr what is
    being drawn (the animation's rollout and the saliency take a while)."""
    run_dir = pathlib.Path(run_dir)
    status = say if progress else (lambda message: None)
    written: list[pathlib.Path] = []
    algorithm = make_algorithm(robot, context.algorithm)
    # Only the animation needs a rollout; without it the pictures use seed 0 (whose parameters
    # are finite: failed iterations never update them).
    chosen: int | None = 0
    recording: tuple[np.ndarray, ...] | None = None  # (positions, actuation[, scenery positions])
    if animation:
        status("pictures: simulating the final robot for robot.gif")
        chosen, recording = _first_healthy_seed(robot, algorithm, result.state, context.seed_ids, stride)
    state = seed_slice(result.state, chosen if chosen is not None else 0)
    if pictures:
        status("pictures: the report (task_loss.png, recon_loss.png, table1, summary.md)")
        written += write_report(run_dir).files
        figure = draw(robot).figure
        figure.savefig(run_dir / "robot.png", dpi=100)
        plt.close(figure)
        written.append(run_dir / "robot.png")
        if isinstance(state.design, dict):  # a body design space (litl.designs.body)
            written += draw_seed_bodies(robot, result.state, chosen or 0, context, run_dir)
        if chosen is not None:
            status(
                "pictures: the observer's representation (clusters, or snapshots, latent sweeps and saliency)"
            )
            written += _representation(
                robot, algorithm, state, run_dir, stride=context.algorithm.loop.snapshot_stride
            )
    if animation and recording is not None:
        status("pictures: robot.gif")
        positions, actuation, *scenery = recording
        gif = run_dir / "robot.gif"
        written.append(
            animate_rollout(
                robot,
                positions,
                actuation,
                gif,
                fps=20,
                scenery=scenery[0] if scenery else None,
                frame_seconds=robot.config.dt * min(stride, algorithm.steps),
            )
        )
    return written


def draw_seed_bodies(robot, states, chosen: int, context, run_dir: pathlib.Path) -> list[pathlib.Path]:
    """body.png: the final body of seed index `chosen` beside the body as built; with several
    seeds, bodies/seed<S>.png for every seed S too."""
    kind = context.record.get("design", {}).get("kind", "modulus")

    def drawn(index: int, path: pathlib.Path) -> pathlib.Path:
        seed = context.seed_ids[index]
        title = f"{robot.name}, seed {seed}: the final body (design={kind}) beside the body as built"
        draw_body(robot, seed_slice(states, index).design, path=path, title=title)
        return path

    written = [drawn(chosen, run_dir / "body.png")]
    if len(context.seed_ids) > 1:
        (run_dir / "bodies").mkdir(exist_ok=True)
        written += [drawn(i, run_dir / "bodies" / f"seed{s}.png") for i, s in enumerate(context.seed_ids)]
    return written


def _first_healthy_seed(robot, algorithm, states, seeds, stride):
    """(index, (positions, actuation)) of the first of `seeds` whose final rollout stays finite."""
    steps = algorithm.steps
    for index, seed in enumerate(seeds):
        state = seed_slice(states, index)
        try:
            recording = record_rollout(
                robot,
                algorithm.policy,
                (state.controller, state.observer),
                steps,
                design=robot.design_space.to_design(state.design),
                stride=min(stride, steps),
                check=True,
                field=algorithm.field,
                scenery=bool(robot.scenery),
            )
        except SimulationError as error:
            say(f"pictures: skipping seed {seed}: {error}")
            continue
        if all(np.all(np.isfinite(a)) for a in recording):
            return index, recording
        say(f"pictures: skipping seed {seed}: its rollout is not finite")
    say("pictures: no seed has a finite final rollout; no animation or representation pictures were drawn")
    return None, None


def _representation(robot, algorithm, state, run_dir: pathlib.Path, stride: int) -> list[pathlib.Path]:
    """The observer's own pictures of its representation (`Observer.pictures`), if it has any."""
    draw_pictures = algorithm.observer.pictures
    return [] if draw_pictures is None else list(draw_pictures(robot, algorithm, state, run_dir, stride))
