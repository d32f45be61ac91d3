"""Peak memory of differentiating a long 3D rollout, with and without segment checkpointing.

    python benchmarks/memory_scale.py --particles 2000 --steps 64 --checkpoint-every none 8  # smoke
    python benchmarks/memory_scale.py --particles 100000 --steps 4096 --checkpoint-every none 64
    python benchmarks/memory_scale.py ... --json          # one JSON list, one object per setting
    python benchmarks/memory_scale.py --curves            # the curves below; --out DIR
    python benchmarks/memory_scale.py --curves --quick    # smoke: 1000 particles, 32/64 steps
    python benchmarks/memory_scale.py --replot DIR        # redraw DIR's figure from its JSON

`--curves` sweeps the horizon (--horizons, default 256 512 1024 2048 4096 steps at --particles,
default 10000) and the particle count (--particle-counts, default 10000 30000 100000 at --steps,
default 256), each point without segments and with K = `litl.sim.memory.square_root_segment(
steps, 1)` (≈ √steps), each in a fresh process. Per point: peak memory (resident on a CPU, the
allocator's `peak_bytes_in_use` on a GPU), XLA's planned temporaries, compile time, and the
median times of forward (the jitted loss) and forward+backward (its value_and_grad) over up to
--repeats runs (default 3; fewer once a measurement's runs took --repeat-budget s, default 60;
`forward_runs` and `forward_backward_runs` say how many), as particle-steps/s and their ratio.
A point whose kept states exceed --max-memory-gb (default 10), by the states' estimate before
starting or XLA's plan after compiling, is skipped and said so. It prints the device and a row
per point, and writes memory_scale.json, .csv and .png (memory and particle-steps/s against
steps and against particles) to --out (default outputs/memory_scale). Measured on the shared
2-core CPU (2026-11-25, 47 min; docs/results/2026-11-25-memory-and-speed.md): at 10,648
particles, XLA plans 276 -> 4020 MB from 256 to 4096 steps without segments (peak RSS 990 ->
4710 MB) and 58 -> 151 MB with K ≈ √steps (peak RSS 0.84-1.07 GB, mostly JAX and the
compiler); forward+backward takes 2.9-3.7 forward passes without segments and 4.2-4.4 with;
forward 0.53-1.19 and forward+backward 0.13-0.30 million particle-steps/s (higher with more
particles), the CPU shared with other jobs throughout.

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
import csv
import datetime
import json
import os
import resource
import statistics
import sys
import time

import numpy as np
from fresh_process import measure_in_fresh_process

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def _compile(function, argument):
    """(compiled `function` at `argument`, compile seconds, XLA's temporary bytes or None)."""
    import jax

    start = time.perf_counter()
    compiled = jax.jit(function).lower(argument).compile()
    compile_s = time.perf_counter() - start
    analysis = compiled.memory_analysis()
    temp = getattr(analysis, "temp_size_in_bytes", None) if analysis is not None else None
    return compiled, compile_s, temp


def _current_rss_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def stored_states_bytes(
    particles: int, steps: int, checkpoint_every: int | None, dim: int = 3, itemsize: int = 4
) -> int:
    """Bytes of the particle states reverse mode keeps (each step's input x, v, C, F).

    Args:
      particles: n.
      steps: T.
      checkpoint_every: K, or None for no segments (T states; else ceil(T / K) + K).
    """
    state = itemsize * particles * (2 * dim + 2 * dim * dim)
    kept = steps if not checkpoint_every else -(-steps // checkpoint_every) + checkpoint_every
    return kept * state


def measure(
    particles: int, steps: int, checkpoint_every: int | None, n_grid: int, compile_only: bool
) -> dict:
    import jax
    from sim_speed import block_problem, device_info

    _, gradient, youngs, n = block_problem(steps, particles, n_grid, checkpoint_every)
    compiled, compile_s, temp = _compile(gradient, youngs)
    result = {
        "particles": n,
        "steps": steps,
        "checkpoint_every": checkpoint_every,
        "grid": [n_grid] * 3,
        "compile_s": round(compile_s, 1),
        "xla_temp_mb": None if temp is None else round(temp / 2**20, 1),
        "stored_states_mb": round(stored_states_bytes(n, steps, checkpoint_every) / 2**20, 1),
        "rss_before_run_mb": round(_current_rss_mb(), 1),
        "device": device_info(),
    }
    if not compile_only:
        start = time.perf_counter()
        (_, health), _ = jax.block_until_ready(compiled(youngs))
        result["run_s"] = round(time.perf_counter() - start, 2)
        result["healthy"] = bool(
            np.asarray(health.first_nonfinite_step) < 0 and np.asarray(health.first_escape_step) < 0
        )
    stats = jax.devices()[0].memory_stats() or {}  # None on CPU
    peak = stats.get("peak_bytes_in_use")
    result["peak_device_mb"] = None if peak is None else round(peak / 2**20, 1)
    result["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    return result


# --curves: the default sweep (horizons at --particles, particle counts at --steps) and --quick's.
HORIZONS = (256, 512, 1024, 2048, 4096)
PARTICLE_COUNTS = (10_000, 30_000, 100_000)
QUICK = {"horizons": (32, 64), "particle_counts": (1000, 2000), "particles": 1000, "steps": 32, "grid": 32}
CSV_FIELDS = (
    "sweeps",
    "particles",
    "steps",
    "segments",
    "checkpoint_every",
    "grid",
    "peak_mb",
    "peak_rss_mb",
    "rss_before_run_mb",
    "peak_device_mb",
    "xla_temp_mb",
    "stored_states_mb",
    "forward_s",
    "forward_runs",
    "forward_backward_s",
    "forward_backward_runs",
    "forward_particle_steps_per_s",
    "forward_backward_particle_steps_per_s",
    "backward_forward_ratio",
    "compile_s",
    "forward_compile_s",
    "healthy",
    "skipped",
    "platform",
    "device_kind",
)


def _timed(function, argument, repeats: int, budget_s: float):
    """Run `function(argument)` up to `repeats` times, stopping early once the runs together
    took `budget_s`; (median seconds, number of runs, the last output)."""
    import jax

    times = []
    while len(times) < repeats:
        start = time.perf_counter()
        out = jax.block_until_ready(function(argument))
        times.append(time.perf_counter() - start)
        if sum(times) >= budget_s:
            break
    return statistics.median(times), len(times), out


def measure_curve_point(
    particles: int,
    steps: int,
    checkpoint_every: int | None,
    n_grid: int,
    repeats: int,
    repeat_budget_s: float,
    max_memory_mb: float,
) -> dict:
    """One point of --curves: compile the forward rollout and its value_and_grad, then time the
    forward (jitted rollout and loss) and forward+backward runs, the peak memory after both."""
    import jax
    from sim_speed import block_problem, device_info

    forward, gradient, youngs, n = block_problem(steps, particles, n_grid, checkpoint_every)
    gradient_compiled, compile_s, temp = _compile(gradient, youngs)
    start = time.perf_counter()
    forward_compiled = jax.jit(forward).lower(youngs).compile()
    forward_compile_s = time.perf_counter() - start
    result = {
        "particles": n,
        "steps": steps,
        "checkpoint_every": checkpoint_every,
        "grid": n_grid,
        "compile_s": round(compile_s, 2),
        "forward_compile_s": round(forward_compile_s, 2),
        "xla_temp_mb": None if temp is None else round(temp / 2**20, 1),
        "stored_states_mb": round(stored_states_bytes(n, steps, checkpoint_every) / 2**20, 1),
        "rss_before_run_mb": round(_current_rss_mb(), 1),
        "device": device_info(),
    }
    if temp is not None and temp / 2**20 > max_memory_mb:
        result["skipped"] = (
            f"XLA plans {temp / 2**30:.1f} GiB of temporaries, over --max-memory-gb {max_memory_mb / 1024:g}"
        )
    else:
        forward_s, forward_runs, (_, health) = _timed(forward_compiled, youngs, repeats, repeat_budget_s)
        backward_s, backward_runs, ((_, health_b), _) = _timed(
            gradient_compiled, youngs, repeats, repeat_budget_s
        )
        particle_steps = n * steps
        result.update(
            {
                "forward_s": round(forward_s, 4),
                "forward_runs": forward_runs,
                "forward_backward_s": round(backward_s, 4),
                "forward_backward_runs": backward_runs,
                "forward_particle_steps_per_s": float(f"{particle_steps / forward_s:.4g}"),
                "forward_backward_particle_steps_per_s": float(f"{particle_steps / backward_s:.4g}"),
                "backward_forward_ratio": round(backward_s / forward_s, 2),
                "healthy": bool(
                    all(
                        np.asarray(h.first_nonfinite_step) < 0 and np.asarray(h.first_escape_step) < 0
                        for h in (health, health_b)
                    )
                ),
            }
        )
    stats = jax.devices()[0].memory_stats() or {}  # None on CPU
    peak = stats.get("peak_bytes_in_use")
    result["peak_device_mb"] = None if peak is None else round(peak / 2**20, 1)
    result["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    return result


def _curve_points(horizons, particles, particle_counts, steps):
    """[(particles, steps, sweeps)]: the horizon sweep then the particle sweep, a point shared by
    both measured once."""
    points = {}
    for horizon in horizons:
        points.setdefault((particles, horizon), []).append("steps")
    for count in particle_counts:
        points.setdefault((count, steps), []).append("particles")
    return [(p, t, sweeps) for (p, t), sweeps in points.items()]


def _write_curves(out: str, header: dict, rows: list[dict]) -> None:
    with open(os.path.join(out, "memory_scale.json"), "w") as file:
        json.dump({**header, "points": rows}, file, indent=1)
    with open(os.path.join(out, "memory_scale.csv"), "w", newline="") as file:
        writer = csv.DictWriter(file, CSV_FIELDS, extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow(
                {
                    **row,
                    "sweeps": "+".join(row["sweeps"]),
                    "platform": row["device"]["platform"],
                    "device_kind": row["device"]["device_kind"],
                }
            )


def _plot_curves(path: str, header: dict, rows: list[dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    device = header["device"]
    on_device = any(r.get("peak_device_mb") is not None for r in rows)
    memory_label = (
        "MB: peak device memory (solid), XLA's plan (dotted)"
        if on_device
        else "MB: peak resident memory (solid), XLA's plan (dotted)"
    )
    figure, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    styles = {"none": ("C0", "no segments"), "sqrt": ("C3", "segments, K ≈ √steps")}
    for column, (sweep, x_key, fixed_key, x_label) in enumerate(
        [("steps", "steps", "particles", "steps (horizon)"), ("particles", "particles", "steps", "particles")]
    ):
        memory_axis, rate_axis = axes[0, column], axes[1, column]
        chosen = [r for r in rows if sweep in r["sweeps"]]
        fixed = sorted({r[fixed_key] for r in chosen})
        for segments, (colour, label) in styles.items():
            line = sorted((r for r in chosen if r["segments"] == segments), key=lambda r: r[x_key])
            measured = [r for r in line if r.get("peak_mb") is not None]
            memory_axis.plot(
                [r[x_key] for r in measured],
                [r["peak_mb"] for r in measured],
                "o-",
                color=colour,
                label=f"peak, {label}",
            )
            planned = [r for r in line if r.get("xla_temp_mb") is not None]
            memory_axis.plot(
                [r[x_key] for r in planned],
                [r["xla_temp_mb"] for r in planned],
                "^:",
                color=colour,
                label=f"XLA's planned temporaries, {label}",
            )
            timed = [r for r in line if r.get("forward_s") is not None]
            xs = [r[x_key] for r in timed]
            rate_axis.plot(
                xs,
                [r["forward_particle_steps_per_s"] / 1e6 for r in timed],
                "s--",
                color=colour,
                label=f"forward, {label}",
            )
            rate_axis.plot(
                xs,
                [r["forward_backward_particle_steps_per_s"] / 1e6 for r in timed],
                "o-",
                color=colour,
                label=f"forward+backward, {label}",
            )
            for r in line:
                if r.get("skipped"):
                    memory_axis.annotate(
                        f"{label}: skipped",
                        (r[x_key], 0.97),
                        xycoords=("data", "axes fraction"),
                        color=colour,
                        fontsize=8,
                        ha="right",
                        va="top",
                    )
        where = f"{fixed_key} = {', '.join(map(str, fixed))}"
        memory_axis.set(
            xscale="log",
            yscale="log",
            xlabel=x_label,
            ylabel=memory_label,
            title=f"peak memory vs {sweep} ({where})",
        )
        rate_axis.set(
            xscale="log",
            xlabel=x_label,
            ylabel="million particle-steps / s",
            title=f"throughput vs {sweep} ({where})",
        )
        rate_axis.set_ylim(bottom=0)
        xs = sorted({r[x_key] for r in chosen})
        for axis in (memory_axis, rate_axis):
            axis.minorticks_off()
            axis.set_xticks(xs, [str(x) for x in xs])
            axis.grid(alpha=0.3)
            axis.legend(fontsize=8)
        memory_axis.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda value, _: f"{value:g}"))
    figure.suptitle(
        f"memory_scale.py --curves: {device['device_kind']} ({device['platform']}), "
        f"{header['date']}; elastic block, grid {header['grid']}³, float32"
    )
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def curves(args) -> None:
    """--curves: each point in a fresh process, the table as it goes, JSON, CSV and a figure."""
    from litl.sim.memory import square_root_segment

    quick = QUICK if args.quick else {}
    horizons = args.horizons or quick.get("horizons", HORIZONS)
    counts = args.particle_counts or quick.get("particle_counts", PARTICLE_COUNTS)
    particles = args.particles or quick.get("particles", 10_000)
    steps = args.steps or quick.get("steps", 256)
    grid = args.grid or quick.get("grid", 64)
    out = args.out or os.path.join("outputs", "memory_scale_quick" if args.quick else "memory_scale")
    os.makedirs(out, exist_ok=True)
    device = measure_in_fresh_process(__file__, ["--device-info"], "device info")
    header = {
        "command": " ".join(
            ["python", "benchmarks/memory_scale.py", *(sys.argv[1:] if args.argv is None else args.argv)]
        ),
        "date": datetime.date.today().isoformat(),
        "device": device,
        "grid": grid,
        "repeats": args.repeats,
        "repeat_budget_s": args.repeat_budget,
        "max_memory_gb": args.max_memory_gb,
        "host_cpus": os.cpu_count(),
    }
    print(
        f"device: {device['device_kind']} ({device['platform']}, {device['device_count']} "
        f"device{'s' if device['device_count'] > 1 else ''}; the first one is used; "
        f"{os.cpu_count()} CPU cores); grid {grid}^3; medians of up to {args.repeats} runs "
        f"(fewer once they take {args.repeat_budget:g} s)",
        flush=True,
    )
    print(
        f"{'particles':>9s} {'steps':>5s} {'K':>4s} {'peak_MB':>8s} {'xla_MB':>8s} "
        f"{'fwd_s':>8s} {'f+b_s':>8s} {'runs':>5s} {'fwd_Mps/s':>9s} {'f+b_Mps/s':>9s} "
        f"{'f+b/fwd':>7s} {'compile_s':>9s}",
        flush=True,
    )
    show = lambda value, spec: "-" if value is None else format(value, spec)
    rows = []
    started = time.perf_counter()
    for n, horizon, sweeps in _curve_points(horizons, particles, counts, steps):
        for every in (None, square_root_segment(horizon, 1)):
            states_mb = stored_states_bytes(n, horizon, every) / 2**20
            if states_mb > 1024 * args.max_memory_gb:
                row = {
                    "particles": n,
                    "steps": horizon,
                    "checkpoint_every": every,
                    "grid": grid,
                    "stored_states_mb": round(states_mb, 1),
                    "device": device,
                    "skipped": f"the backward pass keeps ~{states_mb / 1024:.1f} GiB of "
                    f"states, over --max-memory-gb {args.max_memory_gb:g}",
                }
            else:
                arguments = [
                    "--one-curve",
                    "--particles",
                    str(n),
                    "--steps",
                    str(horizon),
                    "--grid",
                    str(grid),
                    "--checkpoint-every",
                    str(every).lower(),
                    "--repeats",
                    str(args.repeats),
                    "--repeat-budget",
                    str(args.repeat_budget),
                    "--max-memory-gb",
                    str(args.max_memory_gb),
                ]
                case = f"{n} particles, {horizon} steps, checkpoint_every={every}"
                try:
                    row = measure_in_fresh_process(__file__, arguments, case)
                except SystemExit as failure:  # out of memory, say: record it, go on
                    print(failure, file=sys.stderr)
                    row = {
                        "particles": n,
                        "steps": horizon,
                        "checkpoint_every": every,
                        "grid": grid,
                        "device": device,
                        "skipped": f"failed: {str(failure).splitlines()[-1][:200]}",
                    }
            row["sweeps"] = sweeps
            row["segments"] = "none" if every is None else "sqrt"
            if row.get("forward_s") is not None:
                row["peak_mb"] = (
                    row["peak_device_mb"] if row["peak_device_mb"] is not None else row["peak_rss_mb"]
                )
            rows.append(row)
            _write_curves(out, header, rows)
            runs = f"{row['forward_runs']}/{row['forward_backward_runs']}" if "forward_runs" in row else "-"
            rate = lambda key, row=row: None if row.get(key) is None else row[key] / 1e6
            print(
                f"{row['particles']:9d} {horizon:5d} {str(every or '-'):>4s} "
                f"{show(row.get('peak_mb'), '8.0f')} {show(row.get('xla_temp_mb'), '8.0f')} "
                f"{show(row.get('forward_s'), '8.2f')} "
                f"{show(row.get('forward_backward_s'), '8.2f')} {runs:>5s} "
                f"{show(rate('forward_particle_steps_per_s'), '9.3f')} "
                f"{show(rate('forward_backward_particle_steps_per_s'), '9.3f')} "
                f"{show(row.get('backward_forward_ratio'), '7.2f')} "
                f"{show(row.get('compile_s'), '9.1f')}",
                flush=True,
            )
            if row.get("skipped"):
                print(f"  skipped: {row['skipped']}", flush=True)
            elif row.get("healthy") is False:
                print("  (the rollout went non-finite or left the grid)", flush=True)
    header["sweep_s"] = round(time.perf_counter() - started, 1)
    _write_curves(out, header, rows)
    _plot_curves(os.path.join(out, "memory_scale.png"), header, rows)
    print(
        "K: segment length (checkpoint_every; - none); peak_MB: the device allocator's peak "
        "where it reports one, else the process's peak resident memory; xla_MB: XLA's planned "
        "temporaries of value_and_grad; runs: forward/forward+backward runs timed; Mps/s: "
        "million particle-steps per second"
    )
    print(
        f"sweep took {header['sweep_s'] / 60:.1f} min; wrote {out}/memory_scale.json, "
        f"memory_scale.csv, memory_scale.png"
    )


def _segments(text: str) -> int | None:
    if text.lower() == "none":
        return None
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"--checkpoint-every takes integers >= 1 or none, got {text}")
    return value


def main(argv=None):
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--particles",
        type=int,
        default=None,
        help="at least this many particles (rounded up to a cube of cells); "
        "default 100000, with --curves the horizon sweep's 10000",
    )
    parser.add_argument(
        "--steps", type=int, default=None, help="default 4096, with --curves the particle sweep's 256"
    )
    parser.add_argument(
        "--checkpoint-every",
        type=_segments,
        nargs="+",
        default=[None, 64],
        metavar="K",
        help="segment lengths to compare; none: no segments",
    )
    parser.add_argument("--grid", type=int, default=None, help="nodes per axis (default 64)")
    parser.add_argument(
        "--compile-only", action="store_true", help="report XLA's buffer plan without running the rollout"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON list")
    curve = parser.add_argument_group(
        "--curves: peak memory and particle-steps/s by horizon "
        "and by particle count, with and without segments"
    )
    curve.add_argument("--curves", action="store_true", help="run the sweep (see above)")
    curve.add_argument(
        "--quick",
        action="store_true",
        help="a tiny sweep to smoke-test --curves (1000 particles, 32/64 steps, grid 32^3)",
    )
    curve.add_argument(
        "--horizons",
        type=int,
        nargs="+",
        default=None,
        metavar="T",
        help=f"steps of the horizon sweep (default {' '.join(map(str, HORIZONS))})",
    )
    curve.add_argument(
        "--particle-counts",
        type=int,
        nargs="+",
        default=None,
        metavar="N",
        help=f"particles of the particle sweep (default {' '.join(map(str, PARTICLE_COUNTS))})",
    )
    curve.add_argument(
        "--repeats",
        type=int,
        default=3,
        help="timed runs per measurement after compilation, their median (default 3)",
    )
    curve.add_argument(
        "--repeat-budget",
        type=float,
        default=60.0,
        metavar="S",
        help="stop repeating a measurement once its runs took S seconds (default 60; at least one run)",
    )
    curve.add_argument(
        "--max-memory-gb",
        type=float,
        default=10.0,
        help="skip a point whose backward pass would keep more (the states' "
        "estimate, then XLA's plan; default 10)",
    )
    curve.add_argument(
        "--out",
        default=None,
        help="folder for memory_scale.json/.csv/.png (default "
        "outputs/memory_scale, or outputs/memory_scale_quick)",
    )
    curve.add_argument(
        "--replot",
        metavar="DIR",
        help="redraw DIR/memory_scale.png from DIR/memory_scale.json, measuring nothing",
    )
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)  # internal
    parser.add_argument("--one-curve", action="store_true", help=argparse.SUPPRESS)  # internal
    parser.add_argument("--device-info", action="store_true", help=argparse.SUPPRESS)  # internal
    args = parser.parse_args(argv)
    args.argv = argv
    if (
        any(
            value is not None and value < 1
            for value in (
                args.particles,
                args.steps,
                args.grid,
                *(args.horizons or ()),
                *(args.particle_counts or ()),
            )
        )
        or args.repeats < 1
    ):
        parser.error(
            "--particles, --steps, --grid, --horizons, --particle-counts and --repeats must be positive"
        )
    if args.device_info:
        from sim_speed import device_info

        print(json.dumps(device_info()))
        return
    if args.one_curve:
        print(
            json.dumps(
                measure_curve_point(
                    args.particles,
                    args.steps,
                    args.checkpoint_every[0],
                    args.grid,
                    args.repeats,
                    args.repeat_budget,
                    1024 * args.max_memory_gb,
                )
            )
        )
        return
    if args.replot:
        with open(os.path.join(args.replot, "memory_scale.json")) as file:
            saved = json.load(file)
        _plot_curves(os.path.join(args.replot, "memory_scale.png"), saved, saved["points"])
        return
    if args.curves or args.quick:
        curves(args)
        return
    args.particles = args.particles or 100_000
    args.steps = args.steps or 4096
    args.grid = args.grid or 64
    if args.one:
        print(
            json.dumps(
                measure(args.particles, args.steps, args.checkpoint_every[0], args.grid, args.compile_only)
            )
        )
        return
    results = []
    for every in args.checkpoint_every:
        arguments = [
            "--one",
            "--particles",
            str(args.particles),
            "--steps",
            str(args.steps),
            "--grid",
            str(args.grid),
            "--checkpoint-every",
            str(every).lower(),
        ]
        arguments += ["--compile-only"] if args.compile_only else []
        results.append(measure_in_fresh_process(__file__, arguments, f"checkpoint_every={every}"))
        if not args.json:
            r = results[-1]
            if len(results) == 1:
                device = r["device"]
                print(
                    f"device: {device['device_kind']} ({device['platform']}); "
                    f"{r['particles']} particles, {r['steps']} steps, grid {args.grid}^3"
                )
                print(
                    f"{'checkpoint_every':>16s} {'peak_rss_MB':>11s} {'before_run':>10s} "
                    f"{'device_MB':>9s} {'xla_temp_MB':>11s} {'states_MB':>9s} {'run_s':>7s} "
                    f"{'compile_s':>9s}"
                )
            show = lambda value, spec: "-" if value is None else format(value, spec)
            print(
                f"{str(r['checkpoint_every']):>16s} {r['peak_rss_mb']:11.0f} "
                f"{r['rss_before_run_mb']:10.0f} {show(r['peak_device_mb'], '9.0f')} "
                f"{show(r['xla_temp_mb'], '11.0f')} {r['stored_states_mb']:9.0f} "
                f"{show(r.get('run_s'), '7.2f')} {r['compile_s']:9.1f}",
                flush=True,
            )
            if r.get("healthy") is False:
                print("  (the rollout went non-finite or left the grid)")
    if args.json:
        print(json.dumps(results))


if __name__ == "__main__":
    main()
