"""litl: learning-in-the-loop co-design of soft robots with differentiable MPM.

`import litl` is light: the subpackages a user reaches for (`litl.sim`, `litl.robots`,
`litl.models`, `litl.loop`, `litl.viz`, `litl.report`, `litl.claims`, `litl.config`) are imported on
first use, so `import litl.config` does not pay for the simulator or matplotlib.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_SUBPACKAGES = ("sim", "robots", "models", "loop", "viz", "report", "claims", "config", "errors")

__all__ = [*_SUBPACKAGES, "__version__"]


def __getattr__(name: str):
    if name in _SUBPACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module 'litl' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_SUBPACKAGES))
