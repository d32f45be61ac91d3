"""What `make_algorithm` decides before anything runs: the learning schedule and the rollout's
memory plan."""

import pytest

from litl.loop import LearningSchedule
from litl.loop.algorithm import make_algorithm
from tests.loop.tiny import tiny_config, tiny_robot


@pytest.mark.parametrize(
    ("observer", "schedule", "expected"),
    [
        ("vae", "alternating", LearningSchedule.alternating),
        ("vae", "one_shot", LearningSchedule.one_shot),
        ("ae", "simultaneous", LearningSchedule.simultaneous),
        # An observer that does not learn follows none of loop.schedule's values.
        ("kmeans", "alternating", LearningSchedule.fixed),
        ("none", "one_shot", LearningSchedule.fixed),
    ],
)
def test_the_schedule_is_the_settings_unless_the_observer_does_not_learn(observer, schedule, expected):
    algorithm = make_algorithm(
        tiny_robot(), tiny_config(observer={"kind": observer}, loop={"schedule": schedule}).algorithm
    )
    assert algorithm.schedule is expected
    assert algorithm.retrains == (expected is LearningSchedule.alternating)


@pytest.mark.parametrize(
    ("observer", "sim", "expected"),
    [
        # (checkpoint_every, carry bytes, per-step bytes, budget) of one seed's rollout, as the
        # rollout planned them while `optimize` was traced; the VAE reads the grid field, so it
        # is in the carry; the budget (GiB) is shared by the 2 seeds. Per step: the observation is
        # the (2, 2) centroid and task point.
        ("kmeans", {"memory_budget": 0.4 / 1024}, (10, 6300, 851, 209_715)),
        ("vae", {"memory_budget": 1.0 / 1024}, (10, 14492, 851, 524_288)),
        ("none", {"checkpoint_every": 20}, (20, 6300, 851, None)),
        ("kmeans", {"checkpoint_every": None}, (None, 6300, 851, None)),
    ],
)
def test_the_checkpoint_plan_is_known_before_anything_is_traced(observer, sim, expected):
    algorithm = make_algorithm(tiny_robot(), tiny_config(observer={"kind": observer}, sim=sim).algorithm)
    plan = algorithm.checkpoint_plan()
    assert (plan.checkpoint_every, plan.carry_bytes, plan.per_step_bytes, plan.budget_bytes) == expected
    assert plan.steps == algorithm.steps == 40
