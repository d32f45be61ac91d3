"""The parts of the config that registries fill: the observer, the controller, the world and the
optimization method.

A part has a `kind` (a registered name), an optional `module` (imported first: it registers a
user's own) and one settings section per registered settings dataclass, read as attributes
(``config.observer.vae``) and written as keys (``observer.vae.latent_dim=4``); each observer and
controller declares its section's dataclass when it registers (`litl.settings.registry`). run.json records
the chosen kind's section only (`PartConfig.record`).
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from litl.settings import Settings, SettingsError, json_safe
from litl.settings.registry import import_module, registry


class PartConfig(Settings):
    """A part of the config that a registry fills (`ObserverConfig`, `ControllerConfig`): `kind`
    (a registered name), `module` (imported first: it registers a user's own) and one settings
    section per registered settings dataclass, read as attributes (``config.observer.vae``) and
    written as keys (``observer.vae.latent_dim=4``). `sections` holds them, as (name, settings)
    pairs; building the part fills in every registered section's defaults."""

    PART: ClassVar[str] = ""
    if TYPE_CHECKING:  # every subclass has these fields
        kind: str
        module: str | None
        sections: tuple[tuple[str, Settings], ...]

    def __post_init__(self) -> None:
        import_module(f"{self.PART}.module", self.module, f"litl.{self.PART}s.register")
        given = dict(self.sections)
        known = registry(self.PART).sections()
        unknown = sorted(set(given) - set(known))
        if unknown:
            raise SettingsError(self._unknown_sections(unknown), f"{self.PART}.{unknown[0]}")
        filled = tuple((name, given.get(name) or kind()) for name, kind in known.items())
        object.__setattr__(self, "sections", filled)
        super().__post_init__()

    def check(self) -> None:
        if registry(self.PART).find(self.kind) is None:
            hint = (
                f"; {self.PART}.module={self.module!r} registered no {self.PART} of that name"
                if self.module
                else f"; a{'n' if self.PART[0] in 'aeiou' else ''} {self.PART} of your own: "
                f"{self.PART}.kind=<name> {self.PART}.module=<module that registers it>"
            )
            raise SettingsError(
                f"{self.PART}.kind={self.kind!r}: unknown {self.PART}; choose one of "
                f"{list(registry(self.PART).names())}{hint}",
                f"{self.PART}.kind",
            )

    def _unknown_sections(self, unknown: list[str]) -> str:
        names = list(registry(self.PART).sections())
        return (
            f"unknown {self.PART} section(s) {[f'{self.PART}.{u}' for u in unknown]}: no registered "
            f"{self.PART} reads them; the sections are {names} (a{'n' if self.PART[0] in 'aeiou' else ''} "
            f"{self.PART} of your own: {self.PART}.module=<module that registers it>)"
        )

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name == "sections":
            raise AttributeError(name)
        for section, settings in self.sections:
            if section == name:
                return settings
        raise AttributeError(f"{type(self).__name__} has no field or section {name!r}")

    @property
    def section(self) -> Settings | None:
        """The settings of the chosen `kind` (its section), or None if it has none."""
        return dict(self.sections).get(registry(self.PART).get(self.kind).section)

    def replace(self, **changes: Any) -> Any:
        from litl.settings.old import moved_changes

        changes = moved_changes(self.KEY, changes)
        own = {f.name for f in dataclasses.fields(self)} - {"sections"}
        plain = {key: value for key, value in changes.items() if key in own}
        if plain.get("module"):
            import_module(f"{self.PART}.module", plain["module"], f"litl.{self.PART}s.register")
        sections = dict(self.sections)
        known = registry(self.PART).sections()
        unknown = sorted(set(changes) - own - set(known))
        if unknown:
            raise SettingsError(self._unknown_sections(unknown), f"{self.PART}.{unknown[0]}")
        for name in set(changes) - own:
            value = changes[name]
            current = sections.get(name) or known[name]()
            sections[name] = _replaced(current, value, f"{self.PART}.{name}")
        return dataclasses.replace(self, **plain, sections=tuple(sections.items()))

    def to_tree(self) -> dict[str, Any]:
        own = {
            f.name: json_safe(getattr(self, f.name)) for f in dataclasses.fields(self) if f.name != "sections"
        }
        return {**own, **{name: json_safe(settings) for name, settings in self.sections}}

    def record(self) -> dict[str, Any]:
        """What run.json records: the part's own keys and the chosen kind's section only (two
        runs differ in their observer exactly when that section differs)."""
        tree = self.to_tree()
        read = registry(self.PART).get(self.kind).section
        return {key: value for key, value in tree.items() if not isinstance(value, dict) or key == read}

    @classmethod
    def from_tree(cls, values: dict[Any, Any]) -> Any:
        own = {f.name for f in dataclasses.fields(cls)} - {"sections"}
        plain = {key: value for key, value in values.items() if key in own}
        import_module(f"{cls.PART}.module", plain.get("module"), f"litl.{cls.PART}s.register")
        known = registry(cls.PART).sections()
        sections = {}
        for name, value in values.items():
            if name in own:
                continue
            if name not in known or not isinstance(value, dict):
                names = list(known)
                raise SettingsError(
                    f"unknown setting {cls.PART}.{name}: the {cls.PART}'s keys are {sorted(own)} and "
                    f"the sections {names} (a{'n' if cls.PART[0] in 'aeiou' else ''} {cls.PART} of "
                    f"your own: {cls.PART}.module=<module that registers it>)",
                    f"{cls.PART}.{name}",
                )
            sections[name] = known[name].from_tree(value)
        return cls(**plain, sections=tuple(sections.items()))  # type: ignore[call-arg]  # a dataclass


def _replaced(current: Settings, value: Any, key: str) -> Settings:
    """`current` with `value`'s changes (a dict of its keys), or `value` itself (a section of
    the same class)."""
    if isinstance(value, dict):
        return current.replace(**value)
    if not isinstance(value, type(current)):
        raise SettingsError(
            f"{key}: give a dict of its keys or a {type(current).__name__}, got {value!r}", key
        )
    return value


@dataclass(frozen=True)
class ObserverConfig(PartConfig):
    """What the controller sees: a registered observer (`litl.observers`) and its settings.

    Attributes:
      kind: vae (the method), ae (plain autoencoder), pca (linear baseline), kmeans (the
        paper's baseline), none (no features: open-loop control), or your own.
      module: a module to import first, which registers observers of your own
        (`litl.observers.register`); then kind=<its name>.
      sections: every registered observer's settings (read as ``observer.vae``,
        ``observer.kmeans``, ...; each observer's dataclass documents its keys).
    """

    KEY = "observer"
    PART = "observer"
    kind: str = "vae"
    module: str | None = None
    sections: tuple[tuple[str, Any], ...] = ()


@dataclass(frozen=True)
class ControllerConfig(PartConfig):
    """The controller θ (a registered controller, `litl.controllers`), its settings and its
    optimizer.

    Attributes:
      kind: mlp (closed loop on the observer's features) or sinusoid (open loop; needs observer
        none), or your own.
      module: a module to import first, which registers controllers of your own.
      learning_rate: Adam step size of θ.
      sections: every registered controller's settings (``controller.mlp``,
        ``controller.sinusoid``).
    """

    KEY = "controller"
    PART = "controller"
    kind: str = "mlp"
    module: str | None = None
    learning_rate: float = 0.01
    sections: tuple[tuple[str, Any], ...] = ()

    def check(self) -> None:
        super().check()
        self._positive_numbers("learning_rate")


@dataclass(frozen=True)
class WorldConfig(PartConfig):
    """The world the robot is put in (a registered world, `litl.worlds`) and its settings.

    Attributes:
      kind: flat (the empty box), slope, steps, bumps (terrain ahead of the robot), sand, water
        (a bed under it), push_box (a box to push: the world's own task), or your own.
      module: a module to import first, which registers worlds of your own
        (`litl.worlds.register`); then kind=<its name>.
      sections: every registered world's settings (``world.slope``, ``world.sand``, ...; each
        world's dataclass documents its keys).
    """

    KEY = "world"
    PART = "world"
    kind: str = "flat"
    module: str | None = None
    sections: tuple[tuple[str, Any], ...] = ()

    def replace(self, **changes: Any) -> Any:
        """As `PartConfig.replace`; the keys of the world's section before worlds were parts
        (``replace(kind="slope", angle=15)``) go to the chosen world's section, with a warning."""
        from litl.settings.old import OLD_SECTIONS, sectioned_key, sectioned_message

        old = [key for key in changes if key in OLD_SECTIONS["world"][1]]
        if old:
            kind = str(changes.get("kind", self.kind))
            section = dict(changes.get(kind, {}) or {})
            for key in old:
                if sectioned_key(f"world.{key}", kind) is None:
                    raise SettingsError(sectioned_message(f"world.{key}", kind), f"world.{key}")
                warnings.warn(sectioned_message(f"world.{key}", kind), FutureWarning, stacklevel=3)
                section[key] = changes.pop(key)
            changes[kind] = section
        return super().replace(**changes)


@dataclass(frozen=True)
class OptimizerConfig(PartConfig):
    """What optimizes the controller and the design (a registered method, `litl.optimizers`) and
    its settings.

    Attributes:
      kind: litl (litl's loop, Algorithm 1: its settings are the config's `loop`), cmaes,
        sep_cmaes, openai_es (evolution strategies), ppo, or your own.
      module: a module to import first, which registers methods of your own
        (`litl.optimizers.register`); then kind=<its name>.
      sections: every registered method's settings (``optimizer.cmaes``, ``optimizer.ppo``, ...).
    """

    KEY = "optimizer"
    PART = "optimizer"
    kind: str = "litl"
    module: str | None = None
    sections: tuple[tuple[str, Any], ...] = ()


@dataclass(frozen=True)
class DesignConfig(PartConfig):
    """What co-design changes about the robot's body (a registered design space,
    `litl.designs`) and its settings.

    Attributes:
      kind: modulus (one Young's modulus per design region, the paper's), actuators (where the
        muscles are, per particle), or your own.
      module: a module to import first, which registers design spaces of your own
        (`litl.designs.register`); then kind=<its name>.
      sections: every registered design space's settings (``design.actuators``, ...).
    """

    KEY = "design"
    PART = "design"
    kind: str = "modulus"
    module: str | None = None
    sections: tuple[tuple[str, Any], ...] = ()
