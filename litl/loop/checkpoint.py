"""Orbax checkpoints of a run at episode boundaries: all seeds' `LoopState` plus the run's counters.

A checkpoint holds the batched `LoopState` (parameters, optimizer states, replay buffer, PRNG key,
latest learning statistics) and `counters`: numpy arrays of the run's shell, e.g. the number of
episodes finished and of metrics lines written by then. A process killed mid-save leaves a temporary directory that orbax ignores, so the
latest complete checkpoint is always the one restored.
"""

from __future__ import annotations

import pathlib

import jax
import numpy as np
import orbax.checkpoint as ocp


class Checkpoints:
    """Save and restore `{"state": LoopState (batched), "counters": {name: array}}` by episode."""

    def __init__(self, directory: pathlib.Path, keep: int = 2):
        options = ocp.CheckpointManagerOptions(max_to_keep=keep, enable_async_checkpointing=False)
        self.manager = ocp.CheckpointManager(pathlib.Path(directory).absolute(), options=options)

    def latest(self) -> int | None:
        """Episodes finished at the latest complete checkpoint, or None."""
        return self.manager.latest_step()

    def save(self, episodes_done: int, state, counters: dict) -> None:
        item = {"state": state, "counters": {k: np.asarray(v) for k, v in counters.items()}}
        self.manager.save(episodes_done, args=ocp.args.StandardSave(item), force=True)
        self.manager.wait_until_finished()

    def restore(self, template_state, template_counters: dict):
        """(state, counters) of the latest checkpoint, shaped like the templates."""
        template = {"state": template_state,
                    "counters": {k: np.asarray(v) for k, v in template_counters.items()}}
        abstract = jax.tree.map(ocp.utils.to_shape_dtype_struct, template)
        item = self.manager.restore(self.manager.latest_step(),
                                    args=ocp.args.StandardRestore(abstract))
        return item["state"], item["counters"]

    def close(self):
        self.manager.close()
