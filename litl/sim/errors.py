"""The simulator's error for bad settings, and the one check of a strain limit's value: below
`litl.sim.config` and `litl.sim.materials`, which both raise it."""

from __future__ import annotations

import math

from litl.errors import UserError


class SimConfigError(UserError, ValueError):
    """A simulator setting (`SimConfig`, a wall, a material, a robot's scene) is invalid; the
    message says which and how to fix it. (Not `litl.config.SettingsError`, which names a setting
    of a run.)"""


def is_stretch_bound(value: object) -> bool:
    """Whether `value` can bound a particle's principal stretch (the strain limit): a finite number
    above 1, not a bool. The one check of a limit's value; "no limit" is spelled None inside the
    simulator (`Elastic.max_stretch`) and inf only at the edges (`litl.robots.Material`, the
    command line's `robot.material.max_stretch=inf`)."""
    return (
        isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 1
    )
