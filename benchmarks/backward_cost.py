"""What a backward step costs in forward steps: the counting rule of the baseline comparison.

    python benchmarks/backward_cost.py                       # the demo biped, vae and kmeans
    python benchmarks/backward_cost.py --robot bunny --repeats 5 --json out.json
    python benchmarks/backward_cost.py --smoke               # seconds

For each observer, one seed's rollout as litl's loop runs it (`Algorithm.simulate`: the simulator,
the observer and the controller at every step) is timed forward (the task loss) and forward +
backward (`jax.value_and_grad` with respect to the controller and the design), each jitted and
compiled apart, medians of --repeats calls. ``backward_in_forward_steps`` = (forward+backward -
forward) / forward: what one simulated step of the backward pass costs in forward steps of the
same rollout. The baseline comparison counts a litl iteration as (1 + that) x steps.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import time

import jax


def measure(robot_name: str, observer: str, repeats: int, smoke: bool) -> dict:
    from litl.app import build_robot, compose
    from litl.loop.algorithm import make_algorithm

    overrides = [f"robot={robot_name}", f"observer={observer}"] + (["+scale=smoke"] if smoke else [])
    if observer == "none":
        overrides.append("controller=sinusoid")
    config = compose(overrides)
    robot = build_robot(config)
    algorithm = make_algorithm(robot, config.algorithm)
    state = algorithm.init(0)

    def loss(controller, design):
        return algorithm.simulate(controller, design, state.observer)[0]

    forward = jax.jit(loss)
    both = jax.jit(jax.value_and_grad(loss, argnums=(0, 1)))
    timings = {}
    for name, fn in (("forward", forward), ("forward_backward", both)):
        start = time.perf_counter()
        jax.block_until_ready(fn(state.controller, state.design))
        timings[f"{name}_compile_s"] = round(time.perf_counter() - start, 2)
        calls = []
        for _ in range(repeats):
            start = time.perf_counter()
            jax.block_until_ready(fn(state.controller, state.design))
            calls.append(time.perf_counter() - start)
        timings[f"{name}_s"] = statistics.median(calls)
    ratio = (timings["forward_backward_s"] - timings["forward_s"]) / timings["forward_s"]
    return {
        "robot": robot.name,
        "observer": observer,
        "steps": algorithm.steps,
        "dx": robot.config.dx,
        **{k: round(v, 4) for k, v in timings.items()},
        "backward_in_forward_steps": round(ratio, 2),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
    }


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--robot", default="biped")
    parser.add_argument("--observers", default="vae,kmeans")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--smoke", action="store_true", help="the robot at smoke scale")
    parser.add_argument("--json", help="write the rows to this file")
    args = parser.parse_args(argv)
    rows = [measure(args.robot, o, args.repeats, args.smoke) for o in args.observers.split(",")]
    print(
        "| robot | observer | steps | forward (s) | forward+backward (s) | backward / forward | compile (s) |"
    )
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        compile_s = f"{r['forward_compile_s']} / {r['forward_backward_compile_s']}"
        print(
            f"| {r['robot']} | {r['observer']} | {r['steps']} | {r['forward_s']} | "
            f"{r['forward_backward_s']} | {r['backward_in_forward_steps']} | {compile_s} |"
        )
    print(f"{jax.devices()[0].platform}, peak RSS {max(r['peak_rss_mb'] for r in rows)} MB")
    if args.json:
        with open(args.json, "w") as out:
            json.dump({"device": str(jax.devices()[0]), "rows": rows}, out, indent=1)


if __name__ == "__main__":
    main()
