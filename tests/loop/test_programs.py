"""Runs of one process that need the same programs share them (`litl.loop.programs`): robots
and settings compared by content, the first seed's number and the output left out; sharing
changes no result."""

import dataclasses
import io
import re

import numpy as np
import pytest

import litl.robots
from litl.errors import UserError
from litl.loop import programs as shared
from litl.loop.run import run
from tests.loop.tiny import tiny_config, tiny_robot


def one_episode(**changes):
    return tiny_config(loop={"episodes": 1, "iterations": 1}).replace(**changes)


def test_equal_robots_and_settings_share_their_programs_and_others_do_not():
    first = shared.programs(tiny_robot(), one_episode().algorithm, False, 2)
    # Built again alike, another first seed, other output settings: the same programs.
    again = shared.programs(
        tiny_robot(), one_episode(seed=7, output={"logger": "tensorboard"}).algorithm, False, 2
    )
    assert again is first
    # More episodes: the run passes its length (the step sizes' cosine) to `optimize` as a value.
    assert shared.programs(tiny_robot(), one_episode(loop={"episodes": 3}).algorithm, False, 2) is first
    others = [
        shared.programs(
            litl.robots.get("biped", dx=1 / 24), one_episode().algorithm, False, 2
        ),  # other particles
        shared.programs(tiny_robot(), one_episode(controller={"learning_rate": 0.01}).algorithm, False, 2),
        shared.programs(
            tiny_robot(), one_episode(loop={"alpha": 0.25}).algorithm, False, 2
        ),  # the soft update
        shared.programs(tiny_robot(), one_episode(seeds=3).algorithm, False, 3),  # each seed's memory budget
        shared.programs(tiny_robot(), one_episode().algorithm, True, 2),  # epochs reported
        shared.programs(
            tiny_robot(), one_episode().algorithm, False, 1
        ),  # learning phases one seed at a time
    ]
    assert all(other is not first for other in others)
    assert len({id(other) for other in others}) == len(others)


def test_content_keys_compare_values_and_refuse_what_they_cannot_compare():
    key = shared.content_key
    assert key(np.arange(3.0)) == key(np.arange(3.0)) != key(np.arange(3.0).astype(np.float32))
    assert key(float("nan")) == key(float("nan")) and key(1) != key(1.0) != key(True)
    assert key({"a": [1, 2]}) == key({"a": [1, 2]}) != key({"a": (1, 2)})
    robot = tiny_robot()
    layout = dataclasses.replace(robot.layout, positions=robot.layout.positions + 1e-6)
    moved = dataclasses.replace(robot, layout=layout)
    assert key(robot) == key(tiny_robot()) != key(moved)
    with pytest.raises(shared._Unkeyable):
        key(io.StringIO())


def test_a_value_that_cannot_be_compared_builds_afresh(monkeypatch):
    monkeypatch.setattr(shared, "_key", lambda *args: shared.content_key(io.StringIO()))
    assert shared.programs(tiny_robot(), one_episode().algorithm, False, 2) is not shared.programs(
        tiny_robot(), one_episode().algorithm, False, 2
    )


@pytest.mark.parametrize("value", ["-1", "many"])
def test_a_bad_cache_size_is_refused_naming_the_variable(monkeypatch, value):
    monkeypatch.setenv(shared.SWITCH, value)
    with pytest.raises(UserError, match=f"{shared.SWITCH}={value!r}: must be a whole number >= 0"):
        shared.programs(tiny_robot(), one_episode().algorithm, False, 2)


def test_the_cache_keeps_its_size_and_zero_turns_sharing_off(monkeypatch):
    monkeypatch.setenv(shared.SWITCH, "1")
    first = shared.programs(tiny_robot(), one_episode().algorithm, False, 2)
    shared.programs(tiny_robot(), one_episode().algorithm, False, 1)  # pushes the first out
    assert shared.programs(tiny_robot(), one_episode().algorithm, False, 2) is not first
    monkeypatch.setenv(shared.SWITCH, "0")
    assert shared.programs(tiny_robot(), one_episode().algorithm, False, 2) is not shared.programs(
        tiny_robot(), one_episode().algorithm, False, 2
    )


def test_a_run_on_shared_programs_equals_the_run_that_built_them_and_reports_its_epochs(tmp_path, capsys):
    """The second run of the same settings shares the first's programs (nothing traced or
    compiled again); its records equal the first's, and its epoch reports reach its own progress
    display, which the programs let go of when it ends."""
    config = one_episode(seed=3)
    built = run(tiny_robot(), config, tmp_path / "built", progress=True)
    programs = shared.programs(tiny_robot(), config.algorithm, True, 2)
    capsys.readouterr()
    again = run(tiny_robot(), config, tmp_path / "again", progress=True)
    assert shared.programs(tiny_robot(), config.algorithm, True, 2) is programs
    assert re.search(r"learning phase: epoch [1-9]", capsys.readouterr().err)
    assert programs.epochs.to is None
    strip = lambda records: [{k: v for k, v in r.items() if k != "wall_s"} for r in records]
    assert strip(again.metrics) == strip(built.metrics)


def test_a_longer_run_on_shared_programs_follows_its_own_step_size_schedule(tmp_path):
    """A run of three episodes shares the programs a one-episode run built (the number of
    episodes is passed as a value), and its step sizes follow its own cosine over 3 x 1
    iterations: its second iteration, from where the one-episode run ended, is the shared
    program's with a length of 3, not 1 (the second step at 0.55 x, not 0.1 x)."""
    short, longer = one_episode(seed=3), one_episode(seed=3, loop={"episodes": 3})
    ended = run(tiny_robot(), short, tmp_path / "short", progress=True)
    programs = shared.programs(tiny_robot(), short.algorithm, True, 2)
    on_shared = run(tiny_robot(), longer, tmp_path / "shared", progress=True)
    assert shared.programs(tiny_robot(), longer.algorithm, True, 2) is programs
    strip = lambda records: [{k: v for k, v in r.items() if k != "wall_s"} for r in records]
    assert strip(on_shared.metrics[:2]) == strip(ended.metrics)  # the first episode: the same
    second = [r["design_mean"] for r in on_shared.metrics[2:4]]
    for length, equal in ((3, True), (1, False)):
        _, metrics = programs.optimize(ended.state, np.int32(length))
        assert (list(np.asarray(metrics["design_mean"])) == second) is equal, length
