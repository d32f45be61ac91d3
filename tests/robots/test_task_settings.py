"""The `task.*` keys: walk either way, walk to a coordinate, and their refusals."""

import jax.numpy as jnp
import numpy as np
import pytest

from litl.app import build_robot, compose
from litl.config import SettingsError
from litl.robots import LayoutError, Locomotion, Position, Task, make_task_loss


def test_position_is_the_centroids_squared_distance_to_the_target_at_the_end():
    robot = build_robot(compose(["task=position", "task.target=0.4", "+scale=smoke"]))
    (term,) = robot.task.terms
    assert term == Position(target=0.4, axis=0)
    start = robot.initial_state()
    x = float(np.mean(np.asarray(start.x[:, 0])))
    end = start.replace(x=start.x + jnp.asarray([0.4 - x + 0.05, 0.3], start.x.dtype))
    total, parts = make_task_loss(robot.task, robot.layout)(start, end)
    assert set(parts) == {"position"}
    # the height does not count, only the coordinate along the axis
    assert float(total) == pytest.approx(0.05**2, rel=1e-3)


def test_locomotion_the_other_way_counts_displacement_toward_minus_x():
    robot = build_robot(compose(["task=locomotion", "task.direction=-1", "+scale=smoke"]))
    assert robot.task.terms == (Locomotion(axis=0, measure="distance", direction=-1.0),)
    start = robot.initial_state()
    end = start.replace(x=start.x - jnp.asarray([0.1, 0.0], start.x.dtype))
    total, _ = make_task_loss(robot.task, robot.layout)(start, end)
    assert float(total) == pytest.approx(-0.1, rel=1e-4)  # walking -x lowers the loss


@pytest.mark.parametrize(
    "overrides, key, message",
    [
        (["task=position"], "task.target", "task=position needs the coordinate"),
        (["task=position", "task.target=1.5"], "task.target", r"outside the domain along axis 0, \(0, 1\)"),
        (["task=position", "task.target=0.3", "task.axis=2"], "task.axis", "biped is 2D"),
        (["task=locomotion", "task.direction=0.5"], "task.direction", "must be 1 or -1"),
        (["task.direction=-1"], "task.direction", "applies to task=locomotion or velocity"),
        (["task=velocity", "task.target=0.3"], "task.target", "applies to task=position"),
        (["task.axis=1"], "task.axis", "not task=default"),
        (["task=locomotion", "task.axis=-1"], "task.axis", "must be an axis index"),
    ],
)
def test_bad_task_settings_are_refused_naming_the_key(overrides, key, message):
    with pytest.raises(SettingsError, match=message) as caught:
        build_robot(compose([*overrides, "+scale=smoke"]))
    assert caught.value.key == key


def test_a_position_term_checks_its_axis_and_target():
    robot = build_robot(compose(["+scale=smoke"]))
    with pytest.raises(LayoutError, match="axis 2 does not exist in 2D"):
        make_task_loss(Task(Position(target=0.3, axis=2)), robot.layout)
    with pytest.raises(LayoutError, match="finite coordinate"):
        make_task_loss(Task(Position(target=float("nan"))), robot.layout)


def test_position_of_a_group_moves_that_groups_centroid_and_is_the_task_point():
    robot = build_robot(
        compose(["robot=arm", "task=position", "task.target=0.55", "task.group=tip", "+scale=smoke"])
    )
    (term,) = robot.task.terms
    assert term == Position(target=0.55, axis=0, group="tip")
    assert robot.task.point_group == "tip"
    start = robot.initial_state()
    tip = np.asarray(robot.layout.groups["tip"])
    x = start.x.at[tip, 0].add(0.05)  # only the tip moves
    end = start.replace(x=x)
    tip_x = float(np.mean(np.asarray(start.x[tip, 0])))
    total, _ = make_task_loss(robot.task, robot.layout)(start, end)
    assert float(total) == pytest.approx((tip_x + 0.05 - 0.55) ** 2, rel=1e-3)
    np.testing.assert_allclose(robot.task_point(end), np.asarray(end.x[tip]).mean(axis=0), rtol=1e-6)
    # the arm's own task reaches with the tip; a walker's moves its whole body
    assert build_robot(compose(["robot=arm", "+scale=smoke"])).task.point_group == "tip"
    biped = build_robot(compose(["+scale=smoke"]))
    assert biped.task.point_group is None
    np.testing.assert_allclose(biped.task_point(start := biped.initial_state()), start.x.mean(axis=0))


@pytest.mark.parametrize(
    "overrides, message",
    [
        (
            ["robot=arm", "task=position", "task.target=0.5", "task.group=hand"],
            r"no such particle group .*'tip'",
        ),
        (["robot=arm", "task=locomotion", "task.group=tip"], "applies to task=position"),
    ],
)
def test_a_bad_task_group_is_refused_naming_the_key(overrides, message):
    with pytest.raises(SettingsError, match=message) as caught:
        build_robot(compose([*overrides, "+scale=smoke"]))
    assert caught.value.key == "task.group"


def test_a_shifted_robot_starts_further_along_x_with_its_reach_targets():
    biped = build_robot(compose(["+scale=smoke"]))
    moved = build_robot(compose(["robot.shift=0.3", "+scale=smoke"]))
    np.testing.assert_allclose(moved.layout.positions[:, 0], biped.layout.positions[:, 0] + 0.3, atol=1e-12)
    np.testing.assert_allclose(moved.layout.positions[:, 1], biped.layout.positions[:, 1])
    arm = build_robot(compose(["robot=arm", "+scale=smoke"]))
    left = build_robot(compose(["robot=arm", "robot.shift=-0.1", "+scale=smoke"]))
    (reach,) = arm.task.terms
    (moved_reach,) = left.task.terms
    np.testing.assert_allclose(moved_reach.target, np.asarray(reach.target) + [-0.1, 0.0])
    # the task is the same relative to the body: equal losses for the same motion
    for robot in (arm, left):
        start = robot.initial_state()
        end = start.replace(x=start.x + jnp.asarray([0.05, 0.0], start.x.dtype))
        total, _ = make_task_loss(robot.task, robot.layout)(start, end)
        assert float(total) == pytest.approx(
            float(
                make_task_loss(arm.task, arm.layout)(
                    arm.initial_state(),
                    arm.initial_state().replace(x=arm.initial_state().x + jnp.asarray([0.05, 0.0])),
                )[0]
            ),
            rel=1e-4,
        )


@pytest.mark.parametrize(
    "shift, message", [("0.9", r"through a wall; shifts from -0\.\d+ to 0\.\d+"), ("nan", "finite length")]
)
def test_a_shift_through_a_wall_is_refused_with_the_shifts_that_fit(shift, message):
    with pytest.raises(SettingsError, match=message) as caught:
        build_robot(compose([f"robot.shift={shift}", "+scale=smoke"]))
    assert caught.value.key == "robot.shift"
