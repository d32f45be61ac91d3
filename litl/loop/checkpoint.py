"""Orbax checkpoints of a run at episode boundaries: all seeds' `LoopState` plus the run's counters.

A checkpoint holds the batched `LoopState` (parameters, optimizer states, replay buffer, PRNG key,
latest learning statistics) and `counters`: numpy arrays of the run's shell, e.g. the number of
episodes finished and of metrics lines written by then. A process killed mid-save leaves a
temporary directory that orbax ignores; a complete checkpoint damaged later (a truncated file,
lost metadata) is skipped on restore in favour of the previous one (two are kept).

A checkpoint written by an earlier litl whose replay buffer lacks leaves added since
(`litl.models.replay_buffer.ADDED_LATER`) restores upgraded (`replay_buffer.upgrade`): without
``actions``, with zero actions and no transitions (its snapshots still train the observer, and a
latent dynamics model learns only from later rollouts); without ``point_velocities``, with the
robot's velocities in their place.
"""

from __future__ import annotations

import pathlib

import jax
import jax.numpy as jnp
import numpy as np
import orbax.checkpoint as ocp

from litl.errors import UserError
from litl.loop.progress import say
from litl.models.replay_buffer import ReplayBuffer, saved_layout, upgrade


class CheckpointError(UserError, RuntimeError):
    """No checkpoint of a run directory restores; the message says what to do."""


class Checkpoints:
    """Save and restore `{"state": LoopState (batched), "counters": {name: array}}` by episode."""

    def __init__(self, directory: pathlib.Path, keep: int = 2):
        if keep < 2:
            raise ValueError(
                f"keep at least two checkpoints (a damaged newest one falls back to "
                f"the previous), got {keep!r}"
            )
        options = ocp.CheckpointManagerOptions(max_to_keep=keep, enable_async_checkpointing=False)
        self.directory = pathlib.Path(directory).absolute()
        self.manager = ocp.CheckpointManager(self.directory, options=options)

    def latest(self) -> int | None:
        """Episodes finished at the latest complete checkpoint, or None."""
        return self.manager.latest_step()

    def save(self, episodes_done: int, state, counters: dict) -> None:
        item = {"state": state, "counters": {k: np.asarray(v) for k, v in counters.items()}}
        self.manager.save(episodes_done, args=ocp.args.StandardSave(item), force=True)
        self.manager.wait_until_finished()

    def restore(self, template_state, template_counters: dict):
        """(state, counters) of the newest checkpoint that restores cleanly, the state placed as
        `template_state` is (committed to its devices or not; `_placed_like`).

        A newer checkpoint that fails to restore (a truncated file, missing metadata) is moved
        aside to `<checkpoints>/damaged-<episodes>` (`-2`, `-3`, ... if that name is taken; kept,
        not deleted) and named on stderr; the run continues from the next older one.

        Raises:
          CheckpointError: no checkpoint restores; the message says what to do.
        """
        template = _template(template_state, template_counters)
        failures = []
        for step in sorted(self.manager.all_steps(), reverse=True):
            try:
                item = self._restore(step, template)
            except Exception as error:  # orbax/tensorstore raise many kinds for damaged files
                reason = (
                    str(error).strip().splitlines()[0][:200] if str(error).strip() else type(error).__name__
                )
                failures.append((step, reason))
                continue
            for bad, reason in failures:
                aside = self._free_name(f"damaged-{bad}")
                (self.directory / str(bad)).rename(aside)
                say(
                    f"litl: checkpoint {bad} (episodes done) could not be restored ({reason}); "
                    f"moved it to {aside} and resumed from checkpoint {step}"
                )
            if failures:
                self.manager.reload()
            return jax.tree.map(_placed_like, template_state, item["state"]), item["counters"]
        listing = "; ".join(f"{step}: {reason}" for step, reason in failures)
        raise CheckpointError(
            f"no checkpoint in {self.directory} can be restored ({listing}). Start a new run "
            f"directory, or move {self.directory} away to start this run over."
        )

    def read_latest(self, template_state, template_counters: dict):
        """(state, counters) of the newest checkpoint, read only: unlike `restore`, nothing is
        moved aside and a failure raises (for readers of a finished run, `litl.latent.control`)."""
        step = self.latest()
        if step is None:
            raise CheckpointError(f"{self.directory} holds no checkpoint")
        template = _template(template_state, template_counters)
        item = self._restore(step, template)
        return jax.tree.map(_placed_like, template_state, item["state"]), item["counters"]

    def _restore(self, step: int, template: dict) -> dict:
        """Checkpoint `step` read into host arrays shaped as `template`'s leaves (np.empty: no
        memory touched), an older litl's buffer upgraded to the template's."""
        state = template["state"]
        older = self._older_buffer(step, state)
        if older is not None:
            template = {**template, "state": state.replace(buffer=older)}
        abstract = jax.tree.map(lambda leaf: np.empty(np.shape(leaf), leaf.dtype), template)
        item = self.manager.restore(step, args=ocp.args.StandardRestore(abstract))
        if older is not None:
            restored = item["state"]
            item = {**item, "state": restored.replace(buffer=upgrade(restored.buffer, state.buffer))}
        return item

    def _older_buffer(self, step: int, template_state) -> dict | None:
        """A template for checkpoint `step`'s replay buffer where an earlier litl wrote it with
        fewer leaves (`replay_buffer.saved_layout`; `template_state` has a current `ReplayBuffer`
        as its ``buffer``), else None. A checkpoint whose metadata cannot be read is left to the
        plain restore, which reports it."""
        if not isinstance(getattr(template_state, "buffer", None), ReplayBuffer):
            return None
        try:
            buffer = self.manager.item_metadata(step).tree["state"]["buffer"]
        except Exception:  # damaged metadata: the restore below fails and says why
            return None
        if not isinstance(buffer, dict):
            return None
        return saved_layout(buffer.keys(), template_state.buffer)

    def close(self):
        self.manager.close()

    def _free_name(self, name: str) -> pathlib.Path:
        """`directory / name`, or `name-2`, `name-3`, ... whichever does not exist yet."""
        candidate, suffix = self.directory / name, 2
        while candidate.exists():
            candidate, suffix = self.directory / f"{name}-{suffix}", suffix + 1
        return candidate


def _template(template_state, template_counters: dict) -> dict:
    """The item a checkpoint holds, shaped as the state and counters it restores into."""
    return {"state": template_state, "counters": {k: np.asarray(v) for k, v in template_counters.items()}}


def _placed_like(template, restored: np.ndarray):
    """`restored` where the template's leaf is: on its sharding if that leaf is committed to
    devices, uncommitted if it is not (a fresh state's arrays), a host array if it is one. orbax
    alone gives arrays committed to a device, and `jax.jit` compiles a second program for those:
    one more compilation per resume, and on a compiler that rounds the two programs apart (XLA's
    older CPU emitters do), a resumed run that is not bit for bit the uninterrupted one."""
    if not isinstance(template, jax.Array):
        return restored
    if template.committed:
        return jax.device_put(restored, template.sharding)
    return jnp.asarray(restored)
