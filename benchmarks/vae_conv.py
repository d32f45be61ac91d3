"""The autoencoder's convolutions: XLA's against litl's shifted matrix products (`litl.models.conv`).

    python benchmarks/vae_conv.py                 # table
    python benchmarks/vae_conv.py --json          # one JSON object
    python benchmarks/vae_conv.py --quick         # small windows (smoke)

For each window size and implementation ("xla", "matmul"), three programs of the default VAE
(channels 8-16-32-32-64, latent 8, kernel 3, float32):

  train_step   `jax.value_and_grad` of `vae.losses` (litl's, momentum head 0.3) on a batch of 8
               (loop.learning.batch_size): one SGD step of a learning phase, without the optimizer update
  encode       the encoder on one field (what a rollout step's controller reads)
  encode_grad  its gradient with respect to the field (`controller.feature_gradient=full`)

--seeds S vmaps every program over S seeds, each with its own parameters and inputs (as the
loop runs its seeds); XLA's CPU convolution then becomes a grouped one.

Times: median of --repeats calls after compilation (compile: lowering + compilation, apart);
memory: XLA's temporary buffers of the compiled program (`memory_analysis().temp_size_in_bytes`).
Each program's outputs are asserted equal between the implementations (rtol 1e-4) first.

Sizes: 2d32 (the 2D robots' window at dx 1/64: 0.5 -> 32x32 nodes), 2d64 (dx 1/128: 64x64),
3d32 (the 3D walkers at dx 1/32: 0.5 -> 16 nodes, rounded up to 32^3); --quick: 2d32, 3d16.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)

SIZES = {"2d32": (32, 32), "2d64": (64, 64), "3d32": (32, 32, 32), "3d16": (16, 16, 16)}
IMPLEMENTATIONS = ("xla", "matmul")
BATCH = 8


def programs(shape, implementation, seeds=1):
    """{name: (jitted function, args)} of one size and implementation; seeds > 1: each program
    vmapped over that many seeds' parameters and inputs."""
    import jax
    import jax.numpy as jnp

    from litl.models import vae

    model = vae.ConvAutoencoder(grid_shape=shape, convolution=implementation)
    keys = jax.random.split(jax.random.PRNGKey(0), seeds)
    params = jax.vmap(lambda key: vae.init_autoencoder(model, key))(keys)
    fields = jax.random.normal(jax.random.PRNGKey(1), (seeds, BATCH, *shape, len(shape)))
    one = fields[:, :1]

    def train_loss(p, x):
        return vae.losses(model, p, x, jax.random.PRNGKey(2), momentum_weight=0.3)["total"]

    def encode(p, x):
        return model.apply(p.network, x, method=model.encode)[0]

    def encode_sum(p, x):
        return jnp.sum(jnp.sin(encode(p, x)))

    functions = {
        "train_step": jax.value_and_grad(train_loss),
        "encode": encode,
        "encode_grad": jax.grad(encode_sum, argnums=1),
    }
    if seeds == 1:
        params, fields, one = jax.tree.map(lambda leaf: leaf[0], (params, fields, one))
    else:
        functions = {name: jax.vmap(function) for name, function in functions.items()}
    inputs = {"train_step": fields, "encode": one, "encode_grad": one}
    return {name: (jax.jit(function), (params, inputs[name])) for name, function in functions.items()}


def measure(size: str, repeats: int, seeds: int = 1) -> dict:
    import jax

    shape = SIZES[size]
    built = {impl: programs(shape, impl, seeds) for impl in IMPLEMENTATIONS}
    rows = {}
    for name in built["xla"]:
        outputs = {}
        for impl in IMPLEMENTATIONS:
            function, args = built[impl][name]
            start = time.perf_counter()
            compiled = function.lower(*args).compile()
            compile_s = time.perf_counter() - start
            outputs[impl] = jax.block_until_ready(compiled(*args))
            times = []
            for _ in range(repeats):
                start = time.perf_counter()
                jax.block_until_ready(compiled(*args))
                times.append(time.perf_counter() - start)
            analysis = compiled.memory_analysis()
            rows[f"{name}/{impl}"] = {
                "median_ms": 1e3 * statistics.median(times),
                "compile_s": compile_s,
                "temp_mb": analysis.temp_size_in_bytes / 2**20 if analysis else None,
            }
        for a, b in zip(*(jax.tree_util.tree_leaves(outputs[i]) for i in IMPLEMENTATIONS), strict=True):
            scale = float(np.max(np.abs(a))) or 1.0
            np.testing.assert_allclose(
                np.asarray(b) / scale, np.asarray(a) / scale, rtol=1e-4, atol=1e-5, err_msg=f"{size} {name}"
            )
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", choices=sorted(SIZES), default=None)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument(
        "--seeds", type=int, default=1, help="vmap every program over this many seeds (default 1: no vmap)"
    )
    parser.add_argument("--quick", action="store_true", help="2d32 and 3d16, 3 repeats")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    sizes = args.sizes or (["2d32", "3d16"] if args.quick else ["2d32", "2d64", "3d32"])
    repeats = 3 if args.quick else args.repeats

    import jax

    results = {
        "device": str(jax.devices()[0]),
        "backend": jax.default_backend(),
        "repeats": repeats,
        "seeds": args.seeds,
        "sizes": {s: measure(s, repeats, args.seeds) for s in sizes},
    }
    if args.json:
        print(json.dumps(results, indent=1))
        return
    print(f"device {results['device']}, medians of {repeats}, {args.seeds} seed(s) vmapped")
    print(
        f"{'size':6} {'program':12} {'xla ms':>9} {'matmul ms':>10} {'speedup':>8} "
        f"{'compile s (x/m)':>16} {'temp MB (x/m)':>15}"
    )
    for size, rows in results["sizes"].items():
        for name in ("train_step", "encode", "encode_grad"):
            x, m = rows[f"{name}/xla"], rows[f"{name}/matmul"]
            print(
                f"{size:6} {name:12} {x['median_ms']:9.2f} {m['median_ms']:10.2f} "
                f"{x['median_ms'] / m['median_ms']:8.2f} "
                f"{x['compile_s']:7.1f}/{m['compile_s']:<7.1f} "
                f"{x['temp_mb'] or 0:7.1f}/{m['temp_mb'] or 0:<7.1f}"
            )


if __name__ == "__main__":
    main()
