"""litl's loop (Algorithm 1, `litl.loop.run_loop`) as an optimization method: ``optimizer=litl``, the
default. Its settings are the config's `loop` section (episodes, iterations, the learning phases,
the safeguards), which the `method=` presets set."""

from __future__ import annotations

import pathlib
from typing import Any

from litl.config import RunContext
from litl.loop import run_loop
from litl.loop.progress import say
from litl.loop.run_directory import RunDirectoryLock
from litl.records.stuck import seed_ends, shown
from litl.robots.robot import Robot


class LoopOptimizer:
    """Algorithm 1 for the context's seeds at once; then the run's pictures and animation
    (`context.output`) and the final task loss per seed, a stuck seed said."""

    name = "litl"

    def __init__(self, robot: Robot, context: RunContext):
        self.robot, self.context = robot, context

    def budget(self) -> str:
        loop = self.context.algorithm.loop
        return f"{loop.episodes} x {loop.iterations} iterations"

    def run(self, run_dir: Any, progress: bool, config_files: dict[str, str]) -> Any:
        robot, context, run_dir = self.robot, self.context, pathlib.Path(run_dir)
        output = context.output
        with RunDirectoryLock(run_dir):  # held through the pictures too
            result = run_loop(robot, context, run_dir, progress=progress, config_files=config_files)
            if output.pictures or output.animation:
                from litl.viz.run_pictures import draw_run

                draw_run(
                    robot,
                    context,
                    result,
                    run_dir,
                    animation=output.animation,
                    pictures=output.pictures,
                    stride=output.animation_stride,
                    progress=progress,
                )
        say_final_losses(result.metrics, context.seed_ids, run_dir)
        return result


def say_final_losses(metrics: list[dict], seeds: list[int], run_dir: pathlib.Path) -> None:
    """The final task loss per seed; a seed whose last iterations were skipped reports its last
    good loss, marked, and is said to have ended stuck (`litl.records.stuck`)."""
    ends = seed_ends(metrics)
    shown_losses = ", ".join(shown(ends[seed]) if seed in ends else "n/a" for seed in seeds)
    say(f"litl: final task loss per seed [{shown_losses}]; results in {run_dir}")
    for seed in seeds:
        end = ends.get(seed)
        if end is not None and end.stuck:
            last = (
                "it never had a finite task loss"
                if end.last_good_step is None
                else f"its loss is that of iteration {end.last_good_step}, its last good one"
            )
            say(
                f"litl: seed {seed} ended stuck at its last good parameters (its last "
                f"{end.skipped_at_end} iteration(s) were skipped); {last}"
            )


def litl_loop(robot: Robot, settings: None, context: RunContext) -> LoopOptimizer:
    """`optimizer=litl`: litl's loop (it reads the config's `loop` section)."""
    return LoopOptimizer(robot, context)
