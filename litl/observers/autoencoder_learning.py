"""The autoencoder observer's learning phase (Algorithm 1): train the copy Θ′ on the replay buffer
(the loop's `litl.loop.retraining` then moves Θ toward it).

Written for one seed and batched with `jax.vmap`. The buffer has a static capacity and a dynamic
`count`, so the train/validation split, the minibatches and early stopping are all masks:

* Split: the valid slots are put in a uniformly random order; the first ceil(count/2) form the
  training half, the other floor(count/2) the validation half (drawn once per phase). Every random
  draw is tied to a slot index, so the result depends on the valid entries and their slots, not
  on the buffer's capacity or its invalid slots (up to float rounding of the scale's sum).
* Epochs: each epoch shuffles the training half again and walks it in minibatches of b drawn
  without replacement; only the minibatches that hold real entries run, so an epoch's cost
  follows the number of snapshots in the buffer, not its capacity. A last partial minibatch is
  used, its loss averaged over its real entries only (a mask, not drop-partial: early in a run
  the buffer may hold fewer than b entries).
  Minibatch slots past the end of the training half are padding: their inputs are zeroed, their
  losses masked out, and a minibatch with no real entry does not step the optimizer.
* Early stopping (`patience` in epochs, or `patience_steps` in SGD steps, and an optional
  `max_steps` budget): after every epoch the validation loss is the "total" VAE loss (reconstruction +
  β·KL per value, the objective being trained) with the encoder means (no sampling noise). The
  parameters of the epoch with the lowest validation loss so far are kept; training stops when
  `patience` epochs in a row bring no strictly lower loss, or after `max_epochs`. The initial Θ′ is
  not a candidate: the phase returns the best of epochs 1..N, as in the paper.
* The loop is a `lax.while_loop`; under `vmap` a seed that has stopped keeps its carry unchanged
  while others go on, so batched seeds equal separate runs.
* Fewer than two valid entries leave nothing to validate on: the phase then returns the
  parameters unchanged with `epochs_used == 0`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, Self

import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from litl.config import LearningConfig
from litl.models.replay_buffer import ReplayBuffer
from litl.models.vae import (
    AutoencoderParams,
    ConvAutoencoder,
    active_units,
    explained_variance,
    fit_scale,
    loss_terms,
)


@struct.dataclass
class Split:
    """Random even split of the valid buffer slots; padded to static sizes.

    With C the capacity, T = ceil(C/2) and V = floor(C/2) bound the two halves for any count.

    Attributes:
      train: (T,) int32 buffer slots of the training half (first `train_mask.sum()` are real).
      train_mask: (T,) bool, True for real training slots.
      validation: (V,) int32 buffer slots of the validation half.
      validation_mask: (V,) bool, True for real validation slots.
    """

    train: jnp.ndarray
    train_mask: jnp.ndarray
    validation: jnp.ndarray
    validation_mask: jnp.ndarray


@struct.dataclass
class LearningStats:
    """Losses at the returned (best) parameters and how the phase went; all () arrays.

    Losses over an empty half are NaN.

    Attributes:
      recon_loss_train: mean per-value reconstruction error over the training half (encoder
        means, no sampling noise).
      recon_loss_val: the same over the validation half.
      recon_explained: 1 - recon_loss_val / (mean squared validation input): the fraction of the
        held-out fields' energy the reconstructions explain (0: no better than an empty field).
      active_units: () int32 latent units whose encoder mean varies over the validation half
        (variance > 0.01, Burda et al. 2016).
      velocity_r2: (d,) how well the codes tell the robot's velocity: R² over the validation half
        of a linear (least-squares) fit on the training half from [code, 1] to each component
        of the robot's velocity at the snapshot (the particles' mean velocity, `ReplayBuffer`).
      kl: mean KL divergence per snapshot over the validation half.
      val_loss: the early-stopping criterion, recon_loss_val + beta * kl / values per snapshot.
      epochs_used: () int32 epochs run before stopping.
      best_epoch: () int32 epoch (1-based) whose parameters were kept; 0 if no epoch ran or none
        reached a finite validation loss (the parameters are then returned untrained).
      val_recon_history: (max_epochs,) validation reconstruction loss per epoch (NaN: not run).
      val_distance_history: (max_epochs,) the validation half's mean reconstruction error per
        grid node, |D(E(v)) - v| in the field's units, per epoch (the paper's Fig. 5: "average
        pixel distance"; NaN: not run).
      steps_per_epoch: () int32 SGD steps (minibatches) per epoch.
      update_accepted: () bool, whether the observer took this phase's soft update (False: the
        loop's check `loop.safeguards.update_tolerance` kept the old observer; True where unchecked).
    """

    recon_loss_train: jnp.ndarray
    recon_loss_val: jnp.ndarray
    recon_explained: jnp.ndarray
    active_units: jnp.ndarray
    velocity_r2: jnp.ndarray
    kl: jnp.ndarray
    val_loss: jnp.ndarray
    epochs_used: jnp.ndarray
    best_epoch: jnp.ndarray
    val_recon_history: jnp.ndarray
    val_distance_history: jnp.ndarray
    steps_per_epoch: jnp.ndarray
    update_accepted: jnp.ndarray

    if TYPE_CHECKING:  # flax.struct adds `replace` at run time; declared for the type checker

        def replace(self, **changes: Any) -> Self: ...

    # A mapping of named values, as the loop takes an observer's statistics (`dict(stats)`).
    def keys(self) -> tuple[str, ...]:
        return tuple(field.name for field in dataclasses.fields(self))

    def __getitem__(self, name: str) -> jnp.ndarray:
        return getattr(self, name)


@struct.dataclass
class _LearningState:
    """Carry of the epoch loop.

    Attributes:
      epoch: () int32 epochs completed.
      network: flax parameters being trained.
      opt_state: Adam state of `network`.
      best_network: parameters of the best validation epoch so far.
      best_loss: () lowest validation loss so far (inf before the first epoch).
      best_epoch: () int32 epoch that reached it.
      stale_epochs: () int32 epochs since the last improvement.
      val_recon_history: (max_epochs,) validation reconstruction loss per epoch (NaN: not run).
      val_distance_history: (max_epochs,) validation mean error per node per epoch (NaN: not run).
    """

    epoch: jnp.ndarray
    network: Mapping[str, Any]
    opt_state: optax.OptState
    best_network: Mapping[str, Any]
    best_loss: jnp.ndarray
    best_epoch: jnp.ndarray
    stale_epochs: jnp.ndarray
    val_recon_history: jnp.ndarray
    val_distance_history: jnp.ndarray


def _broadcast_mask(mask, like):
    """(B,) mask -> broadcastable against (B, ...) `like`."""
    return mask.reshape(mask.shape + (1,) * (like.ndim - 1))


def fit_scale_masked(params: AutoencoderParams, fields, mask, floor=1e-6) -> AutoencoderParams:
    """`vae.fit_scale` over the snapshots where `mask` is True only.

    Args:
      fields: (B, *grid_shape, d) velocity fields; entries where mask is False may hold anything.
      mask: (B,) bool, which fields to use.
    """
    # Select before squaring: stale slots may hold huge values whose square is inf, and inf * 0
    # would poison the sum. Zeroed entries count as empty nodes, which the fit leaves out.
    fields = jnp.where(_broadcast_mask(mask, fields), fields, 0)
    return fit_scale(params, fields, floor)


def fit_readout(gram, cross, ridge=1e-6):
    """Least-squares b ((r + 1, d)) from the moments A^T A / n and A^T y / n (a tiny ridge keeps
    it defined when codes are collinear or constant)."""
    regularizer = ridge * (jnp.trace(gram) / gram.shape[0] + 1.0)
    return jnp.linalg.solve(gram + regularizer * jnp.eye(gram.shape[0], dtype=gram.dtype), cross)


def readout_r2(means):
    """(d,) R² = 1 - MSE / variance of the target, from `masked_means` with a readout."""
    variance = means["target_square"] - means["target"] ** 2
    return 1.0 - means["residual"] / variance


def _slot_uniform(key, slots):
    """(n,) slot indices -> (n,) uniforms in [0, 1), each drawn from the key and its slot alone.

    A slot's draw does not depend on the capacity or on the other slots, so the split and the
    minibatches of the valid entries are the same whatever the buffer's capacity.
    """
    return jax.vmap(lambda slot: jax.random.uniform(jax.random.fold_in(key, slot)))(slots)


def random_split(count, capacity: int, key) -> Split:
    """Split the valid slots [0, count) randomly and evenly into training and validation halves.

    Args:
      count: () int number of valid slots (dynamic).
      capacity: C, the number of slots (static).
      key: PRNG key.
    """
    slots = jnp.arange(capacity)
    # Random keys for valid slots, and a larger one for the rest, so sorting puts the valid slots
    # first in a uniformly random order.
    order = jnp.argsort(jnp.where(slots < count, _slot_uniform(key, slots), 2.0))
    order = order.astype(jnp.int32)
    n_validation = count // 2
    n_train = count - n_validation
    train_size, validation_size = capacity - capacity // 2, capacity // 2
    # n_train + validation_size <= capacity, so the slice never runs past the end.
    validation = jax.lax.dynamic_slice(order, (n_train,), (validation_size,))
    return Split(
        train=order[:train_size],
        train_mask=jnp.arange(train_size) < n_train,
        validation=validation,
        validation_mask=jnp.arange(validation_size) < n_validation,
    )


def _chunks(slots, mask, size):
    """(n,) slots and mask -> (ceil(n/size), size) each, padded with slot 0 and False."""
    n_chunks = -(-slots.shape[0] // size)
    pad = n_chunks * size - slots.shape[0]
    slots = jnp.pad(slots, (0, pad)).reshape(n_chunks, size)
    mask = jnp.pad(mask, (0, pad)).reshape(n_chunks, size)
    return slots, mask


def make_learning_phase(
    model: ConvAutoencoder,
    config: LearningConfig,
    on_epoch: Callable | None = None,
    *,
    beta: float = 1.0,
    momentum_weight: float = 0.3,
) -> LearningPhase:
    """Build `learn(params, buffer, key) -> (best_params, LearningStats)` (a `LearningPhase`).

    `learn` refits the input scale on the valid buffer entries, trains the network of `params` (Θ′)
    with a fresh Adam state on a random training half, and returns the parameters of the epoch with
    the lowest validation loss (see the module docstring for the exact rules). It is pure, jittable
    and vmappable over seeds (params, buffer and key batched together).

    Args:
      model: the observer architecture.
      config: the phase's hyperparameters.
      beta, momentum_weight: the loss's weights (`vae.loss_terms`; the observer's settings,
        `observer.vae.beta` and `.momentum_weight`, whose defaults these are).
      on_epoch: if given, `on_epoch(epoch, validation_loss)` (numpy; one entry per seed under
        vmap) is called after every epoch, from inside the compiled phase (a host callback; a
        program holding one cannot be reused from JAX's persistent compilation cache in another
        process, so a run without a progress display leaves it out). The whole history is also
        returned (`LearningStats.val_recon_history`).
    """
    if not isinstance(config, LearningConfig):
        raise ValueError(f"config must be a LearningConfig, got {type(config).__name__}")
    return LearningPhase(model, config, on_epoch, beta, momentum_weight)


def _gather(buffer: ReplayBuffer, slots, mask, dtype):
    """(b, *grid, d) the buffer's fields at `slots`; padding slots (mask False) point at arbitrary
    data and are zeroed, so nothing non-finite enters the network."""
    fields = buffer.fields[slots].astype(dtype)
    return jnp.where(_broadcast_mask(mask, fields), fields, 0)


@dataclasses.dataclass(frozen=True)
class LearningPhase:
    """One learning phase of one seed, in named pieces; call it as
    ``phase(params, buffer, key) -> (best_params, LearningStats)`` (see `make_learning_phase`).

    Attributes:
      model: the observer architecture.
      config: the phase's hyperparameters.
      on_epoch: called after every epoch with (epoch, validation loss), or None.
      beta, momentum_weight: the loss's weights (the observer's settings, `vae.loss_terms`).
    """

    model: ConvAutoencoder
    config: LearningConfig
    on_epoch: Callable | None = None
    beta: float = 1.0
    momentum_weight: float = 0.3

    def _report_epoch(self, epoch, validation):
        self.on_epoch(np.asarray(epoch), np.asarray(validation))

    @property
    def optimizer(self) -> optax.GradientTransformation:
        return optax.adam(self.config.learning_rate)

    def losses(self, params, fields, key) -> dict:
        """(B, *grid, d) fields -> dict of (B,) losses, one per snapshot (`vae.loss_terms` each);
        key None: the encoder means, no sampling noise."""
        weights = dict(beta=self.beta, momentum_weight=self.momentum_weight)
        if key is None:
            return jax.vmap(lambda f: loss_terms(self.model, params, f[None], None, **weights))(fields)
        keys = jax.random.split(key, fields.shape[0])
        return jax.vmap(lambda f, k: loss_terms(self.model, params, f[None], k, **weights))(fields, keys)

    def masked_means(self, params, buffer, slots, mask, readout=None) -> dict:
        """Means over the masked slots (NaN if none), with the encoder means (no sampling noise).

        recon, kl, total and signal (mean squared input) per snapshot; code and code_square, the
        mean and mean square of the (r,) codes; gram and cross, the moments A^T A / n and
        A^T y / n of a linear readout y ~ A b from A = [code, 1] to y = the robot's velocity
        stored with the snapshot (`ReplayBuffer.velocities`); with a readout b ((r + 1, d)): residual, the
        mean squared error of A b per velocity component, and target, target_square, the mean and
        mean square of y.
        """
        dim, latent_dim, batch_size = self.model.dim, self.model.latent_dim, self.config.batch_size
        dtype = params.scale.dtype

        def add_chunk(sums, chunk_slots, chunk_mask):
            fields = _gather(buffer, chunk_slots, chunk_mask, dtype)
            out = self.losses(params, fields, None)
            code = out["code"][:, 0]
            features = jnp.concatenate([code, jnp.ones_like(code[:, :1])], axis=1)
            target = jnp.where(chunk_mask[:, None], buffer.velocities[chunk_slots], 0).astype(dtype)
            out = {
                **out,
                "code": code,
                "code_square": code**2,
                "gram": features[:, :, None] * features[:, None, :],
                "cross": features[:, :, None] * target[:, None, :],
            }
            if readout is not None:
                out.update(
                    residual=(features @ readout - target) ** 2, target=target, target_square=target**2
                )
            return {
                k: sums[k]
                + jnp.sum(jnp.where(_broadcast_mask(chunk_mask, out[k]), out[k], 0), axis=0).astype(
                    sums[k].dtype
                )
                for k in sums
            }

        zero = jnp.zeros((), dtype)
        codes = jnp.zeros((latent_dim,), dtype)
        width = latent_dim + 1
        sums = {
            "recon": zero,
            "distance": zero,
            "kl": zero,
            "total": zero,
            "signal": zero,
            "code": codes,
            "code_square": codes,
            "gram": jnp.zeros((width, width), dtype),
            "cross": jnp.zeros((width, dim), dtype),
        }
        if readout is not None:
            sums.update({k: jnp.zeros((dim,), dtype) for k in ("residual", "target", "target_square")})
        chunk_slots, chunk_mask = _chunks(slots, mask, batch_size)
        n = jnp.sum(mask)
        # Real slots come first: only the chunks holding them are evaluated, so the cost follows
        # the buffer's content, not its capacity.
        sums = jax.lax.fori_loop(
            0,
            (n + batch_size - 1) // batch_size,
            lambda i, sums: add_chunk(sums, chunk_slots[i], chunk_mask[i]),
            sums,
        )
        return {k: jnp.where(n > 0, v / jnp.maximum(n, 1), jnp.nan) for k, v in sums.items()}

    def train_minibatch(self, params, buffer, carry, slots, mask, index):
        """One Adam step on the minibatch at `slots` (carry: network, opt_state, batch_key)."""
        network, opt_state, batch_key = carry
        fields = _gather(buffer, slots, mask, params.scale.dtype)

        def objective(network):
            out = self.losses(params.replace(network=network), fields, jax.random.fold_in(batch_key, index))
            return jnp.sum(jnp.where(mask, out["total"], 0)) / jnp.maximum(jnp.sum(mask), 1)

        grads = jax.grad(objective)(network)
        updates, new_opt_state = self.optimizer.update(grads, opt_state, network)
        new_network = optax.apply_updates(network, updates)
        # An all-padding minibatch must not step Adam: its moments and step count would move.
        real = jnp.any(mask)
        network, opt_state = jax.tree.map(
            lambda new, old: jnp.where(real, new, old),
            (new_network, new_opt_state),
            (network, opt_state),
        )
        return network, opt_state, batch_key

    def run_epoch(
        self, params, buffer, split: Split, steps_per_epoch, epochs_key, state: _LearningState
    ) -> _LearningState:
        """One epoch: reshuffle the training half, its minibatches, then the validation loss."""
        shuffle_key, batch_key = jax.random.split(jax.random.fold_in(epochs_key, state.epoch))
        noise = _slot_uniform(shuffle_key, split.train)
        order = jnp.argsort(jnp.where(split.train_mask, noise, 2.0))
        slots, mask = _chunks(split.train[order], split.train_mask, self.config.batch_size)
        # The real training slots come first: only their minibatches run (a dynamic count, so
        # an epoch costs what the buffer holds, not its capacity).
        network, opt_state, _ = jax.lax.fori_loop(
            0,
            steps_per_epoch,
            lambda i, carry: self.train_minibatch(params, buffer, carry, slots[i], mask[i], i),
            (state.network, state.opt_state, batch_key),
        )
        means = self.masked_means(
            params.replace(network=network), buffer, split.validation, split.validation_mask
        )
        validation = means["total"].astype(state.best_loss.dtype)
        epoch = state.epoch + 1
        if self.on_epoch is not None:
            jax.debug.callback(self._report_epoch, epoch, validation)
        improved = validation < state.best_loss
        return _LearningState(
            epoch=epoch,
            network=network,
            opt_state=opt_state,
            best_network=jax.tree.map(
                lambda new, old: jnp.where(improved, new, old), network, state.best_network
            ),
            best_loss=jnp.where(improved, validation, state.best_loss),
            best_epoch=jnp.where(improved, epoch, state.best_epoch),
            stale_epochs=jnp.where(improved, 0, state.stale_epochs + 1),
            val_recon_history=state.val_recon_history.at[state.epoch].set(
                means["recon"].astype(state.val_recon_history.dtype)
            ),
            val_distance_history=state.val_distance_history.at[state.epoch].set(
                means["distance"].astype(state.val_distance_history.dtype)
            ),
        )

    def keep_going(self, enough, steps_per_epoch, state: _LearningState):
        """Whether another epoch runs: the epoch cap, the patience (in epochs or SGD steps) and
        the SGD-step budget."""
        config = self.config
        going = enough & (state.epoch < config.max_epochs)
        if config.patience_steps is None:
            going &= state.stale_epochs < config.patience
        else:
            going &= state.stale_epochs * steps_per_epoch < config.patience_steps
        if config.max_steps is not None:
            going &= state.epoch * steps_per_epoch < config.max_steps
        return going

    def statistics(self, best, buffer, split: Split, final: _LearningState, steps_per_epoch) -> LearningStats:
        """`LearningStats` of the best parameters: losses on both halves, recon_explained and
        active units on the held-out half, and the R² of a linear readout fitted on the
        training half."""
        train = self.masked_means(best, buffer, split.train, split.train_mask)
        readout = fit_readout(train["gram"], train["cross"])
        validation = self.masked_means(best, buffer, split.validation, split.validation_mask, readout)
        return LearningStats(
            recon_loss_train=train["recon"],
            recon_loss_val=validation["recon"],
            recon_explained=explained_variance(validation["recon"], validation["signal"]),
            active_units=active_units(validation["code"], validation["code_square"]),
            velocity_r2=readout_r2(validation),
            kl=validation["kl"],
            val_loss=validation["total"],
            epochs_used=final.epoch,
            best_epoch=final.best_epoch,
            val_recon_history=final.val_recon_history,
            val_distance_history=final.val_distance_history,
            steps_per_epoch=steps_per_epoch,
            update_accepted=jnp.ones((), bool),
        )

    def __call__(self, params: AutoencoderParams, buffer: ReplayBuffer, key):
        """One learning phase for one seed.

        Args:
          params: Θ′, the observer copy to train (its scale is refitted).
          buffer: replay buffer of (capacity, *model.grid_shape, d) snapshots.
          key: PRNG key for the split, shuffling and VAE sampling noise.

        Returns:
          The best parameters and `LearningStats` computed at them.
        """
        expected = tuple(self.model.grid_shape) + (self.model.dim,)
        if tuple(buffer.fields.shape[1:]) != expected:
            raise ValueError(
                f"buffer snapshots have shape {tuple(buffer.fields.shape[1:])}, but the model "
                f"expects {expected}"
            )
        capacity, batch_size = buffer.capacity, self.config.batch_size
        split_key, epochs_key = jax.random.split(key)
        split = random_split(buffer.count, capacity, split_key)
        # Nothing to validate on with fewer than two entries: keep Θ′ as it is.
        enough = buffer.count >= 2
        steps_per_epoch = (jnp.sum(split.train_mask) + batch_size - 1) // batch_size
        fitted = fit_scale_masked(params, buffer.fields, jnp.arange(capacity) < buffer.count)
        params = params.replace(scale=jnp.where(enough, fitted.scale, params.scale))
        zero = jnp.zeros((), jnp.int32)
        initial = _LearningState(
            epoch=zero,
            network=params.network,
            opt_state=self.optimizer.init(params.network),
            best_network=params.network,
            best_loss=jnp.asarray(jnp.inf, params.scale.dtype),
            best_epoch=zero,
            stale_epochs=zero,
            val_recon_history=jnp.full((self.config.max_epochs,), jnp.nan, params.scale.dtype),
            val_distance_history=jnp.full((self.config.max_epochs,), jnp.nan, params.scale.dtype),
        )
        final = jax.lax.while_loop(
            lambda state: self.keep_going(enough, steps_per_epoch, state),
            lambda state: self.run_epoch(params, buffer, split, steps_per_epoch, epochs_key, state),
            initial,
        )
        best = params.replace(network=final.best_network)
        return best, self.statistics(best, buffer, split, final, steps_per_epoch)
