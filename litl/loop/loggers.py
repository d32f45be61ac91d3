"""Live run logs in the field's viewers: TensorBoard event files (default) or Weights & Biases.

`metrics.jsonl` and `learning.jsonl` stay the source of truth; a logger mirrors them while the run
goes. Per seed (a TensorBoard run `tensorboard/seed<N>` each):

* every optimization iteration (step = global iteration): ``task/loss`` and the task's terms
  ``task/<term>``, ``design/mean|min|max``, ``gradients/controller_norm|design_norm``, and
  ``observer/simultaneous_recon_loss`` in the simultaneous ablation;
* every learning phase (step = the iteration it precedes): ``learning/recon_loss_train|val``,
  ``learning/recon_explained``, ``learning/active_units``, ``learning/kl``,
  ``learning/velocity_r2_<axis>``, ``learning/epochs_used``, ``learning/wall_s``; and the
  validation reconstruction loss after every epoch, ``learning/val_recon_by_sgd_step`` (step =
  SGD steps since the run began: the paper's Fig. 5);
* at every episode boundary of a learned observer: ``observer/snapshots`` (seed 0's newest
  snapshots, top, and their reconstructions, bottom, as speed |v| on one colour scale; the full
  picture with latent codes is `snapshots.png` at the end).

A resumed run rewrites the event files from the records restored with it, so the logs always
match `metrics.jsonl` (images of episodes before the resume are not redrawn).
"""

from __future__ import annotations

import json
import math
import pathlib
import shutil
from typing import TypeGuard

import numpy as np

KINDS = ("tensorboard", "wandb", "none")
ITERATION_TAGS = {
    "task_loss": "task/loss",
    "design_mean": "design/mean",
    "design_min": "design/min",
    "design_max": "design/max",
    "controller_grad_norm": "gradients/controller_norm",
    "design_grad_norm": "gradients/design_norm",
    "simultaneous_recon_loss": "observer/simultaneous_recon_loss",
}
PHASE_KEYS = (
    "recon_loss_train",
    "recon_loss_val",
    "recon_explained",
    "active_units",
    "kl",
    "epochs_used",
    "wall_s",
)
AXES = "xyz"


def _number(value) -> TypeGuard[int | float]:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def iteration_scalars(record: dict) -> dict:
    """{tag: value} of one metrics.jsonl record (finite numbers only)."""
    scalars = {tag: record.get(key) for key, tag in ITERATION_TAGS.items()}
    scalars.update({key: value for key, value in record.items() if key.startswith("task/")})
    return {tag: float(value) for tag, value in scalars.items() if _number(value)}


def phase_scalars(record: dict) -> dict:
    """{tag: value} of one learning.jsonl record's statistics (finite numbers only)."""
    scalars = {f"learning/{key}": record.get(key) for key in PHASE_KEYS}
    # strict=False: "xyz" names up to three axes, a 2D run records two.
    for axis, value in zip(AXES, record.get("velocity_r2") or (), strict=False):
        scalars[f"learning/velocity_r2_{axis}"] = value
    return {tag: float(value) for tag, value in scalars.items() if _number(value)}


class RunLogger:
    """Mirrors a run's records into a viewer; `make_logger` picks the kind. The run shell calls
    `iteration` with each iteration's records (all seeds), `phase` with a learning phase's,
    `image` at episode boundaries, and `close` at the end."""

    def __init__(self, iterations: int):
        self.iterations = iterations  # optimization iterations per episode
        self.sgd_steps: dict[int, int] = {}  # per seed, SGD steps of the phases so far

    def iteration(self, records: list[dict]) -> None:
        for record in records:
            self.scalars(record["seed"], iteration_scalars(record), record["step"])

    def phase(self, records: list[dict]) -> None:
        for record in records:
            seed, phase = record["seed"], record["phase"]
            step = phase * self.iterations
            self.scalars(seed, phase_scalars(record), step)
            done = self.sgd_steps.get(seed, 0)
            per_epoch = record.get("steps_per_epoch") or 0
            for epoch, loss in enumerate(record.get("val_recon_history") or (), start=1):
                if _number(loss):
                    self.scalars(
                        seed, {"learning/val_recon_by_sgd_step": float(loss)}, done + epoch * per_epoch
                    )
            self.sgd_steps[seed] = done + int(record.get("sgd_steps") or 0)

    def restore(self, metrics: list[dict], learning: list[dict]) -> None:
        """Write the records a resumed run starts from."""
        for record in learning:
            self.phase([record])
        self.iteration(metrics)

    def scalars(self, seed: int, values: dict, step: int) -> None:
        raise NotImplementedError

    def image(self, seed: int, tag: str, pixels: np.ndarray, step: int) -> None:
        """Log an (H, W, 3) uint8 image."""
        raise NotImplementedError

    def close(self) -> None:
        pass


class NoLogger(RunLogger):
    def scalars(self, seed, values, step):
        pass

    def image(self, seed, tag, pixels, step):
        pass


def snapshot_strip(
    snapshots: np.ndarray, reconstructions: np.ndarray, zoom: int = 4, percentile: float = 98.0
) -> np.ndarray:
    """(H, W, 3) uint8: the snapshots' speed |v| in the top row, their reconstructions' below,
    x to the right and up upwards, on one colour scale (``magma`` up to the `percentile` of the
    inputs' nonzero speeds); a 3D field shows its mid-depth slice. Cheap enough for every
    episode (no figure layout)."""
    import matplotlib

    def speed(field):
        field = np.asarray(field, np.float64)
        if field.ndim == 4:
            field = field[:, :, field.shape[2] // 2]
        return np.linalg.norm(field, axis=-1).T[::-1]  # rows: y from the top

    top = [speed(f) for f in snapshots]
    bottom = [speed(f) for f in reconstructions]
    values = np.concatenate([t.ravel() for t in top])
    values = values[values > 0]
    limit = float(np.percentile(values, percentile)) if values.size else 1.0
    gap = np.full((top[0].shape[0], 1), np.nan)
    rows = [np.hstack([x for panel in row for x in (panel, gap)][:-1]) for row in (top, bottom)]
    grid = np.vstack([rows[0], np.full((1, rows[0].shape[1]), np.nan), rows[1]])
    colors = matplotlib.colormaps["magma"](np.clip(grid / (limit or 1.0), 0, 1))[..., :3]
    colors[np.isnan(grid)] = 1.0
    pixels = (colors * 255).astype(np.uint8)
    return np.repeat(np.repeat(pixels, zoom, axis=0), zoom, axis=1)


class TensorBoardLogger(RunLogger):
    """Event files under `run_dir/tensorboard/seed<N>/` (tensorboardX)."""

    def __init__(self, run_dir: pathlib.Path, seeds: list[int], iterations: int):
        from tensorboardX import SummaryWriter

        super().__init__(iterations)
        root = pathlib.Path(run_dir) / "tensorboard"
        shutil.rmtree(root, ignore_errors=True)  # rewritten from the records (see the module)
        self.writers = {seed: SummaryWriter(str(root / f"seed{seed}"), flush_secs=5) for seed in seeds}

    def scalars(self, seed, values, step):
        writer = self.writers[seed]
        for tag, value in values.items():
            writer.add_scalar(tag, value, step)

    def image(self, seed, tag, pixels, step):
        self.writers[seed].add_image(tag, pixels, step, dataformats="HWC")

    def close(self):
        for writer in self.writers.values():
            writer.close()


class WandbLogger(RunLogger):
    """One Weights & Biases run per litl run (tags prefixed ``seed<N>/``); resumes with it."""

    def __init__(self, run_dir: pathlib.Path, seeds: list[int], iterations: int, settings: dict):
        import hashlib

        import wandb

        super().__init__(iterations)
        self.wandb = wandb
        run_id = hashlib.sha1(str(pathlib.Path(run_dir).resolve()).encode()).hexdigest()[:16]
        self.run = wandb.init(
            project="litl",
            dir=str(run_dir),
            id=run_id,
            resume="allow",
            name=pathlib.Path(run_dir).name,
            config=json.loads(json.dumps(settings)),
        )
        # Charts against litl's step (global iteration, or SGD steps for the per-epoch curve),
        # not wandb's count of log calls.
        self.run.define_metric("litl_step")
        self.run.define_metric("*", step_metric="litl_step")

    silent = False

    def scalars(self, seed, values, step):
        if not self.silent:
            self.run.log({f"seed{seed}/{tag}": value for tag, value in values.items()} | {"litl_step": step})

    def image(self, seed, tag, pixels, step):
        self.run.log({f"seed{seed}/{tag}": self.wandb.Image(pixels), "litl_step": step})

    def restore(self, metrics, learning):
        """A new W&B run gets the resumed run's history; a resumed W&B run already holds it, so
        the records only advance the step bookkeeping (iterations logged after the last
        checkpoint before an interruption are logged again, at the same litl_step, as the run
        redoes them)."""
        self.silent = bool(getattr(self.run, "resumed", False))
        try:
            super().restore(metrics, learning)
        finally:
            self.silent = False

    def close(self):
        self.run.finish()


def check_kind(kind: str) -> None:
    """Raise a clear error for a logger that cannot be used (before the run starts)."""
    from litl.config import SettingsError

    if kind not in KINDS:
        raise SettingsError(f"output.logger={kind!r}: choose one of {list(KINDS)}", "output.logger")
    if kind == "wandb":
        try:
            import wandb  # noqa: F401
        except ImportError:
            raise SettingsError(
                "logger=wandb needs the Weights & Biases package: pip install "
                "wandb (then `wandb login`, or WANDB_MODE=offline); or use "
                "logger=tensorboard",
                "output.logger",
            ) from None


def make_logger(
    kind: str, run_dir, seeds: list[int], iterations: int, settings: dict | None = None
) -> RunLogger:
    """The run's logger: ``"tensorboard"``, ``"wandb"`` or ``"none"``."""
    check_kind(kind)
    if kind == "tensorboard":
        return TensorBoardLogger(run_dir, seeds, iterations)
    if kind == "wandb":
        return WandbLogger(run_dir, seeds, iterations, settings or {})
    return NoLogger(iterations)
