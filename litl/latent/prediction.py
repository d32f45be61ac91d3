"""Multi-step prediction error of a latent dynamics model, beside the constant-latent baseline.

From a chronological sequence of encoded latents and the actions recorded between them (as
`litl.models.replay_buffer.chronological` orders the buffer), each start z_t whose next h
snapshots follow it in one rollout is rolled forward h steps under the recorded actions,
ẑ_{t+h} = f(... f(f(z_t, a_{t+1}), a_{t+2}) ..., a_{t+h}), and compared with the encoded z_{t+h};
the baseline predicts z_{t+h} ≈ z_t. Errors are root mean squares per latent, in latent units
(decoding back to the grid is the observer's, and not done here).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
from flax import struct

from litl.latent.dynamics import check_sequence


@struct.dataclass
class PredictionError:
    """Prediction error by horizon.

    Attributes:
      horizons: the horizons h (control steps ahead), static.
      model: (H,) RMS error per latent of the model's h-step prediction (NaN where no start
        has h linked steps).
      constant: (H,) the same for the constant-latent baseline z_{t+h} ≈ z_t.
      starts: (H,) int32 how many starts each horizon averages over.
    """

    horizons: tuple[int, ...] = struct.field(pytree_node=False)
    model: jnp.ndarray
    constant: jnp.ndarray
    starts: jnp.ndarray

    def as_dict(self) -> dict[str, float]:
        """{"model/h=1": ..., "constant/h=1": ..., "starts/h=1": ...} as Python numbers (outside jit)."""
        values: dict[str, float] = {}
        for i, h in enumerate(self.horizons):
            values[f"model/h={h}"] = float(self.model[i])
            values[f"constant/h={h}"] = float(self.constant[i])
            values[f"starts/h={h}"] = int(self.starts[i])
        return values


def check_horizons(horizons: Sequence[int], steps: int | None = None) -> tuple[int, ...]:
    """The horizons as a tuple of positive ints (below `steps`, the sequence's length, if
    given); ValueError naming the bad one otherwise."""
    horizons = tuple(horizons)
    if not horizons:
        raise ValueError("horizons must name at least one horizon (a positive int)")
    for h in horizons:
        if isinstance(h, bool) or not isinstance(h, int) or h < 1:
            raise ValueError(f"horizons: each must be a positive int (control steps ahead), got {h!r}")
        if steps is not None and h >= steps:
            raise ValueError(
                f"horizons: {h} must be below the sequence's length T={steps} (1 <= h <= {steps - 1})"
            )
    return horizons


def prediction_error(
    step: Callable, latents, actions, links, horizons: Sequence[int] = (1, 5, 20)
) -> PredictionError:
    """RMS error of h-step predictions under the recorded actions, and of the constant baseline.

    Jittable (`horizons` static).

    Args:
      step: ``step(z, a) -> z'`` for one (r,) latent and (m,) action (a model's `step`).
      latents: (T, r) encoded latents in time order.
      actions: (T, m) actions[t] led from latents[t - 1] to latents[t].
      links: (T,) bool, links[t] True where latents[t] follows latents[t - 1] under actions[t].
      horizons: the h to measure, each in [1, T - 1].

    Returns:
      `PredictionError`.
    """
    latents, actions, links = jnp.asarray(latents), jnp.asarray(actions), jnp.asarray(links, bool)
    check_sequence(latents, actions, links)
    horizons = check_horizons(horizons, latents.shape[0])
    model, constant, starts = [], [], []
    for h in horizons:
        predicted, usable = predict(step, latents, actions, links, h)
        target = latents[h:]
        n = jnp.sum(usable)
        model.append(_rms(predicted, target, usable, n))
        constant.append(_rms(latents[:-h], target, usable, n))
        starts.append(n.astype(jnp.int32))
    return PredictionError(
        horizons=horizons, model=jnp.stack(model), constant=jnp.stack(constant), starts=jnp.stack(starts)
    )


def predict(step: Callable, latents, actions, links, h: int):
    """The h-step predictions from every start, and which starts are usable. Jittable (h static).

    Args: as `prediction_error`'s, with one horizon h in [1, T - 1].

    Returns:
      predicted: (T - h, r) ẑ_{t+h} from z_t, t = 0 ... T - h - 1, under the recorded actions
        (compare with latents[h:]).
      usable: (T - h,) bool, True where links[t + 1 ... t + h] all hold: the h steps lie in one
        rollout (the other rows are predictions across rollouts, meaningless).
    """
    count = latents.shape[0] - h
    window = jnp.stack([links[j : j + count] for j in range(1, h + 1)])
    usable = jnp.all(window, axis=0)
    ahead = jnp.stack([actions[j : j + count] for j in range(1, h + 1)])  # (h, count, m)
    batched = jax.vmap(step)
    predicted, _ = jax.lax.scan(lambda z, a: (batched(z, a), None), latents[:count], ahead)
    return predicted, usable


def _rms(guess, target, usable, count):
    """() RMS per latent of guess - target (count, r) over the `usable` rows (NaN if none)."""
    squared = jnp.sum(jnp.where(usable[:, None], (guess - target) ** 2, 0))
    return jnp.where(count > 0, jnp.sqrt(squared / jnp.maximum(count * target.shape[1], 1)), jnp.nan)
