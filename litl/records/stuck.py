"""A seed that ends stuck, and the result it still has: the one rule that the run's final line
and `final.json` (litl.loop, litl.app), the report (litl.report) and the claims tables
(litl.claims) share, without any of them importing another.

An optimization iteration whose rollout blew up or lost particles, or whose loss or gradient was
not finite, is skipped: it changes no parameters (`litl.loop.algorithm`). A seed whose *last*
iterations were skipped ends *stuck* at its last good parameters, and its final parameters have
no loss worth reporting (their rollout is the one that failed). Its result is its *last good
task loss*: the task loss of its last iteration that was not skipped. It is reported with that
iteration and marked as stuck (``-0.31 (stuck)``); only a seed that never had a finite task loss
has none (``n/a``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any


@dataclasses.dataclass(frozen=True)
class SeedEnd:
    """How one seed's run ended, read from its metrics records.

    Attributes:
      seed: the seed.
      task_loss: its final task loss: its last iteration's, or for a stuck seed its last good
        one; None where there is none (not finite).
      stuck: its last iteration was skipped.
      skipped_at_end: iterations skipped in a row at its end (0 unless stuck).
      last_good_step: the global iteration of its last iteration that was not skipped (None:
        there was none).
    """

    seed: int
    task_loss: float | None
    stuck: bool
    skipped_at_end: int
    last_good_step: int | None


def skipped(record: Mapping[str, Any]) -> bool:
    """Whether a metrics record is of a skipped iteration (its ``skipped`` names the reason)."""
    return isinstance(record.get("skipped"), str)


def _finite(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    return float(value)


def seed_end(seed: int, records: Sequence[Mapping[str, Any]]) -> SeedEnd:
    """How seed `seed` ended, from its metrics records in the order of their steps.

    Args:
      seed: the seed.
      records: its records (``step``, ``task_loss``, ``skipped``), ascending in ``step``;
        non-finite losses as None or NaN.
    """
    trailing = 0
    for record in reversed(records):
        if not skipped(record):
            break
        trailing += 1
    good = [r for r in records if not skipped(r) and _finite(r.get("task_loss")) is not None]
    last_good = good[-1] if good else None
    if trailing == 0:
        loss = _finite(records[-1].get("task_loss")) if records else None
    else:
        loss = None if last_good is None else _finite(last_good.get("task_loss"))
    return SeedEnd(
        seed=seed,
        task_loss=loss,
        stuck=trailing > 0,
        skipped_at_end=trailing,
        last_good_step=None if last_good is None else int(last_good["step"]),
    )


def seed_ends(records: Iterable[Mapping[str, Any]]) -> dict[int, SeedEnd]:
    """{seed: `SeedEnd`} of one run's metrics records (any order; each seed's by step)."""
    by_seed: dict[int, list[Mapping[str, Any]]] = {}
    for record in records:
        by_seed.setdefault(int(record["seed"]), []).append(record)
    return {
        seed: seed_end(seed, sorted(rows, key=lambda r: int(r["step"]))) for seed, rows in by_seed.items()
    }


def shown(end: SeedEnd) -> str:
    """A seed's final task loss for people: ``-0.312``, ``-0.31 (stuck)``, or ``n/a`` where it
    never had a finite one (6 significant digits, never ``-0``)."""
    if end.task_loss is None:
        return "n/a"
    text = f"{end.task_loss + 0.0:.6g}"
    return f"{text} (stuck)" if end.stuck else text
