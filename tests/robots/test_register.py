"""A robot of your own: `litl.robots.register`, then `litl.robots.get` and the CLI reach it."""

import pytest

import litl.robots
from litl.robots import catalog
from tests.guide import guide_block

# The guide's example module (`my_robots.py`); tests/test_cli.py runs it through the CLI.
STOOL_MODULE = guide_block("robots.md", "# my_robots.py")


@pytest.fixture
def registry(monkeypatch):
    """Registrations made in the test are undone after it."""
    monkeypatch.setattr(catalog, "ROBOTS", dict(catalog.ROBOTS))


def test_a_registered_robot_is_reachable_by_name(registry):
    namespace = {}
    exec(STOOL_MODULE, namespace)
    assert "stool" in litl.robots.names()
    robot = litl.robots.get("stool")
    assert robot.config.dx == 1 / 64 and robot.n_actuators == 2
    assert litl.robots.get("stool", dx=1 / 32).config.dx == 1 / 32


def test_register_refuses_what_it_cannot_use(registry):
    build = lambda dx: None
    with pytest.raises(ValueError, match="already registered.*replace=True"):
        litl.robots.register("biped", build, dim=2)
    litl.robots.register("biped", build, dim=2, replace=True)  # allowed when asked
    with pytest.raises(ValueError, match="non-empty string"):
        litl.robots.register("", build, dim=2)
    with pytest.raises(ValueError, match="dim must be 2 or 3"):
        litl.robots.register("flat", build, dim=1)
    with pytest.raises(ValueError, match="build must be a function"):
        litl.robots.register("flat", "not callable", dim=2)
    with pytest.raises(catalog.UnknownRobotError, match="register your own"):
        litl.robots.get("no_such_robot")
