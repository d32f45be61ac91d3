"""Old spellings of settings, translated where old command lines and old run.json files are read.

Two tables, because they are two namespaces: dotted keys that moved since the config model was
written (`MOVED_KEYS`; still accepted, with a warning, on the command line by
`translate_overrides`, in `Settings.replace` by `moved_changes`, and in older run.json files), and
the flat layout of run.json files from before it (`FLAT_RUN_KEYS`, read by `recorded_settings`).
`upgrade` brings a recorded run's settings to today's layout: the command line
(`litl.app.compose`), resuming (`litl.loop.run`), replaying (`litl.replay`) and reports
(`litl.report.runs`) are the readers.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from typing import Any

from litl.settings.trees import flatten, unflatten

MOVED_KEYS = {
    "observer.latent_dim": "observer.vae.latent_dim",
    "observer.window": "observer.vae.window",
    "observer.channels": "observer.vae.channels",
    "observer.activation": "observer.vae.activation",
    "observer.field": "observer.vae.field",
    "observer.clusters": "observer.kmeans.clusters",
    "controller.widths": "controller.mlp.widths",
    "controller.period": "controller.mlp.period",
    "controller.feature_scale": "controller.mlp.feature_scale",
    "controller.feature_gradient": "controller.mlp.feature_gradient",
    "controller.omega": "controller.sinusoid.omega",
    "loop.gradient_clip": "loop.safeguards.gradient_clip",
    "loop.update_tolerance": "loop.safeguards.update_tolerance",
    "loop.step_back_tolerance": "loop.safeguards.step_back_tolerance",
    "loop.final_learning_rate_fraction": "loop.safeguards.final_learning_rate_fraction",
    "loop.replay": "loop.replay_buffer",
    "loop.replay_capacity": "loop.buffer_capacity",
    "loop.learning.beta": "observer.vae.beta",
    "loop.learning.momentum_weight": "observer.vae.momentum_weight",
}


# Sections that held every kind's keys before their kinds were registered parts (2026-12-02):
# ``world.angle`` is now ``world.slope.angle``, ``baseline.population`` is
# ``optimizer.cmaes.population``: where a key moved depends on the kind chosen (`sectioned_key`).
# {old section: (its part now, {old key: the kinds that read it})}; only the built-in kinds
# existed then. cmaes and sep_cmaes never read baseline.learning_rate.
_EVOLUTION = ("cmaes", "sep_cmaes", "openai_es")
OLD_SECTIONS: dict[str, tuple[str, dict[str, tuple[str, ...]]]] = {
    "world": (
        "world",
        {
            "angle": ("slope",),
            "step_height": ("steps",),
            "step_length": ("steps",),
            "amplitude": ("bumps",),
            "wavelength": ("bumps",),
            "seed": ("bumps",),
            "contact": ("slope", "steps", "bumps"),
            "friction": ("slope", "steps", "bumps"),
            "gap": ("slope", "steps", "bumps", "push_box"),
            "depth": ("sand", "water"),
            "friction_angle": ("sand",),
            "density": ("sand", "water", "push_box"),
            "observe": ("sand", "water", "push_box"),
            "box_size": ("push_box",),
            "push": ("push_box",),
        },
    ),
    "baseline": (
        "optimizer",
        {
            "population": _EVOLUTION,
            "generations": _EVOLUTION,
            "sigma": _EVOLUTION,
            "learning_rate": ("openai_es", "ppo"),
            **{
                f"ppo.{key}": ("ppo",)
                for key in (
                    "timesteps",
                    "envs",
                    "rollout",
                    "epochs",
                    "minibatches",
                    "hold",
                    "evaluations",
                    "gamma",
                    "normalize",
                )
            },
        },
    ),
}
# Kinds renamed with their part: baseline=none was litl's loop.
OLD_KINDS = {"baseline": {"none": "litl"}}


def new_kind(section: str, kind: str) -> str:
    """A kind as its part names it now (``baseline=none``: ``optimizer=litl``)."""
    return OLD_KINDS.get(section, {}).get(kind, kind)


def sectioned_key(key: str, kind: str) -> str | None:
    """Where an old key of a section that held every kind's keys (``world.angle``,
    ``baseline.population``) lives now for a run of `kind` (``world.slope.angle``,
    ``optimizer.cmaes.population``); None where that kind does not read it. ``baseline.kind`` is
    ``optimizer.kind``. Other keys: unchanged."""
    head, _, name = key.partition(".")
    if head not in OLD_SECTIONS:
        return key
    part, keys = OLD_SECTIONS[head]
    if name == "kind" and part != head:
        return f"{part}.kind"
    if name not in keys:
        return key
    kind = new_kind(head, kind)
    inner = name.removeprefix("ppo.")
    return f"{part}.{kind}.{inner}" if kind in keys[name] else None


def sectioned_message(key: str, kind: str) -> str:
    """What to type instead of an old key of such a section, or why `kind` does not read it."""
    head, _, name = key.partition(".")
    part, keys = OLD_SECTIONS[head]
    kind = new_kind(head, kind)
    now = sectioned_key(key, kind)
    if now is None:
        return (
            f"{key}: the {part}'s keys moved into each {part}'s own section ({part}.<name>.<key>), and "
            f"{part}={kind} has no {name.removeprefix('ppo.')!r}; it is a key of "
            f"{part}={'|'.join(keys[name])}"
        )
    return f"{key} is now {now} (with {part}={kind}); the old spelling still works for now, but not for ever"


def chosen_kinds(overrides: Iterable[str]) -> dict[str, str]:
    """The kind each old section's part is given in `overrides` ({"world": "slope", "baseline":
    "cmaes"}), by its old or its new name; the default where none is."""
    kinds = {"world": "flat", "baseline": "litl"}
    for override in overrides:
        key, _, value = override.lstrip("+~").partition("=")
        for head, (part, _) in OLD_SECTIONS.items():
            if key in (head, f"{head}.kind", part, f"{part}.kind"):
                kinds[head] = new_kind(head, value)
    return kinds


# run.json files written before the config model (before 2026-11-23) kept the run's settings in
# one flat "loop" object; where each of its keys lives now. They are no keys of today's command
# line (`observer=` there picks a group, not `observer.kind`), so only `recorded_settings` reads them.
FLAT_RUN_KEYS = {
    "episodes": "loop.episodes",
    "iterations": "loop.iterations",
    "steps": "sim.steps",
    "dtype": "sim.dtype",
    "observer": "observer.kind",
    "latent_dim": "observer.vae.latent_dim",
    "window": "observer.vae.window",
    "channels": "observer.vae.channels",
    "activation": "observer.vae.activation",
    "clusters": "observer.kmeans.clusters",
    "controller": "controller.kind",
    "controller_widths": "controller.mlp.widths",
    "controller_omega": "controller.sinusoid.omega",
    "controller_period": "controller.mlp.period",
    "feature_gradient": "controller.mlp.feature_gradient",
    "learning_rate": "controller.learning_rate",
    "design_learning_rate": "loop.design_learning_rate",
    "gradient_clip": "loop.safeguards.gradient_clip",
    "snapshot_stride": "loop.snapshot_stride",
    "replay_capacity": "loop.buffer_capacity",
    "alpha": "loop.alpha",
    "replay": "loop.replay_buffer",
    "codesign": "loop.codesign",
    "learning": "loop.learning",
    "seeds": "seeds",
    "seed": "seed",
}


def current_key(key: str) -> str:
    """Where a setting lives now, under any spelling a run.json may hold: a moved dotted key
    (`MOVED_KEYS`), a key of the flat layout (`FLAT_RUN_KEYS`) or today's."""
    return FLAT_RUN_KEYS.get(key) or MOVED_KEYS.get(key, key)


def moved_message(old: str) -> str:
    return f"{old} is now {MOVED_KEYS[old]}; the old spelling still works for now, but will not for ever"


def moved_changes(section: str, changes: dict[str, Any]) -> dict[str, Any]:
    """`changes` to the section at `section` with moved keys renamed (a warning each): at the
    top, ``loop={"replay": False}`` becomes ``loop={"replay_buffer": False}``.

    Raises:
      ValueError: a key that moved out of `section` (``loop.learning.beta``, now
        ``observer.vae.beta``), given to that section: it can only be set from the whole config.
    """
    prefix = f"{section}." if section else ""
    flat = flatten(changes, prefix)
    if not any(key in MOVED_KEYS for key in flat):
        return changes
    for key in flat:
        if key in MOVED_KEYS:
            if not MOVED_KEYS[key].startswith(prefix):
                raise ValueError(
                    f"{key} is now {MOVED_KEYS[key]}, outside {section}: set it there, from the whole "
                    f"config (Config.replace or {MOVED_KEYS[key]}=... on the command line)"
                )
            warnings.warn(moved_message(key), FutureWarning, stacklevel=4)
    return unflatten({MOVED_KEYS.get(key, key)[len(prefix) :]: value for key, value in flat.items()})


def translate_overrides(overrides: Iterable[str]) -> tuple[list[str], list[str]]:
    """Command-line overrides with moved keys renamed (`MOVED_KEYS`; an old world key into the
    chosen kind's section, `sectioned_key`), and a message for each:
    ``["loop.replay=false"] -> (["loop.replay_buffer=false"], ["loop.replay is now ..."])``.
    ``baseline=cmaes`` (the group) is ``optimizer=cmaes``. An old key the chosen kind does not read
    (``world.angle=15`` without ``world=slope``) is left as it is (`litl.app.compose` refuses it
    with `sectioned_message`)."""
    overrides = list(overrides)
    kinds = chosen_kinds(overrides)
    translated, messages = [], []
    for override in overrides:
        prefix = override[:1] if override[:1] in "+~" else ""
        key, equals, value = override[len(prefix) :].partition("=")
        if key in MOVED_KEYS:
            messages.append(moved_message(key))
            override = f"{prefix}{MOVED_KEYS[key]}{equals}{value}"
        elif key in OLD_SECTIONS and OLD_SECTIONS[key][0] != key:  # a group renamed
            part = OLD_SECTIONS[key][0]
            messages.append(
                f"{key}={value} is now {part}={new_kind(key, value)}; the old spelling still works for now"
            )
            override = f"{prefix}{part}{equals}{new_kind(key, value)}"
        elif sectioned_key(key, kinds.get(key.partition(".")[0], "")) not in (key, None):
            head = key.partition(".")[0]
            now = sectioned_key(key, kinds[head])
            if key.endswith(".kind"):  # baseline.kind: optimizer.kind
                messages.append(f"{key} is now {now}; the old spelling still works for now")
                value = new_kind(head, value)
            else:
                messages.append(sectioned_message(key, kinds[head]))
            override = f"{prefix}{now}{equals}{value}"
        translated.append(override)
    return translated, messages


def _today(flat: dict[str, Any]) -> dict[str, Any]:
    """Dotted settings of any date with today's keys: moved keys renamed, the method of a run
    recorded before methods were named (litl's), the PCA observer's field (it read the VAE's
    until it had its own, 2026-11-27)."""
    flat = {MOVED_KEYS.get(key, key): value for key, value in flat.items()}
    for head, (part, _) in OLD_SECTIONS.items():  # kinds' keys into their sections (2026-12-02)
        if f"{head}.kind" in flat and f"{head}.module" not in flat:
            kind = new_kind(head, str(flat[f"{head}.kind"]))
            moved = {
                (sectioned_key(key, kind) if key.startswith(f"{head}.") else key): value
                for key, value in flat.items()
            }
            flat = {key: value for key, value in moved.items() if key is not None}
            flat[f"{part}.kind"] = kind
            flat[f"{part}.module"] = None
    flat.setdefault("method", "litl")
    flat.setdefault("controller.module", None)  # controllers of one's own came on 2026-11-27
    if "loop.dynamics.mlp.widths" in flat:  # multi-step training came on 2026-12-07
        flat.setdefault("loop.dynamics.mlp.rollout", 1)
    if "observer.pca.components" in flat:
        flat.setdefault("observer.pca.field", flat.get("observer.vae.field", "mass_weighted"))
    return flat


def recorded_settings(saved: dict[str, Any]) -> dict[str, Any]:
    """A parsed run.json's settings by today's dotted key (``"loop.alpha"``), as
    `Config.run_settings` names them; older layouts translated (`FLAT_RUN_KEYS`). Older runs
    keep every observer's section they recorded (`Run.observer_reads` says which one counts)."""
    if isinstance(saved.get("config"), dict):
        flat = flatten(saved["config"])
    else:
        legacy: dict[str, Any] = dict(saved.get("loop", {}))
        one_shot = legacy.pop("one_shot", False)
        simultaneous = legacy.pop("simultaneous", False)
        schedule = "one_shot" if one_shot else "simultaneous" if simultaneous else "alternating"
        moved = {FLAT_RUN_KEYS.get(key, key): value for key, value in legacy.items()}
        flat = {**flatten(moved), "loop.schedule": schedule}
    return _today(flat)


def upgrade(tree: dict[str, Any]) -> dict[str, Any]:
    """A run's nested settings (`run.json`'s "config", or a composed config's) in today's
    layout (`recorded_settings`' translation); a section added since the run ran with its
    defaults, which building the `Config` fills in. (Older runs recorded every built-in
    observer's and controller's section: `litl.config.read_sections_only` keeps the chosen
    one's, as run.json records them today.)"""
    return unflatten(_today(flatten(tree)))
