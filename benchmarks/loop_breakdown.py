"""Where an optimization iteration's time goes: the simulation, the observer in the loop, the rest.

    python benchmarks/loop_breakdown.py                       # biped at dx 1/128, 1 and 10 seeds
    python benchmarks/loop_breakdown.py --seeds 10 --dx 0.0078125 --repeats 3 --json
    python benchmarks/loop_breakdown.py --seeds 1 --dx 0.03125 --steps 100 --repeats 2   # smoke

The same biped, steps and seeds (vmapped) in four programs, each compiled and timed on its own
(each in a fresh process, so its peak memory is its own):

  rollout_fb   the bare simulation's forward+backward: `jax.value_and_grad` of the task loss
               through the rollout with respect to the design, an open-loop sinusoid controller
               (no observer, no optimizer, no snapshots kept)
  none         one whole optimization iteration (`Algorithm.optimize`) with no observer and the
               sinusoid controller: the simulation plus Adam, projection, skip checks, metrics,
               the replay buffer's snapshots
  kmeans       the same with the k-means observer and the MLP controller (cheap features)
  vae          the same with the VAE observer (the method): its encoder runs at every step
               and is differentiated through

For each: `compile_s`, `median_s` (of --repeats calls after compilation), `hlo_kb` (the compiled
program's text size, a proxy for its size), `flops` (XLA's cost analysis, where it reports one),
`peak_rss_mb`. The breakdown then reads: simulation = rollout_fb; loop overhead without observer
= none - rollout_fb; the observer's and controller's share = vae - none (or kmeans - none).
The run shell's host work per iteration (metrics to numpy, JSON lines) is timed apart as
`host_s` (the records of one iteration written to a throwaway file).
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import tempfile
import time

from fresh_process import measure_in_fresh_process

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)

PROGRAMS = ("rollout_fb", "none", "kmeans", "vae")


def _config(program: str, seeds: int, steps: int | None):
    from litl.config import Config

    config = Config().replace(seeds=seeds, sim={"steps": steps})
    if program in ("rollout_fb", "none"):
        return config.replace(observer={"kind": "none"}, controller={"kind": "sinusoid"})
    return config.replace(observer={"kind": program})


def measure(program: str, seeds: int, dx: float, steps: int | None, repeats: int) -> dict:
    import jax
    import numpy as np

    import litl.robots
    from litl.loop import make_algorithm, stack_seeds
    from litl.loop.run import iteration_records

    robot = litl.robots.get("biped", dx=dx)
    config = _config(program, seeds, steps)
    algorithm = make_algorithm(robot, config.algorithm)
    state = stack_seeds([algorithm.init(s) for s in range(seeds)])
    if program == "rollout_fb":

        def loss(state):
            return algorithm.simulate(state.controller, state.design, state.observer)[0]

        function = jax.jit(
            jax.vmap(jax.value_and_grad(lambda design, state: loss(state.replace(design=design))))
        )
        arguments = (state.design, state)
    else:
        function = jax.jit(jax.vmap(algorithm.optimize))
        arguments = (state,)
    start = time.perf_counter()
    compiled = function.lower(*arguments).compile()
    compile_s = time.perf_counter() - start
    out = jax.block_until_ready(compiled(*arguments))
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        out = jax.block_until_ready(compiled(*arguments))
        times.append(time.perf_counter() - start)
    host_s = None
    if program != "rollout_fb":
        _, metrics = out
        start = time.perf_counter()
        metrics = jax.tree.map(np.asarray, metrics)
        records = iteration_records(
            metrics,
            jax.tree.map(np.asarray, state.stats),
            np.asarray(state.design),
            list(range(seeds)),
            (0, 0, 0),
            None,
            0.0,
            algorithm.observer.learner,
        )
        with tempfile.TemporaryFile("w") as sink:
            sink.writelines(json.dumps(r) + "\n" for r in records)
        host_s = time.perf_counter() - start
    cost = compiled.cost_analysis()
    cost = cost[0] if isinstance(cost, list) and cost else cost
    flops = (cost or {}).get("flops") if isinstance(cost, dict) else None
    return {
        "program": program,
        "seeds": seeds,
        "dx": dx,
        "particles": robot.layout.n_particles,
        "steps": algorithm.steps,
        "compile_s": round(compile_s, 1),
        "median_s": round(statistics.median(times), 4),
        "host_s": None if host_s is None else round(host_s, 4),
        "hlo_kb": round(len(compiled.as_text()) / 1024),
        "flops": None if flops is None else float(flops),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
        "device": jax.devices()[0].device_kind,
    }


def main(argv=None):
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 10])
    parser.add_argument("--dx", type=float, default=1 / 128, help="the biped's grid spacing (default 1/128)")
    parser.add_argument("--steps", type=int, default=None, help="rollout steps (default: the robot's 1 s)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--programs", nargs="+", choices=PROGRAMS, default=list(PROGRAMS))
    parser.add_argument("--one", nargs=2, help=argparse.SUPPRESS)  # internal: PROGRAM SEEDS
    args = parser.parse_args(argv)
    if args.repeats < 1 or min(args.seeds) < 1 or args.dx <= 0 or (args.steps is not None and args.steps < 1):
        parser.error("--repeats, --seeds, --dx and --steps must be positive")
    if args.one:
        print(json.dumps(measure(args.one[0], int(args.one[1]), args.dx, args.steps, args.repeats)))
        return
    results = []
    for seeds in args.seeds:
        for program in args.programs:
            arguments = ["--one", program, str(seeds), "--dx", str(args.dx), "--repeats", str(args.repeats)]
            arguments += ["--steps", str(args.steps)] if args.steps else []
            results.append(measure_in_fresh_process(__file__, arguments, f"{program}, {seeds} seeds"))
            if not args.json:
                r = results[-1]
                host = "" if r["host_s"] is None else f"{r['host_s'] * 1000:8.1f}"
                print(
                    f"{r['seeds']:3d} seeds  {r['program']:<10s} {r['median_s']:8.3f} s  compile "
                    f"{r['compile_s']:6.1f} s  host ms {host:>8s}  HLO {r['hlo_kb']:6d} KB  "
                    f"peak {r['peak_rss_mb']:6d} MB",
                    flush=True,
                )
    if args.json:
        print(json.dumps(results))


if __name__ == "__main__":
    main()
