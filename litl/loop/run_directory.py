"""The run directory: what a run (litl's loop or a baseline) leaves on disk, and who may write it.

A run directory holds

* `run.json`: the settings that shape the run's results (`claim` records them, or checks that a
  resumed run's equal them; its backend and the litl that made it are recorded beside them);
* `.lock`: one process at a time on the directory (`RunDirectoryLock`);
* `metrics.jsonl` (and litl's `learning.jsonl`): one JSON record per line, cut back on resume to
  the lines its checkpoint covers (`read_metrics`; values made plain by `json_value`);
* `checkpoints/`: orbax checkpoints (`litl.loop.checkpoint`);
* litl's loop's finals: `final/` and `best/`, every seed's parameters (`save_parameters`,
  `save_best`, `load_final`), and `final.json` / `best.json`, their task losses
  (`save_final_losses`, `save_best`).

`litl.loop.run` (the loop) and `litl.optimizers.rounds` (every method that runs in rounds) use
these pieces; what a run records in `run.json` is theirs to say.
"""

from __future__ import annotations

import json
import math
import os
import pathlib

import jax
import numpy as np
import orbax.checkpoint as ocp

from litl import backend
from litl.config import Config, RunContext, flatten, read_sections_only
from litl.errors import UserError
from litl.loop.algorithm import Best, LoopState, make_algorithm, stack_seeds
from litl.loop.progress import say
from litl.records import provenance
from litl.records.stuck import seed_ends
from litl.robots.robot import Robot
from litl.settings.old import upgrade


class RunDirectoryError(UserError, ValueError):
    """The run directory belongs to a different run."""


def json_value(value):
    """`value` (an array or scalar) as plain JSON: nested lists, bools, ints, and floats with
    non-finite ones as null."""
    value = np.asarray(value)
    if value.ndim:
        return [json_value(v) for v in value]
    if value.dtype == bool:
        return bool(value)
    if np.issubdtype(value.dtype, np.integer):
        return int(value)
    value = float(value)
    return value if math.isfinite(value) else None


class RunDirectoryLock:
    """One process at a time on a run directory: an OS lock (`flock`) on `<run_dir>/.lock`.

    The lock belongs to the open file, so it dies with its process: a SIGKILLed run leaves no
    stale lock. A second process gets `RunDirectoryError` at once, naming the holder's pid, before
    it has touched anything in the directory. Within one process the lock is re-entrant (the CLI
    holds it while it records its config, `run` takes it again).
    """

    _held: dict = {}  # resolved lock path -> [open file, depth], for this process

    def __init__(self, run_dir: pathlib.Path):
        self.path = pathlib.Path(run_dir) / ".lock"
        self.key = str(self.path.absolute().resolve())

    def __enter__(self):
        import fcntl

        held = self._held.get(self.key)
        if held is not None:
            held[1] += 1
            return self
        handle = open(self.path, "a+")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.seek(0)
            holder = handle.read().strip() or "unknown"
            handle.close()
            raise RunDirectoryError(
                f"{self.path.parent} is in use by another litl run (process {holder}); wait for "
                f"it to finish, or choose another run directory. Nothing was changed."
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"{os.getpid()}\n")
        handle.flush()
        self._held[self.key] = [handle, 1]
        return self

    def __exit__(self, *exc):
        import fcntl

        held = self._held[self.key]
        held[1] -= 1
        if held[1] == 0:
            del self._held[self.key]
            fcntl.flock(held[0], fcntl.LOCK_UN)
            held[0].close()
        return False


def claim(run_dir: pathlib.Path, wanted: dict, config_files: dict[str, str]) -> None:
    """Record the run's settings in `run.json`, or check that they equal those recorded (a
    resumed run); then write the caller's config files."""
    settings_file = run_dir / "run.json"
    if settings_file.exists():
        found = json.loads(settings_file.read_text())
        if "config" not in found:
            raise RunDirectoryError(
                f"{run_dir} holds a run written by an earlier version of litl (its run.json has "
                f"no 'config'); it cannot be resumed. Choose a new run directory (`python -m "
                f"litl.report` still reads it). Nothing was changed."
            )
        # Settings recorded under keys that have moved since, and the observer's description,
        # which follows from them (what the report reads); the backend is not a setting.
        recorded = read_sections_only(upgrade(found["config"]))
        found = {**found, "config": recorded, "observer": wanted["observer"]}
        if "task" not in found:  # a run from before run.json recorded the task: it ran this one
            found["task"] = wanted.get("task")
        if "origin" not in found:  # nor where the robot stood (robots could not be shifted)
            found["origin"] = wanted.get("origin")
        if "max_stretch" not in found:  # a run from before the strain limit: purely elastic
            found["max_stretch"] = None
            found["material"] = {**found.get("material", {}), "max_stretch": math.inf}
        for record in ("backend", "provenance", "resumed_on"):  # where it ran, not how
            found.pop(record, None)
        if found != wanted:
            found, wanted_flat = flatten(found), flatten(wanted)
            changed = sorted(k for k in set(found) | set(wanted_flat) if found.get(k) != wanted_flat.get(k))
            hint = ""
            if "max_stretch" in changed:  # method=paper runs elastic since 2026-11-27: say how
                limit = found["max_stretch"]
                hint = f" (it was made with robot.material.max_stretch={'inf' if limit is None else limit})"
            raise RunDirectoryError(
                f"{run_dir} holds a run with other settings (differences in {changed}){hint}; resume "
                f"it with the same settings or choose a new run directory. Nothing was changed."
            )
        _say_if_resumed_elsewhere(run_dir, json.loads(settings_file.read_text()))
    else:
        settings_file.write_text(
            json.dumps({**wanted, "backend": backend.record(), "provenance": provenance.record()}, indent=1)
        )
    for name, text in config_files.items():
        (run_dir / name).parent.mkdir(parents=True, exist_ok=True)
        (run_dir / name).write_text(text)


def _say_if_resumed_elsewhere(run_dir: pathlib.Path, found: dict) -> None:
    """A run resumed in another determinism mode, on another platform or by another litl
    (commit) than it started with is told so, and run.json lists what it was resumed on: its
    results can no longer be expected to equal an uninterrupted run's bit for bit."""
    started, now = found.get("backend") or {}, backend.record()
    started_by, now_by = found.get("provenance"), provenance.record()
    differs = [key for key in ("determinism", "platform") if started and started.get(key) != now[key]]
    if differs:
        was = ", ".join(f"{key} {started.get(key)}" for key in differs)
        is_now = ", ".join(f"{key} {now[key]}" for key in differs)
        say(
            f"litl: warning: {run_dir} was started with {was} and is resumed with {is_now}: the "
            f"resumed run will not equal an uninterrupted one bit for bit (set {backend.SWITCH}="
            f"{started.get('determinism')} to resume in the mode it started in)."
        )
    other_litl = started_by is not None and started_by.get("commit") != now_by.get("commit")
    if other_litl:
        say(
            f"litl: warning: {run_dir} was started by {provenance.describe(started_by)} and is "
            f"resumed by {provenance.describe(now_by)}: its iterations come from two versions of litl."
        )
    if not differs and not other_litl:
        return
    recorded = json.loads((run_dir / "run.json").read_text())
    recorded.setdefault("resumed_on", []).append({**now, "provenance": now_by})
    (run_dir / "run.json").write_text(json.dumps(recorded, indent=1))


def read_metrics(path: pathlib.Path, lines: int) -> list[dict]:
    """The first `lines` records of a metrics file (those covered by the checkpoint)."""
    kept = path.read_text().splitlines()[:lines] if path.exists() else []
    if len(kept) < lines:
        raise RunDirectoryError(
            f"{path} has {len(kept)} lines but the checkpoint expects {lines}; it was edited or "
            f"truncated. Restore it or start a new run directory."
        )
    return [json.loads(line) for line in kept]


def parameters(state) -> dict:
    """What `final/` and `best/` hold of a `LoopState` (or its `Best`): controller, design, observer."""
    return {"controller": state.controller, "design": state.design, "observer": state.observer}


def save_parameters(path: pathlib.Path, state: LoopState | Best):
    """Every seed's `parameters` into the orbax checkpoint at `path` (`final/`, `best/`)."""
    with ocp.StandardCheckpointer() as saver:
        saver.save(path.absolute(), jax.tree.map(np.asarray, parameters(state)), force=True)


def save_best(run_dir: pathlib.Path, state: LoopState, seeds):
    """`best/`: each seed's best rollout's parameters; `best.json`: its task loss and step."""
    save_parameters(run_dir / "best", state.best)
    losses, steps = np.asarray(state.best.task_loss), np.asarray(state.best.step)
    summary = [
        {"seed": seed, "task_loss": json_value(losses[s]), "step": int(steps[s])}
        for s, seed in enumerate(seeds)
    ]
    (run_dir / "best.json").write_text(json.dumps(summary, indent=1))


def save_final_losses(run_dir: pathlib.Path, losses, seeds, records):
    """final.json: the task loss of each seed's final parameters (one more forward simulation;
    `python -m litl.replay` reproduces it). A seed whose last iterations were skipped is stuck
    (`litl.records.stuck`): its task_loss is its last good one, with ``"stuck": true``,
    skipped_at_end, last_good_step and final_parameters_loss (what the forward simulation of
    its final parameters gave; null: not finite). A seed whose last iteration was healthy but
    whose final parameters (after that iteration's update) fail in this forward simulation keeps
    that iteration's loss too, with ``"final_parameters_failed": true``, last_good_step and
    ``final_parameters_loss: null``. The other seeds' entries are as they were."""
    losses = np.asarray(losses)
    ends = seed_ends(records)
    summary = []
    for s, seed in enumerate(seeds):
        end = ends.get(seed)
        final_loss = json_value(losses[s])
        if end is not None and not end.stuck and final_loss is None and end.task_loss is not None:
            summary.append(
                {
                    "seed": seed,
                    "task_loss": end.task_loss,
                    "final_parameters_failed": True,
                    "last_good_step": end.last_good_step,
                    "final_parameters_loss": None,
                }
            )
            continue
        if end is None or not end.stuck:
            summary.append({"seed": seed, "task_loss": final_loss})
            continue
        summary.append(
            {
                "seed": seed,
                "task_loss": end.task_loss,
                "stuck": True,
                "skipped_at_end": end.skipped_at_end,
                "last_good_step": end.last_good_step,
                "final_parameters_loss": json_value(losses[s]),
            }
        )
    (run_dir / "final.json").write_text(json.dumps(summary, indent=1))


def load_final(run_dir, robot: Robot, config: Config | RunContext, which: str = "final") -> dict:
    """The {controller, design, observer} of every seed saved by `run`.

    Args:
      config: the run's settings, or its `RunContext`: what it reads of them is Algorithm 1's
        settings (`algorithm`) and the first seed (`seed`).
      which: ``"final"`` (after the last iteration) or ``"best"`` (of each seed's best rollout).
    """
    if which not in ("final", "best"):
        raise ValueError(f"which must be 'final' or 'best', got {which!r}")
    settings = config.algorithm
    algorithm = make_algorithm(robot, settings)
    template = stack_seeds([algorithm.init(config.seed + s) for s in range(settings.seeds)])
    abstract = jax.tree.map(ocp.utils.to_shape_dtype_struct, jax.tree.map(np.asarray, parameters(template)))
    with ocp.StandardCheckpointer() as loader:
        return loader.restore((pathlib.Path(run_dir) / which).absolute(), abstract)
