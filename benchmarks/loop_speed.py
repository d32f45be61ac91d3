"""Cost of one episode of Algorithm 1 on the biped: its optimization phase against its learning phase.

    python benchmarks/loop_speed.py                          # demo and paper resolution, 1 and 10 seeds
    python benchmarks/loop_speed.py --json
    python benchmarks/loop_speed.py --seeds 1 --dx 0.03125 --steps 100 --repeats 2   # smoke
    python benchmarks/loop_speed.py --method paper --seeds 10 --dx 0.015625 --at-once 1 10

For each resolution and seed count S (each in its own process, so peak memory is that of S alone),
with the VAE observer and the defaults of --method (litl: 10 iterations per episode; the learning
phase of `litl.config.LearningConfig`: minibatch 8, Adam 3e-3, at most 320 SGD steps, patience 100
steps; a 0.5 window around the robot. paper: the whole grid, epochs only, at most 100, patience 5),
all S seeds vmapped in the optimization; the learning phase once per --at-once value A
(`loop.learning_seeds_at_once`: A seeds' phases vmapped together, the groups one after another):

  optimize_s         median wall time of one optimization iteration (closed-loop rollout with the
                     encoder in the loop, backpropagation to controller and design, Adam,
                     projection, snapshots into the buffer)
  episode_opt_s      iterations per episode x optimize_s: the optimization phase of an episode
  learn_s            {A: median wall time of one whole learning phase (split, epochs with early
                     stopping, statistics, target update and its check: two forward
                     simulations, `loop.safeguards.update_tolerance`) on the replay buffer the
                     optimization filled (full: 500 snapshots), for all S seeds}
  learn_steps        SGD steps that phase took (the most over seeds; a vmapped group runs this many)
  learn_steps_mean   SGD steps per seed, the mean (one seed at a time runs S x this many)
  learn_share        the fastest learn_s / episode_opt_s (the issue's target: <= 1)
  *_compile_s        lowering + compilation of each
  peak_rss_mb        peak resident memory of the process
  peak_device_mb     on a GPU, the device allocator's peak (null where the device reports none)
  device             platform, kind and count of the devices (the seeds run on the first one)
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import time

from fresh_process import measure_in_fresh_process

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)

RESOLUTIONS = {"demo": 1 / 64, "paper": 1 / 128}


def _timed(function, *args):
    start = time.perf_counter()
    out = function(*args)
    import jax

    jax.block_until_ready(out)
    return out, time.perf_counter() - start


def measure(
    seeds: int,
    repeats: int,
    dx: float,
    steps: int | None,
    method: str = "litl",
    at_once: tuple[int, ...] = (1,),
) -> dict:
    import functools

    import jax

    import litl.robots
    from litl.config import Config
    from litl.loop import make_algorithm, stack_seeds

    robot = litl.robots.get("biped", dx=dx)
    config = Config.for_method(method).replace(seeds=seeds, sim={"steps": steps})  # stride 20,
    # capacity 500
    algorithm = make_algorithm(robot, config.algorithm)
    state = stack_seeds([algorithm.init(s) for s in range(seeds)])
    state, _ = jax.jit(jax.vmap(algorithm.bootstrap))(state)

    start = time.perf_counter()
    optimize = jax.jit(jax.vmap(algorithm.optimize)).lower(state).compile()
    optimize_compile = time.perf_counter() - start
    # Fill the buffer while timing: 500 / (steps / 20) iterations fill it completely.
    per_rollout = (config.sim.steps or robot.steps) // config.loop.snapshot_stride
    fill = -(-config.loop.buffer_capacity // per_rollout)
    times = []
    for _ in range(max(repeats, fill)):
        (state, _), seconds = _timed(optimize, state)
        times.append(seconds)
    optimize_s = statistics.median(times[:repeats])

    learn_s, learn_compile = {}, {}
    for group in sorted({min(a, seeds) for a in at_once}):
        start = time.perf_counter()
        learn = jax.jit(functools.partial(algorithm.learn_seeds, at_once=group)).lower(state).compile()
        learn_compile[group] = round(time.perf_counter() - start, 1)
        phases = []
        for _ in range(repeats):
            (_, stats), seconds = _timed(learn, state)
            phases.append(seconds)
        learn_s[group] = round(statistics.median(phases), 2)
    steps_taken = stats["epochs_used"] * stats["steps_per_epoch"]
    episode_opt_s = config.loop.iterations * optimize_s
    device = jax.devices()[0]
    peak_device = (device.memory_stats() or {}).get("peak_bytes_in_use")  # None on CPU
    return {
        "seeds": seeds,
        "dx": dx,
        "method": method,
        "particles": robot.layout.n_particles,
        "grid": list(robot.config.grid_shape),
        "window": list(algorithm.model.grid_shape),
        "steps": config.sim.steps or robot.steps,
        "buffer": int(state.buffer.count.min()),
        "optimize_s": round(optimize_s, 3),
        "optimize_compile_s": round(optimize_compile, 1),
        "episode_opt_s": round(episode_opt_s, 2),
        "learn_s": learn_s,
        "learn_steps": int(steps_taken.max()),
        "learn_steps_mean": round(float(steps_taken.mean()), 1),
        "learn_share": round(min(learn_s.values()) / episode_opt_s, 2),
        "learn_compile_s": learn_compile,
        "recon_explained": [round(float(v), 3) for v in stats["recon_explained"]],
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
        "peak_device_mb": None if peak_device is None else round(peak_device / 2**20),
        "device": {
            "platform": device.platform,
            "device_kind": device.device_kind,
            "device_count": jax.device_count(),
            "determinism": litl.backend.mode(),
            "xla_flags": os.environ.get("XLA_FLAGS", ""),
        },
    }


def main(argv=None):
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 10])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--dx",
        type=float,
        nargs="+",
        default=list(RESOLUTIONS.values()),
        help="biped resolutions (default: demo 1/64 and paper 1/128)",
    )
    parser.add_argument("--steps", type=int, default=None, help="rollout steps (default: 1 s)")
    parser.add_argument("--method", choices=("litl", "paper"), default="litl")
    parser.add_argument(
        "--at-once",
        type=int,
        nargs="+",
        default=[1, 10],
        help="learning phases run this many seeds together (default: 1 and 10)",
    )
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.repeats < 1 or min(args.seeds) < 1 or min(args.dx) <= 0 or min(args.at_once) < 1:
        parser.error("--repeats, --seeds, --dx and --at-once must be positive")
    if args.one:
        print(
            json.dumps(
                measure(args.one, args.repeats, args.dx[0], args.steps, args.method, tuple(args.at_once))
            )
        )
        return
    results = []
    for dx in args.dx:
        for seeds in args.seeds:
            arguments = ["--one", str(seeds), "--repeats", str(args.repeats), "--dx", str(dx)]
            arguments += ["--steps", str(args.steps)] if args.steps else []
            arguments += ["--method", args.method, "--at-once", *map(str, args.at_once)]
            results.append(measure_in_fresh_process(__file__, arguments, f"dx {dx}, {seeds} seeds"))
            if not args.json:
                r = results[-1]
                if len(results) == 1:
                    device = r["device"]
                    print(
                        f"device: {device['device_kind']} ({device['platform']}, "
                        f"{device['device_count']} device(s); the seeds run on the first)"
                    )
                    print(
                        f"{'dx':>7s} {'seeds':>5s} {'optimize_s':>10s} {'episode_s':>9s} "
                        f"{'learn_s by seeds at once':>26s} {'steps max/mean':>14s} "
                        f"{'share':>5s} {'optimize compile_s':>18s} {'peak_MB':>8s}"
                    )
                learn = " ".join(f"{a}:{t:.1f}" for a, t in r["learn_s"].items())
                print(
                    f"1/{round(1 / r['dx']):<5d} {r['seeds']:5d} {r['optimize_s']:10.2f} "
                    f"{r['episode_opt_s']:9.2f} {learn:>26s} "
                    f"{r['learn_steps']:>6d}/{r['learn_steps_mean']:<7.0f} "
                    f"{r['learn_share']:5.2f} {r['optimize_compile_s']:18.1f} "
                    f"{r['peak_rss_mb']:8d}",
                    flush=True,
                )
    if args.json:
        print(json.dumps(results))


if __name__ == "__main__":
    main()
