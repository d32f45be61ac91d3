"""litl: learning-in-the-loop co-design of soft robots with differentiable MPM.

`import litl` is light: the subpackages a user reaches for (`litl.sim`, `litl.robots`,
`litl.models`, `litl.loop`, `litl.viz`, `litl.report`, `litl.claims`, `litl.config`) are imported on
first use, so `import litl.config` does not pay for the simulator or matplotlib.

Importing litl also asks XLA for deterministic GPU computations unless `LITL_DETERMINISM=off`
(`litl.backend`): XLA reads its flags when JAX's backend starts, so import litl before the first
JAX computation.
"""

from __future__ import annotations

import importlib
import sys

from litl import backend as _backend

__version__ = "0.1.0"

try:
    _backend.configure()
except _backend.DeterminismError as _error:
    if sys.argv[:1] == ["-m"]:  # `python -m litl...`: one line, like every other bad setting
        sys.stderr.write(f"litl: error: {_error}\n")
        raise SystemExit(2) from None
    raise

_SUBPACKAGES = (
    "backend",
    "sim",
    "robots",
    "models",
    "observers",
    "loop",
    "viz",
    "report",
    "claims",
    "config",
    "errors",
    "records",
    "settings",
)

__all__ = [*_SUBPACKAGES, "__version__"]


def __getattr__(name: str):
    if name in _SUBPACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module 'litl' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_SUBPACKAGES))
