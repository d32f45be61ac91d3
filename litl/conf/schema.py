"""Hydra's view of the config: a schema built from `litl.config.Config` and the registries.

`register_with_hydra` stores the schema in Hydra's ConfigStore as `litl_schema` (which
`conf/config.yaml` extends) and makes every registered observer, controller or world without a YAML file
of its own (a user's) an option of its group; `from_hydra` turns a composed config back into a
checked `Config`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import field
from typing import Any

from litl.config import Config
from litl.settings import Settings, from_dict
from litl.settings.parts import PartConfig
from litl.settings.registry import registry


def hydra_schema(kind: type[Settings] = Settings) -> type:
    """The Hydra schema of `Config` (or of one section): the same dataclasses, with each part
    (`PartConfig`) a dataclass whose fields are its keys and its registered sections, so Hydra
    types every key of every registered observer and controller."""
    from litl.settings import field_types, settings_class_of

    kind = Config if kind is Settings else kind
    hints = field_types(kind)
    fields: list[tuple[str, Any, Any]] = []
    for f in dataclasses.fields(kind):
        if f.name == "sections":
            part: Any = kind
            for name, settings in registry(part.PART).sections().items():
                fields.append((name, settings, field(default_factory=settings)))
            continue
        nested = settings_class_of(hints[f.name])
        if nested is not None and issubclass(nested, PartConfig):
            schema = hydra_schema(nested)
            fields.append((f.name, schema, field(default_factory=schema)))
        elif f.default is not dataclasses.MISSING:
            fields.append((f.name, hints[f.name], field(default=f.default)))
        else:
            fields.append((f.name, hints[f.name], field(default_factory=f.default_factory)))
    return dataclasses.make_dataclass(f"{kind.__name__}Schema", fields)


def register_with_hydra() -> None:
    """Put `Config` in Hydra's ConfigStore as `litl_schema`, which `conf/config.yaml` extends.

    The dataclasses are frozen for the Python API; Hydra merges YAML files and overrides into
    the node, so its read-only flags are lifted (the result is frozen again by `from_dict`)."""
    from hydra.core.config_store import ConfigStore
    from omegaconf import DictConfig, OmegaConf

    def writable(node: Any) -> None:
        node._set_flag("readonly", None)
        if isinstance(node, DictConfig):
            for key in node:
                writable(node._get_node(key))

    node = OmegaConf.structured(hydra_schema())
    writable(node)
    store = ConfigStore.instance()
    store.store(name="litl_schema", node=node)
    # A registered observer or controller without a YAML file of its own (a user's) is an option
    # of its group too: observer=<name>.
    from importlib import resources

    for part in ("observer", "controller", "world", "optimizer", "design"):
        files = resources.files("litl.conf") / part
        for name in registry(part).names():
            if not (files / f"{name}.yaml").is_file():
                store.store(group=part, name=name, node={"kind": name})


def from_hydra(cfg: Any) -> Config:
    """Convert a composed Hydra config (DictConfig) into `Config`, checking every value."""
    from omegaconf import OmegaConf, SCMode

    plain = OmegaConf.to_container(cfg, resolve=True, structured_config_mode=SCMode.DICT)
    assert isinstance(plain, dict)  # a DictConfig converts to a dict
    plain.pop("hydra", None)
    return from_dict(Config, plain)
