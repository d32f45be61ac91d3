"""Peak memory of differentiating a long 3D rollout, with and without segment checkpointing.

    python benchmarks/memory_scale.py --particles 2000 --steps 64 --checkpoint-every none 8  # smoke
    python benchmarks/memory_scale.py --particles 100000 --steps 4096 --checkpoint-every none 64
    python benchmarks/memory_scale.py ... --json          # one JSON list, one object per setting

The second line is issue 13's case (>= 100k particles x 4096 steps within 20 GB): the elastic
block of `sim_speed.block_scene` (24^3 cells x 8 = 110,592 particles for 100000, on a 64^3 grid by
default), its mean final position differentiated for every particle's Young's modulus. Without
segments, reverse mode keeps each step's input, once per step: the particle state (3 + 3 + 9 + 9
floats per particle), 10.1 MiB per step there, 40.5 GiB for 4096 steps. A policy that reads the
grid velocity (an observer in the loop) adds it too, 3 floats per node (3 MiB on 64^3); this
scene's policy does not. `--checkpoint-every K` (`make_rollout(..., checkpoint_every=K)`) keeps
one state per K steps plus the K of the segment being differentiated, at the price of one more
forward pass: for K = 64 = sqrt(4096), 128 states, 1.3 GiB. `--compile-only` reports XLA's
buffer plan without running (about 20 s of compilation per setting); for that case on XLA:CPU
(2026-11-23) it plans 41,661 MiB of temporaries without segments and 1,485 MiB with K = 64. The
run with K = 64 (2-core CPU, 2026-11-24): peak_rss_mb 2275 (787 before the run), healthy, run_s
2045 with the CPU shared with other runs for most of it; without segments (~41 GiB) it was not
run on this 24 GB machine.

Each setting runs in a fresh process (so that its peak is its own) and reports:
  peak_rss_mb         peak resident memory of the process (compilation included; JAX and XLA
                      alone take ~400 MB on CPU)
  rss_before_run_mb   resident memory after compilation, before the run
  peak_device_mb      on a GPU, the allocator's `peak_bytes_in_use` (null where not reported)
  xla_temp_mb         XLA's planned temporary buffers for the compiled value_and_grad (from
                      `compiled.memory_analysis()`; null where the backend gives none)
  stored_states_mb    the estimate above: particle states kept for the backward pass x their size
  run_s, compile_s    wall time of the value_and_grad run and of its compilation
  healthy             whether the rollout stayed finite and inside the grid
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import time

import numpy as np

from fresh_process import measure_in_fresh_process


def _current_rss_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def stored_states_bytes(particles: int, steps: int, checkpoint_every: int | None,
                        dim: int = 3, itemsize: int = 4) -> int:
    """Bytes of the particle states reverse mode keeps (each step's input x, v, C, F).

    Args:
      particles: n.
      steps: T.
      checkpoint_every: K, or None for no segments (T states; else ceil(T / K) + K).
    """
    state = itemsize * particles * (2 * dim + 2 * dim * dim)
    kept = steps if not checkpoint_every else -(-steps // checkpoint_every) + checkpoint_every
    return kept * state


def measure(particles: int, steps: int, checkpoint_every: int | None, n_grid: int,
            compile_only: bool) -> dict:
    import jax

    from sim_speed import block_problem, device_info

    _, gradient, youngs, n = block_problem(steps, particles, n_grid, checkpoint_every)
    start = time.perf_counter()
    compiled = jax.jit(gradient).lower(youngs).compile()
    compile_s = time.perf_counter() - start
    analysis = compiled.memory_analysis()
    temp = getattr(analysis, "temp_size_in_bytes", None) if analysis is not None else None
    result = {
        "particles": n,
        "steps": steps,
        "checkpoint_every": checkpoint_every,
        "grid": [n_grid] * 3,
        "compile_s": round(compile_s, 1),
        "xla_temp_mb": None if temp is None else round(temp / 2**20, 1),
        "stored_states_mb": round(
            stored_states_bytes(n, steps, checkpoint_every) / 2**20, 1),
        "rss_before_run_mb": round(_current_rss_mb(), 1),
        "device": device_info(),
    }
    if not compile_only:
        start = time.perf_counter()
        (_, health), _ = jax.block_until_ready(compiled(youngs))
        result["run_s"] = round(time.perf_counter() - start, 2)
        result["healthy"] = bool(np.asarray(health.first_nonfinite_step) < 0
                                 and np.asarray(health.first_escape_step) < 0)
    stats = jax.devices()[0].memory_stats() or {}           # None on CPU
    peak = stats.get("peak_bytes_in_use")
    result["peak_device_mb"] = None if peak is None else round(peak / 2**20, 1)
    result["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    return result


def _segments(text: str) -> int | None:
    if text.lower() == "none":
        return None
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"--checkpoint-every takes integers >= 1 or none, "
                                         f"got {text}")
    return value


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--particles", type=int, default=100_000,
                        help="at least this many particles (rounded up to a cube of cells)")
    parser.add_argument("--steps", type=int, default=4096)
    parser.add_argument("--checkpoint-every", type=_segments, nargs="+", default=[None, 64],
                        metavar="K", help="segment lengths to compare; none: no segments")
    parser.add_argument("--grid", type=int, default=64, help="nodes per axis (default 64)")
    parser.add_argument("--compile-only", action="store_true",
                        help="report XLA's buffer plan without running the rollout")
    parser.add_argument("--json", action="store_true", help="print one JSON list")
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)  # internal
    args = parser.parse_args(argv)
    if args.particles < 1 or args.steps < 1:
        parser.error("--particles and --steps must be positive")
    if args.one:
        print(json.dumps(measure(args.particles, args.steps, args.checkpoint_every[0], args.grid,
                                 args.compile_only)))
        return
    results = []
    for every in args.checkpoint_every:
        arguments = ["--one", "--particles", str(args.particles), "--steps", str(args.steps),
                     "--grid", str(args.grid), "--checkpoint-every", str(every).lower()]
        arguments += ["--compile-only"] if args.compile_only else []
        results.append(measure_in_fresh_process(__file__, arguments, f"checkpoint_every={every}"))
        if not args.json:
            r = results[-1]
            if len(results) == 1:
                device = r["device"]
                print(f"device: {device['device_kind']} ({device['platform']}); "
                      f"{r['particles']} particles, {r['steps']} steps, grid {args.grid}^3")
                print(f"{'checkpoint_every':>16s} {'peak_rss_MB':>11s} {'before_run':>10s} "
                      f"{'device_MB':>9s} {'xla_temp_MB':>11s} {'states_MB':>9s} {'run_s':>7s} "
                      f"{'compile_s':>9s}")
            show = lambda value, spec: "-" if value is None else format(value, spec)
            print(f"{str(r['checkpoint_every']):>16s} {r['peak_rss_mb']:11.0f} "
                  f"{r['rss_before_run_mb']:10.0f} {show(r['peak_device_mb'], '9.0f')} "
                  f"{show(r['xla_temp_mb'], '11.0f')} {r['stored_states_mb']:9.0f} "
                  f"{show(r.get('run_s'), '7.2f')} {r['compile_s']:9.1f}", flush=True)
            if r.get("healthy") is False:
                print("  (the rollout went non-finite or left the grid)")
    if args.json:
        print(json.dumps(results))


if __name__ == "__main__":
    main()
