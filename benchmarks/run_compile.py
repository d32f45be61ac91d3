"""Where a run's start-up goes: the XLA compilation of each program a run of `python -m litl` builds.

    python benchmarks/run_compile.py                                   # biped, paper and litl, demo
    python benchmarks/run_compile.py --overrides robot=arm experiment=fig4a_arm variant=vae
    python benchmarks/run_compile.py --scale smoke --json

Each case runs `litl.app.run_experiment` in a fresh process (nothing compiled in memory, no
persistent compilation cache) for 2 episodes x 1 iteration with --seeds seeds, so every program
of a full run is built once (the bootstrap, an optimization iteration, a learning phase, the
evaluation) and runs as little as it can; pictures off. It reports, per case:

  wall_s          the whole run, from composing the config to its last record
  compile_s       XLA compilation (backend), summed over every program the run compiled
  trace_s         tracing and lowering to StableHLO, summed
  programs        {program: [seconds of compilation, times compiled]}, the largest first
                  (the initialization's programs: _init_autoencoder, _initial_state, _stack);
                  the small eager operations left are summed under "eager (n programs)"
  peak_rss_mb     peak resident memory of the process
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import re
import resource
import sys
import tempfile
import time

from fresh_process import measure_in_fresh_process

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)

# Programs the run builds itself (the rest are eager operations compiled one by one), the
# initialization's included (the VAE's initializer, the rest of a seed's state, stacking seeds).
RUN_PROGRAMS = (
    "optimize",
    "bootstrap",
    "fill",
    "learn_seeds",
    "evaluate",
    "reconstruct",
    "_init_autoencoder",
    "_initial_state",
    "_stack",
)


def measure(overrides: list[str], seeds: int) -> dict:
    import jax
    import jax.monitoring

    from litl.app import compose, run_experiment

    jax.config.update("jax_log_compiles", True)
    compiled: list[tuple[str, float]] = []

    class _Compiles(logging.Handler):
        def emit(self, record):
            found = re.search(
                r"Finished XLA compilation of jit\((\w+)\) in ([0-9.e-]+) sec", record.getMessage()
            )
            if found:
                compiled.append((found.group(1), float(found.group(2))))

    logger = logging.getLogger("jax")
    logger.addHandler(_Compiles())
    logger.setLevel(logging.DEBUG)
    logger.propagate = False
    totals = {"compile": 0.0, "trace": 0.0}

    def listen(event, seconds, **_):
        if event.endswith("backend_compile_duration"):
            totals["compile"] += seconds
        elif event.endswith(("jaxpr_trace_duration", "jaxpr_to_mlir_module_duration")):
            totals["trace"] += seconds

    jax.monitoring.register_event_duration_secs_listener(listen)
    start = time.perf_counter()
    config = compose(
        [
            *overrides,
            f"seeds={seeds}",
            "loop.episodes=2",
            "loop.iterations=1",
            "output.pictures=false",
            "output.animation=false",
            "output.progress=false",
        ]
    )
    with tempfile.TemporaryDirectory() as run_dir:
        run_experiment(config, run_dir)
    wall = time.perf_counter() - start
    programs: dict[str, list] = {}
    eager = [0.0, 0]
    for name, seconds in compiled:
        entry = programs.setdefault(name, [0.0, 0]) if name in RUN_PROGRAMS else eager
        entry[0] += seconds
        entry[1] += 1
    programs = dict(
        sorted(((k, [round(v[0], 2), v[1]]) for k, v in programs.items()), key=lambda item: -item[1][0])
    )
    programs[f"eager ({eager[1]} programs)"] = [round(eager[0], 2), eager[1]]
    return {
        "overrides": overrides,
        "seeds": seeds,
        "wall_s": round(wall, 2),
        "compile_s": round(totals["compile"], 2),
        "trace_s": round(totals["trace"], 2),
        "programs": programs,
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--overrides",
        nargs="*",
        default=None,
        help="Hydra overrides of one case (default: the biped under method=paper and method=litl)",
    )
    parser.add_argument("--scale", choices=("demo", "smoke"), default="demo")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--json", action="store_true", help="print the results as JSON lines")
    parser.add_argument("--case", help=argparse.SUPPRESS)  # one case, in this process
    args = parser.parse_args()
    if args.case is not None:
        print(json.dumps(measure(json.loads(args.case), args.seeds)))
        return
    scale = ["robot.resolution=demo"] if args.scale == "demo" else ["+scale=smoke"]
    cases = [args.overrides] if args.overrides is not None else [["method=paper"], ["method=litl"]]
    os.environ.pop("JAX_COMPILATION_CACHE_DIR", None)
    for case in cases:
        overrides = [*case, *scale]
        result = measure_in_fresh_process(
            __file__, ["--case", json.dumps(overrides), "--seeds", str(args.seeds)], " ".join(overrides)
        )
        if args.json:
            print(json.dumps(result))
            continue
        print(
            f"{' '.join(overrides)}, {args.seeds} seeds: run {result['wall_s']} s, XLA "
            f"compilation {result['compile_s']} s, tracing {result['trace_s']} s, peak RSS "
            f"{result['peak_rss_mb']} MB"
        )
        for name, (seconds, count) in result["programs"].items():
            print(f"  {name:24s} {seconds:7.2f} s  x{count}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
