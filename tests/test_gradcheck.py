"""`python -m litl.gradcheck`: jax.grad of a robot's rollout against central differences."""

import pytest

from litl.app import compose
from litl.gradcheck import GROUPS, check_gradients, main, relative_error


@pytest.mark.compute_bound
@pytest.mark.parametrize(
    "overrides, steps",
    [
        (["robot=arm", "robot.resolution=smoke", "observer=kmeans"], 30),
        (["robot=quadruped", "robot.resolution=smoke", "+scale=smoke"], 60),
    ],
)
def test_gradients_of_a_2d_and_a_3d_robot_match_central_differences(overrides, steps, capsys):
    assert main([*overrides, "--steps", str(steps), "--directions", "1"]) == 0
    out = capsys.readouterr().out
    assert out.rstrip().endswith("pass")
    for group in GROUPS:  # every parameter group is checked
        assert f"\n{group} " in out


def test_a_gradient_known_to_be_incomplete_fails_the_check():
    # Stopping the gradient through the observer's features (litl's default, on purpose) drops
    # a real part of the derivative: the check must see it. The full gradient of the same robot,
    # steps, direction and seed passes at rtol 1e-4 (the 2D case above).
    config = compose(["robot=arm", "robot.resolution=smoke", "observer=kmeans"])
    stopped, _ = check_gradients(config, steps=30, directions=1, feature_gradient="stop")
    assert max(c.relative_error for c in stopped) > 1e-3


def test_relative_error_and_bad_arguments(capsys):
    assert relative_error(1.0, 1.001) == pytest.approx(1e-3, rel=1e-2)
    assert relative_error(0.0, 0.0) == 0.0
    for argv, message in (
        (["--steps", "0"], "--steps"),
        (["--eps", "2"], "--eps"),
        (["robot=nosuch"], "robot/nosuch"),
        (["robot=biped", "robot.resolution=smoke", "observer=kmeans", "--steps", "1"], "hardly moved"),
    ):
        with pytest.raises(SystemExit) as exit_info:
            main(argv)
        assert exit_info.value.code == 2
        assert message in capsys.readouterr().err
