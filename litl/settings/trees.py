"""Nested dicts and their dotted keys: ``{"loop": {"episodes": 10}}`` and ``{"loop.episodes": 10}``."""

from __future__ import annotations

from typing import Any

__all__ = ["flatten", "unflatten"]


def flatten(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """A nested dict's leaves by dotted key: ``{"loop.episodes": 10, ...}``."""
    flat = {}
    for key, value in tree.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f"{prefix}{key}."))
        else:
            flat[prefix + key] = value
    return flat


def unflatten(flat: dict[str, Any]) -> dict[str, Any]:
    """The nested dict of a dotted-key dict (`flatten`'s inverse)."""
    tree: dict[str, Any] = {}
    for key, value in flat.items():
        *parents, leaf = key.split(".")
        node = tree
        for parent in parents:
            node = node.setdefault(parent, {})
        node[leaf] = value
    return tree
