"""Cost of one episode of Algorithm 1 on the biped: its optimization phase against its learning phase.

    python benchmarks/loop_speed.py                          # demo and paper resolution, 1 and 10 seeds
    python benchmarks/loop_speed.py --json
    python benchmarks/loop_speed.py --seeds 1 --dx 0.03125 --steps 100 --repeats 2   # smoke

For each resolution and seed count S (each in its own process, so peak memory is that of S alone),
with the VAE observer and the default `litl.config.Config` (10 iterations per episode; the learning phase
of `litl.config.LearningConfig`: minibatch 8, Adam 3e-3, at most 320 SGD steps, patience 100 steps; a 0.5
window around the robot), all S seeds vmapped:

  optimize_s         median wall time of one optimization iteration (closed-loop rollout with the
                     encoder in the loop, backpropagation to controller and design, Adam,
                     projection, snapshots into the buffer)
  episode_opt_s      iterations per episode x optimize_s: the optimization phase of an episode
  learn_s            median wall time of one whole learning phase (split, epochs with early
                     stopping, statistics, target update and its check: two forward
                     simulations, `loop.safeguards.update_tolerance`) on the replay buffer the optimization
                     filled (full: 500 snapshots), for all S seeds
  learn_steps        SGD steps that phase took (the most over seeds)
  learn_share        learn_s / episode_opt_s (the issue's target: <= 1)
  *_compile_s        lowering + compilation of each
  peak_rss_mb        peak resident memory of the process
  peak_device_mb     on a GPU, the device allocator's peak (null where the device reports none)
  device             platform, kind and count of the devices (the seeds run on the first one)
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import time

from fresh_process import measure_in_fresh_process

RESOLUTIONS = {"demo": 1 / 64, "paper": 1 / 128}


def _timed(function, *args):
    start = time.perf_counter()
    out = function(*args)
    import jax
    jax.block_until_ready(out)
    return out, time.perf_counter() - start


def measure(seeds: int, repeats: int, dx: float, steps: int | None) -> dict:
    import jax

    import litl.robots
    from litl.config import Config
    from litl.loop import make_algorithm, stack_seeds

    robot = litl.robots.get("biped", dx=dx)
    config = Config(seeds=seeds).replace(sim={"steps": steps})   # stride 20, capacity 500
    algorithm = make_algorithm(robot, config)
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

    start = time.perf_counter()
    learn = jax.jit(jax.vmap(algorithm.learn)).lower(state).compile()
    learn_compile = time.perf_counter() - start
    phases = []
    for _ in range(repeats):
        (_, stats), seconds = _timed(learn, state)
        phases.append(seconds)
    learn_s = statistics.median(phases)
    learn_steps = int((stats.epochs_used * stats.steps_per_epoch).max())
    episode_opt_s = config.loop.iterations * optimize_s
    device = jax.devices()[0]
    peak_device = (device.memory_stats() or {}).get("peak_bytes_in_use")   # None on CPU
    return {
        "seeds": seeds,
        "dx": dx,
        "particles": robot.layout.n_particles,
        "grid": list(robot.config.grid_shape),
        "window": list(algorithm.model.grid_shape),
        "steps": config.sim.steps or robot.steps,
        "buffer": int(state.buffer.count.min()),
        "optimize_s": round(optimize_s, 3),
        "optimize_compile_s": round(optimize_compile, 1),
        "episode_opt_s": round(episode_opt_s, 2),
        "learn_s": round(learn_s, 2),
        "learn_steps": learn_steps,
        "learn_share": round(learn_s / episode_opt_s, 2),
        "learn_compile_s": round(learn_compile, 1),
        "recon_explained": [round(float(v), 3) for v in stats.recon_explained],
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
        "peak_device_mb": None if peak_device is None else round(peak_device / 2**20),
        "device": {"platform": device.platform, "device_kind": device.device_kind,
                   "device_count": jax.device_count()},
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 10])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--dx", type=float, nargs="+", default=list(RESOLUTIONS.values()),
                        help="biped resolutions (default: demo 1/64 and paper 1/128)")
    parser.add_argument("--steps", type=int, default=None, help="rollout steps (default: 1 s)")
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.repeats < 1 or min(args.seeds) < 1 or min(args.dx) <= 0:
        parser.error("--repeats, --seeds and --dx must be positive")
    if args.one:
        print(json.dumps(measure(args.one, args.repeats, args.dx[0], args.steps)))
        return
    results = []
    for dx in args.dx:
        for seeds in args.seeds:
            arguments = ["--one", str(seeds), "--repeats", str(args.repeats), "--dx", str(dx)]
            arguments += ["--steps", str(args.steps)] if args.steps else []
            results.append(measure_in_fresh_process(__file__, arguments,
                                                    f"dx {dx}, {seeds} seeds"))
            if not args.json:
                r = results[-1]
                if len(results) == 1:
                    device = r["device"]
                    print(f"device: {device['device_kind']} ({device['platform']}, "
                          f"{device['device_count']} device(s); the seeds run on the first)")
                    print(f"{'dx':>7s} {'seeds':>5s} {'optimize_s':>10s} {'episode_s':>9s} "
                          f"{'learn_s':>8s} {'steps':>5s} {'share':>5s} {'compile_s':>13s} "
                          f"{'peak_MB':>8s}")
                print(f"1/{round(1 / r['dx']):<5d} {r['seeds']:5d} {r['optimize_s']:10.2f} "
                      f"{r['episode_opt_s']:9.2f} {r['learn_s']:8.2f} {r['learn_steps']:5d} "
                      f"{r['learn_share']:5.2f} {r['optimize_compile_s']:6.1f}/"
                      f"{r['learn_compile_s']:<6.1f} {r['peak_rss_mb']:8d}", flush=True)
    if args.json:
        print(json.dumps(results))


if __name__ == "__main__":
    main()
