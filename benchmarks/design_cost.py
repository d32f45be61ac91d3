"""What each design space costs a co-design iteration: a rollout's forward and forward+backward.

    python benchmarks/design_cost.py                         # the demo biped, every design space
    python benchmarks/design_cost.py --robot quadruped --designs modulus,all --repeats 3
    python benchmarks/design_cost.py --smoke                 # seconds

For each design space (``design=<name>``, `litl.designs`), one seed's rollout as litl's loop runs
it (`Algorithm.simulate`, observer `--observer`) is timed forward (the task loss) and forward +
backward (`jax.value_and_grad` with respect to the controller and the design φ), each jitted and
compiled apart, medians of --repeats calls after the compilation; ``vs_modulus`` is the
forward+backward time over the default space's. Each design space is measured in a fresh process
(`fresh_process.py`), so that its peak RSS is its own.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import time

import jax

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def measure(robot_name: str, design: str, observer: str, repeats: int, smoke: bool) -> dict:
    from litl.app import build_robot, compose
    from litl.loop.algorithm import make_algorithm

    overrides = [f"robot={robot_name}", f"observer={observer}", f"design={design}"]
    overrides += ["+scale=smoke"] if smoke else []
    config = compose(overrides)
    robot = build_robot(config)
    algorithm = make_algorithm(robot, config.algorithm)
    state = algorithm.init(0)

    def loss(controller, phi):
        return algorithm.simulate(controller, phi, state.observer)[0]

    timings = {}
    for name, fn in (
        ("forward", jax.jit(loss)),
        ("forward_backward", jax.jit(jax.value_and_grad(loss, (0, 1)))),
    ):
        start = time.perf_counter()
        jax.block_until_ready(fn(state.controller, state.design))
        timings[f"{name}_compile_s"] = round(time.perf_counter() - start, 2)
        calls = []
        for _ in range(repeats):
            start = time.perf_counter()
            jax.block_until_ready(fn(state.controller, state.design))
            calls.append(time.perf_counter() - start)
        timings[f"{name}_s"] = round(statistics.median(calls), 4)
    return {
        "robot": robot.name,
        "design": design,
        "design_variables": sum(x.size for x in jax.tree.leaves(state.design)),
        "steps": algorithm.steps,
        **timings,
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
    }


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--robot", default="biped")
    parser.add_argument("--designs", default="modulus,actuators,geometry,all")
    parser.add_argument("--observer", default="vae")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--smoke", action="store_true", help="the robot at smoke scale")
    parser.add_argument("--json", help="write the rows to this file")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # one design space, in this process
    args = parser.parse_args(argv)
    if args.one:
        print(json.dumps(measure(args.robot, args.one, args.observer, args.repeats, args.smoke)))
        return
    from fresh_process import measure_in_fresh_process

    common = ["--robot", args.robot, "--observer", args.observer, "--repeats", str(args.repeats)]
    common += ["--smoke"] if args.smoke else []
    rows = [
        measure_in_fresh_process(__file__, [*common, "--one", d], f"design={d}")
        for d in args.designs.split(",")
    ]
    base = next((r["forward_backward_s"] for r in rows if r["design"] == "modulus"), None)
    print(
        "| design | φ size | forward (s) | forward+backward (s) | vs modulus | compile f / f+b (s) | peak |"
    )
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        ratio = f"{r['forward_backward_s'] / base:.2f}x" if base else "n/a"
        print(
            f"| {r['design']} | {r['design_variables']} | {r['forward_s']} | {r['forward_backward_s']} | "
            f"{ratio} | {r['forward_compile_s']} / {r['forward_backward_compile_s']} | "
            f"{r['peak_rss_mb']} MB |"
        )
    print(f"{args.robot}, {rows[0]['steps']} steps, observer {args.observer}, {jax.devices()[0].platform}")
    if args.json:
        with open(args.json, "w") as out:
            json.dump({"device": str(jax.devices()[0]), "rows": rows}, out, indent=1)


if __name__ == "__main__":
    main()
