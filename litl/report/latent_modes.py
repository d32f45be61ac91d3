"""Fig. 8's question, measured: do a learned observer's leading latents decode to rigid motions?

The paper (Discussion, Fig. 8): "some more significant latent feature[s] representing more rigid
motion modes (such as velocity to the right), and less significant latent features representing
higher-frequency, dynamic deformations". For one seed's VAE and the snapshots it learned from:

* a latent's *significance* is the variance of its encoder mean over the snapshots (what the
  controller sees move; a latent the encoder leaves constant carries nothing);
* its *mode* is what it changes in the decoded field, (D(+e_i) - D(-e_i)) / 2, one unit of the
  prior's spread either way;
* its *rigid fraction* is the share of the mode's energy over the body that a rigid motion
  v(x) = t + ω × (x - c) explains (weighted least squares, weights: the snapshots' mean speed at
  each node, so the fit covers where the body moves; c their weighted centroid). 1: the mode is a
  translation and rotation of the body; near 0: a deformation.

The same fraction of the snapshots' own deviations from their mean says how rigid the robot's
motion is to begin with: the reference a leading latent's fraction is read against.

    python -m litl.report.latent_modes RUN_DIR [--seed S] [--out DIR]

reads the run's newest checkpoint (the observer in use and the replay buffer) and writes
`latent_modes.json` and `latent_modes.png` (the latent sweeps ordered by significance).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from litl.errors import UserError


class LatentModesError(UserError, ValueError):
    """The run or the arguments cannot be analysed; the message says why."""


def _rigid_basis(positions: np.ndarray) -> np.ndarray:
    """(n, d, k) the velocity of each rigid motion's unit at each position (relative to the
    centroid): d translations, then the rotations (1 in 2D, 3 in 3D)."""
    n, d = positions.shape
    basis = [np.broadcast_to(np.eye(d)[j], (n, d)) for j in range(d)]
    if d == 2:
        x, y = positions[:, 0], positions[:, 1]
        basis.append(np.stack([-y, x], axis=1))
    else:
        for axis in np.eye(3):
            basis.append(np.cross(np.broadcast_to(axis, (n, 3)), positions))
    return np.stack(basis, axis=2)


def rigid_fraction(field: ArrayLike, weight: ArrayLike, dx: float) -> float:
    """The share of `field`'s weighted energy a rigid motion explains.

    Args:
      field: (*grid, d) velocities on the grid (d = 2 or 3).
      weight: (*grid) non-negative weights (where the body is).
      dx: grid spacing.

    Returns:
      1 - Σ w |v - v_rigid|² / Σ w |v|², v_rigid the weighted least-squares rigid motion; NaN for a
      field without energy under the weights.
    """
    field, weight = np.asarray(field, np.float64), np.asarray(weight, np.float64)
    d = field.shape[-1]
    if field.shape[:-1] != weight.shape or d not in (2, 3) or field.ndim != d + 1:
        raise LatentModesError(f"field {field.shape} and weight {weight.shape} do not match a {d}D grid")
    if np.any(weight < 0) or not np.all(np.isfinite(weight)):
        raise LatentModesError("weights must be finite and non-negative")
    index = np.stack(np.meshgrid(*[np.arange(s) for s in weight.shape], indexing="ij"), -1).reshape(-1, d)
    w = weight.reshape(-1)
    v = field.reshape(-1, d)
    total = float(np.sum(w * np.sum(v**2, axis=1)))
    if not total > 0:
        return float("nan")
    positions = index * dx
    positions = positions - np.sum(w[:, None] * positions, axis=0) / np.sum(w)
    basis = _rigid_basis(positions)  # (n, d, k)
    root = np.sqrt(w)[:, None, None]
    design = (root * basis).reshape(-1, basis.shape[2])
    target = (np.sqrt(w)[:, None] * v).reshape(-1)
    coefficients, *_ = np.linalg.lstsq(design, target, rcond=None)
    residual = target - design @ coefficients
    return float(1.0 - np.sum(residual**2) / total)


def latent_modes(model: Any, params: Any, fields: np.ndarray, dx: float) -> dict[str, Any]:
    """Each latent's significance, mode and rigid fraction, and the snapshots' own.

    Args:
      model: the observer's `litl.models.vae.ConvAutoencoder`.
      params: one seed's `AutoencoderParams`.
      fields: (B, *model.grid_shape, d) the snapshots (raw units, as the replay buffer holds).
      dx: the grid spacing.

    Returns:
      ``order`` (latents by decreasing significance), ``variance`` and ``rigid_fraction`` per latent
      (index = latent), ``snapshot_rigid_fraction`` (the snapshots' deviations from their mean,
      pooled) and ``modes`` ((r, *grid, d) array).
    """
    from litl.viz.latent import decode_fields, encode_means

    fields = np.asarray(fields)
    if fields.ndim != model.dim + 2 or len(fields) < 2:
        raise LatentModesError(
            f"need at least 2 snapshots of shape (*{model.grid_shape}, d), got {fields.shape}"
        )
    codes = encode_means(model, params, fields)
    variance = codes.var(axis=0)
    r = model.latent_dim
    plus, minus = decode_fields(model, params, np.eye(r)), decode_fields(model, params, -np.eye(r))
    modes = (np.asarray(plus, np.float64) - np.asarray(minus, np.float64)) / 2
    weight = np.mean(np.linalg.norm(fields, axis=-1), axis=0)
    deviations = fields - fields.mean(axis=0)
    energy = [float(np.sum(weight * np.sum(f**2, axis=-1))) for f in deviations]
    fractions = [rigid_fraction(f, weight, dx) for f in deviations]
    pooled = (
        float(np.nansum(np.multiply(fractions, energy)) / np.sum(energy)) if np.sum(energy) > 0 else np.nan
    )
    return {
        "order": [int(i) for i in np.argsort(-variance, kind="stable")],
        "variance": [float(x) for x in variance],
        "rigid_fraction": [rigid_fraction(mode, weight, dx) for mode in modes],
        "snapshot_rigid_fraction": pooled,
        "modes": modes,
    }


def _load(run_dir: pathlib.Path, seed: int | None) -> tuple[Any, Any, np.ndarray, float, int, int]:
    """(model, one seed's observer parameters, its buffer's valid snapshots, dx, the seed, the
    episodes done) from the run's newest checkpoint."""
    import jax

    from litl.loop import make_algorithm, stack_seeds
    from litl.loop.checkpoint import Checkpoints
    from litl.models.replay_buffer import valid_mask
    from litl.replay import chosen_seed, load_run_config

    robot, config = load_run_config(run_dir)
    seed = chosen_seed(config, seed)
    seeds = [config.seed + s for s in range(config.seeds)]
    algorithm = make_algorithm(robot, config.algorithm)
    if algorithm.model is None:
        raise LatentModesError(f"{run_dir}: its observer ({config.observer.kind}) learns no latent space")
    checkpoints = Checkpoints(run_dir / "checkpoints")
    try:
        done = checkpoints.latest()
        if done is None:
            raise LatentModesError(f"{run_dir} has no checkpoint yet: let the run finish its bootstrap")
        counters = {
            "episodes_done": 0,
            "metrics_lines": 0,
            "learning_lines": 0,
            "loss_before_retrain": np.zeros(len(seeds)),
        }
        state, _ = checkpoints.restore(stack_seeds([algorithm.init(s) for s in seeds]), counters)
    finally:
        checkpoints.close()
    one = jax.tree.map(lambda leaf: np.asarray(leaf)[seeds.index(seed)], state)
    fields = np.asarray(one.buffer.fields)[np.asarray(valid_mask(one.buffer))]
    return algorithm.model, one.observer, fields, robot.config.dx, seed, int(done)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m litl.report.latent_modes", description=__doc__.split("\n")[0]
    )
    parser.add_argument("run_dir", type=pathlib.Path)
    parser.add_argument("--seed", type=int, default=None, help="which seed (default: the run's first)")
    parser.add_argument("--out", type=pathlib.Path, default=None, help="default: RUN_DIR/latent_modes")
    args = parser.parse_args(argv)
    try:
        model, params, fields, dx, seed, done = _load(args.run_dir, args.seed)
        result = latent_modes(model, params, fields, dx)
    except UserError as error:  # this module's, and a run directory that cannot be read
        print(f"litl.report.latent_modes: {error}", file=sys.stderr)
        return 2
    from litl.viz.latent import draw_latent_sweeps

    out = args.out or args.run_dir / "latent_modes"
    out.mkdir(parents=True, exist_ok=True)
    figure = draw_latent_sweeps(model, params, order=result["order"], path=out / "latent_modes.png")
    figure.clear()
    summary = {k: v for k, v in result.items() if k != "modes"}
    summary |= {"run_dir": str(args.run_dir), "seed": seed, "episodes_done": done, "snapshots": len(fields)}
    (out / "latent_modes.json").write_text(json.dumps(summary, indent=1) + "\n")
    ranked = ", ".join(
        f"z{i}: var {result['variance'][i]:.3g}, rigid {result['rigid_fraction'][i]:.2f}"
        for i in result["order"]
    )
    print(
        f"seed {seed}, {len(fields)} snapshots, after {done} episodes; snapshots' own rigid fraction "
        f"{result['snapshot_rigid_fraction']:.2f}; by significance: {ranked}"
    )
    print(out / "latent_modes.json")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
