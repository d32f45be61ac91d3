"""`python -m litl.replay RUN_DIR`: simulate a trained robot again and draw it.

    python -m litl.replay outputs/demo/biped/vae/<time>                 # seed 0's final robot
    python -m litl.replay RUN_DIR --seed 2 --steps 2000 --out walk.mp4  # longer, another seed
    python -m litl.replay RUN_DIR --which best --color stiffness        # best rollout, by E
    python -m litl.replay RUN_DIR --design actuators                    # its co-designed muscles

It rebuilds the run's robot and settings (from `.hydra/config.yaml` for a CLI run, else from
`run.json`), loads the saved controller, design and observer (`final/` or `best/`), simulates
them and writes, next to `--out` (default `RUN_DIR/replay/seed<N>.gif`):

* the animation (.gif, or .mp4 with ffmpeg): particles coloured by actuation, or by the learned
  Young's modulus per region (`--color stiffness`); 3D robots in perspective;
* `<name>_design.png`: what the design space changed, beside the body as built
  (`litl.viz.bodies.draw_body`): each particle's strongest channel with a legend
  (``design=actuators``, ``all``), its material as opacity (``geometry``, ``all``), the learned
  Young's modulus per region where the space co-designed it (``modulus``, ``all``,
  ``.modulus=true``). `--design KIND` checks that the run co-designed that space: a run that
  recorded another, or none (its run.json has no design section: made before design spaces
  existed, or with the robot's own modulus), is named on stderr with what it lacks, and the
  picture shows what the run holds;
* `<name>_robot.png` and `<name>_robot.json` (a 2D robot whose actuators were co-designed,
  ``design=actuators``): the co-designed body as a drawing in litl's palette with its legend,
  which ``python -m litl robot.image=<name>_robot.png`` loads back;
* `<name>.json`: seed, steps, the task loss and its components, the loss the run recorded for
  the same parameters (`final.json` or `best.json`), which the replay reproduces at the run's
  own step count, and how close the robot came to leaving the grid at each face
  (`escape_margin_cells`, `litl.sim.safety.escape_margins`).

`environment(run_dir, seed)` gives the trained robot as a gymnax-style environment (`litl.envs`),
observed by its trained observer, for RL code of your own.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import pathlib
import sys
from typing import Any, cast

from litl.config import Config, from_dict
from litl.errors import UserError, exit_on_user_error
from litl.settings.old import upgrade


class ReplayError(UserError, ValueError):
    """The run directory cannot be replayed; the message says why and what to do."""


def load_run_config(run_dir: pathlib.Path):
    """(robot, config) of a run directory, rebuilt as the run built them."""
    from litl.app import build_robot, check_observer

    run_dir = pathlib.Path(run_dir)
    try:
        saved = json.loads((run_dir / "run.json").read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ReplayError(
            f"{run_dir} is not a litl run directory: its run.json cannot be read "
            f"({error}); give the directory `python -m litl` printed"
        ) from None
    if "config" not in saved:
        raise ReplayError(
            f"{run_dir / 'run.json'} was written by an earlier version of litl (no "
            f"'config'); it cannot be replayed"
        )
    hydra_config = run_dir / ".hydra" / "config.yaml"
    if hydra_config.exists():  # the CLI's own record: robot, task and material included
        from omegaconf import OmegaConf

        plain = OmegaConf.to_container(OmegaConf.load(hydra_config), resolve=True)
        assert isinstance(plain, dict)  # the file holds a mapping, with string keys
        config = from_dict(Config, upgrade(cast("dict[str, Any]", plain)))
        robot = build_robot(config)
    else:  # a Python API run: the robot by name, dx and material
        import litl.designs
        import litl.robots
        import litl.worlds
        from litl.robots import Material

        config = from_dict(Config, upgrade(saved["config"]))
        robot = litl.robots.get(saved["robot"], dx=saved["dx"])
        material = Material(**saved.get("material", {}))
        if material != robot.material:
            robot = robot.with_material(material)
        robot = _placed(robot, saved.get("origin"), run_dir)
        # In its world and with its design space, as `litl.loop.run` put it.
        robot = litl.designs.apply(litl.worlds.put(robot, config.world), config.design)
    # The run's strain limit as it simulated; runs from before the limit (no key) had none.
    limit = saved.get("max_stretch")
    if robot.config.max_stretch != limit:
        own = dataclasses.replace(robot.config.own_material, max_stretch=limit)
        robot = dataclasses.replace(robot, config=robot.config.with_own_material(own))
    check_observer(config)
    found = {"robot": robot.name, "particles": robot.layout.n_particles, "dt": robot.config.dt}
    recorded = {key: saved.get(key) for key in found}
    if found != recorded:
        raise ReplayError(
            f"the robot rebuilt from {run_dir} ({found}) is not the run's "
            f"({recorded}); was the robot's definition changed since the run?"
        )
    return robot, config


def _placed(robot, origin, run_dir):
    """The robot where the run stood it: shifted along x (`Robot.shifted`) to the lower corner
    of its rest shape that run.json records (`origin`; runs from before it was recorded stood
    where their definition placed them). A `ReplayError` where it stood elsewhere along another
    axis, which no shift litl makes explains."""
    import numpy as np

    if origin is None:
        return robot
    here = robot.layout.bounds()[0]
    offset = np.asarray(origin, float) - np.asarray(here, float)
    if np.any(np.abs(offset[1:]) > 1e-6):
        raise ReplayError(
            f"the robot of {run_dir} stood at {origin}, the {robot.name!r} rebuilt by name at "
            f"{[round(float(x), 6) for x in here]}: moved along more than x, it cannot be rebuilt"
        )
    return robot.shifted(float(offset[0])) if abs(offset[0]) > 1e-6 else robot


def chosen_seed(config, seed: int | None) -> int:
    """`seed`, or the run's first where it is None; a `ReplayError` if the run has no such seed."""
    seeds = [config.seed + s for s in range(config.seeds)]
    if seed is not None and seed not in seeds:
        raise ReplayError(f"seed {seed}: the run has seeds {seeds} (--seed on the command line)")
    return seeds[0] if seed is None else seed


def replay(
    run_dir,
    seed: int | None = None,
    steps: int | None = None,
    out=None,
    which: str = "final",
    color: str = "actuation",
    stride: int = 10,
    gait: bool = False,
    design: str | None = None,
) -> dict:
    """Simulate a saved robot again and write its animation, design picture and losses.

    Args:
      run_dir: a finished run's directory (it holds `final/` or `best/`).
      seed: which seed (default: the run's first).
      steps: simulation steps (default: the run's own).
      out: the animation's path (.gif or .mp4); default `run_dir/replay/seed<N>.gif`.
      which: ``"final"`` (after the last iteration) or ``"best"`` (each seed's best rollout).
      color: ``"actuation"`` or ``"stiffness"`` (the learned Young's modulus per region).
      stride: simulation steps per animation frame.
      gait: also measure and draw how it walked (`litl.viz.draw_gait`: each foot's lifts and
        slip, the pace over the second half, the stance's change, a side view) into
        `<out stem>_gait.png` and the summary's ``gait``; replaying more `steps` than the run's
        tells a steady gait (it keeps its pace) from a lunge or a stretch (it does not).
      design: the design space whose body to draw (``actuators``, ``geometry``, ``all``,
        ``modulus``); None: the run's own. A run that did not co-design it is named on stderr
        with what it lacks (`design_note`), and its own design is drawn.

    Returns:
      The summary written to `<out>.json` (seed, steps, task_loss, components, recorded_loss,
      files, the design note where there is one, and gait if asked).
    """
    import numpy as np

    from litl.loop.progress import say
    from litl.sim.safety import escape_margins

    run_dir = pathlib.Path(run_dir)
    robot, config, seed, out = _checked(run_dir, seed, steps, out, which, color, stride)
    note = design_note(run_dir, config, design)
    if note is not None:
        say(f"replay: {note}")
    if steps is not None:
        config = config.replace(sim={"steps": steps})
    evaluated = _evaluate(run_dir, robot, config, seed, which)
    evaluated["title"] = f"{robot.name}, seed {seed} ({which}): design={config.design.kind}"
    files, positions, gait_numbers = _draw(robot, evaluated, out, color, stride, gait)
    one, steps = evaluated["one"], evaluated["steps"]
    space = robot.design_space
    summary = {
        "run_dir": str(run_dir),
        "seed": seed,
        "which": which,
        "steps": steps,
        "run_steps": json.loads((run_dir / "run.json").read_text())["steps"],
        "task_loss": evaluated["task_loss"],
        "components": evaluated["components"],
        "recorded_loss": recorded_loss(run_dir, which, seed),
        "design": np.asarray(space.modulus(one["design"])).tolist(),
        "design_bounds": list(space.bounds),
        # How close the robot came to leaving the grid, per face (recorded frames only).
        "escape_margin_cells": escape_margins(robot.config, positions),
        "files": files,
    }
    if note is not None:
        summary["design_note"] = note
    if gait_numbers is not None:
        summary["gait"] = gait_numbers
    out.with_suffix(".json").write_text(json.dumps(summary, indent=1))
    return summary


def _checked(run_dir: pathlib.Path, seed, steps, out, which: str, color: str, stride: int):
    """(robot, config, seed, out) of a replay whose arguments are checked (`ReplayError` names the
    one that is wrong)."""
    if which not in ("final", "best"):
        raise ReplayError(f"--which {which!r}: choose final or best")
    if color not in ("actuation", "stiffness"):
        raise ReplayError(f"--color {color!r}: choose actuation or stiffness")
    if not (run_dir / which).is_dir():
        raise ReplayError(
            f"{run_dir} holds no {which}/ parameters: the run has not finished "
            f"(resume it with the same command) or is not a litl run directory"
        )
    robot, config = load_run_config(run_dir)
    seed = chosen_seed(config, seed)
    if steps is not None and (not isinstance(steps, int) or steps < 1):
        raise ReplayError(f"--steps {steps}: must be a positive integer")
    if not isinstance(stride, int) or stride < 1:
        raise ReplayError(f"--stride {stride}: must be a positive integer")
    out = pathlib.Path(out) if out is not None else run_dir / "replay" / f"seed{seed}.gif"
    if out.suffix.lower() not in (".gif", ".mp4"):
        raise ReplayError(f"--out {out}: use a .gif or .mp4 file name")
    return robot, config, seed, out


def _evaluate(run_dir: pathlib.Path, robot, config, seed: int, which: str) -> dict:
    """The saved parameters' task loss for `seed`, from the run's own evaluation batched over its
    seeds exactly as the run did it; with its loss components, the seed's parameters (`one`) and
    the algorithm."""
    import jax
    import numpy as np

    from litl.loop import load_final, make_algorithm, stack_seeds

    seeds = [config.seed + s for s in range(config.seeds)]
    algorithm = make_algorithm(robot, config.algorithm)
    saved = load_final(run_dir, robot, config, which)
    index = seeds.index(seed)
    template = stack_seeds([algorithm.init(s) for s in seeds])
    state = template.replace(
        controller=saved["controller"], design=saved["design"], observer=saved["observer"]
    )
    losses = np.asarray(jax.jit(jax.vmap(algorithm.evaluate))(state))
    one = jax.tree.map(lambda leaf: np.asarray(leaf)[index], saved)
    return {
        "algorithm": algorithm,
        "one": one,
        "steps": algorithm.steps,
        "task_loss": float(losses[index]),
        "components": _components(robot, algorithm, one, algorithm.steps),
    }


def _draw(robot, evaluated: dict, out: pathlib.Path, color: str, stride: int, gait: bool):
    """Record the seed's rollout and write its animation, its design picture and (`gait`) its gait;
    returns (files, the recorded positions, the gait's numbers or None)."""
    import numpy as np

    from litl.viz import animate_rollout, draw_gait, record_rollout

    algorithm, one, steps = evaluated["algorithm"], evaluated["one"], evaluated["steps"]
    space = robot.design_space
    design = np.asarray(space.modulus(one["design"]))  # the Young's modulus per region
    positions, actuation, *scenery = record_rollout(
        robot,
        algorithm.policy,
        (one["controller"], one["observer"]),
        steps,
        design=space.to_design(one["design"]),
        stride=min(stride, steps),
        check=False,
        field=algorithm.field,
        scenery=bool(robot.scenery),
    )
    coloring = {"stiffness": design, "stiffness_range": space.bounds} if color == "stiffness" else {}
    out.parent.mkdir(parents=True, exist_ok=True)
    terrain = scenery[0] if scenery else None
    every = robot.config.dt * min(stride, steps)
    animate_rollout(
        robot, positions, actuation, out, fps=20, scenery=terrain, frame_seconds=every, **coloring
    )
    picture = out.with_name(out.stem + "_design.png")
    _draw_design(robot, one["design"], picture, evaluated["title"])
    files = [str(out), str(picture)]
    gait_numbers = None
    if gait:
        gait_picture = out.with_name(out.stem + "_gait.png")
        _, gait_numbers = draw_gait(robot, positions, min(stride, steps) * robot.config.dt, path=gait_picture)
        files.append(str(gait_picture))
    files += _write_body(robot, space, one["design"], out)
    return files, positions, gait_numbers


def _write_body(robot, space, phi, out: pathlib.Path) -> list[str]:
    """The co-designed body (a design space that shapes it: `placed_layout`) as a file that
    ``robot.image=`` loads back: a 2D drawing (.png, its legend beside it) or 3D voxels (.npz)."""
    from litl.loop.progress import say
    from litl.robots import LayoutError
    from litl.robots.image import write_png, write_voxels

    placed = getattr(space, "placed_layout", None)
    if placed is None:
        return []
    try:
        body = placed(phi, robot.layout)
    except LayoutError as error:
        say(f"replay: the co-designed body is not written as a robot: {error}")
        return []
    if robot.dim == 2:
        return [str(path) for path in write_png(body, out.with_name(out.stem + "_robot.png"))]
    return [str(write_voxels(body, out.with_name(out.stem + "_robot.npz")))]


def environment(
    run_dir, seed: int | None = None, which: str = "final", hold: int = 8, period: float | None = None
):
    """`(env, env_params)` of a trained litl run: its robot with the seed's co-designed design,
    observed by the seed's observer (a trained VAE's latent, k-means clusters, ...) and the clock.

    Args:
      run_dir: a finished run's directory (`python -m litl` printed it).
      seed: which seed (default: the run's first).
      which: ``"final"`` (after the last iteration) or ``"best"`` (each seed's best rollout).
      hold, period: as in `litl.envs.make`.
    """
    import jax
    import jax.numpy as jnp

    from litl.envs import make
    from litl.loop import load_final, make_algorithm

    run_dir = pathlib.Path(run_dir)
    if not (run_dir / which).is_dir():
        raise ReplayError(f"{run_dir} holds no {which}/ parameters: the run has not finished (resume it)")
    robot, config = load_run_config(run_dir)
    seed = chosen_seed(config, seed)
    seeds = [config.seed + s for s in range(config.seeds)]
    algorithm = make_algorithm(robot, config.algorithm)
    if algorithm.observer.n_features == 0:
        raise ReplayError(f"{run_dir}: its observer ({config.observer.kind}) has no features to observe")
    saved = jax.tree.map(lambda x: x[seeds.index(seed)], load_final(run_dir, robot, config, which))
    dtype = jnp.dtype(config.sim.dtype.value)
    env, params = make(
        robot, hold, period, "observer", dtype, observer=algorithm.observer, observer_params=saved["observer"]
    )
    design = robot.design_space.to_design(saved["design"], dtype)
    return env, params.replace(design=design)


def _components(robot, algorithm, params, steps) -> dict:
    """The task loss's components for one seed's parameters (an unbatched forward simulation)."""
    import jax
    import numpy as np

    from litl.sim import make_rollout

    rollout = jax.jit(
        make_rollout(robot.config, robot.body(), algorithm.policy, steps, field=algorithm.field)
    )
    initial = robot.initial_state()
    final, _ = rollout(
        (params["controller"], params["observer"]), robot.design_space.to_design(params["design"]), initial
    )
    _, components = robot.task_loss()(initial, final)
    return {name: float(np.asarray(value)) for name, value in components.items()}


def recorded_loss(run_dir: pathlib.Path, which: str, seed: int):
    """The loss the run recorded for the same parameters (None if it recorded none). A seed that
    ended stuck reports its last good loss in final.json (`litl.records.stuck`); its final parameters'
    own loss is `final_parameters_loss` there (also for a seed whose final parameters failed
    after a healthy last iteration)."""
    path = run_dir / f"{which}.json"
    if not path.exists():
        return None
    entry = next((r for r in json.loads(path.read_text()) if r["seed"] == seed), None)
    if entry is None:
        return None
    return entry["final_parameters_loss"] if "final_parameters_loss" in entry else entry["task_loss"]


def _draw_design(robot, phi, path: pathlib.Path, title: str) -> None:
    """What the design space changed (`litl.viz.bodies.draw_body`), beside the body as built."""
    from litl.viz.bodies import draw_body

    draw_body(robot, phi, path=path, title=title)


# What each body design space co-designs, as `design_note` names it.
_DESIGNED = {
    "actuators": "actuator placement",
    "geometry": "material (occupancy per particle)",
    "all": "actuator placement and material",
    "modulus": "Young's modulus per region",
}


def design_note(run_dir: pathlib.Path, config, asked: str | None) -> str | None:
    """Why the run cannot show the body of design space `asked` (what it lacks, and what is drawn
    instead), or None where it co-designed that space (or `asked` is None)."""
    import litl.designs

    own = config.design.kind
    if asked is not None and asked not in litl.designs.names():
        raise ReplayError(f"--design {asked}: choose one of {', '.join(litl.designs.names())}")
    if asked is None or asked == own or own == "all":  # design=all co-designs every part
        return None
    lacks = _DESIGNED.get(asked, f"design={asked}'s design")
    saved = json.loads((pathlib.Path(run_dir) / "run.json").read_text()).get("config", {})
    if "design" not in saved:
        return (
            f"{run_dir}: its run.json has no design section (a run made before design={asked} "
            f"existed, or with the robot's own design=modulus), so it holds no {lacks} to draw; "
            f"drawing the body as built and the Young's modulus per region it co-designed"
        )
    return f"{run_dir} co-designed design={own}, not design={asked}: it holds no {lacks}; drawing its own"


def _parser() -> argparse.ArgumentParser:
    """The command line of `main`."""
    parser = argparse.ArgumentParser(
        prog="python -m litl.replay",
        description="Simulate a trained robot from a run directory again and write its "
        "animation, a picture of its learned design and its task loss.",
    )
    parser.add_argument("run_dir", type=pathlib.Path, help="a finished run's directory")
    parser.add_argument("--seed", type=int, default=None, help="which seed (default: the first)")
    parser.add_argument(
        "--steps", type=int, default=None, help="simulation steps (default: the run's own rollout length)"
    )
    parser.add_argument(
        "--out",
        type=pathlib.Path,
        default=None,
        help="animation file, .gif or .mp4 (default: RUN_DIR/replay/seed<N>.gif)",
    )
    parser.add_argument(
        "--which",
        choices=("final", "best"),
        default="final",
        help="the final parameters or each seed's best rollout's",
    )
    parser.add_argument(
        "--color",
        choices=("actuation", "stiffness"),
        default="actuation",
        help="colour particles by actuation or by the learned Young's modulus",
    )
    parser.add_argument("--stride", type=int, default=10, help="simulation steps per frame")
    parser.add_argument(
        "--design",
        default=None,
        help="the design space whose body to draw (actuators, geometry, all, modulus; default: "
        "the run's own); a run without it is named with what it lacks, and its own is drawn",
    )
    parser.add_argument(
        "--gait",
        action="store_true",
        help="also write <out>_gait.png and the feet's lifts and slip (walkers)",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    """Replay a run; returns 0 (bad input: exit status 2 and a one-line message)."""
    args = _parser().parse_args(argv)
    with exit_on_user_error("litl.replay"):
        summary = replay(
            args.run_dir,
            args.seed,
            args.steps,
            args.out,
            args.which,
            args.color,
            args.stride,
            args.gait,
            args.design,
        )
    recorded = summary["recorded_loss"]
    same = (
        ""
        if recorded is None
        else f" (the run recorded {recorded:.6g} for these parameters)"
        if summary["steps"] == summary["run_steps"]
        else f" (the run recorded {recorded:.6g} at its {summary['run_steps']} steps)"
    )
    print(
        f"litl.replay: seed {summary['seed']}, {summary['steps']} steps: task loss "
        f"{summary['task_loss'] + 0.0:.6g}{same}; wrote {', '.join(summary['files'])}"
    )
    if "gait" in summary:
        gait = summary["gait"]
        feet = "; ".join(
            f"{foot['travel']:.3g} / {foot['lifted_fraction']:.0%} / "
            f"{'-' if foot['slip'] is None else format(foot['slip'], '.2f')}"
            for foot in gait["feet"]
        )
        print(
            f"litl.replay: gait: the centroid went {gait['centroid_travel']:.3g} in "
            f"{gait['duration']:.3g} s, {gait['late_speed']:.3g} per second over the second "
            f"half; the stance grew {gait['stance_change']:.3g}; feet, back to front (travel "
            f"/ lifted / slip): {feet}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
