"""How much of the grid velocity field a latent code of size r can explain, on a run's own data.

    python benchmarks/observer_capacity.py RUN_DIR             # a finished VAE run (e.g. the demo)
    python benchmarks/observer_capacity.py RUN_DIR --json --components 4 8 16 32

Reads the replay buffer of the first seed at the run's latest checkpoint (the windows the
observer learned from), splits it in halves (train / held out, seeded) and reports, on the held-out
half, the fraction of the fields' energy explained (`recon_explained`: 1 - MSE / mean square, as
`litl.loop.learning.LearningStats`) by

* the run's own observer Θ (its reconstructions);
* the best linear code of r components (PCA fitted on the training half, no centring, so a blank
  field scores 0 as in `recon_explained`), for each r in `--components`;
* the same PCA on the field average-pooled 2x and 4x per axis, and Gaussian-smoothed (sigma 1
  node): whether a coarser or smoother view of the motion is low-dimensional.

and how well each code tells the robot's velocity (the particles' mean velocity the buffer keeps
beside each snapshot): the held-out R² per axis of a linear readout fitted on the training half,
from the run's observer's latents and from each PCA code of the field (`velocity_r2` of
`LearningStats` is the same measure for the observer).

Reading it: PCA with r components is the best any *linear* r-dimensional code can do; a
convolutional VAE can beat it, but when PCA needs far more than r components to explain most of
the energy, the field is not low-dimensional at that resolution and an r-latent autoencoder
cannot reconstruct it closely either.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys

import numpy as np

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def load_buffer(run_dir: pathlib.Path):
    """(fields (n, *window, d), velocities (n, d), algorithm, observer params of seed 0) of a run
    directory."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
    from gradient_horizon import state_of_run

    from litl.loop import make_algorithm

    robot, config, state = state_of_run(run_dir)
    algorithm = make_algorithm(robot, config.algorithm)
    if not algorithm.observer.learned:
        raise SystemExit(
            f"{run_dir}: observer {config.observer.kind!r} does not learn from "
            f"snapshots; give a run of a learned observer (vae, ae)"
        )
    count = int(state.buffer.count)
    fields = np.asarray(state.buffer.fields[:count], np.float64)
    return fields, np.asarray(state.buffer.velocities[:count], np.float64), algorithm, state.observer


def explained_by_pca(fields, train, held_out, components) -> dict[int, float]:
    """{r: held-out explained energy} of the uncentred rank-r projection fitted on `train`."""
    flat = fields.reshape(len(fields), -1)
    _, _, basis = np.linalg.svd(flat[train], full_matrices=False)
    signal = np.mean(flat[held_out] ** 2)
    result = {}
    for r in components:
        projector = basis[:r]
        reconstruction = flat[held_out] @ projector.T @ projector
        result[r] = float(1 - np.mean((reconstruction - flat[held_out]) ** 2) / signal)
    return result


def velocity_readout_r2(codes, velocities, train, held_out) -> list[float]:
    """Per axis, held-out R² of a least-squares readout [codes, 1] -> velocities fitted on train."""
    design = np.c_[codes, np.ones(len(codes))]
    weights = np.linalg.lstsq(design[train], velocities[train], rcond=None)[0]
    residual = np.mean((design[held_out] @ weights - velocities[held_out]) ** 2, axis=0)
    return [float(v) for v in 1 - residual / np.var(velocities[held_out], axis=0)]


def pca_codes(fields, train, r: int):
    """(n, r) codes of every field on the top r principal directions of the training half."""
    flat = fields.reshape(len(fields), -1)
    _, _, basis = np.linalg.svd(flat[train], full_matrices=False)
    return flat @ basis[:r].T


def pooled(fields, factor: int):
    """Average-pool every spatial axis of (n, *grid, d) fields by `factor`."""
    n, *grid, d = fields.shape
    shape = [n]
    for size in grid:
        shape += [size // factor, factor]
    trimmed = fields[(slice(None),) + tuple(slice(0, size // factor * factor) for size in grid)]
    return trimmed.reshape(shape + [d]).mean(axis=tuple(range(2, 2 * len(grid) + 1, 2)))


def explained_by_observer(algorithm, params, fields) -> float:
    import jax.numpy as jnp

    model = algorithm.model
    x = jnp.asarray(fields, jnp.float32) / params.scale
    reconstruction, _, _ = model.apply(params.network, x)
    return float(1 - jnp.mean((reconstruction - x) ** 2) / jnp.mean(x**2))


def observer_codes(algorithm, params, fields) -> np.ndarray:
    """(n, r) encoder means of the run's observer."""
    import jax.numpy as jnp

    x = jnp.asarray(fields, jnp.float32) / params.scale
    return np.asarray(algorithm.model.apply(params.network, x, method="encode")[0], np.float64)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dir", type=pathlib.Path)
    parser.add_argument("--components", type=int, nargs="+", default=[4, 8, 16, 32])
    parser.add_argument("--seed", type=int, default=0, help="of the train/held-out split")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    from scipy.ndimage import gaussian_filter

    fields, velocities, algorithm, params = load_buffer(args.run_dir)
    order = np.random.default_rng(args.seed).permutation(len(fields))
    train, held_out = order[: len(order) // 2], order[len(order) // 2 :]
    spatial = fields.ndim - 2
    views = {
        "field": fields,
        "pooled 2x": pooled(fields, 2),
        "pooled 4x": pooled(fields, 4),
        "smoothed (sigma 1 node)": gaussian_filter(
            fields, sigma=(0,) + (1.0,) * spatial + (0,), mode="constant"
        ),
    }
    result = {
        "run": str(args.run_dir),
        "snapshots": len(fields),
        "window": list(fields.shape[1:-1]),
        "latent_dim": algorithm.model.latent_dim,
        "observer_explained_held_out": explained_by_observer(algorithm, params, fields[held_out]),
        "pca_explained_held_out": {
            view: explained_by_pca(data, train, held_out, args.components) for view, data in views.items()
        },
        "velocity_r2_held_out": {
            "observer": velocity_readout_r2(
                observer_codes(algorithm, params, fields), velocities, train, held_out
            ),
            **{
                f"pca r={r}": velocity_readout_r2(pca_codes(fields, train, r), velocities, train, held_out)
                for r in args.components
            },
        },
    }
    if args.json:
        print(json.dumps(result, indent=1))
        return
    print(f"{result['run']}: {result['snapshots']} snapshots of {result['window']} nodes")
    print(
        f"the run's observer (r = {result['latent_dim']}): "
        f"{result['observer_explained_held_out']:.3f} of the held-out energy "
        f"(it saw part of these snapshots in training)"
    )
    print("PCA, held-out energy explained by r components:")
    print("  view                      " + "".join(f"r={r:<6}" for r in args.components))
    for view, by_rank in result["pca_explained_held_out"].items():
        print(f"  {view:<26}" + "".join(f"{by_rank[r]:<8.3f}" for r in args.components))
    print("velocity readout, held-out R² per axis:")
    for code, r2 in result["velocity_r2_held_out"].items():
        print(f"  {code:<26}" + "  ".join(f"{v:.3f}" for v in r2))


if __name__ == "__main__":
    main()
