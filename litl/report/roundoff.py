"""When a task loss is round-off: the one rule that `litl.gradcheck` and the report share.

A robot that has hardly moved has a task loss (a displacement, a velocity) at the level of the
float arithmetic that computed it. Its derivatives cannot be checked by differences, and its
numbers are not a result. Positions live in the unit domain, so the arithmetic's own level is
the spacing of floats at 1 (`numpy.finfo(dtype).eps`: 1.2e-7 in float32, 2.2e-16 in float64);
in float64 that is far below anything a finite difference can check, so a floor of STILL
applies.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, DTypeLike

# A task loss below this is too small for any check in float64 (central differences at steps of
# 1e-6 would carry round-off of ~1e-10, a tenth of it).
STILL = 1e-9


def threshold(dtype: DTypeLike) -> float:
    """The magnitude under which a task loss computed in `dtype` is round-off.

    Args:
      dtype: the simulation's float type (``"float32"``, ``"float64"`` or a numpy/JAX dtype).

    Raises:
      ValueError: `dtype` is not a floating-point type.
    """
    try:
        info = np.finfo(np.dtype(dtype))
    except (TypeError, ValueError) as error:
        raise ValueError(f"a task loss's round-off needs a float dtype, got {dtype!r}") from error
    return max(STILL, float(info.eps))


def hardly_moved(task_losses: ArrayLike, dtype: DTypeLike) -> bool:
    """Whether every finite task loss of a rollout (or of all a seed's iterations) is round-off.

    Args:
      task_losses: one value or (n,) values; NaN (a skipped iteration) is left out.
      dtype: the float type they were computed in.

    Returns:
      True when there is at least one finite value and every finite one is smaller in
      magnitude than `threshold(dtype)`.
    """
    values = np.atleast_1d(np.asarray(task_losses, np.float64))
    finite = values[np.isfinite(values)]
    return bool(finite.size) and bool(np.all(np.abs(finite) < threshold(dtype)))
