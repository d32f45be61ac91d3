"""`python -m litl.latent.control RUN_DIR`: steer a trained run's robot to a new goal by planning in
its observer's latent space.

    python -m litl.latent.control RUN_DIR --goal walk:-1                      # walk the other way
    python -m litl.latent.control RUN_DIR --goal reach:0.6 --planner latent_lqr
    python -m litl.latent.control RUN_DIR --goal reach:0.6 --set horizon=20 --set iterations=50
    python -m litl.latent.control RUN_DIR --goal reach:0.6 --planner trained  # the run's own MLP
    python -m litl.latent.control RUN_DIR --goal reach:0.6 --control-steps 64  # twice the run's 1 s
    python -m litl.latent.control RUN_DIR --goal reach:0.6 --data both         # and random actions
    python -m litl.latent.control RUN_DIR --goal walk:-1 --set warm_start=better

From the run's newest checkpoint (its replay buffer, with the actions recorded between snapshots,
and its observer) it fits, per seed, a `litl.latent.model.LatentModel` (the dynamics model of
`loop.dynamics`' settings, on every transition, and the velocity readout), then runs one episode
of the robot (its co-designed body) in `litl.envs` under the planner, every seed vmapped in one
jit-compiled program. `--data explored` fits the model on exploratory random-action episodes
instead (`litl.latent.exploration`; `--explore-episodes`, `--explore-hold`), which any observer
with features allows (k-means too); `--data both` on both. Planners (`controller=` names,
`litl.latent.planning`): ``latent_mpc``
(shooting MPC through the MLP model; `--set model=linear` for the linear one), ``latent_ilqr``
(the same cost minimized by iLQR), ``latent_lqr``
(reach goals only), and three references: ``trained`` (the run's own controller, which was
trained for its own task, simulated as the run simulated it), ``rest`` (no actuation) and
``oracle_mpc`` (the same MPC, `latent_mpc`'s settings, planning through the simulator itself).

Writes `RUN_DIR/control/<planner>-<goal>.json` (or `--out`; with `--animate` also the first
chosen seed's episode as a .gif beside it): per seed the position of the point the task steers
(`Robot.task_point`: a walker's centroid, the arm's tip; `point` in the file) along the goal's
axis at every control step, the final position, the goal's error (reach: |x_T − target|;
walk: the displacement in the goal's direction), the speed along the axis over the last control
step (`final_speed`: near 0 where a reach ended at rest), the fit's readout R², the planning's model
evaluations per control step, and the wall time (compile apart). A run whose observer has no
latent space, or whose buffer holds no actions, is refused, naming it; so is a reach target outside
the domain; a non-finite plan is named with its seed and control step (exit status 1).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import pathlib
import sys
import time
from typing import Any

from litl.errors import UserError, exit_on_user_error

REFERENCES = ("trained", "rest", "oracle_mpc")
# What the latent model is fitted on: the run's replay buffer (the trained controller's
# behaviour), exploratory random-action episodes (`litl.latent.exploration`), or both.
DATA = ("buffer", "explored", "both")


class ControlError(UserError, ValueError):
    """A run or request the latent planners cannot serve; the message says why and what to do."""


def planner_settings(planner: str, overrides: list[str]):
    """The planner's settings with `key=value` overrides (types from the dataclass's fields)."""
    from litl.latent.planning import PLANNERS, MPCSettings

    cls = PLANNERS.get(planner, MPCSettings)  # oracle_mpc: the MPC's settings
    return overridden(cls(), overrides, "--set", planner)


def overridden(base, overrides, flag: str, what: str):
    """The frozen settings `base` with `KEY=VALUE` overrides, each value read as its field's
    default's type (a tuple of ints as ``64,64``); a `ControlError` naming `flag` for an unknown
    key or a value of the wrong type, and the settings' own error for one out of range."""
    names = [f.name for f in dataclasses.fields(base)]
    values: dict[str, Any] = {}
    for item in overrides:
        key, sep, text = item.partition("=")
        if not sep or key not in names:
            raise ControlError(f"{flag} {item!r}: write KEY=VALUE with KEY one of {sorted(names)} ({what})")
        default = getattr(base, key)
        try:
            if isinstance(default, str):
                values[key] = text
            elif isinstance(default, tuple):
                values[key] = tuple(int(part) for part in text.split(","))
            else:
                values[key] = type(default)(text)
        except ValueError:
            kind = "comma-separated ints" if isinstance(default, tuple) else type(default).__name__
            raise ControlError(f"{flag} {item!r}: {key} takes {kind}") from None
    return dataclasses.replace(base, **values)


def load(run_dir: pathlib.Path, latent: bool = True, features: bool = False):
    """(robot, config, algorithm, seeds, state) of a run's newest checkpoint, refused with a
    `ControlError` where the latent planners cannot use it: `latent` (a model fitted on the
    buffer) needs a latent codec and recorded actions; `features` (a model fitted on exploratory
    episodes only) any observer with features; neither: any trained run, for the ``trained``
    reference, e.g. open-loop sinusoids."""
    import numpy as np

    from litl.loop import make_algorithm, stack_seeds
    from litl.loop.checkpoint import Checkpoints
    from litl.replay import load_run_config

    robot, config = load_run_config(run_dir)
    algorithm = make_algorithm(robot, config.algorithm)
    learner = algorithm.observer.learner
    if latent and (learner is None or learner.latent is None):
        raise ControlError(
            f"{run_dir}: its observer ({config.observer.kind}) has no latent space to plan in; "
            f"the latent planners need a run with observer vae, ae or pca (or, with --data "
            f"explored, any observer with features, e.g. kmeans)"
        )
    if features and algorithm.observer.n_features == 0:
        raise ControlError(
            f"{run_dir}: its observer ({config.observer.kind}) has no features to plan with; "
            f"the latent planners need a run with an observer (vae, ae, pca or kmeans)"
        )
    checkpoints = run_dir / "checkpoints"
    if not checkpoints.is_dir():
        raise ControlError(f"{run_dir} holds no checkpoints/ (its replay buffer): not a litl run directory")
    seeds = [config.seed + s for s in range(config.seeds)]
    template = stack_seeds([algorithm.init(s) for s in seeds])
    counters: dict[str, Any] = {"episodes_done": 0, "metrics_lines": 0, "learning_lines": 0}
    counters["loss_before_retrain"] = np.full(len(seeds), np.nan)  # the run shell's counters
    try:
        state, _ = Checkpoints(checkpoints).read_latest(template, counters)
    except Exception as error:  # orbax raises many kinds for a mismatched or damaged checkpoint
        raise ControlError(
            f"{checkpoints}: its newest checkpoint cannot be read as this run's "
            f"({str(error).strip().splitlines()[0][:200]}); was it written by another litl version?"
        ) from None
    if latent and (state.buffer.n_actions == 0 or not np.any(np.asarray(state.buffer.follows))):
        raise ControlError(
            f"{run_dir}: its replay buffer records no actions between snapshots (a run made before "
            f"they were recorded); train the run again to plan with it"
        )
    return robot, config, algorithm, seeds, state


def run(
    run_dir,
    goal: str,
    planner: str = "latent_mpc",
    overrides=(),
    seeds=None,
    out=None,
    animate=False,
    control_steps: int | None = None,
    data: str = "buffer",
    exploration=None,
    model_overrides=(),
) -> dict:
    """Plan toward `goal` in every seed of the run (see the module docstring); the summary
    written to `out` (its ``failures`` name the seeds whose plans were not finite); `animate`:
    also the first chosen seed's episode as a .gif beside it (not for ``trained``: use
    `python -m litl.replay`); `control_steps`: the episode's length (None: the run's rollout's;
    longer shows whether a reach ends at rest; not for ``trained``, which replays the run's);
    `data`: what the latent model is fitted on (`DATA`); `exploration`: the exploratory episodes'
    `litl.latent.exploration.Exploration` (default settings where `data` needs them);
    `model_overrides`: ``KEY=VALUE`` changes to the MLP model's training (`loop.dynamics.mlp`,
    e.g. ``rollout=5``)."""
    import jax
    import jax.numpy as jnp

    from litl.latent.planning import PLANNERS, Goal
    from litl.models.controller import MLPController
    from litl.settings.dynamics import MLPSettings

    run_dir = pathlib.Path(run_dir)
    if planner not in (*PLANNERS, *REFERENCES):
        raise ControlError(f"--planner {planner!r}: choose one of {(*PLANNERS, *REFERENCES)}")
    if control_steps is not None and (
        isinstance(control_steps, bool) or not isinstance(control_steps, int) or control_steps < 1
    ):
        raise ControlError(f"--control-steps {control_steps!r}: a positive number of control steps")
    if control_steps is not None and planner == "trained":
        raise ControlError(
            "--control-steps: the trained reference replays the run's own rollout; leave it out"
        )
    exploration = _checked_data(data, exploration)
    parsed = Goal.parse(goal)
    settings = planner_settings(planner, list(overrides)) if planner in (*PLANNERS, "oracle_mpc") else None
    model_overrides = list(model_overrides)
    overridden(MLPSettings(), model_overrides, "--model", "loop.dynamics.mlp")  # refused before loading
    planned = planner not in ("trained", "rest")  # rest plans nothing: any observer will do
    robot, config, algorithm, all_seeds, state = load(
        run_dir, latent=planned and data != "explored", features=planned
    )
    warm = getattr(settings, "warm_start", "previous")
    if warm != "previous" and not isinstance(algorithm.controller, MLPController):
        raise ControlError(
            f"--set warm_start={warm}: it starts from the run's trained controller, "
            f"which must read the observer's features (controller mlp); this run's is "
            f"{config.controller.kind}"
        )
    parsed.check((0.0, robot.config.grid_shape[parsed.axis] * robot.config.dx))
    chosen = all_seeds if seeds is None else list(seeds)
    missing = [s for s in chosen if s not in all_seeds]
    if missing:
        raise ControlError(f"--seeds {missing}: the run has seeds {all_seeds}")
    state = jax.tree.map(lambda leaf: leaf[jnp.asarray([all_seeds.index(s) for s in chosen])], state)
    mlp = overridden(config.loop.dynamics.mlp, model_overrides, "--model", "loop.dynamics.mlp")
    dynamics = dataclasses.replace(config.loop.dynamics, mlp=mlp)
    episode = Episode(
        robot, config, algorithm, parsed, planner, settings, control_steps, data, exploration, dynamics
    )
    if planner == "trained":
        results, fits, times = _trained(robot, algorithm, state, episode.stride, parsed.axis), None, {}
    else:
        results, fits, times = episode.run(state, chosen)
    summary = _summary(run_dir, episode, chosen, results, fits, times)
    out = pathlib.Path(out) if out else run_dir / "control" / f"{planner}-{parsed.kind}{parsed.value:g}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    failures = summary.pop("failures")
    out.write_text(json.dumps(summary, indent=1))
    files = [str(out)]
    if animate and "particles" in results:
        files.append(str(_animate(robot, episode, results, 0, out)))
    return {**summary, "out": str(out), "files": files, "failures": failures}


def _animate(robot, episode, results, index: int, out: pathlib.Path) -> pathlib.Path:
    """The first chosen seed's episode as `<out stem>.gif`: its particles after every control
    step, coloured by the action held over it."""
    import numpy as np

    from litl.viz import animate_rollout

    path = out.with_name(f"{out.stem}.gif")
    particles = np.asarray(results["particles"][index])
    actions = np.asarray(results["actions"][index])
    control_dt = episode.stride * robot.config.dt
    return animate_rollout(robot, particles, actions, path, fps=8, frame_seconds=control_dt)


@dataclasses.dataclass(frozen=True)
class Episode:
    """One planner's episode of every chosen seed, as one jit-compiled vmapped program."""

    robot: Any
    config: Any
    algorithm: Any
    goal: Any
    planner: str
    settings: Any
    steps: int | None = None  # control steps of the episode; None: the run's rollout's
    data: str = "buffer"  # what the latent model is fitted on (`DATA`)
    exploration: Any = None  # the exploratory episodes' `Exploration` (data explored or both)
    dynamics: Any = None  # the latent model's settings (`DynamicsConfig`; None: the run's)

    @property
    def stride(self) -> int:
        """Simulation steps per control step: the snapshot stride the model was fitted on."""
        return min(self.config.loop.snapshot_stride, self.algorithm.steps)

    @property
    def control_steps(self) -> int:
        return self.steps if self.steps is not None else self.algorithm.steps // self.stride

    def program(self, state, chosen):
        """(the jitted program of every seed, vmapped: fit, then the episode; its arguments)."""
        import jax
        import jax.numpy as jnp

        from litl.envs import make

        dtype = jnp.dtype(self.config.sim.dtype.value)
        first = jax.tree.map(lambda leaf: leaf[0], state.observer)  # each seed's replaces it
        observer = self.algorithm.observer
        env, env_params = make(
            self.robot, self.stride, None, "observer", dtype, observer=observer, observer_params=first
        )
        one = lambda *args: self._one(env, env_params, dtype, *args)
        keys = jax.vmap(lambda s: jax.random.fold_in(jax.random.key(s), 78))(jnp.asarray(chosen))
        arguments = (state.observer, state.buffer, state.design, state.controller, keys)
        return jax.jit(jax.vmap(one)), arguments

    def run(self, state, chosen):
        """(results, the fits' statistics, {compile_s, run_s}) of every seed, vmapped."""
        import jax

        program, arguments = self.program(state, chosen)
        started = time.perf_counter()
        compiled = program.lower(*arguments).compile()
        compile_s = time.perf_counter() - started
        started = time.perf_counter()
        results, fits = jax.block_until_ready(compiled(*arguments))
        return results, fits, {"compile_s": compile_s, "run_s": time.perf_counter() - started}

    def _one(self, env, env_params, dtype, observer, buffer, design, controller, key):
        import jax
        import jax.numpy as jnp

        from litl.latent.exploration import explore, join
        from litl.latent.model import buffer_sequence, fit_sequence
        from litl.latent.planning import control

        robot, goal = self.robot, self.goal
        params = env_params.replace(design=robot.design_space.to_design(design, dtype), observer=observer)
        kind = getattr(self.settings, "model", "linear" if self.planner == "latent_lqr" else "mlp")
        control_dt = self.stride * robot.config.dt
        parts = []
        learner = self.algorithm.observer.learner
        if self.data != "explored" and learner is not None and learner.latent is not None:
            parts.append(buffer_sequence(learner.latent, observer, buffer))
        if self.data != "buffer":
            explored = jax.random.fold_in(key, 1)  # the exploration's own draws
            parts.append(explore(env, params, explored, self.exploration, self.control_steps))
        # The model's fit (and its statistics) wherever there are data for it; `rest` on a run
        # without a latent codec has none, and needs none.
        fit = None
        if parts:
            settings = self.dynamics or self.config.loop.dynamics
            model, fit = fit_sequence(join(*parts), key, settings, control_dt, kind)
        if self.planner != "rest":
            oracle = self.planner == "oracle_mpc"
            module = self.algorithm.controller
            guide = lambda z, t: module.apply(controller, z.astype(dtype), time=jnp.asarray(t, dtype))
            steps = self.control_steps
            return control(env, params, model, goal, self.settings, key, steps, oracle, guide), fit
        _, env_state = env.reset(key, params)
        zero = jnp.zeros(env.num_actions, dtype)

        def still(carry, _):
            carry = env.step_env(key, carry, zero, params)[1]
            return carry, (env.robot.task_point(carry.sim)[goal.axis], env.robot.own(carry.sim).x)

        _, (positions, particles) = jax.lax.scan(still, env_state, None, length=self.control_steps)
        start = env.robot.task_point(env_state.sim)[goal.axis][None]
        actions = jnp.zeros((self.control_steps, env.num_actions), dtype)
        return {
            "positions": jnp.concatenate([start, positions]),
            "particles": particles,
            "actions": actions,
        }, fit


def _summary(run_dir, episode: Episode, chosen, results, fits, times) -> dict:
    """What the command writes: the episode's settings and costs, and each seed's entry."""
    from litl.latent.planning import model_steps

    settings, goal = episode.settings, episode.goal
    run_s = times.get("run_s")
    summary = {
        "run_dir": pathlib.Path(run_dir).name,
        "planner": episode.planner,
        "goal": {"kind": goal.kind, "value": goal.value, "axis": goal.axis},
        # what the goal moves: the task's group (the arm's tip) or the whole robot's centroid
        "point": (episode.robot.task and episode.robot.task.point_group) or "centroid",
        "settings": dataclasses.asdict(settings) if settings is not None else None,
        # what the latent model was fitted on, and the exploratory episodes' settings
        "data": episode.data if episode.planner != "trained" else None,
        "exploration": dataclasses.asdict(episode.exploration) if episode.exploration else None,
        "model_settings": dataclasses.asdict((episode.dynamics or episode.config.loop.dynamics).mlp),
        "control_dt": episode.stride * episode.robot.config.dt,
        "control_steps": episode.control_steps,
        "compile_s": times.get("compile_s"),
        "run_s": run_s,
        "wall_s_per_control_step": None if run_s is None else run_s / episode.control_steps / len(chosen),
        "model_steps_per_control_step": model_steps(settings) if settings is not None else None,
        # the oracle's planning simulates (and differentiates) this many steps per control step
        "sim_steps_per_control_step": (
            model_steps(settings) * episode.stride if episode.planner == "oracle_mpc" else None
        ),
        "seeds": [],
        "failures": [],
    }
    for i, seed in enumerate(chosen):
        entry = _seed_entry(goal, i, seed, results, fits, summary["control_dt"])
        summary["seeds"].append(entry)
        if entry.get("first_nonfinite_step") is not None:
            step = entry["first_nonfinite_step"]
            summary["failures"].append(
                f"seed {seed}: the plan's prediction was not finite at control step {step}"
            )
    return summary


def _seed_entry(goal, i: int, seed: int, results, fits, control_dt: float) -> dict:
    import numpy as np

    from litl.latent.planning import first_nonfinite

    track = np.asarray(results["positions"][i], float)
    entry = {
        "seed": seed,
        "start": float(track[0]),
        "final": float(track[-1]),
        "positions": [round(float(x), 6) for x in track],
        # along the goal's axis over the last control step: near 0 where a reach ended at rest
        "final_speed": float((track[-1] - track[-2]) / control_dt),
    }
    if goal.kind == "reach":
        entry["error"] = abs(float(track[-1]) - goal.value)
        entry["start_error"] = abs(float(track[0]) - goal.value)
    else:
        entry["displacement"] = float(np.sign(goal.value) * (track[-1] - track[0]))
    if fits is not None:
        entry["readout_r2"] = np.asarray(fits["readout_r2"][i], float).tolist()
        entry["model_epochs"] = int(fits["epochs"][i])
        entry["transitions"] = int(fits["transitions"][i])
    if "predicted" in results:  # the model's one-step position error under the planner's actions
        miss = np.asarray(results["predicted"][i], float) - track[1:]
        entry["one_step_position_rms"] = float(np.sqrt(np.mean(miss**2)))
        entry["one_step_motion_rms"] = float(np.sqrt(np.mean(np.diff(track) ** 2)))
    if "nonfinite" in results:
        entry["first_nonfinite_step"] = first_nonfinite(results["nonfinite"][i])
    return entry


def _trained(robot, algorithm, state, stride: int, axis: int) -> dict:
    """The run's own controller, simulated as the run simulated it: the task point every
    `stride` steps from the start."""
    import jax
    import jax.numpy as jnp

    from litl.sim import make_rollout

    observe = lambda s: robot.task_point(s)[axis]
    rollout = make_rollout(
        robot.config, robot.body(), algorithm.policy, algorithm.steps, field=algorithm.field, observe=observe
    )
    initial = robot.initial_state()

    def one(controller, observer, design):
        _, trajectory = rollout((controller, observer), robot.design_space.to_design(design), initial)
        track = trajectory.observations[stride - 1 :: stride]
        return jnp.concatenate([observe(initial)[None], track])

    positions = jax.jit(jax.vmap(one))(state.controller, state.observer, state.design)
    return {"positions": positions}


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m litl.latent.control", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("run_dir", type=pathlib.Path)
    parser.add_argument("--goal", required=True, help="reach:<x position> or walk:<+1 or -1>")
    parser.add_argument(
        "--planner",
        default="latent_mpc",
        help="latent_mpc, latent_ilqr, latent_lqr, trained, rest or oracle_mpc",
    )
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a planner setting")
    parser.add_argument("--seeds", type=lambda s: [int(x) for x in s.split(",")], default=None)
    parser.add_argument("--out", type=pathlib.Path, default=None)
    parser.add_argument("--animate", action="store_true", help="the first seed's episode as a .gif")
    parser.add_argument(
        "--control-steps", type=int, default=None, help="the episode's length (default: the run's rollout's)"
    )
    parser.add_argument(
        "--data",
        default="buffer",
        choices=DATA,
        help="what the latent model is fitted on: the run's buffer, exploratory episodes, or both",
    )
    parser.add_argument(
        "--model",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a setting of the MLP latent model's training (loop.dynamics.mlp), e.g. rollout=5",
    )
    parser.add_argument(
        "--explore-episodes", type=int, default=None, help="exploratory episodes (default 32)"
    )
    parser.add_argument(
        "--explore-hold", type=int, default=None, help="control steps each random action is held (default 4)"
    )
    return parser


def _checked_data(data: str, exploration):
    """The exploration `data` uses (its defaults where none is given); a `ControlError` for an
    unknown `data` or exploration settings that `data` does not use."""
    from litl.latent.exploration import Exploration

    if data not in DATA:
        raise ControlError(f"--data {data!r}: choose one of {DATA}")
    if exploration is not None and data == "buffer":
        raise ControlError("--explore-episodes/--explore-hold: set --data explored or both to use them")
    return Exploration() if data != "buffer" and exploration is None else exploration


def _exploration(episodes: int | None, hold: int | None):
    """The exploration the command line asks for (None where it names neither setting)."""
    if episodes is None and hold is None:
        return None
    from litl.latent.exploration import Exploration

    defaults = Exploration()
    return Exploration(
        episodes if episodes is not None else defaults.episodes, hold if hold is not None else defaults.hold
    )


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    with exit_on_user_error("python -m litl.latent.control", os_errors=True):
        summary = run(
            args.run_dir,
            args.goal,
            args.planner,
            args.set,
            args.seeds,
            args.out,
            args.animate,
            args.control_steps,
            args.data,
            _exploration(args.explore_episodes, args.explore_hold),
            args.model,
        )
    for entry in summary["seeds"]:
        what = (
            f"error {entry['error']:.4f} (from {entry['start_error']:.4f})"
            if "error" in entry
            else f"displacement {entry['displacement']:+.4f}"
        )
        print(f"seed {entry['seed']}: final {entry['final']:.4f}, {what}")
    print("wrote " + ", ".join(summary["files"]))
    for failure in summary["failures"]:
        print(f"litl.latent.control: {failure}", file=sys.stderr)
    return 1 if summary["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
