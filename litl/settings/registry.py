"""Registries by name: how observers and controllers, built-in or a user's, become selectable.

A `Registry` maps a name (``observer=<name>`` on the command line) to an `Entry`: the factory
that builds the thing, the frozen settings dataclass it reads (`litl.settings.Settings`; its
section of the config is ``<part>.<section>``, e.g. ``observer.vae``), the name reports show and
where they list it. `litl.observers.register` and `litl.controllers.register` are two
registries' `register`. This module imports neither JAX nor the rest of litl; the two packages
that fill the registries are imported on first use (`observers`, `controllers`).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
from collections.abc import Callable, Mapping
from typing import Any

from litl.settings import Settings, SettingsError


@dataclasses.dataclass(frozen=True)
class Entry:
    """One registered name.

    Attributes:
      name: the name (``observer=<name>``).
      factory: ``factory(robot, settings, context)``: builds it (`litl.observers.Observer`,
        `litl.controllers.Controller`).
      settings: its settings dataclass (a `litl.settings.Settings`), or None: it has none.
      section: the section of the config it reads (``observer.<section>``); its own name unless
        it shares another's (``ae`` reads ``vae``'s).
      label: how reports and the claims suite name it.
      order: where reports list it (registration order).
      traits: what the config must know before building it (a controller's ``open_loop``).
    """

    name: str
    factory: Callable[..., Any]
    settings: type[Settings] | None
    section: str
    label: str
    order: int
    traits: Mapping[str, Any]


class Registry:
    """Names of one part of the config (``"observer"``, ``"controller"``) and their entries."""

    def __init__(self, part: str, package: str):
        self.part = part
        self.package = package  # registers the built-in ones when imported
        self._entries: dict[str, Entry] = {}

    def register(
        self,
        name: str,
        factory: Callable[..., Any],
        settings: type[Settings] | None = None,
        *,
        section: str | None = None,
        label: str | None = None,
        replace: bool = False,
        **traits: Any,
    ) -> None:
        """Make `factory(robot, settings, context)` selectable as `name`; `settings` is its
        frozen settings dataclass deriving from `litl.settings.Settings` (``<part>.<name>.<key>=
        value`` on the command line), or None; `section` shares another name's section instead
        (the settings class must be the same).

        Raises:
          SettingsError: at once, for what would otherwise fail later: a taken name (without
            `replace`), a factory of the old signature, settings that are not a frozen
            `Settings` dataclass (a plain one included: the message says to subclass
            `Settings`), or defaults that cannot be built, that its check refuses or that
            run.json cannot hold.
        """
        part = self.part
        if not isinstance(name, str) or not name.isidentifier():
            raise SettingsError(
                f"a{'n' if part[0] in 'aeiou' else ''} {part}'s name must be an identifier, got {name!r}"
            )
        if name in self._entries and not replace:
            raise SettingsError(
                f"a{'n' if part[0] in 'aeiou' else ''} {part} named {name!r} is already registered "
                f"(by {self._entries[name].factory!r}); pass replace=True to replace it"
            )
        if not callable(factory):
            raise SettingsError(f"{part} {name!r}: the factory must be callable, got {factory!r}")
        _check_factory(part, name, factory)
        section = section or name
        if settings is not None:
            _check_settings(part, name, section, settings)
        shared = next((e for e in self._entries.values() if e.section == section and e.name != name), None)
        if shared is not None and shared.settings is not settings:
            raise SettingsError(
                f"{part} {name!r} shares section {section!r} with {shared.name!r}, whose settings "
                f"class is {shared.settings!r}, not {settings!r}"
            )
        order = self._entries[name].order if name in self._entries else len(self._entries)
        self._entries[name] = Entry(name, factory, settings, section, label or name, order, dict(traits))

    def names(self) -> tuple[str, ...]:
        """The registered names, in registration order."""
        return tuple(self._entries)

    def get(self, name: str) -> Entry:
        """The entry of `name`; a `SettingsError` naming the choices if there is none."""
        if name not in self._entries:
            raise SettingsError(
                f"{self.part}.kind={name!r}: unknown {self.part}; choose one of {list(self._entries)}",
                f"{self.part}.kind",
            )
        return self._entries[name]

    def build(self, name_or_config: Any, robot: Any, context: Any, returns: type) -> tuple[Entry, Any]:
        """(entry, what its factory built) for `robot`: `name_or_config` is the config's part
        (its `kind` with its `section`) or a registered name (its settings' defaults); the factory
        must return a `returns`."""
        if isinstance(name_or_config, str):
            entry = self.get(name_or_config)
            settings = entry.settings() if entry.settings is not None else None
        else:
            entry = self.get(name_or_config.kind)
            settings = name_or_config.section
        built = entry.factory(robot, settings, context)
        if not isinstance(built, returns):
            raise SettingsError(
                f"{self.part} {entry.name!r}: its factory returned {type(built).__name__}, not a "
                f"{returns.__module__.rsplit('.', 1)[0]}.{returns.__name__}",
                f"{self.part}.kind",
            )
        return entry, built

    def find(self, name: str) -> Entry | None:
        return self._entries.get(name)

    def sections(self) -> dict[str, type[Settings]]:
        """Every registered section and its settings class (``{"vae": AutoencoderSettings, ...}``)."""
        return {e.section: e.settings for e in self._entries.values() if e.settings is not None}


def _check_settings(part: str, name: str, section: str, settings: Any) -> None:
    """Refuse, at registration, settings that would fail once a run has started: a class that is
    not a frozen dataclass deriving from `Settings` (a plain dataclass's values are neither
    checked nor written to run.json), and defaults its own check refuses or run.json cannot
    hold (`Settings.__post_init__` checks both); name the section's key (``observer.<section>``)."""
    if not (isinstance(settings, type) and dataclasses.is_dataclass(settings)):
        raise SettingsError(
            f"{part} {name!r}: settings must be a frozen dataclass deriving from "
            f"litl.settings.Settings, got {settings!r}"
        )
    if not settings.__dataclass_params__.frozen:  # type: ignore[attr-defined]
        raise SettingsError(
            f"{part} {name!r}: settings {settings.__name__} must be frozen (@dataclass(frozen=True))"
        )
    if not issubclass(settings, Settings):
        raise SettingsError(
            f"{part} {name!r}: settings {settings.__name__} is a plain dataclass; subclass "
            f"litl.settings.Settings (class {settings.__name__}(Settings), still frozen) so that its "
            f"values are checked and written to run.json"
        )
    if not settings.KEY:
        settings.KEY = f"{part}.{section}"
    try:
        settings()  # its defaults: checked by its own check, its annotations and for run.json
    except TypeError as error:
        raise SettingsError(
            f"{part} {name!r}: settings {settings.__name__}() cannot be built from its defaults "
            f"({error}); every field needs a default",
            settings.KEY,
        ) from None


def _check_factory(part: str, name: str, factory: Callable[..., Any]) -> None:
    """Refuse a factory of the old signature ``(robot, config, sim_config, dtype)`` early."""
    try:
        parameters = [
            p
            for p in inspect.signature(factory).parameters.values()
            if p.default is inspect.Parameter.empty
            and p.kind in (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
        ]
    except (TypeError, ValueError):  # a builtin or C callable: trust it
        return
    if len(parameters) > 3:
        raise SettingsError(
            f"{part} {name!r}: its factory takes {len(parameters)} arguments; factories are "
            f"called as factory(robot, settings, context) since 2026-11-27 (settings: its own "
            f"settings dataclass, given as register(..., settings=...); context: the simulator's "
            f"config, dtype and learning-phase settings). See docs/guide/observers.md"
        )


_REGISTRIES: dict[str, Registry] = {}


def registry(part: str) -> Registry:
    """The registry of `part` (``"observer"``, ``"controller"``, ``"world"``, ``"optimizer"``
    or ``"design"``), its built-ins registered."""
    packages = {
        "observer": "litl.observers",
        "controller": "litl.controllers",
        "world": "litl.worlds",
        "optimizer": "litl.optimizers",
        "design": "litl.designs",
    }
    if part not in _REGISTRIES:
        _REGISTRIES[part] = Registry(part, packages[part])
    importlib.import_module(packages[part])  # registers the built-in ones (once)
    return _REGISTRIES[part]


def section_of(part: str, name: str) -> str:
    """The section `name` reads (its own name if it is not registered: a user's module that is
    not imported)."""
    entry = registry(part).find(name)
    return entry.section if entry is not None else name


def import_module(key: str, module: str | None, registers: str) -> None:
    """Import the module a setting names (``observer.module``: it registers observers of the
    user's own); a clear error if it cannot be imported."""
    if not module:
        return
    try:
        importlib.import_module(module)
    except ImportError as error:
        raise SettingsError(
            f"{key}={module!r} could not be imported ({error}); give a module "
            f"importable from the working directory or installed, which calls "
            f"{registers}",
            key,
        ) from None
