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
from typing import Any

from litl.config import Config, LoopConfig, Method, flatten
from litl.errors import UserError
from litl.settings.old import current_key, recorded_settings

_METHOD = LoopConfig()
# The ablation switches: named in a run's label only when the run departs from their default
# (`LoopConfig()`, the default method's, litl's; method=paper sets none of them, so the two
# methods share these values and a run of either is labelled by the same rule).
ABLATIONS = (
    # (setting, the method's value, how a run that departs from it is named)
    ("loop.replay_buffer", _METHOD.replay_buffer, lambda value: "no replay"),
    ("loop.schedule", _METHOD.schedule.value, lambda value: str(value).replace("_", "-")),
    ("loop.alpha", _METHOD.alpha, lambda value: f"α={value:g}"),
    ("loop.codesign", _METHOD.codesign, lambda value: "control only"),
)
# What the built-in observers read, for run.json files that predate the settings' sections (they
# listed single keys, and missed some).
LEGACY_READS = {
    "vae": ("observer.vae", "loop.learning"),
    "ae": ("observer.vae", "loop.learning"),
    "kmeans": ("observer.kmeans",),
}
# Settings that never distinguish runs: seeds split over several directories are pooled.
IGNORED = ("seed", "seeds", "sim.steps", "observer.kind", "controller.kind")
# How a core setting that differs between runs is named in their labels (an observer's or a
# controller's: its field's ``short`` metadata; others by their key).
CORE_SHORT_NAMES = (
    ("controller.learning_rate", "lr"),
    ("loop.design_learning_rate", "design lr"),
    ("world.kind", "world"),
    ("design.kind", "design"),
)


def short_names() -> dict[str, str]:
    """Short names of settings in run labels: the core's, and each registered observer's and
    controller's fields with ``short`` metadata (``observer.vae.latent_dim``: r)."""
    from litl.settings.registry import registry

    names = dict(CORE_SHORT_NAMES)
    for part in ("observer", "controller"):
        for section, settings in registry(part).sections().items():
            for f in dataclasses.fields(settings):
                if "short" in f.metadata:
                    names[f"{part}.{section}.{f.name}"] = f.metadata["short"]
    return names


def head_rank(head: str) -> tuple[int, str]:
    """Where reports list runs headed by `head`: observers, then open-loop controllers, each in
    registration order (`litl.settings.registry`); unregistered names last."""
    from litl.settings.registry import registry

    observers, controllers = registry("observer"), registry("controller")
    entry = observers.find(head)
    if entry is not None:
        return entry.order, entry.label
    entry = controllers.find(head)
    if entry is not None:
        return len(observers.names()) + entry.order, entry.label
    return len(observers.names()) + len(controllers.names()), head


def method_defaults(method: str) -> dict[str, Any]:
    """The settings `method` sets, by dotted key: those where the methods differ."""
    starts = {m.value: flatten(Config.for_method(m).run_settings()) for m in Method}
    return {
        key: value
        for key, value in starts[method].items()
        if key != "method" and len({json.dumps(s.get(key)) for s in starts.values()}) > 1
    }


REQUIRED_KEYS = ("seed", "step", "task_loss")


class ReportError(UserError, ValueError):
    """The input cannot be reported on; the message says which file and what is wrong."""


@dataclasses.dataclass(frozen=True)
class Run:
    """One run directory.

    Attributes:
      path: the run directory.
      settings: the parsed `run.json` (``robot``, ``dx``, ``steps``, ..., ``config``; see
        `litl.loop.run`).
      records: the parsed lines of `metrics.jsonl`, in file order; non-finite and null floats
        are NaN.
      learning: the parsed lines of `learning.jsonl` (one per learning phase and seed; empty when
        the file is absent, e.g. for k-means).
    """

    path: pathlib.Path
    settings: dict[str, Any]
    records: tuple[dict[str, Any], ...]
    learning: tuple[dict[str, Any], ...] = ()

    @property
    def robot(self) -> str:
        return str(self.settings.get("robot", "robot"))

    @property
    def config(self) -> dict[str, Any]:
        """The run's settings by dotted key (``"loop.alpha"``, ``"observer.kind"``), as
        `litl.config.Config.run_settings` names them (older run.json files translated)."""
        return recorded_settings(self.settings)

    @property
    def observer(self) -> str:
        return str(self.config.get("observer.kind", "vae"))

    @property
    def controller(self) -> str:
        return str(self.config.get("controller.kind", "mlp"))

    @property
    def head(self) -> str:
        """What heads the run's label: an optimization method's name other than litl's loop
        (``"cmaes"``), else what feeds the controller: the observer, or an open-loop controller's
        name (``"sinusoid"``)."""
        from litl.settings.parts import OptimizerConfig
        from litl.settings.registry import registry

        default = OptimizerConfig().kind
        optimizer = str(self.config.get("optimizer.kind", default))
        if optimizer != default:
            return optimizer
        entry = registry("controller").find(self.controller)
        open_loop = entry.traits.get("open_loop", False) if entry is not None else self.controller != "mlp"
        return self.controller if open_loop else self.observer

    @property
    def learned(self) -> bool:
        """Whether the observer is learned (has a reconstruction loss)."""
        known = self.settings.get("observer", {}).get("learned")
        if known is not None:
            return bool(known)
        return "loop.learning" in LEGACY_READS.get(self.observer, ())  # older run.json

    @property
    def observer_reads(self) -> tuple[str, ...]:
        """The settings the run's observer depends on (`Observer.reads`, dotted keys)."""
        known = self.settings.get("observer", {}).get("reads")
        if known is None:
            return LEGACY_READS.get(self.observer, ())  # older run.json
        moved = tuple(current_key(key) for key in known)
        if moved != tuple(known) and self.observer in LEGACY_READS:
            return LEGACY_READS[self.observer]  # older run.json: the observer's sections
        return moved

    @property
    def seeds(self) -> list[int]:
        return sorted({int(r["seed"]) for r in self.records})


def _natural_key(path: pathlib.Path) -> list[tuple[int, int, str]]:
    # Hydra numbers jobs 0, 1, ..., 10: sort "10" after "9".
    return [
        (0, int(part), "") if part.isdigit() else (1, 0, part)
        for part in re.split(r"(\d+)", str(path))
        if part
    ]


def find_run_dirs(path: str | os.PathLike[str]) -> list[pathlib.Path]:
    """Every directory at or below `path` holding both `run.json` and `metrics.jsonl`."""
    path = pathlib.Path(path)
    if not path.exists():
        raise ReportError(f"{path} does not exist")
    if not path.is_dir():
        raise ReportError(f"{path} is not a directory; give a run or multirun directory")
    found = [
        pathlib.Path(root)
        for root, _, files in os.walk(path)
        if "run.json" in files and "metrics.jsonl" in files
    ]
    return sorted(found, key=_natural_key)


def _finite(value: Any) -> Any:
    # NaN and inf are written as null; a float that is not finite is treated the same way.
    if value is None:
        return math.nan
    if isinstance(value, float) and not math.isfinite(value):
        return math.nan
    return value


def read_metrics(path: str | os.PathLike[str]) -> tuple[dict[str, Any], ...]:
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
                    f"fix or delete the line"
                ) from None
            if not isinstance(record, dict):
                raise ReportError(
                    f"{path}, line {number}: expected a JSON object, got {type(record).__name__}"
                )
            missing = [key for key in REQUIRED_KEYS if key not in record]
            if missing:
                raise ReportError(f"{path}, line {number}: missing {', '.join(missing)}")
            if not all(isinstance(record[key], int) for key in ("seed", "step")):
                raise ReportError(
                    f"{path}, line {number}: seed and step must be integers, got "
                    f"{record['seed']!r} and {record['step']!r}"
                )
            records.append({key: _finite(value) for key, value in record.items()})
    return tuple(records)


def load_run(path: str | os.PathLike[str]) -> Run:
    """Read one run directory (`run.json` and `metrics.jsonl`)."""
    path = pathlib.Path(path)
    try:
        settings = json.loads((path / "run.json").read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ReportError(f"{path / 'run.json'}: cannot be read ({error})") from None
    if not isinstance(settings, dict) or not isinstance(settings.get("config", settings.get("loop")), dict):
        raise ReportError(f"{path / 'run.json'}: expected an object with a 'config' object")
    return Run(
        path=path,
        settings=settings,
        records=read_metrics(path / "metrics.jsonl"),
        learning=read_learning(path / "learning.jsonl"),
    )


def read_learning(path: str | os.PathLike[str]) -> tuple[dict[str, Any], ...]:
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
        # The rest of a record is the observer's statistics, whatever it names them.
        if not isinstance(record, dict) or not {"seed", "phase"} <= set(record):
            raise ReportError(f"{path}, line {number}: expected a learning-phase record with seed and phase")
        records.append(record)
    return tuple(records)


def load_runs(path: str | os.PathLike[str]) -> list[Run]:
    """All runs at or below `path` (a run directory or a Hydra multirun directory).

    Raises:
      ReportError: `path` does not exist, holds no run directories, or a file is malformed.
    """
    run_dirs = find_run_dirs(path)
    if not run_dirs:
        raise ReportError(
            f"no runs found in {path}: no directory below it holds both run.json and "
            f"metrics.jsonl (written by `python -m litl` or `litl.loop.run`)"
        )
    return [load_run(run_dir) for run_dir in run_dirs]


def _relevant(name: str, run: Run) -> bool:
    """Whether setting `name` can tell `run` apart: settings of an observer or controller a run
    does not use cannot; the observer (or open-loop controller) heads every label and ablation
    switches are named by `ABLATIONS`."""
    if name.startswith(("observer.", "loop.learning.")) and name not in IGNORED:
        return any(name == read or name.startswith(read + ".") for read in run.observer_reads)
    if name.startswith("controller.") and name.count(".") > 1:  # controller.<kind>.<key>
        return name.split(".")[1] == run.controller
    return name not in (*IGNORED, *(setting for setting, _, _ in ABLATIONS))


def _ablation_applies(setting: str, run: Run) -> bool:
    # Without a learned observer there is no learning phase to ablate, only the design.
    return setting == "loop.codesign" or run.learned


def _format(value: Any, name: str = "") -> str:
    if name == "dx" and isinstance(value, float) and value > 0 and abs(1 / value - round(1 / value)) < 1e-9:
        return f"1/{round(1 / value)}"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, (list, tuple)):
        return "(" + ",".join(_format(v) for v in value) + ")"
    return str(value)


# Parts whose settings sections tell runs apart only within their kind, and their default kind
# (a run recorded without the part had it: runs before worlds and design spaces existed).
SECTIONED = {"world": "flat", "design": "modulus"}


def _own_sections(config: dict[str, Any]) -> dict[str, Any]:
    """`config` with its world and its design space each reduced to the kind and the keys of that
    kind's own section (``world.slope.angle``); the others do not tell runs apart."""
    kept = dict(config)
    for part, default in SECTIONED.items():
        kind = config.get(f"{part}.kind", default)
        kept = {k: v for k, v in kept.items() if not k.startswith(f"{part}.")}
        kept[f"{part}.kind"] = kind
        kept.update({k: v for k, v in config.items() if k.startswith(f"{part}.{kind}.")})
    return kept


def _comparable(run: Run) -> dict[str, Any]:
    """A run's settings that may tell it apart from other runs of the same robot (the steps
    used, not `sim.steps`, which may be null: the robot's default)."""
    return {
        **_own_sections(run.config),
        **flatten({"material": run.settings.get("material", {})}),
        **{k: v for k, v in run.settings.items() if k in ("dx", "dt", "steps")},
    }


def labels(runs: list[Run]) -> list[str]:
    """A label per run: its observer, settings that differ between runs, non-default ablations.

    For example ``"vae"``, ``"kmeans"``, ``"vae, no replay"``, ``"vae, α=1"``,
    ``"vae, control only"``, or ``"vae r=4"`` / ``"kmeans k=6"`` when runs of the same robot
    differ in latent size or cluster count. Runs of different robots are labelled independently.
    """
    by_robot: dict[str, list[int]] = {}
    for index, run in enumerate(runs):
        by_robot.setdefault(run.robot, []).append(index)
    names = short_names()
    result = [""] * len(runs)
    for indices in by_robot.values():
        settings = [_comparable(runs[i]) for i in indices]
        keys = sorted({key for s in settings for key in s}, key=lambda key: names.get(key, key))
        varying = []
        for key in keys:
            # A world's (a design space's) own setting tells runs apart only among runs in that
            # kind of world (of design space).
            part = key.partition(".")[0]
            own = part in SECTIONED and key != f"{part}.kind"
            values = {
                (s.get(f"{part}.kind") if own else None, json.dumps(s.get(key), sort_keys=True))
                for s, i in zip(settings, indices, strict=True)
                if _relevant(key, runs[i]) and (not own or key in s)
            }
            if len({value for _, value in values}) > 1 and len(values) > len({kind for kind, _ in values}):
                varying.append(key)
        for s, i in zip(settings, indices, strict=True):
            run = runs[i]
            # Where runs differ in their method, a key at its method's value is the method's.
            start = method_defaults(s["method"]) if "method" in varying else {}
            head = [head_rank(run.head)[1]] + [
                f"{names.get(key, key)}={_format(s[key], key)}"
                for key in varying
                if _relevant(key, run) and key in s and (key not in start or start[key] != s[key])
            ]
            config = run.config
            tail = [
                name(config[key])
                for key, default, name in ABLATIONS
                if key in config and config[key] != default and _ablation_applies(key, run)
            ]
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
    for run, label in zip(runs, labels(runs), strict=True):
        pooled.setdefault((run.robot, label), []).append(run)

    def order(key: tuple[str, str]) -> tuple[str, int, str]:
        robot, label = key
        return robot, head_rank(pooled[key][0].head)[0], label

    return [Group(robot, label, tuple(pooled[(robot, label)])) for robot, label in sorted(pooled, key=order)]
