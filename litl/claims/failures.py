"""How each cell of a claims suite fared: its failures, time and origin, beside its verdicts.

A verdict compares final task losses; how many seeds got there cleanly is a result too (the paper
reports k-means failing in 4 of 10 runs). Per cell: seeds with a final loss, seeds that ended
stuck (their last iterations skipped: `litl.records.stuck`), iterations skipped (a rollout that escaped the
grid or went non-finite, or a non-finite gradient: nothing of them was kept), iterations stepped
back (litl's step-back safeguard retook them at half the step), its wall time (`timings.json`),
and the commit and material that made it (`litl.claims.origins`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from litl.claims.origins import Origin, material, platform
from litl.claims.verdicts import final_losses, stuck_seeds
from litl.records.stuck import skipped
from litl.report.runs import Group


@dataclasses.dataclass(frozen=True)
class CellRecord:
    """One finished cell's failures.

    Attributes:
      name: ``method/panel/variant``.
      seeds: seeds with a final task loss.
      stuck: seeds that ended stuck (counted with their last good loss).
      skipped: iterations skipped, over all seeds.
      stepped_back: iterations stepped back, over all seeds.
      iterations: iterations run, over all seeds (metrics.jsonl lines).
    """

    name: str
    seeds: int
    stuck: int
    skipped: int
    stepped_back: int
    iterations: int


def cell_record(name: str, group: Group) -> CellRecord:
    """The failures of one cell's runs."""
    records = [r for run in group.runs for r in run.records]
    return CellRecord(
        name=name,
        seeds=int(np.isfinite(final_losses(group)).sum()),
        stuck=stuck_seeds(group),
        skipped=sum(skipped(r) for r in records),
        stepped_back=sum(bool(r.get("stepped_back")) for r in records),
        iterations=len(records),
    )


def cell_records(groups: Mapping[tuple[str, str], Mapping[str, Group]]) -> list[CellRecord]:
    """Every finished cell's failures, in the suite's order of methods and panels."""
    return [
        cell_record(f"{method}/{panel}/{variant}", group)
        for (method, panel), variants in groups.items()
        for variant, group in variants.items()
    ]


def cells_markdown(
    cells: list[CellRecord], timings: Mapping[str, float], found: Mapping[str, Origin]
) -> list[str]:
    """claims.md's section on the cells: one row each."""
    if not cells:
        return []
    lines = [
        "",
        "## The cells",
        "",
        "Seeds with a final task loss; seeds that ended stuck (counted with their last good loss); "
        "iterations skipped (nothing of them kept) and stepped back (retaken at half the step), "
        "over all seeds; wall time (`timings.json`); the commit and material that made the cell, and "
        "where it ran (cells of one table may come from different platforms: their numbers are "
        "comparable, not bit-identical).",
        "",
        "| cell | seeds | stuck | skipped | stepped back | iterations | wall time | commit | material "
        "| platform |",
        "|---|---:|---:|---:|---:|---:|---:|---|---|---|",
    ]
    for c in cells:
        seconds = timings.get(c.name)
        time = "—" if seconds is None else f"{seconds / 60:.1f} min"
        origin = found.get(c.name)
        commit = (origin.commit or "—")[:12] if origin else "—"
        made_of = material(origin.max_stretch) if origin else "—"
        where = platform(origin.backend) if origin else "—"
        lines.append(
            f"| {c.name} | {c.seeds} | {c.stuck} | {c.skipped} | {c.stepped_back} | {c.iterations} "
            f"| {time} | {commit} | {made_of} | {where} |"
        )
    return lines
