"""Cost of Algorithm 1's two phases on the biped: one optimization iteration, one learning phase.

    python benchmarks/loop_speed.py                 # table: 1 seed and 10 vmapped seeds
    python benchmarks/loop_speed.py --json
    python benchmarks/loop_speed.py --seeds 1 --dx 0.03125 --steps 100 --repeats 2   # smoke

For each seed count S (each in its own process, so peak memory is that of S alone), with the VAE
observer and the default `LoopConfig` (latent 8, channels (8, 16, 32, 32, 64), replay capacity
500, snapshot every 20 steps):

  optimize_s        median wall time of one optimization iteration: a closed-loop rollout with the
                    encoder in the loop, backpropagation to controller and design, Adam, projection,
                    snapshots into the buffer — for all S seeds at once
  optimize_compile_s its lowering + compilation
  learn_epoch_s     median time of one learning epoch over a full buffer (the learning phase
                    is run with max_epochs = patience + 1 = 2 epochs and divided by 2)
  learn_compile_s   its lowering + compilation
  peak_rss_mb       peak resident memory of the process
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time


def measure(seeds: int, repeats: int, dx: float | None, steps: int | None) -> dict:
    import jax

    import litl.robots
    from litl.loop import LearningConfig, LoopConfig, make_algorithm, stack_seeds

    robot = litl.robots.get("biped", dx=dx)
    config = LoopConfig(seeds=seeds, steps=steps, snapshot_stride=20, replay_capacity=500,
                        learning=LearningConfig(max_epochs=2, patience=1, learning_rate=0.0))
    algorithm = make_algorithm(robot, config)
    state = stack_seeds([algorithm.init(s) for s in range(seeds)])
    optimize, learn = jax.vmap(algorithm.optimize), jax.vmap(algorithm.learn)

    start = time.perf_counter()
    optimize = jax.jit(optimize).lower(state).compile()
    optimize_compile = time.perf_counter() - start
    times = []
    # Fill the buffer while timing: 500 / (steps / 20) iterations fill it completely.
    per_rollout = (config.steps or robot.steps) // config.snapshot_stride
    fill = -(-config.replay_capacity // per_rollout)
    for _ in range(max(repeats, fill)):
        start = time.perf_counter()
        state, metrics = jax.block_until_ready(optimize(state))
        times.append(time.perf_counter() - start)
    optimize_s = statistics.median(times[:repeats])

    start = time.perf_counter()
    learn = jax.jit(learn).lower(state).compile()
    learn_compile = time.perf_counter() - start
    epochs = []
    for _ in range(repeats):
        start = time.perf_counter()
        _, stats = jax.block_until_ready(learn(state))
        epochs.append((time.perf_counter() - start) / max(int(stats.epochs_used.max()), 1))
    return {
        "seeds": seeds,
        "particles": robot.layout.n_particles,
        "grid": list(robot.config.grid_shape),
        "steps": config.steps or robot.steps,
        "buffer": int(state.buffer.count.min()),
        "optimize_s": round(optimize_s, 3),
        "optimize_compile_s": round(optimize_compile, 1),
        "learn_epoch_s": round(statistics.median(epochs), 3),
        "learn_compile_s": round(learn_compile, 1),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
        "device": jax.devices()[0].platform,
        "observer": config.observer,
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 10])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--dx", type=float, default=None, help="biped resolution (default 1/128)")
    parser.add_argument("--steps", type=int, default=None, help="rollout steps (default 1000)")
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.repeats < 1 or min(args.seeds) < 1:
        parser.error("--repeats and --seeds must be positive")
    if args.one:
        print(json.dumps(measure(args.one, args.repeats, args.dx, args.steps)))
        return
    results = []
    for seeds in args.seeds:
        command = [sys.executable, __file__, "--one", str(seeds), "--repeats", str(args.repeats)]
        command += ["--dx", str(args.dx)] if args.dx else []
        command += ["--steps", str(args.steps)] if args.steps else []
        done = subprocess.run(command, capture_output=True, text=True, env=os.environ.copy())
        if done.returncode:
            raise SystemExit(f"{seeds} seeds failed:\n{done.stderr[-4000:]}")
        results.append(json.loads(done.stdout.strip().splitlines()[-1]))
    if args.json:
        print(json.dumps(results))
        return
    print(f"{'seeds':>5s} {'optimize_s':>10s} {'compile_s':>9s} {'epoch_s':>8s} {'compile_s':>9s} "
          f"{'peak_MB':>8s}")
    for r in results:
        print(f"{r['seeds']:5d} {r['optimize_s']:10.2f} {r['optimize_compile_s']:9.1f} "
              f"{r['learn_epoch_s']:8.2f} {r['learn_compile_s']:9.1f} {r['peak_rss_mb']:8d}")


if __name__ == "__main__":
    main()
