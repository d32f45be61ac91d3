"""The environment of the processes tests start: the checkout first on PYTHONPATH, the user's own
entries kept after it (packages carried to a GPU machine, say, which a child must still import)."""

from __future__ import annotations

import os
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[1]


def child_environment(first: pathlib.Path = ROOT, **variables: str) -> dict[str, str]:
    """This process's environment with `first` ahead on PYTHONPATH and `variables` set."""
    path = os.pathsep.join(p for p in (str(first), os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PYTHONPATH": path, **variables}
