"""Worlds are registered parts (`litl.worlds.register`): each with its own settings section, a
user's world from `world.module=`, the old flat spellings translated, bad input refused early."""

import sys
import warnings

import pytest

import litl.worlds
from litl.app import build_robot, compose
from litl.config import SettingsError
from litl.settings import Settings
from litl.settings.old import upgrade
from tests.guide import guide_block

LEDGE_MODULE = guide_block("robots.md", "# my_worlds.py")


@pytest.fixture
def user_worlds(tmp_path, monkeypatch):
    """The guide's module importable from tmp_path; the registry as it was afterwards."""
    (tmp_path / "my_worlds.py").write_text(LEDGE_MODULE)
    (tmp_path / "registers_nothing.py").write_text("X = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(litl.worlds.WORLDS, "_entries", dict(litl.worlds.WORLDS._entries))
    yield tmp_path
    for name in ("my_worlds", "registers_nothing"):
        sys.modules.pop(name, None)


def test_the_built_in_worlds_are_registered_each_with_its_own_section():
    assert litl.worlds.names() == ("flat", "slope", "steps", "bumps", "sand", "water", "push_box")
    config = compose(["world=sand", "world.sand.friction_angle=40"])
    assert config.world.sand.friction_angle == 40 and config.world.section is config.world.sand
    assert config.world.water.density == 1.0 and config.world.sand.density == 1.5  # their own defaults
    assert litl.worlds.brings_task("push_box") and not litl.worlds.brings_task(config.world)


def test_a_users_world_from_its_module_acts_and_is_recorded(user_worlds):
    config = compose(["world=ledge", "world.module=my_worlds", "world.ledge.height=0.08", "+scale=smoke"])
    assert config.run_settings()["world"] == {
        "kind": "ledge",
        "module": "my_worlds",
        "ledge": {"gap": 2.0, "contact": "sticky", "friction": 0.5, "height": 0.08},
    }
    robot = build_robot(config)
    (ground,) = robot.config.boundary.colliders
    assert max(ground.shape.heights) == pytest.approx(ground.shape.heights[0] + 0.08)
    with pytest.raises(SettingsError, match=r"^world.ledge.height=0.0: must be a positive number"):
        compose(["world=ledge", "world.module=my_worlds", "world.ledge.height=0"])


def test_unknown_worlds_and_modules_that_register_nothing_are_refused(user_worlds):
    with pytest.raises(SettingsError, match="world.module='registers_nothing' registered no world"):
        compose(["world.kind=ledge2", "world.module=registers_nothing"])
    with pytest.raises(SettingsError, match=r"unknown world; choose one of \['flat'.*world.module=<module"):
        compose(["world.kind=ice"])
    with pytest.raises(SettingsError, match="world.module='no_such_module' could not be imported"):
        compose(["world.module=no_such_module"])


def test_a_plain_dataclass_as_a_worlds_settings_is_refused_at_register(user_worlds):
    import dataclasses

    @dataclasses.dataclass(frozen=True)
    class Plain:
        height: float = 0.1

    with pytest.raises(SettingsError, match="plain dataclass; subclass litl.settings.Settings"):
        litl.worlds.register("plain", lambda robot, settings, context: robot, Plain)

    @dataclasses.dataclass(frozen=True)
    class Unwritable(Settings):
        where: object = frozenset({1})

    with pytest.raises(SettingsError, match="cannot be written to run.json"):
        litl.worlds.register("unwritable", lambda robot, settings, context: robot, Unwritable)
    assert "plain" not in litl.worlds.names() and "unwritable" not in litl.worlds.names()


def test_the_old_flat_spellings_go_to_the_chosen_worlds_section():
    with pytest.warns(FutureWarning, match="world.angle is now world.slope.angle"):
        assert compose(["world=slope", "world.angle=15"]).world.slope.angle == 15
    with pytest.warns(FutureWarning, match="world.depth is now world.water.depth"):
        assert compose(["world=water", "world.depth=0.06"]).world.water.depth == 0.06
    with pytest.raises(SettingsError, match="world=flat has no 'angle'; it is a key of world=slope"):
        compose(["world.angle=15"])
    with pytest.raises(SettingsError, match="world=slope has no 'depth'; it is a key of world=sand\\|water"):
        compose(["world=slope", "world.depth=0.1"])
    from litl.config import Config

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        assert Config().replace(world={"kind": "bumps", "seed": 3}).world.bumps.seed == 3


def test_a_run_json_of_the_old_layout_reads_as_todays():
    """run.json files before 2026-12-02 recorded one world section with every kind's keys."""
    old = {
        "kind": "water",
        "angle": 10.0,
        "gap": 2.0,
        "depth": 0.06,
        "density": 1.0,
        "observe": "robot",
        "friction_angle": 30.0,
        "box_size": 0.08,
    }
    today = upgrade({"world": old})["world"]
    assert today == {
        "kind": "water",
        "module": None,
        "water": {"depth": 0.06, "density": 1.0, "observe": "robot"},
    }
    flat = upgrade({"world": {"kind": "flat", "angle": 10.0, "gap": 2.0}})["world"]
    assert flat == {"kind": "flat", "module": None}
