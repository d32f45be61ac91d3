"""Baselines without litl's gradients, from well-kept libraries: evolution strategies (evosax) and
PPO (rejax), each writing a litl run directory.

    python -m litl baseline=cmaes seeds=10              # CMA-ES on the biped's controller and design
    python -m litl baseline=openai_es +scale=smoke
    python -m litl baseline=ppo seeds=10                # PPO on the biped as an environment

`run_baseline(robot, config, run_dir)` runs `config.baseline` for `config.seeds` seeds:

* ``cmaes`` / ``openai_es`` (`litl.baselines.evolution`): the controller network θ and the design
  φ that litl's loop optimizes, with an evolution strategy; the observer is fixed (kmeans, fitted
  at the start, or none; the preset picks kmeans).
* ``ppo`` (`litl.baselines.ppo`): rejax's PPO on `litl.envs`, controlling only (the design stays
  at its start); it observes the particle summary (the preset sets observer=none).

The run directory is a litl run's: run.json (settings, with the baseline's keys), metrics.jsonl
(one record per round and seed: ``task_loss``, ``simulations`` and ``simulated_steps`` so far, a
forward simulation step counting 1, ``wall_s``, and the method's own figures), checkpoints/
(a killed or paused run resumes from its last one, with the same records) and final.json, so
`python -m litl.report` draws it beside litl's runs (labelled by the baseline's name).
"""

from __future__ import annotations

import pathlib

from litl.config import BaselineKind, Config, SettingsError
from litl.robots.robot import Robot


def make_method(robot: Robot, config: Config):
    """The baseline's `litl.baselines.runner.Method` (refusing settings it cannot use)."""
    kind = config.baseline.kind
    if kind == BaselineKind.none:
        raise SettingsError("baseline.kind=none: there is no baseline to run (litl's loop runs instead)")
    if kind == BaselineKind.ppo:
        from litl.baselines.ppo import PPOBaseline

        return PPOBaseline(robot, config)
    from litl.baselines.evolution import EvolutionStrategy

    return EvolutionStrategy(robot, config)


def run_baseline(
    robot: Robot, config: Config, run_dir, progress: bool = True, config_files: dict[str, str] | None = None
) -> dict:
    """Run (or resume) `config.baseline` for `config.seeds` seeds in `run_dir`; returns
    {"run_dir", "final": [per seed], "records"}. `config_files` ({relative path: text}) are
    written into the run directory once it is claimed (the command line's .hydra/*.yaml)."""
    from litl.baselines.runner import run_rounds
    from litl.loop.algorithm import make_algorithm
    from litl.loop.run import settings

    method = make_method(robot, config)
    seeds = [config.seed + s for s in range(config.seeds)]
    algorithm = getattr(method, "algorithm", None) or make_algorithm(robot, config)
    wanted = settings(robot, config, algorithm)
    return run_rounds(method, seeds, pathlib.Path(run_dir), wanted, config_files or {}, progress)
