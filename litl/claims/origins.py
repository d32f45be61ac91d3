"""Which litl and which material made each cell of a claims suite.

A claim compares cells, so a table is citable only when it says which litl (commit) and which
material (elastic, or the strain limit's value) made them; and a cell resumed by another commit
or with another material would mix two programs in one curve. `check_resumable` refuses that
before anything runs; `describe` gives the lines a claims table prints; `commits` says whether a
table mixes cells of several commits.
"""

from __future__ import annotations

import dataclasses
import json
import os
import pathlib
from collections.abc import Callable, Sequence
from typing import Any

from litl import backend as backend_module
from litl.claims.slices import is_finished, slice_dirs
from litl.claims.suite import Cell, ClaimsError
from litl.config import Config
from litl.records import provenance


@dataclasses.dataclass(frozen=True)
class Origin:
    """What made a cell's run (its run.json).

    Attributes:
      commit: the git commit of the litl that started it (None: not from a checkout, or a run from
        before litl recorded it).
      recorded: run.json's "provenance" (None: a run from before 2026-11-27).
      max_stretch: the simulator's strain limit (None: purely elastic).
      backend: run.json's "backend": platform, device, determinism (None: not recorded).
    """

    commit: str | None
    recorded: dict[str, Any] | None
    max_stretch: float | None
    backend: dict[str, Any] | None = None

    @property
    def litl(self) -> str:
        return provenance.describe(self.recorded)


def origin(run_dir: str | os.PathLike[str]) -> Origin | None:
    """The origin of the run in `run_dir` (None: no run.json yet)."""
    path = os.path.join(run_dir, "run.json")
    if not os.path.exists(path):
        return None
    with open(path) as file:
        saved = json.load(file)
    recorded = saved.get("provenance")
    # A run from before the strain limit has no "max_stretch": it was purely elastic.
    commit = recorded.get("commit") if recorded else None
    return Origin(commit, recorded, saved.get("max_stretch"), saved.get("backend"))


def material(max_stretch: float | None) -> str:
    """The material in words: ``elastic`` or ``yields past a stretch of 3``."""
    return "elastic (no strain limit)" if max_stretch is None else f"yields past a stretch of {max_stretch:g}"


def platform(backend: dict[str, Any] | None) -> str:
    """Where a run ran, in words: ``NVIDIA H200, determinism off`` or ``cpu, deterministic``."""
    if not backend:
        return "—"
    device = backend_module.device_of(backend) or "?"
    mode = {"on": "deterministic", "off": "determinism off"}.get(str(backend.get("determinism")), "")
    return f"{device}, {mode}" if mode else str(device)


def check_resumable(
    out: str | os.PathLike[str], suite: Sequence[Cell], config_of: Callable[[Cell], Config]
) -> None:
    """Refuse (`ClaimsError`, before anything runs) to resume an unfinished cell that another
    commit of litl started, or that ran another material than `config_of(cell)` asks for; the
    message names both, and nothing is changed. Finished cells are only read, never refused."""
    from litl.app import build_robot

    commit, dirty = provenance.checkout()
    now = provenance.describe({"litl": _version(), "commit": commit, "dirty": dirty})
    for cell in suite:
        for run_dir in slice_dirs(cell.run_dir(out)):
            found = origin(run_dir)
            if found is None or is_finished(run_dir):
                continue
            _check_origin(cell, run_dir, found, commit, now, build_robot(config_of(cell)).config.max_stretch)


def _check_origin(
    cell: Cell, run_dir: pathlib.Path, found: Origin, commit: str | None, now: str, wanted: float | None
) -> None:
    if found.commit != commit:
        raise ClaimsError(
            f"{cell.name} ({run_dir}) was started by {found.litl}; this is {now}. A cell resumed "
            f"by another litl would mix two programs in one run: resume it from that commit "
            f"(git worktree add DIR {found.commit or '<its commit>'}), or give another --out. "
            f"Nothing was changed."
        )
    if found.max_stretch != wanted:
        raise ClaimsError(
            f"{cell.name} ({run_dir}) was run with a material that {material(found.max_stretch)}; "
            f"this suite asks for one that {material(wanted)}. Give another --out, or resume it "
            f"with the material it was made with. Nothing was changed."
        )


def _version() -> str:
    from litl import __version__

    return __version__


def judging_litl() -> str:
    """The litl that judges now, in words (``litl 0.1.0, commit 1a2b3c4d5e6f``): a table's
    verdicts are this code's, whichever commit made the runs it reads."""
    commit, dirty = provenance.checkout()
    return provenance.describe({"litl": _version(), "commit": commit, "dirty": dirty})


def origins(out: str | os.PathLike[str], suite: Sequence[Cell]) -> dict[str, Origin]:
    """{cell name: its origin} of the cells that have a run.json."""
    found = {cell.name: _first_origin(cell.run_dir(out)) for cell in suite}
    return {name: o for name, o in found.items() if o is not None}


def _first_origin(cell_dir: pathlib.Path) -> Origin | None:
    """The origin of a cell run whole, or of its first slice (`litl.claims.slices.read_cell`
    refuses slices of different commits)."""
    for run_dir in slice_dirs(cell_dir):
        found = origin(run_dir)
        if found is not None:
            return found
    return None


def commits(found: dict[str, Origin]) -> dict[str, list[str]]:
    """{litl description: the cells it made}, in the suite's order."""
    made: dict[str, list[str]] = {}
    for name, o in found.items():
        made.setdefault(o.litl, []).append(name)
    return made


def describe(found: dict[str, Origin]) -> list[str]:
    """Markdown lines for a claims table: which litl and which material made its cells."""
    if not found:
        return []
    lines = []
    made = commits(found)
    if len(made) == 1:
        lines.append(f"Made by {next(iter(made))}.")
    else:
        lines.append(f"Made by {len(made)} versions of litl (their verdicts mix programs):")
        lines += [f"- {litl}: {', '.join(cells)}" for litl, cells in made.items()]
    materials: dict[str, list[str]] = {}
    for name, o in found.items():
        materials.setdefault(material(o.max_stretch), []).append(name.split("/")[0])
    parts = [f"{m} ({', '.join(sorted(set(methods)))})" for m, methods in materials.items()]
    lines.append(f"Material: {'; '.join(parts)}.")
    return lines
