"""Finding and reading run directories, and naming each run by what distinguishes it.

A run directory (written by `litl.loop.run`) holds `run.json` (the settings) and `metrics.jsonl`
(one JSON object per optimization iteration and seed). A Hydra multirun directory holds many of
them, numbered and possibly nested (a date folder, `0/`, `1/`, ...); `load_runs` finds them all.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import pathlib
import re

# The paper's method: these ablation switches are named in a label only when a run departs from
# them. They mirror `LoopConfig`'s defaults (a test keeps them equal); they are copied rather than
# imported because `litl.loop` imports JAX, which a report never needs.
ABLATIONS = (
    # (field, the method's value, how a run that departs from it is named)
    ("replay", True, lambda value: "no replay"),
    ("one_shot", False, lambda value: "one-shot"),
    ("simultaneous", False, lambda value: "simultaneous"),
    ("alpha", 0.5, lambda value: f"α={value:g}"),
    ("codesign", True, lambda value: "control only"),
)
# Run directories written before run.json recorded its observer's reads (`Observer.reads`).
LEGACY_READS = {"vae": ("latent_dim", "window", "channels", "activation", "learning"),
                "ae": ("latent_dim", "window", "channels", "activation", "learning"),
                "kmeans": ("clusters",)}
# Settings some observer reads: they distinguish runs only where the run's observer reads them.
OBSERVER_SETTINGS = ("latent_dim", "window", "channels", "activation", "learning", "clusters")
OBSERVER_ORDER = ("vae", "ae", "kmeans", "none", "sinusoid")
# Settings that never distinguish runs: seeds split over several directories are pooled.
IGNORED = ("seed", "seeds")
# How a setting that differs between runs is named in their labels.
SHORT_NAMES = (("latent_dim", "r"), ("clusters", "k"), ("learning_rate", "lr"),
               ("design_learning_rate", "design lr"))
REQUIRED_KEYS = ("seed", "step", "task_loss")


class ReportError(ValueError):
    """The input cannot be reported on; the message says which file and what is wrong."""


@dataclasses.dataclass(frozen=True)
class Run:
    """One run directory.

    Attributes:
      path: the run directory.
      settings: the parsed `run.json` (``robot``, ``dx``, ``steps``, ..., ``loop``).
      records: the parsed lines of `metrics.jsonl`, in file order; non-finite and null floats
        are NaN.
      learning: the parsed lines of `learning.jsonl` (one per learning phase and seed; empty when
        the file is absent, e.g. for k-means).
    """

    path: pathlib.Path
    settings: dict
    records: tuple[dict, ...]
    learning: tuple[dict, ...] = ()

    @property
    def robot(self) -> str:
        return str(self.settings.get("robot", "robot"))

    @property
    def loop(self) -> dict:
        return self.settings.get("loop", {})

    @property
    def observer(self) -> str:
        return str(self.loop.get("observer", "vae"))

    @property
    def controller(self) -> str:
        return str(self.loop.get("controller", "mlp"))

    @property
    def head(self) -> str:
        """What feeds the controller, heading the run's label: the observer, or an open-loop
        controller's name (``"sinusoid"``)."""
        return self.observer if self.controller == "mlp" else self.controller

    @property
    def learned(self) -> bool:
        """Whether the observer is learned (has a reconstruction loss)."""
        known = self.settings.get("observer", {}).get("learned")
        if known is not None:
            return bool(known)
        return "learning" in LEGACY_READS.get(self.observer, ())               # older run.json

    @property
    def observer_reads(self) -> tuple[str, ...]:
        """The loop settings the run's observer depends on (`Observer.reads`)."""
        known = self.settings.get("observer", {}).get("reads")
        if known is not None:
            return tuple(known)
        return LEGACY_READS.get(self.observer, ())                              # older run.json

    @property
    def seeds(self) -> list[int]:
        return sorted({int(r["seed"]) for r in self.records})


def _natural_key(path: pathlib.Path):
    # Hydra numbers jobs 0, 1, ..., 10: sort "10" after "9".
    return [(0, int(part), "") if part.isdigit() else (1, 0, part)
            for part in re.split(r"(\d+)", str(path)) if part]


def find_run_dirs(path) -> list[pathlib.Path]:
    """Every directory at or below `path` holding both `run.json` and `metrics.jsonl`."""
    path = pathlib.Path(path)
    if not path.exists():
        raise ReportError(f"{path} does not exist")
    if not path.is_dir():
        raise ReportError(f"{path} is not a directory; give a run or multirun directory")
    found = [pathlib.Path(root) for root, _, files in os.walk(path)
             if "run.json" in files and "metrics.jsonl" in files]
    return sorted(found, key=_natural_key)


def _finite(value):
    # NaN and inf are written as null; a float that is not finite is treated the same way.
    if value is None:
        return math.nan
    if isinstance(value, float) and not math.isfinite(value):
        return math.nan
    return value


def read_metrics(path) -> tuple[dict, ...]:
    """The records of one `metrics.jsonl`; a malformed line is a `ReportError` naming it."""
    path = pathlib.Path(path)
    records = []
    with open(path) as lines:
        for number, line in enumerate(lines, start=1):
            if not line.strip():
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError as error:
                raise ReportError(
                    f"{path}, line {number}: not valid JSON ({error.msg}, column {error.colno}); "
                    f"fix or delete the line") from None
            if not isinstance(record, dict):
                raise ReportError(f"{path}, line {number}: expected a JSON object, got "
                                  f"{type(record).__name__}")
            missing = [key for key in REQUIRED_KEYS if key not in record]
            if missing:
                raise ReportError(f"{path}, line {number}: missing {', '.join(missing)}")
            if not all(isinstance(record[key], int) for key in ("seed", "step")):
                raise ReportError(f"{path}, line {number}: seed and step must be integers, got "
                                  f"{record['seed']!r} and {record['step']!r}")
            records.append({key: _finite(value) for key, value in record.items()})
    return tuple(records)


def load_run(path) -> Run:
    """Read one run directory (`run.json` and `metrics.jsonl`)."""
    path = pathlib.Path(path)
    try:
        settings = json.loads((path / "run.json").read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ReportError(f"{path / 'run.json'}: cannot be read ({error})") from None
    if not isinstance(settings, dict) or not isinstance(settings.get("loop", {}), dict):
        raise ReportError(f"{path / 'run.json'}: expected an object with a 'loop' object")
    return Run(path=path, settings=settings, records=read_metrics(path / "metrics.jsonl"),
               learning=read_learning(path / "learning.jsonl"))


def read_learning(path) -> tuple[dict, ...]:
    """The learning phases of a run (`learning.jsonl`); () if the file does not exist."""
    path = pathlib.Path(path)
    if not path.exists():
        return ()
    records = []
    for number, line in enumerate(path.read_text().splitlines(), 1):
        try:
            record = json.loads(line)
        except json.JSONDecodeError as error:
            raise ReportError(f"{path}, line {number}: not valid JSON ({error.msg})") from None
        if not isinstance(record, dict) or not {"seed", "phase", "steps_per_epoch",
                                                "val_recon_history"} <= set(record):
            raise ReportError(f"{path}, line {number}: expected a learning-phase record with "
                              f"seed, phase, steps_per_epoch and val_recon_history")
        records.append(record)
    return tuple(records)


def load_runs(path) -> list[Run]:
    """All runs at or below `path` (a run directory or a Hydra multirun directory).

    Raises:
      ReportError: `path` does not exist, holds no run directories, or a file is malformed.
    """
    run_dirs = find_run_dirs(path)
    if not run_dirs:
        raise ReportError(
            f"no runs found in {path}: no directory below it holds both run.json and "
            f"metrics.jsonl (written by `python -m litl` or `litl.loop.run`)")
    return [load_run(run_dir) for run_dir in run_dirs]


def _flatten(settings: dict, prefix: str = "") -> dict:
    flat = {}
    for key, value in settings.items():
        if isinstance(value, dict):
            flat.update(_flatten(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def _relevant(name: str, run: Run) -> bool:
    # Settings of an observer a run does not use cannot distinguish it.
    root = name.split(".")[0]
    if root in OBSERVER_SETTINGS or root in run.observer_reads:
        return root in run.observer_reads
    if name in ("controller_widths", "controller_period", "feature_gradient"):
        return run.controller == "mlp"
    if name == "controller_omega":
        return run.controller == "sinusoid"
    # The observer (or open-loop controller) heads every label; ablation switches are named by
    # `ABLATIONS`.
    return name not in (*IGNORED, "observer", "controller", *(field for field, _, _ in ABLATIONS))


def _ablation_applies(field: str, run: Run) -> bool:
    # Without a learned observer there is no learning phase to ablate, only the design.
    return field == "codesign" or run.learned


def _format(value, name: str = "") -> str:
    if name == "dx" and isinstance(value, float) and value > 0 and abs(
            1 / value - round(1 / value)) < 1e-9:
        return f"1/{round(1 / value)}"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, (list, tuple)):
        return "(" + ",".join(_format(v) for v in value) + ")"
    return str(value)


def _comparable(settings: dict) -> dict:
    """A run's settings that may tell it apart from other runs of the same robot."""
    loop = _flatten(settings.get("loop", {}))
    # The loop's `steps` may be None (the robot's default); the top level holds the steps used.
    loop.pop("steps", None)
    return {**loop, **{k: v for k, v in settings.items() if k in ("dx", "dt", "steps")}}


def labels(runs: list[Run]) -> list[str]:
    """A label per run: its observer, settings that differ between runs, non-default ablations.

    For example ``"vae"``, ``"kmeans"``, ``"vae, no replay"``, ``"vae, α=1"``,
    ``"vae, control only"``, or ``"vae r=4"`` / ``"kmeans k=6"`` when runs of the same robot
    differ in latent size or cluster count. Runs of different robots are labelled independently.
    """
    by_robot: dict[str, list[int]] = {}
    for index, run in enumerate(runs):
        by_robot.setdefault(run.robot, []).append(index)
    names = dict(SHORT_NAMES)
    result = [""] * len(runs)
    for indices in by_robot.values():
        settings = [_comparable(runs[i].settings) for i in indices]
        keys = sorted({key for s in settings for key in s})
        varying = []
        for key in keys:
            values = {json.dumps(s.get(key), sort_keys=True)
                      for s, i in zip(settings, indices) if _relevant(key, runs[i])}
            if len(values) > 1:
                varying.append(key)
        for s, i in zip(settings, indices):
            run = runs[i]
            head = [run.head] + [f"{names.get(key, key)}={_format(s[key], key)}"
                                     for key in varying if _relevant(key, run) and key in s]
            tail = [name(run.loop[field]) for field, default, name in ABLATIONS
                    if field in run.loop and run.loop[field] != default
                    and _ablation_applies(field, run)]
            result[i] = ", ".join([" ".join(head)] + tail)
    return result


@dataclasses.dataclass(frozen=True)
class Group:
    """Runs of one robot with the same label; their seeds are pooled.

    Attributes:
      robot: the robot's name.
      label: the label shared by the runs (see `labels`).
      runs: the runs.
    """

    robot: str
    label: str
    runs: tuple[Run, ...]

    @property
    def learned(self) -> bool:
        return all(run.learned for run in self.runs)

    @property
    def n_seeds(self) -> int:
        return sum(len(run.seeds) for run in self.runs)


def group_runs(runs: list[Run]) -> list[Group]:
    """Pool runs by (robot, label), ordered by robot, then observer (vae, ae, kmeans), label."""
    pooled: dict[tuple[str, str], list[Run]] = {}
    for run, label in zip(runs, labels(runs)):
        pooled.setdefault((run.robot, label), []).append(run)

    def order(key):
        robot, label = key
        observer = pooled[key][0].head
        rank = OBSERVER_ORDER.index(observer) if observer in OBSERVER_ORDER else len(OBSERVER_ORDER)
        return robot, rank, label

    return [Group(robot, label, tuple(pooled[(robot, label)]))
            for robot, label in sorted(pooled, key=order)]
