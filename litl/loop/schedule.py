"""How a run alternates the observer's learning with optimization: `loop.schedule` (the paper's
ablations), or `fixed` for an observer that does not learn, whatever `loop.schedule` says."""

from __future__ import annotations

import enum

from litl.config import Schedule


class LearningSchedule(enum.StrEnum):
    """The schedule a run follows (`litl.loop.algorithm.Algorithm.schedule`).

    Strings as `litl.config.Schedule`'s are (``"alternating"``, ...), so that they print and
    compare as the values of `loop.schedule` do; `fixed` is the one value it has no setting for.
    """

    alternating = "alternating"  # Algorithm 1: a learning phase after every episode
    one_shot = "one_shot"  # learned once, from the initial rollout, never again
    simultaneous = "simultaneous"  # one observer step per optimization iteration, no phases
    fixed = "fixed"  # an observer that does not learn (k-means, none): no learning at all

    @classmethod
    def of(cls, schedule: Schedule, learns: bool) -> LearningSchedule:
        """The schedule of a run with `loop.schedule` = `schedule` whose observer `learns` (has
        a `Learner`) or not."""
        return cls(Schedule(schedule).value) if learns else cls.fixed
