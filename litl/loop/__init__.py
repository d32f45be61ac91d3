"""Learning-in-the-loop (Algorithm 1): the run, its pure per-seed pieces, and their building blocks.

    from litl.config import Config
    from litl.loop import run
    result = run(litl.robots.get("biped"), Config(seeds=10), "outputs/biped")

Observers (`litl.observers`) are an interface of pure functions with a registry by name; the loop
knows only that interface.
"""

from litl.loop.algorithm import Algorithm, LoopState, make_algorithm, seed_slice, stack_seeds
from litl.loop.observers import Learner, Observer
from litl.loop.retraining import soft_update
from litl.loop.run import RunResult, run, run_loop
from litl.loop.run_directory import RunDirectoryError, load_final
from litl.loop.schedule import LearningSchedule
from litl.models.replay_buffer import ReplayBuffer, add, clear, replace_with, valid_fields, valid_mask

__all__ = [
    "Algorithm",
    "LearningSchedule",
    "Learner",
    "LoopState",
    "Observer",
    "ReplayBuffer",
    "RunDirectoryError",
    "RunResult",
    "add",
    "clear",
    "load_final",
    "make_algorithm",
    "replace_with",
    "run",
    "run_loop",
    "seed_slice",
    "soft_update",
    "stack_seeds",
    "valid_fields",
    "valid_mask",
]
