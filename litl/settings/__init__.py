"""The settings schema: checked, frozen dataclasses that the Python API and the Hydra CLI share.

A section of settings is a frozen dataclass deriving from `Settings`. Its `KEY` is its place in
the config tree (``"loop.learning"``); its values are normalized (lists to tuples, strings to the
enum a field is annotated with) and type-checked from its annotations (`typing.get_type_hints`)
when it is built, and then `check`ed; every error names the key as typed on the command line:

    @dataclasses.dataclass(frozen=True)
    class MySettings(litl.settings.Settings):
        width: int = 4            # observer.mine.width=abc -> "must be an integer"

        def check(self):
            self._positive_ints("width")

Observers and controllers declare such a class with their registration
(`litl.observers.register(name, factory, settings=MySettings)`); `litl.config` holds the sections
the core owns (robot, sim, loop, output). This module imports neither JAX nor the rest of litl;
old spellings of keys are `litl.settings.old`'s, dotted trees `litl.settings.trees`'.

The package is the settings' machinery, the bottom layer every section, registry and reader
builds on: this schema; `litl.settings.registry`, registries by name (how an observer, a
controller, a world, a method or a design space becomes selectable); `litl.settings.parts`, the
parts of the config that registries fill; `litl.settings.trees`, nested dicts and dotted keys;
`litl.settings.old`, old spellings. Hydra's view of the config is `litl.conf.schema`, beside
its YAML groups.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
import types
import typing
from typing import TYPE_CHECKING, Any, ClassVar, NoReturn, Self, TypeVar

from litl.errors import UserError


class SettingsError(UserError, ValueError):
    """A setting litl cannot use; the message names its key (as typed on the command line) and
    says how to fix it.

    Attributes:
      key: the dotted key at fault (``"loop.episodes"``), or None when several are.
    """

    def __init__(self, message: str, key: str | None = None):
        super().__init__(message)
        self.key = key


def number(value: object) -> bool:
    """Whether `value` is a finite int or float (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


class Settings:
    """The base of every settings section (see the module docstring).

    `KEY` is the section's place in the tree; a registered observer's or controller's section
    gets its key (``"observer.<name>"``) when it is registered.
    """

    KEY = ""
    if TYPE_CHECKING:  # every subclass is a dataclass
        __dataclass_fields__: ClassVar[dict[str, dataclasses.Field[Any]]]

    def __post_init__(self) -> None:
        types_ = field_types(type(self))
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            kind = enum_of(types_[f.name])
            if kind is not None and value is not None and not isinstance(value, kind):
                try:
                    value = kind(value)
                except ValueError:
                    self._invalid(f.name, f"choose one of {[k.value for k in kind]}")
            if isinstance(value, list):
                value = tuple(value)
            object.__setattr__(self, f.name, value)
        # The section's own check first (its messages say what is allowed); then the annotations'
        # types, for what it does not check (a wrong type it tripped on included).
        try:
            self.check()
        except TypeError:
            self._check_types(types_)
            raise
        self._check_types(types_)
        self._check_json()

    def _check_json(self) -> None:
        """Refuse a value run.json cannot hold now, when the section is built, rather than when
        a run writes its run.json (nested sections check their own)."""
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, Settings):
                continue
            try:
                json.dumps(json_safe(value))
            except (TypeError, ValueError) as error:
                self._invalid(
                    f.name,
                    f"cannot be written to run.json ({error}); a setting's value is a number, a "
                    "string, true or false, null, or a list or mapping of those",
                )

    def _check_types(self, types_: dict[str, Any]) -> None:
        for f in dataclasses.fields(self):
            self._check_type(f.name, types_[f.name])

    def check(self) -> None:
        """Raise `SettingsError` for a value that cannot be used."""

    def _key(self, name: str) -> str:
        return f"{self.KEY}.{name}" if self.KEY else name

    def _invalid(self, name: str, text: str) -> NoReturn:
        raise SettingsError(f"{self._key(name)}={getattr(self, name)!r}: {text}", self._key(name))

    def _check_type(self, name: str, annotation: object) -> None:
        """Refuse a value of another type than a plain annotation (int, float, bool, str, an
        enum, a nested section, and those or None) admits; other annotations are the
        section's `check`'s to check."""
        value = getattr(self, name)
        admitted = classes(annotation)
        if value is None and (type(None) in admitted or not admitted):
            return
        simple = [a for a in admitted if a is not type(None)]
        if not simple or any(
            a not in (int, float, bool, str) and not issubclass(a, (enum.Enum, Settings)) for a in simple
        ):
            return  # tuples, unions of other things, Any: the section's own check
        for kind in simple:
            if kind is float and isinstance(value, (int, float)) and not isinstance(value, bool):
                return  # an int is a float here (YAML writes 1 for 1.0); inf and nan are floats
            if kind is int and isinstance(value, int) and not isinstance(value, bool):
                return
            if kind in (bool, str) and isinstance(value, kind):
                return
            if issubclass(kind, (enum.Enum, Settings)) and isinstance(value, kind):
                return
        wanted = " or ".join(describe(kind) for kind in simple) + (
            " or null" if type(None) in admitted else ""
        )
        self._invalid(name, f"must be {wanted}")

    def _positive_ints(self, *names: str, optional: tuple[str, ...] = ()) -> None:
        for name in names:
            value = getattr(self, name)
            if value is None and name in optional:
                continue
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                self._invalid(
                    name, "must be a positive integer" + (", or null for none" if name in optional else "")
                )

    def _positive_numbers(self, *names: str, optional: tuple[str, ...] = (), zero: bool = False) -> None:
        for name in names:
            value = getattr(self, name)
            if value is None and name in optional:
                continue
            if not (number(value) and (value >= 0 if zero else value > 0)):
                self._invalid(
                    name,
                    ("must be a number >= 0" if zero else "must be a positive number")
                    + (", or null for none" if name in optional else ""),
                )

    def replace(self, **changes: Any) -> Self:
        """A copy with `changes`; a dict for a nested section changes only the keys it names:
        ``config.replace(loop={"episodes": 3}, seeds=2)``."""
        from litl.settings.old import moved_changes

        changes = moved_changes(self.KEY, changes)
        fields = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(changes) - fields)
        if unknown:
            prefix = f"{self.KEY}." if self.KEY else ""
            raise SettingsError(
                f"unknown setting(s) {[prefix + u for u in unknown]}; valid: {sorted(fields)}",
                prefix + unknown[0],
            )
        merged = {}
        for name, value in changes.items():
            current = getattr(self, name)
            if isinstance(value, dict) and isinstance(current, Settings):
                value = current.replace(**value)
            merged[name] = value
        return dataclasses.replace(self, **merged)

    def to_tree(self) -> dict[str, Any]:
        """The section as nested plain values (enums as values, tuples as lists), as run.json
        and YAML write it."""
        return {f.name: _tree_of(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_tree(cls, values: dict[Any, Any]) -> Self:
        """The section built from nested plain values (a composed Hydra config as containers,
        or run.json); nested dicts become nested sections."""
        fields = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - fields)
        if unknown:
            prefix = f"{cls.KEY}." if cls.KEY else ""
            raise SettingsError(
                f"unknown setting(s) {[prefix + u for u in unknown]}; valid: {sorted(fields)}"
            )
        hints = field_types(cls)
        built = {}
        for name, value in values.items():
            nested = settings_class_of(hints[name])
            built[name] = nested.from_tree(value) if nested and isinstance(value, dict) else value
        return cls(**built)


def _tree_of(value: Any) -> Any:
    if isinstance(value, Settings):
        return value.to_tree()
    return json_safe(value)


_S = TypeVar("_S", bound=Settings)


def from_dict(kind: type[_S], values: dict[Any, Any]) -> _S:
    """Build the section `kind` from a nested dict (`Settings.from_tree`)."""
    return kind.from_tree(values)


def field_types(kind: type) -> dict[str, Any]:
    """`kind`'s field annotations resolved to types (postponed annotations are strings)."""
    return typing.get_type_hints(kind)


def classes(annotation: object) -> tuple[type, ...]:
    """The classes an annotation admits: ``X`` and ``X | None`` give (X,) and (X, NoneType)."""
    if isinstance(annotation, types.UnionType) or typing.get_origin(annotation) is typing.Union:
        return tuple(a for a in typing.get_args(annotation) if isinstance(a, type))
    return (annotation,) if isinstance(annotation, type) and typing.get_origin(annotation) is None else ()


def enum_of(annotation: object) -> type[enum.Enum] | None:
    """The enum a field's annotation names (its closed set of values), or None."""
    return next((a for a in classes(annotation) if issubclass(a, enum.Enum)), None)


def settings_class_of(annotation: object) -> type[Settings] | None:
    """The section a field's annotation names (a nested section), or None."""
    return next((a for a in classes(annotation) if issubclass(a, Settings)), None)


def describe(kind: type) -> str:
    """How an error names a type: ``an integer``, ``a number``, ``one of [...]``."""
    if issubclass(kind, enum.Enum):
        return f"one of {[k.value for k in kind]}"
    return {int: "an integer", float: "a number", bool: "true or false", str: "a string"}.get(
        kind, kind.__name__
    )


def json_safe(tree: Any) -> Any:
    """Enums as their values, tuples as lists: the tree as `json.dumps` / YAML write it."""
    if isinstance(tree, Settings):
        return tree.to_tree()
    if isinstance(tree, dict):
        return {key: json_safe(value) for key, value in tree.items()}
    if isinstance(tree, (list, tuple)):
        return [json_safe(value) for value in tree]
    return tree.value if isinstance(tree, enum.Enum) else tree
