"""Particle-to-grid scatter: litl's windowed scatter against the alternatives JAX offers.

    python benchmarks/p2g_scatter.py                  # table
    python benchmarks/p2g_scatter.py --json           # one JSON object (see below)
    python benchmarks/p2g_scatter.py --quick          # tiny sizes (smoke)
    python benchmarks/p2g_scatter.py --sizes biped64 --variants window at_add --repeats 9

What is timed is MLS-MPM's whole particle-to-grid transfer of mass and momentum with the
quadratic B-spline 3^d stencil: `litl.sim.transfer.stencil` and `particles_to_grid` (weights,
affine momentum per node), with only the final scatter of the (n, 3, ..., 3, 1 + d) node values
into the grid swapped (`transfer.scatter_to_grid` is replaced while tracing):

  window              litl's own `transfer.scatter_to_grid`: one `lax.scatter_add` whose update
                      windows are each particle's whole 3^d stencil; its transpose (reverse mode)
                      is one windowed gather (custom VJP)
  at_add              `grid.at[ids].add(values)` on the flattened (nodes, 1 + d) grid, one row per
                      stencil contribution (n x 3^d rows); reverse mode gathers those rows
  segment_sum_sorted  the n x 3^d contributions sorted by flat node id (`lax.sort_key_val`, each
                      call: the particles move every step), permuted (a gather whose transpose is
                      an inverse permutation, custom VJP), then `jax.ops.segment_sum(...,
                      indices_are_sorted=True)`. (Unsorted `segment_sum` is `.at[].add` itself.)
  one_hot             an explicit (n x 3^d contributions) x (nodes) one-hot matrix, built each
                      call, and one matmul; only grids of at most --one-hot-max-nodes nodes
  one_hot_separable   the same product without forming that matrix: per-axis one-hots (n, 3,
                      nodes along the axis), contracted by `jnp.einsum` (the big one-hot is their
                      Kronecker product); same node limit
  fixed_point         litl's `scatter_to_grid(..., fixed_point=True)` (`SimConfig.particle_to_grid`):
                      each channel scaled by a power of two, rounded and summed as int32 pairs in
                      the same windowed scatter, deterministic by construction; its transpose is
                      the same windowed gather
  no_scatter          not a transfer (its grid is not checked): the scatter replaced by a plain
                      sum of the node values over particles, i.e. roughly what the rest of the
                      transfer (stencil, node values, objective) costs

Sizes (float32): biped64 (the demo biped, 581 particles, 64x64), block128 (a 100 x 100 block,
10,000 particles, 128x128), quadruped32 (the catalog's quadruped at dx 1/32, 2350 particles,
64x32x32), quadruped64 (`sim_speed.quadruped_scene`, 28,000 particles, 64^3); --quick: biped64
and the quadruped at dx 1/16 (324 particles, 32x16x16). Positions are jittered by up to 0.1
dx. Each timed call runs K transfers in a `lax.fori_loop` (K ~ 2M / contributions, 8 to 200; the
explicit one-hot: 4), the positions carried from one to the next and moved by each result, as a
rollout carries its state, so that dispatch overhead does not count and nothing is hoisted:

  forward_us           median over --repeats runs (after compilation) of one transfer: the grid
  forward_backward_us  the same for `jax.value_and_grad` of sum(R grid^2) (fixed random R; a
                       linear objective would leave the forward scatter dead) with respect to the
                       particles' positions and velocities, forward pass included
  compile_forward_s, compile_forward_backward_s: lowering + compilation of the two loops
  ratio_vs_window      forward_backward_us / window's (< 1: faster than litl's scatter)

The variants run in turn within each repeat (so that a slow spell of a shared machine hits them
alike). Before timing, every variant's grid and its gradients are asserted equal to `window`'s
to float32 tolerance (rtol 1e-4, atol 1e-5 x the largest magnitude).

Measured 2026-11-25 on the 2-core CPU machine class (XLA:CPU, jax 0.10.2, float32), the CPU
shared the whole time with other jobs (load average 6-7 on the 2 cores), so absolute times are
inflated and vary by ~10-30% from run to run; compare within a size. Medians of 7,
microseconds per transfer (compile: the forward and forward+backward loops together):

  size (particles, grid)      variant                forward    fwd+bwd  vs window  compile
  biped64 (581, 64x64)        window                     113        233       1.00    4.4 s
                              at_add                     236        315       1.35    5.2 s
                              segment_sum_sorted        1517       1678       7.22    5.1 s
                              one_hot                 135290     148709        639    4.8 s
                              one_hot_separable         2417       4157       17.9    6.1 s
                              no_scatter                 130        293       1.26    5.3 s
  block128 (10000, 128x128)   window                    1438       2738       1.00    3.9 s
                              at_add                    2747       3820       1.40    4.9 s
                              segment_sum_sorted       26581      29447       10.8    4.2 s
                              no_scatter                1558       3070       1.12    3.5 s
  quadruped32 (2350,          window                    1508       3665       1.00   15.1 s
    64x32x32)                 at_add                    3253       4534       1.24   15.7 s
                              segment_sum_sorted       21530      24331       6.64   15.7 s
                              no_scatter                1927       4012       1.09   16.0 s
  quadruped64 (28000, 64^3)   window                   23495      70261       1.00   14.4 s
                              at_add                   40714      78383       1.12   13.2 s
                              segment_sum_sorted      462113     502732       7.16   21.1 s
                              no_scatter               25581      63342       0.90   16.0 s

A second run at the demo sizes (medians of 9): biped64 window 120 / 229, at_add 242 / 291
(1.27), no_scatter 127 / 277; quadruped32 window 1453 / 3730, at_add 3170 / 4526 (1.21),
no_scatter 1698 / 3872. Two earlier runs, with the positions sliced from a (K, d, n) input
(1.3-5x slower, see `programs`), ranked the variants the same way, except that at quadruped64
at_add's forward+backward came out at 0.95x and 1.20x window's (its forward: 1.15x, 1.38x).

So litl's windowed scatter is the fastest on CPU, forward and forward+backward, at every size:
`.at[].add` on the flat grid takes 1.7-2.2x its forward and 1.1-1.4x its forward+backward;
sorting the n x 3^d contributions for `segment_sum` costs more than the whole transfer
(XLA:CPU's sort); the one-hot products are 18x (per-axis) and 640x (explicit) slower even on
64x64 (14-30x and 590-970x over all runs). The windowed scatter costs about what a plain sum
over the particles costs in its place (`no_scatter`: 0.9-1.26x the forward+backward time): on
CPU the transfer's time goes to the stencil weights and node values and their backward pass, not
to the scatter. litl keeps it on every backend; GPU timings were not measured (no GPU was
available).
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import json
import math
import os
import statistics
import sys
import time

import numpy as np

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)

VARIANTS = (
    "window",
    "fixed_point",
    "at_add",
    "segment_sum_sorted",
    "one_hot",
    "one_hot_separable",
    "no_scatter",
)
SIZES = ("biped64", "block128", "quadruped32", "quadruped64")
QUICK_SIZES = ("biped64", "quadruped16")
ONE_HOT = ("one_hot", "one_hot_separable")
SLOW_LOOPS = 4


def scene(name: str):
    """(positions (n, d) float64, grid_shape, dx) of a named size."""
    if name in ("biped64", "quadruped16", "quadruped32"):
        from litl.robots import catalog

        robot, dx = {
            "biped64": ("biped", 1 / 64),
            "quadruped16": ("quadruped", 1 / 16),
            "quadruped32": ("quadruped", 1 / 32),
        }[name]
        built = catalog.get(robot, dx)
        return np.asarray(built.layout.positions), tuple(built.config.grid_shape), dx
    if name == "block128":
        from litl.robots.primitives import sample_box

        dx = 1 / 128
        # 50 cells x 2 particles per axis: 100 x 100 = 10,000 particles, resting 4 cells up.
        x = sample_box([0.3, 4 * dx], [50.5 * dx, 50.5 * dx], dx)
        return x, (128, 128), dx
    if name == "quadruped64":
        from sim_speed import quadruped_scene

        config, _, _, state = quadruped_scene()
        return np.asarray(state.x, np.float64), tuple(config.grid_shape), config.dx
    raise SystemExit(f"unknown size {name!r}; choose from {SIZES + QUICK_SIZES}")


# ---- the scatters: (stencil, values (n, 3, ..., 3, c), grid_shape) -> (*grid_shape, c)


def _flat(st, values, grid_shape):
    """Flat node id (n * 3^d,) and value row (n * 3^d, c) of every stencil contribution, in the
    C order of `values`' (3, ..., 3) stencil axes."""
    import jax.numpy as jnp

    dim = len(grid_shape)
    offsets = jnp.asarray(list(itertools.product(range(3), repeat=dim)), jnp.int32)
    strides = jnp.asarray(np.cumprod((tuple(grid_shape[1:]) + (1,))[::-1])[::-1].copy(), jnp.int32)
    ids = jnp.sum((st.base[:, None, :] + offsets[None]) * strides, -1).reshape(-1)
    return ids, values.reshape(-1, values.shape[-1])


def scatter_at_add(st, values, grid_shape):
    import jax.numpy as jnp

    ids, rows = _flat(st, values, grid_shape)
    grid = jnp.zeros((math.prod(grid_shape), rows.shape[-1]), rows.dtype)
    grid = grid.at[ids].add(rows, mode="promise_in_bounds")
    return grid.reshape(tuple(grid_shape) + rows.shape[-1:])


def _permutation():
    import jax

    @jax.custom_vjp
    def permute(rows, order):
        return rows[order]

    def forward(rows, order):
        return rows[order], order

    def backward(order, cotangent):
        # The transpose of a permutation is its inverse: a scatter of unique rows, no sums.
        inverse = (
            jax.numpy.zeros_like(cotangent)
            .at[order]
            .set(cotangent, unique_indices=True, mode="promise_in_bounds")
        )
        return inverse, None

    permute.defvjp(forward, backward)
    return permute


def scatter_segment_sum_sorted(st, values, grid_shape):
    import jax
    import jax.numpy as jnp

    ids, rows = _flat(st, values, grid_shape)
    sorted_ids, order = jax.lax.sort_key_val(ids, jnp.arange(ids.shape[0], dtype=jnp.int32))
    rows = _permutation()(rows, order)
    grid = jax.ops.segment_sum(rows, sorted_ids, num_segments=math.prod(grid_shape), indices_are_sorted=True)
    return grid.reshape(tuple(grid_shape) + rows.shape[-1:])


def scatter_one_hot(st, values, grid_shape):
    import jax
    import jax.numpy as jnp

    ids, rows = _flat(st, values, grid_shape)
    nodes = math.prod(grid_shape)
    one_hot = (ids[:, None] == jnp.arange(nodes, dtype=ids.dtype)[None, :]).astype(rows.dtype)
    grid = jnp.dot(one_hot.T, rows, precision=jax.lax.Precision.HIGHEST)
    return grid.reshape(tuple(grid_shape) + rows.shape[-1:])


def scatter_one_hot_separable(st, values, grid_shape):
    import jax
    import jax.numpy as jnp

    dim = len(grid_shape)
    hots = [
        ((st.base[:, a, None, None] + jnp.arange(3)[None, :, None]) == jnp.arange(n)[None, None, :]).astype(
            values.dtype
        )
        for a, n in enumerate(grid_shape)
    ]
    stencil_axes, grid_axes = "abc"[:dim], "ijk"[:dim]
    spec = ",".join(f"p{s}{g}" for s, g in zip(stencil_axes, grid_axes, strict=True))
    spec += f",p{stencil_axes}z->{grid_axes}z"
    return jnp.einsum(spec, *hots, values, optimize="optimal", precision=jax.lax.Precision.HIGHEST)


def no_scatter(st, values, grid_shape):
    """Not a transfer: the node values summed over particles, broadcast to the grid (roughly the
    cost of the transfer without its scatter: stencil, node values, objective)."""
    import jax.numpy as jnp

    total = jnp.sum(values.reshape(-1, values.shape[-1]), 0)
    return jnp.zeros(tuple(grid_shape) + values.shape[-1:], values.dtype) + total


SCATTERS = {
    "at_add": scatter_at_add,
    "segment_sum_sorted": scatter_segment_sum_sorted,
    "one_hot": scatter_one_hot,
    "one_hot_separable": scatter_one_hot_separable,
    "no_scatter": no_scatter,
}


@contextlib.contextmanager
def scatter_as(variant: str):
    """Trace `transfer.particles_to_grid` with the `variant` scatter ("window": litl's own)."""
    from litl.sim import transfer

    own = transfer.scatter_to_grid
    if variant == "fixed_point":
        transfer.scatter_to_grid = lambda st, values, grid_shape, fixed_point=False: own(
            st, values, grid_shape, fixed_point=True
        )
    elif variant != "window":
        transfer.scatter_to_grid = lambda st, values, grid_shape, fixed_point=False: SCATTERS[variant](
            st, values, grid_shape
        )
    try:
        yield
    finally:
        transfer.scatter_to_grid = own


def p2g(x, v, mass, affine, dx, grid_shape):
    """MLS-MPM particle-to-grid of per-component positions x and velocities v, as litl's step."""
    from litl.sim import transfer

    st = transfer.stencil(x, dx, grid_shape)
    return transfer.particles_to_grid(st, mass, [mass * c for c in v], affine, dx, grid_shape)


def problem(name: str, dtype=np.float32, seed: int = 0):
    """Inputs of one size: positions x (d, n) jittered by up to 0.1 dx, v (d, n), mass (n,),
    affine (d, d, n), the objective's weights R, dx, grid_shape and transfers per timed call."""
    x, grid_shape, dx = scene(name)
    n, dim = x.shape
    rng = np.random.default_rng(seed)
    contributions = n * 3**dim
    loops = int(min(200, max(8, 2_000_000 // contributions)))
    x = (x + rng.uniform(-0.1, 0.1, x.shape) * dx).T
    mass = np.full(n, (dx / 2) ** dim)
    v = rng.normal(0.0, 0.3, (dim, n))
    # The affine momentum of a step: stress term plus m C; magnitudes of a moving soft body.
    affine = rng.normal(0.0, 1.0, (dim, dim, n)) * mass * (4.0 / dx)
    weights = rng.normal(0.0, 1.0, tuple(grid_shape) + (1 + dim,))
    cast = lambda a: np.asarray(a, dtype)
    return dict(
        x=cast(x),
        v=cast(v),
        mass=cast(mass),
        affine=cast(affine),
        weights=cast(weights),
        dx=dx,
        grid_shape=grid_shape,
        loops=loops,
        particles=n,
        contributions=contributions,
    )


def programs(prob, loops: int):
    """(one transfer, its gradient, `loops` forward transfers, `loops` forward+backward ones)."""
    import jax
    import jax.numpy as jnp

    dx, grid_shape = prob["dx"], prob["grid_shape"]
    weights = jnp.asarray(prob["weights"])

    def grid_of(x, v, mass, affine):
        return p2g(list(x), list(v), mass, [list(row) for row in affine], dx, grid_shape)

    def objective(x, v, mass, affine):
        # Quadratic in the grid, so that its gradient needs the grid itself, as a step's grid
        # update does (with a linear objective the forward scatter would be dead code).
        grid = grid_of(x, v, mass, affine)
        return jnp.vdot(grid * grid, weights)

    gradient = jax.grad(objective, argnums=(0, 1))
    value_and_gradient = jax.value_and_grad(objective, argnums=(0, 1))

    # The positions are carried from transfer to transfer, moved by up to 1e-3 dx by each result
    # (as a rollout carries its state: nothing can be hoisted out of the loop). Slicing K position
    # sets out of a (K, d, n) input instead made XLA:CPU fuse that dynamic slice into every
    # consumer, which made a transfer 1.3-5x slower than alone.
    def loop(total_of):
        def run(x, v, mass, affine):
            def body(_, carry):
                total, x = carry
                value = total_of(x, v, mass, affine)
                return total + value, x + (1e-3 * dx) * jnp.tanh(value)

            return jax.lax.fori_loop(0, loops, body, (jnp.zeros((), x.dtype), x))[0]

        return run

    def forward_backward_total(x, v, mass, affine):
        value, (gx, gv) = value_and_gradient(x, v, mass, affine)
        return value + jnp.sum(gx) + jnp.sum(gv)

    return grid_of, gradient, loop(objective), loop(forward_backward_total)


def _close(a, b, what):
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    scale = float(np.max(np.abs(b))) or 1.0
    np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5 * scale, err_msg=what)


def measure(name: str, variants, repeats: int, one_hot_max_nodes: int) -> dict:
    import jax

    prob = problem(name)
    nodes = math.prod(prob["grid_shape"])
    variants = [v for v in variants if v not in ONE_HOT or nodes <= one_hot_max_nodes]
    args = tuple(jax.numpy.asarray(prob[k]) for k in ("x", "v", "mass", "affine"))
    compiled, results, reference, loops_of = {}, {}, None, {}
    for variant in variants:
        # The explicit one-hot takes ~1000x longer: fewer transfers per timed call.
        loops = min(prob["loops"], SLOW_LOOPS) if variant == "one_hot" else prob["loops"]
        loops_of[variant] = loops
        with scatter_as(variant):
            grid_of, gradient, forward, forward_backward = programs(prob, loops)
            grid = jax.jit(grid_of)(*args)
            grads = jax.jit(gradient)(*args)
            start = time.perf_counter()
            fwd = jax.jit(forward).lower(*args).compile()
            compile_forward = time.perf_counter() - start
            start = time.perf_counter()
            fwd_bwd = jax.jit(forward_backward).lower(*args).compile()
            compile_forward_backward = time.perf_counter() - start
        if reference is None:
            reference = (grid, grads)
        elif variant != "no_scatter":  # every variant must compute the same transfer
            _close(grid, reference[0], f"{name}: {variant}'s grid")
            for got, want, what in zip(grads, reference[1], ("positions", "velocities"), strict=True):
                _close(got, want, f"{name}: {variant}'s gradient for the {what}")
        jax.block_until_ready((fwd(*args), fwd_bwd(*args)))  # warm-up
        compiled[variant] = (fwd, fwd_bwd)
        results[variant] = {
            "transfers_per_call": loops,
            "compile_forward_s": round(compile_forward, 2),
            "compile_forward_backward_s": round(compile_forward_backward, 2),
        }
    times = {variant: ([], []) for variant in variants}
    for _ in range(repeats):
        for variant in variants:  # in turn, so that a slow spell of the machine hits all alike
            for program, store in zip(compiled[variant], times[variant], strict=True):
                start = time.perf_counter()
                jax.block_until_ready(program(*args))
                store.append((time.perf_counter() - start) / loops_of[variant])
    base = statistics.median(times[variants[0]][1]) if variants[0] == "window" else None
    for variant in variants:
        forward_us = statistics.median(times[variant][0]) * 1e6
        forward_backward_us = statistics.median(times[variant][1]) * 1e6
        results[variant].update(
            forward_us=round(forward_us, 1),
            forward_backward_us=round(forward_backward_us, 1),
            ratio_vs_window=(None if base is None else round(forward_backward_us / (base * 1e6), 3)),
        )
    return {
        "particles": prob["particles"],
        "grid_shape": list(prob["grid_shape"]),
        "contributions": prob["contributions"],
        "repeats": repeats,
        "variants": results,
    }


def main(argv=None):
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--quick", action="store_true", help=f"sizes {' '.join(QUICK_SIZES)}")
    parser.add_argument(
        "--sizes",
        nargs="+",
        choices=SIZES + ("quadruped16",),
        default=None,
        help=f"default: {' '.join(SIZES)}",
    )
    parser.add_argument(
        "--variants",
        nargs="+",
        choices=VARIANTS,
        default=list(VARIANTS),
        help="window (litl's) is the reference and always runs first",
    )
    parser.add_argument("--repeats", type=int, default=7, help="timed runs per measurement (>= 1)")
    parser.add_argument(
        "--one-hot-max-nodes",
        type=int,
        default=64 * 64,
        help="largest grid (nodes) the one-hot variants run on",
    )
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be positive")
    import jax

    sizes = args.sizes or (QUICK_SIZES if args.quick else SIZES)
    variants = ["window"] + [v for v in args.variants if v != "window"]
    device = jax.devices()[0]
    results = {
        "device": {"platform": device.platform, "device_kind": device.device_kind, "jax": jax.__version__},
        "sizes": {name: measure(name, variants, args.repeats, args.one_hot_max_nodes) for name in sizes},
    }
    if args.json:
        print(json.dumps(results))
        return
    print_table(results, args.repeats)


def print_table(results: dict, repeats: int):
    device = results["device"]
    print(
        f"device: {device['device_kind']} ({device['platform']}), jax {device['jax']}; "
        f"microseconds per transfer, medians of {repeats}"
    )
    print(
        f"{'size':12s} {'particles':>9s} {'grid':>10s} {'variant':19s} {'forward_us':>11s} "
        f"{'fwd+bwd_us':>11s} {'vs_window':>9s} {'compile_s':>10s}"
    )
    for name, r in results["sizes"].items():
        grid = "x".join(map(str, r["grid_shape"]))
        for variant, t in r["variants"].items():
            compile_s = t["compile_forward_s"] + t["compile_forward_backward_s"]
            ratio = "" if t["ratio_vs_window"] is None else f"{t['ratio_vs_window']:.2f}"
            print(
                f"{name:12s} {r['particles']:9d} {grid:>10s} {variant:19s} "
                f"{t['forward_us']:11.1f} {t['forward_backward_us']:11.1f} {ratio:>9s} "
                f"{compile_s:10.2f}"
            )
    print(
        "vs_window: forward+backward time / window's; compile_s: forward and forward+backward loops together"
    )


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    main()
