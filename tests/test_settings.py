"""The settings schema (`litl.settings`): types checked from the annotations, errors that name
the key in full, unknown keys named with the valid ones, and the registry's refusals."""

import dataclasses
import enum

import pytest

from litl.settings import Settings, SettingsError
from litl.settings.registry import Registry


class Colour(enum.StrEnum):
    red = "red"
    blue = "blue"


@dataclasses.dataclass(frozen=True)
class Inner(Settings):
    KEY = "part.thing.inner"
    depth: int = 1


@dataclasses.dataclass(frozen=True)
class Thing(Settings):
    KEY = "part.thing"
    count: int = 2
    scale: float = 1.0
    limit: float | None = None
    name: str = "a"
    on: bool = True
    colour: Colour = Colour.red
    sizes: tuple[int, ...] = (1, 2)
    inner: Inner = dataclasses.field(default_factory=Inner)


def test_values_of_the_annotated_types_are_kept_and_normalized():
    thing = Thing(count=3, scale=2, limit=float("inf"), colour="blue", sizes=[4, 5])
    assert (thing.scale, thing.colour, thing.sizes) == (2, Colour.blue, (4, 5))
    assert Thing.from_tree({"inner": {"depth": 4}, "limit": None}).inner.depth == 4
    assert Thing().replace(inner={"depth": 7}).inner == Inner(depth=7)
    assert Thing().to_tree() == {
        "count": 2,
        "scale": 1.0,
        "limit": None,
        "name": "a",
        "on": True,
        "colour": "red",
        "sizes": [1, 2],
        "inner": {"depth": 1},
    }


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"count": "3"}, "^part.thing.count='3': must be an integer$"),
        ({"count": True}, "^part.thing.count=True: must be an integer$"),
        ({"count": 2.5}, "^part.thing.count=2.5: must be an integer$"),
        ({"scale": "x"}, "^part.thing.scale='x': must be a number$"),
        ({"limit": "x"}, "^part.thing.limit='x': must be a number or null$"),
        ({"name": 3}, "^part.thing.name=3: must be a string$"),
        ({"on": "yes"}, "^part.thing.on='yes': must be true or false$"),
        ({"colour": "green"}, r"^part.thing.colour='green': choose one of \['red', 'blue'\]$"),
        ({"inner": {"depth": "deep"}}, "^part.thing.inner.depth='deep': must be an integer$"),
    ],
)
def test_a_value_of_the_wrong_type_names_its_key_in_full(changes, message):
    with pytest.raises(SettingsError, match=message):
        Thing.from_tree(changes)


def test_an_unknown_key_is_named_with_the_valid_ones():
    with pytest.raises(
        SettingsError, match=r"unknown setting\(s\) \['part.thing.cuont'\]; valid: \[.*'count'"
    ):
        Thing().replace(cuont=3)
    with pytest.raises(SettingsError, match=r"unknown setting\(s\) \['part.thing.inner.dpth'\]"):
        Thing.from_tree({"inner": {"dpth": 3}})


def test_the_registry_refuses_taken_names_old_factories_and_unfrozen_settings():
    registry = Registry("gadget", "litl")

    @dataclasses.dataclass
    class Loose(Settings):
        size: int = 1

    @dataclasses.dataclass(frozen=True)
    class Own(Settings):
        size: int = 1

    def factory(robot, settings, context):
        return None

    registry.register("one", factory, Own)
    assert Own.KEY == "gadget.one" and registry.sections() == {"one": Own}
    with pytest.raises(SettingsError, match="'one' is already registered"):
        registry.register("one", factory)
    registry.register("one", factory, Own, replace=True, label="One")
    assert registry.get("one").label == "One" and registry.names() == ("one",)
    with pytest.raises(SettingsError, match="must be frozen"):
        registry.register("two", factory, Loose)
    with pytest.raises(SettingsError, match="shares section 'one'"):
        registry.register("three", factory, Thing, section="one")
    with pytest.raises(SettingsError, match=r"gadget.kind='four': unknown gadget; choose one of \['one'\]"):
        registry.get("four")
