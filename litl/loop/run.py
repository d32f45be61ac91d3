"""The impure shell of a run: seeds batched with vmap, metrics, progress, checkpoints and resume.

    result = run(litl.robots.get("biped"), Config(seeds=10), "outputs/biped")

writes into the run directory (whose pieces, shared with the baselines, are
`litl.loop.run_directory`'s):

* `run.json`: the settings (a rerun on the same directory must use the same ones);
* `metrics.jsonl`: one JSON line per optimization iteration and seed (see `run`);
* `learning.jsonl`: one JSON line per learning phase and seed: seed, phase (0: the initial
  training; k: after episode k - 1), the observer's statistics as its `Learner.records` writes
  them (the autoencoder's: epochs_used, best_epoch, steps_per_epoch, sgd_steps, the
  reconstruction losses, recon_explained, active_units, velocity_r2, kl and val_recon_history,
  the validation reconstruction loss after each epoch: the paper's Fig. 5), update_accepted and
  wall_s (the phase's time for all seeds, compilation included in phase 0);
* `checkpoints/<episodes done>/`: orbax checkpoints at every episode boundary;
* `final/`: the final parameters of every seed (controller, design, observer), and `final.json`
  their task loss per seed (a forward simulation after the last update); a seed whose last
  iterations were skipped is marked stuck and has its last good task loss there (`litl.records.stuck`);
* `best/` and `best.json`: the parameters of each seed's best rollout, its task loss and iteration.

An iteration whose rollout blew up, lost particles or gave a non-finite loss or gradient changes
no parameters, optimizer states or replay buffer; its metrics line says `skipped` with the reason,
and a seed that keeps failing (`MANY_SKIPS` in a row) is reported on stderr.

Started again on a directory holding a checkpoint, `run` continues from it and ends with results
identical to an uninterrupted run: all state lives in the checkpoint, and `metrics.jsonl` is cut
back to the lines written before it.
"""

from __future__ import annotations

import dataclasses
import json
import math
import pathlib
import time

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from litl.config import Config, RunContext, seeds_at_once
from litl.designs import apply as apply_design
from litl.loop.algorithm import SKIP_REASONS, LoopState, seed_slice, stack_seeds
from litl.loop.checkpoint import Checkpoints
from litl.loop.loggers import NoLogger, RunLogger, check_kind, make_logger, snapshot_strip
from litl.loop.programs import Programs, programs
from litl.loop.progress import Progress, say

# The run directory's pieces are `litl.loop.run_directory`'s; RunDirectoryError and load_final
# stay importable from here, as before.
from litl.loop.run_directory import (
    RunDirectoryError as RunDirectoryError,
)
from litl.loop.run_directory import (
    RunDirectoryLock,
    claim,
    json_value,
    read_metrics,
    save_best,
    save_final_losses,
    save_parameters,
)
from litl.loop.run_directory import load_final as load_final
from litl.models.replay_buffer import newest
from litl.observers.interface import every_value
from litl.robots.robot import Robot
from litl.worlds import put, task_note, task_record

# Iterations skipped in a row after which a seed is reported as failing.
MANY_SKIPS = 5


@dataclasses.dataclass
class RunResult:
    """What a finished run leaves in memory (all of it is also on disk).

    Attributes:
      run_dir: the run directory.
      state: the final `LoopState` of every seed, leaves with a leading (S,) seed axis.
      metrics: the metrics records, as written to `metrics.jsonl`.
    """

    run_dir: pathlib.Path
    state: LoopState
    metrics: list[dict]


def settings(robot: Robot, record: dict, algorithm) -> dict:
    """What must match for a run directory to be resumed (`run.json`): the robot's, the run's
    settings as recorded (`record`: `RunContext.record`), and what the report needs to know of the
    observer ("observer": whether it learns, which settings it reads)."""
    return {
        "robot": robot.name,
        "particles": robot.layout.n_particles,
        "grid_shape": list(robot.config.grid_shape),
        "dx": robot.config.dx,
        "dt": robot.config.dt,
        "material": json.loads(json.dumps(dataclasses.asdict(robot.material))),
        "max_stretch": robot.config.max_stretch,  # the simulator's strain limit (None: none)
        "task": task_record(robot.task),  # the robot's own, or its world's (push_box)
        # the lower corner of its rest shape: where it stands (`Robot.shifted` moves it)
        "origin": [float(x) for x in robot.layout.bounds()[0]],
        "steps": algorithm.steps,
        "config": json.loads(json.dumps(record)),
        "observer": {"learned": algorithm.observer.learned, "reads": list(algorithm.observer.reads)},
    }


def shard_seeds(tree):
    """Spread the seed axis over all devices when it divides evenly (else leave it be)."""
    devices = jax.devices()
    seeds = jax.tree.leaves(tree)[0].shape[0]
    if len(devices) < 2 or seeds % len(devices):
        return tree
    sharding = NamedSharding(Mesh(np.asarray(devices), ("seed",)), PartitionSpec("seed"))
    return jax.device_put(tree, sharding)


def run(
    robot: Robot,
    config: Config,
    run_dir,
    progress: bool = True,
    stop_after_episodes: int | None = None,
    config_files: dict[str, str] | None = None,
) -> RunResult:
    """Run (or resume) Algorithm 1 for `config.seeds` seeds at once: `robot` put in the config's
    world (`litl.worlds.put`) with its design space (`litl.designs.apply`), then `run_loop` with
    the config's `context()`.

    Args:
      robot: the robot and its default task.
      config: the run's settings (observer, controller, sim, loop, seeds, seed, output, and the
        world the robot is put in; robot and task are the `robot` argument's).
      run_dir, progress, stop_after_episodes, config_files: as `run_loop` takes them.

    Returns:
      `run_loop`'s `RunResult`.
    """
    # A logger that cannot be used fails before anything is built or any directory is made, so
    # the mistake leaves no empty run directory (nor a lock file) behind.
    check_kind(config.output.logger)
    placed = apply_design(put(robot, config.world), config.design)
    note = task_note(config.world, placed)
    if note:
        say(note)
    return run_loop(placed, config.context(), run_dir, progress, stop_after_episodes, config_files)


def run_loop(
    robot: Robot,
    context: RunContext,
    run_dir,
    progress: bool = True,
    stop_after_episodes: int | None = None,
    config_files: dict[str, str] | None = None,
) -> RunResult:
    """Run (or resume) Algorithm 1 under `context.algorithm` for its seeds at once, `robot`
    already in its world: what `optimizer=litl` runs.

    Args:
      robot: the robot in its world, with its task.
      context: the run's settings besides the method's own (`litl.config.RunContext`).
      run_dir: directory for metrics, checkpoints and final parameters (created if needed).
      progress: show a progress bar on stderr.
      stop_after_episodes: return after this many episodes in total (the run can be resumed
        later); None runs all `loop.episodes`.
      config_files: {relative path: text} written into `run_dir` once the directory is locked
        and its settings agree with `context.record` (the CLI records its composed Hydra config
        so).

    Returns:
      A `RunResult`. Each metrics record has: seed, episode, iteration (within the episode),
      step (global iteration), task_loss and `task/<term>` components, design (per region) with
      design_mean/min/max, recon_loss_train, recon_loss_val, kl, learning_epochs (of the learning
      phase that produced the observer in use), retrain_effect (task objective before the latest
      retraining minus right after it, before any step: what retraining alone cost, negative
      meaning lost progress; on iteration 0 of episodes after a learning phase, else null),
      retrain_change (Table 1: the same after retraining plus one optimization step; on
      iteration 1), health steps, skipped (null, or why the iteration kept nothing of its own: one of
      `SKIP_REASONS`' values), consecutive_skips, stepped_back and step_scale (see
      `litl.loop.algorithm`: whether the iteration went back to the last accepted iterate, and
      the fraction of a full step taken), and wall_s.
    """
    check_kind(context.output.logger)
    algorithm_settings, loop = context.algorithm, context.algorithm.loop
    run_dir = pathlib.Path(run_dir)
    bar = Progress(loop.episodes, loop.iterations, enabled=progress)
    # Learning epochs are reported only where a progress display shows them (a compiled phase
    # without the host callback can come from JAX's persistent cache). The programs are shared
    # with an earlier run of this process that needed the same ones (`litl.loop.programs`).
    at_once = seeds_at_once(loop, algorithm_settings.seeds)
    shared = programs(robot, algorithm_settings, progress, at_once)
    wanted = settings(robot, context.record, shared.algorithm)
    run_dir.mkdir(parents=True, exist_ok=True)
    shared.epochs.to = bar.on_epoch if progress else None
    try:
        with RunDirectoryLock(run_dir):
            files = config_files or {}
            return _run_locked(context, run_dir, shared, wanted, bar, stop_after_episodes, files)
    finally:
        shared.epochs.to = None


def _run_locked(context, run_dir, shared, wanted, bar, stop_after_episodes, config_files):
    claim(run_dir, wanted, config_files)
    loop, algorithm = context.algorithm.loop, shared.algorithm
    seeds = context.seed_ids
    logger = make_logger(context.output.logger, run_dir, seeds, loop.iterations, wanted)
    shell = _Shell(run_dir, shared, seeds, logger)
    try:
        state, counters = shell.start()
        episodes = loop.episodes if stop_after_episodes is None else min(stop_after_episodes, loop.episodes)
        before = np.asarray(counters["loss_before_retrain"], np.float64)
        for episode in range(int(counters["episodes_done"]), episodes):
            state = shell.optimization_phase(state, episode, loop, before, bar)
            if algorithm.retrains:
                before = np.asarray(shell.evaluate(state), np.float64)
                with bar.learning(episode):
                    state = shell.learning_phase(state, episode)
                shell.log_pictures(state, (episode + 1) * loop.iterations)
            else:
                before = np.full(len(seeds), np.nan)
            shell.checkpoints.save(
                episode + 1,
                state,
                {
                    "episodes_done": episode + 1,
                    "metrics_lines": len(shell.records),
                    "learning_lines": len(shell.learning),
                    "loss_before_retrain": before,
                },
            )
        bar.close()
    finally:
        shell.checkpoints.close()
        logger.close()
    if episodes == loop.episodes:
        save_parameters(run_dir / "final", state)
        save_best(run_dir, state, shell.seeds)
        save_final_losses(run_dir, shell.evaluate(state), shell.seeds, shell.records)
    return RunResult(run_dir=run_dir, state=jax.tree.map(np.asarray, state), metrics=shell.records)


class _Shell:
    """The impure side of one run: the seeds' batched (jit of vmap) functions (`Programs`), the
    metrics and learning files, the checkpoints."""

    def __init__(self, run_dir: pathlib.Path, shared: Programs, seeds: list[int], logger: RunLogger):
        self.algorithm, self.seeds, self.logger = shared.algorithm, seeds, logger
        self.programs = shared
        self.plan_checked = False
        self.optimize, self.learn = shared.optimize, shared.learn
        self.bootstrap, self.evaluate = shared.bootstrap, shared.evaluate
        self.checkpoints = Checkpoints(run_dir / "checkpoints")
        self.metrics_file = run_dir / "metrics.jsonl"
        self.learning_file = run_dir / "learning.jsonl"
        self.records: list[dict] = []
        self.learning: list[dict] = []
        self.start_time = math.nan  # of the optimization iterations (wall_s counts from it): start()

    def start(self):
        """(state, counters): from the latest checkpoint (the files cut back to it), or from the
        bootstrap (initial rollout and learning phase) of fresh states."""
        algorithm, seeds = self.algorithm, self.seeds
        template = stack_seeds([algorithm.init(seed) for seed in seeds])
        counters = {
            "episodes_done": 0,
            "metrics_lines": 0,
            "learning_lines": 0,
            "loss_before_retrain": np.full(len(seeds), np.nan),
        }
        if self.checkpoints.latest() is not None:
            state, counters = self.checkpoints.restore(template, counters)
            self.records = read_metrics(self.metrics_file, int(counters["metrics_lines"]))
            self.learning = read_metrics(self.learning_file, int(counters["learning_lines"]))
        else:
            phase_start = time.perf_counter()
            state, stats = jax.block_until_ready(self.bootstrap(shard_seeds(template)))
            self.learning = (
                _learning_records(
                    stats, seeds, 0, time.perf_counter() - phase_start, algorithm.observer.learner
                )
                if algorithm.observer.learned
                else []
            )
            counters["learning_lines"] = len(self.learning)
            self.checkpoints.save(0, state, counters)
            self.log_pictures(state, 0)
        self.logger.restore(self.records, self.learning)
        for path, lines in ((self.metrics_file, self.records), (self.learning_file, self.learning)):
            with open(path, "w") as out:
                out.writelines(json.dumps(r) + "\n" for r in lines)
        self.start_time = time.perf_counter()
        return shard_seeds(state), counters

    def _say_checkpoint_plan(self):
        """Once per run: say so when the rollout's backward pass uses segments to fit the memory
        budget."""
        if self.plan_checked:
            return
        self.plan_checked = True
        plan = self.algorithm.checkpoint_plan()
        if plan.budget_bytes is None or not plan.checkpoint_every:
            return
        say(
            f"litl: the backward pass of a {plan.steps}-step rollout would keep "
            f"{plan.plain_bytes / 2**30:.3g} GiB per seed, over the budget of "
            f"{plan.budget_bytes / 2**30:.3g} GiB (sim.memory_budget): segments of "
            f"{plan.checkpoint_every} steps keep {plan.backward_bytes / 2**30:.3g} GiB, for one "
            f"more forward pass"
        )

    def optimization_phase(self, state, episode: int, loop, before, bar):
        """The episode's optimization iterations (`loop.iterations`), each seed's metrics written
        as they come. The run's length, `loop.episodes` x `loop.iterations` (the step sizes'
        cosine), is passed to the program as a value: runs that differ only in their number of
        episodes share their programs."""
        iterations = loop.iterations
        in_run = np.int32(loop.episodes * loop.iterations)
        stats = jax.tree.map(np.asarray, state.stats)
        with open(self.metrics_file, "a") as out:
            for iteration in range(iterations):
                state, metrics = self.optimize(state, in_run)
                self._say_checkpoint_plan()
                metrics = jax.tree.map(np.asarray, metrics)
                step = episode * iterations + iteration
                new = iteration_records(
                    metrics,
                    stats,
                    np.asarray(jax.vmap(self.algorithm.design_space.modulus)(state.design)),
                    self.seeds,
                    (episode, iteration, step),
                    before if iteration < 2 else None,
                    time.perf_counter() - self.start_time,
                    self.algorithm.observer.learner,
                )
                out.writelines(json.dumps(record) + "\n" for record in new)
                out.flush()
                self.records += new
                self.logger.iteration(new)
                finite = metrics["task_loss"][np.isfinite(metrics["task_loss"])]
                bar.update(episode, iteration, float(finite.mean()) if finite.size else np.nan)
                _warn_unhealthy(metrics, self.seeds, episode, iteration)
        return state

    def learning_phase(self, state, episode: int):
        """The learning phase after `episode`, its statistics appended to learning.jsonl."""
        phase_start = time.perf_counter()
        state, stats = jax.block_until_ready(self.learn(state, first=False))
        phase = _learning_records(
            stats, self.seeds, episode + 1, time.perf_counter() - phase_start, self.algorithm.observer.learner
        )
        with open(self.learning_file, "a") as log:
            log.writelines(json.dumps(r) + "\n" for r in phase)
        self.learning += phase
        self.logger.phase(phase)
        return state

    def log_pictures(self, state, step: int) -> None:
        """The first seed's newest snapshots and their reconstructions into the live log (an
        observer that reconstructs its input only)."""
        learner = self.algorithm.observer.learner
        if isinstance(self.logger, NoLogger) or learner is None or learner.reconstruct is None:
            return
        first = seed_slice(jax.tree.map(np.asarray, state), 0)
        snapshots = newest(first.buffer, 6)
        if len(snapshots):
            pixels = snapshot_strip(snapshots, self.programs.reconstruct(first.observer, snapshots))
            self.logger.image(self.seeds[0], "observer/snapshots", pixels, step)


def iteration_records(metrics, stats, design, seeds, position, before, seconds, learner) -> list[dict]:
    """One `metrics.jsonl` record per seed of an optimization iteration (arrays batched over
    seeds): `position` = (episode, iteration, global step); `stats`, the statistics of the learning
    phase whose observer is in use (what `learner.records` repeats of them); `before`, the task
    losses before the latest retraining (on iterations 0 and 1 of an episode, for retrain_effect
    and retrain_change; else None)."""
    episode, iteration, step = position
    records = []
    for s, seed in enumerate(seeds):
        record = {
            "seed": seed,
            "episode": episode,
            "iteration": iteration,
            "step": step,
            **{k: json_value(v[s]) for k, v in metrics.items()},
            "skipped": SKIP_REASONS.get(int(metrics["skipped"][s])),
            "design": json_value(design[s]),
            **_statistics_records(learner, stats, s)[1],
            "retrain_effect": None,
            "retrain_change": None,
            "wall_s": round(seconds, 3),
        }
        if before is not None and np.isfinite(before[s]):
            name = "retrain_effect" if iteration == 0 else "retrain_change"
            record[name] = float(before[s] - metrics["task_loss"][s])
        records.append(record)
    return records


def _statistics_records(learner, stats, s: int) -> tuple[dict, dict]:
    """Seed `s`'s (learning.jsonl record, what each metrics.jsonl record repeats) of a learning
    phase's statistics (a mapping batched over seeds), as the observer writes them out
    (`Learner.records`; every value, for an observer that does not learn)."""
    one = {name: value[s] for name, value in stats.items()}
    phase, iteration = (learner.records if learner is not None else every_value)(one)
    # The latent dynamics model's (loop.dynamics): in the phase's record only, whatever the learner keeps.
    dynamics = {name: value for name, value in one.items() if name.startswith("dynamics/")}
    phase = {**phase, **dynamics}
    iteration = {name: value for name, value in iteration.items() if name not in dynamics}
    return (
        {name: json_value(value) for name, value in phase.items()},
        {name: json_value(value) for name, value in iteration.items()},
    )


def _learning_records(stats, seeds, phase: int, seconds: float | None, learner) -> list[dict]:
    """One record per seed of a learning phase's statistics (batched over seeds); `seconds` is
    the phase's wall time for all seeds together (compilation included the first time)."""
    stats = jax.tree.map(np.asarray, stats)
    return [
        {
            "seed": seed,
            "phase": phase,
            **_statistics_records(learner, stats, s)[0],
            "wall_s": None if seconds is None else round(seconds, 3),
        }
        for s, seed in enumerate(seeds)
    ]


def _warn_unhealthy(metrics, seeds, episode, iteration):
    for s, seed in enumerate(seeds):
        reason = SKIP_REASONS.get(int(metrics["skipped"][s]))
        if reason is None:
            continue
        bad, escaped = metrics["first_nonfinite_step"][s], metrics["first_escape_step"][s]
        what = {
            "simulation_nonfinite": f"the simulation blew up (NaN) at step {bad}",
            "particles_escaped": f"particles left the grid at step {escaped}",
            "loss_nonfinite": "the task loss was not finite",
            "gradient_nonfinite": "the gradient was not finite",
        }[reason]
        where = f"seed {seed}, episode {episode}, iteration {iteration}"
        in_a_row = int(metrics["consecutive_skips"][s])
        if in_a_row == 1:
            say(
                f"warning: {where}: {what}; iteration skipped (parameters, optimizer and replay "
                f"buffer unchanged)"
            )
        elif in_a_row % MANY_SKIPS == 0:
            say(
                f"warning: {where}: seed {seed} has failed {in_a_row} iterations in a row "
                f"(latest: {what}); it is stuck at its last good parameters. Lower "
                f"controller.learning_rate / loop.design_learning_rate or the actuator "
                f"strength"
            )
