"""What a latent planner costs per control step, against the references, on a trained run.

    python benchmarks/planning_cost.py RUN_DIR                     # latent_mpc, latent_lqr, rest, oracle_mpc
    python benchmarks/planning_cost.py RUN_DIR --seeds 0 --repeats 5 --set horizon=5
    python benchmarks/planning_cost.py RUN_DIR --planners rest,latent_mpc --data both  # + exploration

For each planner, `litl.latent.control`'s program (per seed: the model's fit on the replay
buffer, then one episode of `control_steps` control steps toward --goal), all chosen seeds
vmapped, is compiled once and called --repeats times: compile time apart, the median call, and
that median per control step and seed. The fit is inside every call, so `rest` (the fit and an
episode without planning) is the floor the planners add to; with `--data explored` or `both`
the exploratory episodes (default `Exploration`) are inside every call too. Peak RSS is the process's at the
end (every program compiled).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import resource
import statistics
import time

import jax

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def main() -> None:
    from litl.latent.control import DATA, Episode, load, planner_settings
    from litl.latent.exploration import Exploration
    from litl.latent.planning import Goal

    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("run_dir", type=pathlib.Path)
    parser.add_argument("--planners", default="rest,latent_lqr,latent_mpc,oracle_mpc")
    parser.add_argument("--goal", default="reach:0.37")
    parser.add_argument("--seeds", type=lambda s: [int(x) for x in s.split(",")], default=[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--set", action="append", default=[], help="latent_mpc / oracle_mpc settings")
    parser.add_argument("--data", default="buffer", choices=DATA, help="what the model is fitted on")
    args = parser.parse_args()
    robot, config, algorithm, all_seeds, state = load(
        args.run_dir, latent=args.data != "explored", features=True
    )
    exploration = Exploration() if args.data != "buffer" else None
    state = jax.tree.map(
        lambda leaf: leaf[jax.numpy.asarray([all_seeds.index(s) for s in args.seeds])], state
    )
    goal = Goal.parse(args.goal)
    rows = {}
    for planner in args.planners.split(","):
        overrides = args.set if planner in ("latent_mpc", "oracle_mpc") else []
        settings = None if planner == "rest" else planner_settings(planner, overrides)
        episode = Episode(robot, config, algorithm, goal, planner, settings, None, args.data, exploration)
        program, arguments = episode.program(state, args.seeds)
        start = time.perf_counter()
        compiled = program.lower(*arguments).compile()
        compile_s = time.perf_counter() - start
        calls = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            jax.block_until_ready(compiled(*arguments))
            calls.append(time.perf_counter() - start)
        median = statistics.median(calls)
        rows[planner] = {
            "compile_s": round(compile_s, 2),
            "median_s": round(median, 3),
            "per_control_step_and_seed_ms": round(1e3 * median / episode.control_steps / len(args.seeds), 2),
            "calls_s": [round(c, 3) for c in calls],
        }
        print(planner, rows[planner], flush=True)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(
        json.dumps(
            {
                "goal": args.goal,
                "seeds": args.seeds,
                "data": args.data,
                "settings": args.set,
                "rows": rows,
                "peak_rss_mb": round(peak_mb),
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
