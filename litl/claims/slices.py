"""A claims cell cut along its seeds: each slice a run of its own, the cell read as their union.

A cell's seeds are independent runs, so a cell need not run in one process: `--slice-seeds K`
cuts it into slices of K seeds (the last one smaller when K does not divide the seeds), each a
run directory `<cell dir>/seeds-<first>-<last>` with its own run.json, metrics.jsonl and
learning.jsonl, made by ``python -m litl <the cell's overrides> seeds=<n> seed=<first>``. A
finished slice is never run again; slices run on one machine or many, at any time, and a cell is
judged once every seed it asks for is in a finished slice.

A cell run whole (a run.json in the cell's own directory, as before slices) is read as one slice
holding all its seeds.

`read_cell` refuses what cannot be pooled, naming the slices: slices made by different commits,
with different settings or at another scale; a seed in two slices; a slice edited by hand (a
metrics file with more or fewer records than its run.json and final.json say). Seeds no
finished slice holds are the cell's missing seeds (`CellRuns.missing`).
"""

from __future__ import annotations

import dataclasses
import json
import os
import pathlib
import re
from collections.abc import Sequence
from typing import Any

from litl.claims.suite import Cell, ClaimsError, Scale, finished_records
from litl.report.runs import Run, load_run

SLICE_DIR = re.compile(r"seeds-(\d+)-(\d+)")
# Records of a slice that are not its run: what the launcher planned (slice.json) and the wall
# time it took (timing.json).
PLAN_FILE = "slice.json"
TIMING_FILE = "timing.json"


@dataclasses.dataclass(frozen=True)
class Slice:
    """Seeds ``first, ..., first + count - 1`` of a cell, run together in one process."""

    cell: Cell
    first: int
    count: int

    @property
    def last(self) -> int:
        return self.first + self.count - 1

    @property
    def seeds(self) -> range:
        return range(self.first, self.first + self.count)

    @property
    def dir_name(self) -> str:
        return f"seeds-{self.first}-{self.last}"

    @property
    def name(self) -> str:
        return f"{self.cell.name}/{self.dir_name}"

    def run_dir(self, out: str | os.PathLike[str]) -> pathlib.Path:
        return self.cell.run_dir(out) / self.dir_name

    def overrides(self, scale: Scale) -> list[str]:
        """The command line that makes this slice: ``python -m litl <overrides>``."""
        return [*self.cell.overrides(scale, self.count), f"seed={self.first}"]


def cut(cell: Cell, seeds: Sequence[int], size: int) -> list[Slice]:
    """`cell`'s `seeds` (consecutive) in slices of `size` seeds, the last one smaller if `size`
    does not divide them.

    Raises:
      ClaimsError: `size` below 1 or above the number of seeds.
    """
    if size < 1 or size > len(seeds):
        raise ClaimsError(
            f"--slice-seeds must lie between 1 and the {len(seeds)} seeds of a cell "
            f"(--slice-seeds 2 runs them two at a time); got {size}"
        )
    first = seeds[0]
    return [Slice(cell, first + start, min(size, len(seeds) - start)) for start in range(0, len(seeds), size)]


@dataclasses.dataclass(frozen=True)
class CellRuns:
    """What a cell's directory holds.

    Attributes:
      runs: the finished slices' runs (a whole cell's one run), in seed order.
      missing: the seeds asked for that no finished slice holds, in order.
      unfinished: the slices' directories that have started but not finished.
    """

    runs: tuple[Run, ...]
    missing: tuple[int, ...]
    unfinished: tuple[pathlib.Path, ...] = ()

    @property
    def complete(self) -> bool:
        return not self.missing


def slice_dirs(cell_dir: pathlib.Path) -> list[pathlib.Path]:
    """The started slices of a cell (`seeds-<first>-<last>` holding a run.json), in seed order;
    the cell's own directory where it was run whole."""
    if (cell_dir / "run.json").exists():
        return [cell_dir]
    if not cell_dir.is_dir():
        return []
    found = [p for p in cell_dir.iterdir() if SLICE_DIR.fullmatch(p.name) and (p / "run.json").exists()]
    return sorted(found, key=lambda p: int(SLICE_DIR.fullmatch(p.name).group(1)))  # type: ignore[union-attr]


def read_cell(
    cell_dir: pathlib.Path, seeds: Sequence[int], episodes: int | None = None, iterations: int | None = None
) -> CellRuns:
    """The finished slices of the cell in `cell_dir`, checked to pool, and the `seeds` they lack.

    `episodes`, `iterations`: the size the cell is asked for (None: whatever the slices ran);
    a slice of another size is refused.

    Raises:
      ClaimsError: slices that disagree on commit, settings or size, or with a seed in common; a
        slice whose records do not match its run.json (edited by hand); a slice of another size.
    """
    finished: list[Run] = []
    unfinished: list[pathlib.Path] = []
    for run_dir in slice_dirs(cell_dir):
        run = _checked_run(run_dir)
        size = (_loop(run, "episodes"), _loop(run, "iterations"))
        wanted = (episodes or size[0], iterations or size[1])
        if size != wanted:
            raise ClaimsError(
                f"{run_dir} was run with loop.episodes={size[0]} loop.iterations={size[1]}, but this "
                f"suite asks for {wanted[0]} x {wanted[1]}: give another --out (or move that slice "
                f"away), or the --episodes it was run with"
            )
        if len(run.records) < expected_records(run):
            unfinished.append(run_dir)
        else:
            finished.append(run)
    _check_poolable(finished)
    held: dict[int, pathlib.Path] = {}
    for run in finished:
        for seed in run_seeds(run):
            if seed in held:
                raise ClaimsError(
                    f"seed {seed} is in two slices of {cell_dir}: {held[seed].name} and {run.path.name}; "
                    f"move one of them away"
                )
            held[seed] = run.path
    strangers = sorted(set(held) - set(seeds))
    if strangers:
        holders = ", ".join(sorted({held[seed].name for seed in strangers}))
        raise ClaimsError(
            f"{cell_dir} holds seeds {seed_ranges(strangers)} ({holders}), but this suite asks for "
            f"seeds {seed_ranges(seeds)}: give the --seeds and --first-seed they were run with, or "
            f"another --out"
        )
    missing = tuple(seed for seed in seeds if seed not in held)
    kept = tuple(sorted(finished, key=_first_seed))
    return CellRuns(kept, missing, tuple(unfinished))


def run_seeds(run: Run) -> list[int]:
    """The seeds a run was asked for (its run.json: seed, ..., seed + seeds - 1)."""
    config = run.settings.get("config", {})
    first, count = int(config.get("seed", 0) or 0), int(config.get("seeds", 1))
    return list(range(first, first + count))


def _first_seed(run: Run) -> int:
    return run_seeds(run)[0]


def _loop(run: Run, key: str) -> int:
    return int(run.settings.get("config", {}).get("loop", {}).get(key, 0))


def expected_records(run: Run) -> int:
    """metrics.jsonl lines of the finished `run`: one per seed and optimization iteration."""
    return len(run_seeds(run)) * _loop(run, "episodes") * _loop(run, "iterations")


def _checked_run(run_dir: pathlib.Path) -> Run:
    """The run in `run_dir`, refused when its records are not what its run.json says."""
    run = load_run(run_dir)
    expected = expected_records(run)
    seeds = set(run_seeds(run))
    strangers = sorted({int(r["seed"]) for r in run.records} - seeds)
    if strangers:
        raise ClaimsError(
            f"{run_dir}: metrics.jsonl holds seeds {strangers}, but its run.json runs seeds "
            f"{min(seeds)}-{max(seeds)}; the slice was edited by hand or mixed with another: move it away"
        )
    ended = (run_dir / "final.json").exists()
    if len(run.records) > expected or (ended and len(run.records) < expected):
        raise ClaimsError(
            f"{run_dir}: metrics.jsonl holds {len(run.records)} records, but its run.json "
            f"({len(seeds)} seeds x {_loop(run, 'episodes')} episodes x {_loop(run, 'iterations')} "
            f"iterations) and its final.json say {expected}: the slice was edited by hand or cut "
            f"short; restore it, or move it away to run it again"
        )
    return run


# Run settings that may differ between the slices of one cell: which seeds they run.
SLICED_KEYS = ("seed", "seeds")


def _check_poolable(runs: Sequence[Run]) -> None:
    """Refuse slices that were made by different commits, or with different settings."""
    if len(runs) < 2:
        return
    first = runs[0]
    for run in runs[1:]:
        if _commit(run) != _commit(first):
            raise ClaimsError(
                f"slices {first.path} and {run.path} were made by different commits of litl "
                f"({_commit(first)} and {_commit(run)}); a cell pools the slices of one commit: run "
                f"the other slices again with one of them"
            )
        differences = _differences(first, run)
        if differences:
            raise ClaimsError(
                f"slices {first.path} and {run.path} were run with different settings "
                f"({'; '.join(differences)}); a cell pools slices of the same settings"
            )


def _commit(run: Run) -> str:
    recorded = run.settings.get("provenance") or {}
    commit = recorded.get("commit") or "unknown"
    return f"{commit}{' (dirty)' if recorded.get('dirty') else ''}"


def _differences(a: Run, b: Run) -> list[str]:
    """Each setting (dotted key) `a` and `b` recorded differently, but for their seeds."""
    left, right = a.config, b.config
    keys = sorted((set(left) | set(right)) - set(SLICED_KEYS))
    return [
        f"{key}: {left.get(key)!r} against {right.get(key)!r}"
        for key in keys
        if left.get(key) != right.get(key)
    ]


def timing(run_dir: pathlib.Path) -> dict[str, Any]:
    """A slice's `timing.json` ({} where it has none)."""
    path = run_dir / TIMING_FILE
    return json.loads(path.read_text()) if path.exists() else {}


def lacking(found: CellRuns, seeds: Sequence[int]) -> str:
    """What a cell still lacks, in words: ``no slice yet`` or ``seeds 4-9 (slices under way:
    seeds-4-5)``."""
    if not found.runs and not found.unfinished:
        return "no slice yet: nothing of it ran in this --out"
    lines = f"seeds {seed_ranges(found.missing)} of {seed_ranges(seeds)}"
    if found.unfinished:
        lines += f" (under way: {', '.join(p.name for p in found.unfinished)})"
    return lines


def seed_ranges(seeds: Sequence[int]) -> str:
    """``0-3, 6, 8-9`` for seeds 0, 1, 2, 3, 6, 8, 9."""
    parts: list[str] = []
    ordered = sorted(seeds)
    start = previous = None
    for seed in [*ordered, None]:
        if seed is not None and previous is not None and seed == previous + 1:
            previous = seed
            continue
        if start is not None:
            parts.append(str(start) if start == previous else f"{start}-{previous}")
        start = previous = seed
    return ", ".join(parts)


def is_finished(run_dir: pathlib.Path) -> bool:
    """Whether the run in `run_dir` holds every record its run.json asks for."""
    path = run_dir / "run.json"
    if not path.exists():
        return False
    config = json.loads(path.read_text()).get("config", {})
    loop = config.get("loop", {})
    wanted = int(config.get("seeds", 1)) * int(loop.get("episodes", 0)) * int(loop.get("iterations", 0))
    return (run_dir / "metrics.jsonl").exists() and finished_records(run_dir) >= wanted


# What a finished slice keeps beyond its checkout (a few hundred KB): its records, not its
# checkpoints (checkpoints/, best/, final/ parameters, tensorboard/).
RECORD_FILES = (
    "run.json",
    "metrics.jsonl",
    "learning.jsonl",
    "final.json",
    "best.json",
    PLAN_FILE,
    TIMING_FILE,
)


def has_ended(run_dir: pathlib.Path) -> bool:
    """Whether the run in `run_dir` holds every record and has ended: its last learning phase
    and final evaluation written (`final.json`). A run with every iteration's record but no
    `final.json` is still running them, or died before it did."""
    return is_finished(run_dir) and (run_dir / "final.json").exists()


def copy_records(out: pathlib.Path, cell: Cell, dest: pathlib.Path) -> list[pathlib.Path]:
    """Copy the records (`RECORD_FILES`) of each slice of `cell` under `out` that has ended
    (`has_ended`) to the same place under `dest` (e.g. a folder of the repository, to commit
    them); returns the slice directories written. A slice whose records are there already is
    left as it is."""
    import shutil

    written = []
    for run_dir in slice_dirs(cell.run_dir(out)):
        if not has_ended(run_dir):
            continue
        target = dest / run_dir.relative_to(out)
        if (
            all((target / name).exists() == (run_dir / name).exists() for name in RECORD_FILES)
            and (target / "metrics.jsonl").exists()
        ):
            continue
        target.mkdir(parents=True, exist_ok=True)
        for name in RECORD_FILES:
            if (run_dir / name).exists():
                shutil.copy2(run_dir / name, target / name)
        written.append(target)
    return written
