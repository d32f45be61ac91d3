"""Latent dynamics models z' = f(z, a): what the observer's latent does under an action.

Learned from the replay buffer's transitions (z_t, a_t, z_{t+1}): consecutive snapshots of one
rollout, encoded by the observer, and the action recorded between them
(`litl.models.replay_buffer.chronological`). The models see only vectors, so any latent size r,
any number of actuators m, 2D or 3D:

* `fit_linear`: z' = A z + B a + c by ridge least squares in closed form (`LinearDynamics`; the
  model LQR plans with, `litl.latent.lqr`);
* `fit_mlp`: z' = z + g(z, a), a small MLP residual trained with optax (Adam, full batch) on a
  random train/validation split of the transitions with early stopping (`MLPDynamics`).

Both models are pytrees with a pure ``step(z, a) -> z'`` for one (r,) latent and (m,) action
(vmap it for batches); `litl.latent.prediction` rolls them forward over several steps.
Data arrive padded to static shapes with a mask, as the buffer holds them, so fitting is jittable
and vmappable over seeds; the checks of `Transitions.check` (empty data, non-finite values) run
only where the data are concrete (outside jit).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Self

import jax
import jax.numpy as jnp
import optax
from flax import struct

from litl.settings.dynamics import LinearSettings, MLPSettings


@struct.dataclass
class Transitions:
    """Transitions (z_t, a_t, z_{t+1}), padded to a static count N with a mask.

    Attributes:
      latents: (N, r) z_t.
      actions: (N, m) a_t, the action applied from z_t to z_{t+1}.
      next_latents: (N, r) z_{t+1}.
      mask: (N,) bool, True where the row is a real transition (padding rows may hold anything).
    """

    latents: jnp.ndarray
    actions: jnp.ndarray
    next_latents: jnp.ndarray
    mask: jnp.ndarray

    if TYPE_CHECKING:  # flax.struct adds `replace` at run time; declared for the type checker

        def replace(self, **changes: Any) -> Self: ...

    @classmethod
    def from_sequence(cls, latents, actions, links) -> Transitions:
        """The transitions of a chronological sequence, as the buffer's `chronological` orders it.

        Args:
          latents: (T, r) z in time order.
          actions: (T, m) actions[t] is the action that led from latents[t - 1] to latents[t].
          links: (T,) bool, links[t] True where latents[t] follows latents[t - 1] under actions[t].

        Returns:
          T - 1 rows: (latents[t - 1], actions[t], latents[t]) masked by links[t], t = 1 ... T - 1.
        """
        latents, actions, links = jnp.asarray(latents), jnp.asarray(actions), jnp.asarray(links, bool)
        check_sequence(latents, actions, links)
        return cls(latents[:-1], actions[1:], latents[1:], links[1:])

    @property
    def latent_size(self) -> int:
        return self.latents.shape[-1]

    @property
    def action_size(self) -> int:
        return self.actions.shape[-1]

    def check(self, minimum: int = 1) -> None:
        """Raise ValueError for mismatched shapes and, where the data are concrete (not traced),
        for fewer than `minimum` transitions or non-finite values in a real one."""
        latents, actions, following, mask = self.latents, self.actions, self.next_latents, self.mask
        if latents.ndim != 2 or following.shape != latents.shape:
            raise ValueError(
                f"latents and next_latents must both have shape (N, r), got {latents.shape} and "
                f"{following.shape}"
            )
        if actions.ndim != 2 or actions.shape[0] != latents.shape[0]:
            raise ValueError(f"actions must have shape (N={latents.shape[0]}, m), got {actions.shape}")
        if mask.shape != (latents.shape[0],):
            raise ValueError(f"mask must have shape (N={latents.shape[0]},), got {mask.shape}")
        if any(isinstance(x, jax.core.Tracer) for x in (latents, actions, following, mask)):
            return
        count = int(jnp.sum(mask))
        if count < minimum:
            raise ValueError(
                f"the dataset holds {count} transitions (mask.sum()); at least {minimum} are needed "
                f"(record actions in the replay buffer, and fill it with whole rollouts)"
            )
        for name, values in (("latents", latents), ("actions", actions), ("next_latents", following)):
            bad = mask & ~jnp.all(jnp.isfinite(values), axis=-1)
            if bool(jnp.any(bad)):
                raise ValueError(
                    f"{name} holds non-finite values in {int(jnp.sum(bad))} transition(s) "
                    f"(first at row {int(jnp.argmax(bad))}); all must be finite"
                )


def check_sequence(latents, actions, links) -> None:
    """Raise ValueError unless latents (T, r), actions (T, m) and links (T,) agree, T >= 2."""
    if latents.ndim != 2 or latents.shape[0] < 2:
        raise ValueError(f"latents must have shape (T, r) with T >= 2, got {latents.shape}")
    steps = latents.shape[0]
    if actions.ndim != 2 or actions.shape[0] != steps:
        raise ValueError(f"actions must have shape (T={steps}, m), got {actions.shape}")
    if links.shape != (steps,):
        raise ValueError(f"links must have shape (T={steps},), got {links.shape}")


# ---------------------------------------------------------------------------------------------
# Linear: z' = A z + B a + c


@struct.dataclass
class LinearDynamics:
    """z' = A z + B a + c.

    Attributes:
      A: (r, r) state matrix.
      B: (r, m) input matrix.
      c: (r,) offset.
    """

    A: jnp.ndarray
    B: jnp.ndarray
    c: jnp.ndarray

    def step(self, latent, action):
        """(r,) z, (m,) a -> (r,) z'."""
        return self.A @ latent + self.B @ action + self.c


def fit_linear(data: Transitions, settings: LinearSettings | None = None) -> LinearDynamics:
    """A, B, c minimizing `LinearSettings.ridge`'s objective over the masked transitions.

    Closed form: the normal equations (XᵀX / n + λ D) Θ = XᵀY / n with X = [z, a, 1] (n rows),
    Y = z', D = diag(1, ..., 1, 0), solved with `jnp.linalg.solve`. Jittable; computed in the
    data's dtype (the normal equations square the condition number: fit in float64 where the
    data are ill-conditioned).
    """
    settings = settings or LinearSettings()
    data.check()
    r, m = data.latent_size, data.action_size
    weight = data.mask.astype(data.latents.dtype)[:, None]
    ones = jnp.ones_like(data.latents[:, :1])
    inputs = jnp.where(weight > 0, jnp.concatenate([data.latents, data.actions, ones], axis=1), 0)
    targets = jnp.where(weight > 0, data.next_latents, 0)
    count = jnp.maximum(jnp.sum(weight), 1)
    penalty = jnp.concatenate([jnp.ones(r + m), jnp.zeros(1)]).astype(inputs.dtype)
    gram = inputs.T @ inputs / count + settings.ridge * jnp.diag(penalty)
    theta = jnp.linalg.solve(gram, inputs.T @ targets / count)  # (r + m + 1, r)
    return LinearDynamics(A=theta[:r].T, B=theta[r : r + m].T, c=theta[r + m])


# ---------------------------------------------------------------------------------------------
# MLP residual: z' = z + g(z, a)


@struct.dataclass
class MLPDynamics:
    """z' = z + g(z, a), g an MLP of standardized inputs whose output is in units of the
    training deltas' spread.

    Attributes:
      layers: ((W, b), ...) each W (n_in, n_out), b (n_out,); n_in of the first is r + m, n_out
        of the last r.
      input_mean: (r + m,) mean of the training [z, a].
      input_scale: (r + m,) their standard deviation (1 where it is 0).
      output_scale: (r,) standard deviation of the training z' - z (1 where it is 0).
    """

    layers: tuple
    input_mean: jnp.ndarray
    input_scale: jnp.ndarray
    output_scale: jnp.ndarray

    if TYPE_CHECKING:  # flax.struct adds `replace` at run time; declared for the type checker

        def replace(self, **changes: Any) -> Self: ...

    def step(self, latent, action):
        """(r,) z, (m,) a -> (r,) z'."""
        hidden = (jnp.concatenate([latent, action]) - self.input_mean) / self.input_scale
        for weight, bias in self.layers[:-1]:
            hidden = jnp.tanh(hidden @ weight + bias)
        weight, bias = self.layers[-1]
        return latent + (hidden @ weight + bias) * self.output_scale


@struct.dataclass
class MLPFit:
    """What `fit_mlp` reports besides the model.

    Attributes:
      train_loss: () the best epoch's mean squared error per latent on the training transitions
        (with `MLPSettings.rollout` K > 1: the mean over k = 1 ... K of the k-step error, from
        the starts of K training transitions in a chain).
      validation_loss: () the same on the validation ones.
      best_epoch: () int32 the epoch whose parameters were kept (0: the initial ones).
      epochs: () int32 epochs run before the early stop (or max_epochs).
      train_count: () int32 training transitions.
      validation_count: () int32 validation transitions.
    """

    train_loss: jnp.ndarray
    validation_loss: jnp.ndarray
    best_epoch: jnp.ndarray
    epochs: jnp.ndarray
    train_count: jnp.ndarray
    validation_count: jnp.ndarray


def random_split(key, mask, validation_fraction: float, block: int = 1):
    """(train (N,) bool, validation (N,) bool): a random split of the True rows of `mask`,
    round(fraction · n) of them (at least 1, at most n - 1) to validation, drawn by blocks of
    `block` consecutive rows (1: row by row), so that multi-step windows lie mostly on one side."""
    count = jnp.sum(mask)
    n_validation = jnp.clip(jnp.round(validation_fraction * count), 1, jnp.maximum(count - 1, 1))
    uniform = jax.random.uniform(key, mask.shape)
    uniform = uniform[(jnp.arange(mask.shape[0]) // block) * block]  # a block shares its draw
    draws = jnp.where(mask, uniform, jnp.inf)
    rank = jnp.argsort(jnp.argsort(draws))  # the real rows get ranks 0 ... count - 1
    validation = mask & (rank < n_validation)
    return mask & ~validation, validation


def _masked_mean(values, mask):
    weight = mask.astype(values.dtype)[:, None]
    return jnp.sum(values * weight, axis=0) / jnp.maximum(jnp.sum(weight), 1)


def _init_layers(key, sizes, dtype):
    keys = jax.random.split(key, len(sizes) - 1)
    init = jax.nn.initializers.lecun_normal()
    layers = [
        (init(k, (n_in, n_out), dtype), jnp.zeros((n_out,), dtype))
        for k, n_in, n_out in zip(keys, sizes[:-1], sizes[1:], strict=True)
    ]
    # A zero last layer: the untrained model is the constant-latent baseline z' = z.
    last_w, last_b = layers[-1]
    layers[-1] = (jnp.zeros_like(last_w), last_b)
    return tuple(layers)


def _mse(model: MLPDynamics, data: Transitions, mask):
    """() mean squared error per latent over the rows of `mask`."""
    predicted = jax.vmap(model.step)(data.latents, data.actions)
    squared = jnp.where(mask[:, None], (predicted - data.next_latents) ** 2, 0)
    return jnp.sum(squared) / jnp.maximum(jnp.sum(mask) * data.latent_size, 1)


def rollout_windows(data: Transitions, mask, steps: int):
    """(N,) bool: the rows that start `steps` transitions in a chain, each a row of `mask` and
    each starting where the one before ended (row i + 1's z is row i's z', as
    `Transitions.from_sequence` lays out one rollout; the values are copies, so the test is
    exact)."""
    n = mask.shape[0]
    follows = jnp.all(data.next_latents[:-1] == data.latents[1:], axis=-1)  # row i+1 after row i
    chained = jnp.concatenate([follows, jnp.zeros(1, bool)])
    usable = mask
    for j in range(1, steps):
        ahead = jnp.concatenate([mask[j:] & chained[j - 1 : n - 1], jnp.zeros(j, bool)])
        usable = usable & ahead
    return usable


def rollout_mse(model: MLPDynamics, data: Transitions, starts, steps: int):
    """() the mean over k = 1 ... `steps` of the k-step prediction's squared error per latent,
    rolled through the model under the recorded actions from the rows `starts`
    (`rollout_windows`)."""
    if steps == 1:
        return _mse(model, data, starts)
    n = starts.shape[0]
    index = jnp.minimum(jnp.arange(n)[:, None] + jnp.arange(steps)[None], n - 1)  # (N, K)

    def rolled(start, rows):
        def forward(z, row):
            z = model.step(z, data.actions[row])
            return z, jnp.mean((z - data.next_latents[row]) ** 2)

        return jnp.mean(jax.lax.scan(forward, start, rows)[1])

    errors = jax.vmap(rolled)(data.latents, index)
    return jnp.sum(jnp.where(starts, errors, 0)) / jnp.maximum(jnp.sum(starts), 1)


def fit_mlp(key, data: Transitions, settings: MLPSettings | None = None) -> tuple[MLPDynamics, MLPFit]:
    """Train the residual MLP on a random train/validation split of the masked transitions.

    Full-batch Adam (AdamW with `weight_decay`), one step per epoch, on the one-step error or,
    with `settings.rollout` K > 1, on the mean of the 1- to K-step errors of the model rolled
    forward under the recorded actions (the split then by blocks of K transitions, and only
    windows of K chained transitions on one side count); the parameters of the epoch
    with the lowest validation loss are kept, and training stops after `patience` epochs without
    one. Normalization (inputs, output scale) comes from the training rows. Jittable and
    vmappable over seeds (key and data batched; the loop runs until every seed has stopped,
    later epochs masked out where a seed stopped earlier).

    Args:
      key: PRNG key (split and initialization).
      data: the transitions (at least 2: one to train on, one to validate with).
      settings: the model and its training (None: `MLPSettings()`).

    Returns:
      (the best model, `MLPFit`).
    """
    settings = settings or MLPSettings()
    data.check(minimum=2)
    dtype = data.latents.dtype
    split_key, init_key = jax.random.split(key)
    steps = settings.rollout
    train, validation = random_split(split_key, data.mask, settings.validation_fraction, steps)
    # K-step windows wholly on one side of the split (K = 1: the rows themselves).
    train_starts = rollout_windows(data, train, steps)
    validation_starts = rollout_windows(data, validation, steps)
    inputs = jnp.concatenate([data.latents, data.actions], axis=1)
    mean = _masked_mean(inputs, train)
    spread = jnp.sqrt(_masked_mean((inputs - mean) ** 2, train))
    deltas = data.next_latents - data.latents
    delta_spread = jnp.sqrt(_masked_mean((deltas - _masked_mean(deltas, train)) ** 2, train))
    sizes = (data.latent_size + data.action_size, *settings.widths, data.latent_size)
    model = MLPDynamics(
        layers=_init_layers(init_key, sizes, dtype),
        input_mean=mean,
        input_scale=jnp.where(spread > 0, spread, 1),
        output_scale=jnp.where(delta_spread > 0, delta_spread, 1),
    )
    optimizer = optax.adamw(settings.learning_rate, weight_decay=settings.weight_decay)
    loss = lambda layers: rollout_mse(model.replace(layers=layers), data, train_starts, steps)
    checked_loss = lambda layers: rollout_mse(model.replace(layers=layers), data, validation_starts, steps)

    def epoch(carry):
        layers, opt_state, best, best_loss, best_epoch, index = carry
        grads = jax.grad(loss)(layers)
        updates, opt_state = optimizer.update(grads, opt_state, layers)
        layers = optax.apply_updates(layers, updates)
        index = index + 1
        checked = checked_loss(layers)
        better = checked < best_loss  # a NaN loss is never better
        best = jax.tree.map(lambda new, old: jnp.where(better, new, old), layers, best)
        return (
            layers,
            opt_state,
            best,
            jnp.where(better, checked, best_loss),
            jnp.where(better, index, best_epoch),
            index,
        )

    def going(carry):
        *_, best_epoch, index = carry
        return (index < settings.max_epochs) & (index - best_epoch < settings.patience)

    start = checked_loss(model.layers)
    initial = (model.layers, optimizer.init(model.layers), model.layers, start, jnp.int32(0), jnp.int32(0))
    _, _, best, best_loss, best_epoch, epochs = jax.lax.while_loop(going, epoch, initial)
    model = model.replace(layers=best)
    return model, MLPFit(
        train_loss=rollout_mse(model, data, train_starts, steps),
        validation_loss=best_loss,
        best_epoch=best_epoch,
        epochs=epochs,
        train_count=jnp.sum(train).astype(jnp.int32),
        validation_count=jnp.sum(validation).astype(jnp.int32),
    )
