"""How to cut a claims cell's seeds on a CPU: one process for two seeds, or one process per seed.

    python benchmarks/slice_layout.py                      # the paper-method Fig. 4b VAE cell, dx 1/128
    python benchmarks/slice_layout.py --episodes 1 --overrides +scale=smoke   # seconds, to try it
    python benchmarks/slice_layout.py --json

Runs the same two seeds (default 100 and 101: not reported seeds) of one cell three ways, one
layout after the other, each in fresh processes (`python -m litl`, compilation included, as a
slice pays it):

  together        one process, seeds=2, every core (XLA's default threads)
  apart           two processes at once, seeds=1 each, each pinned to one core with one XLA thread
  together_1x1    one process, seeds=2, loop.learning_seeds_at_once=1 (each seed's learning
                  phase stops at its own epoch instead of the slower seed's)

and prints each layout's wall time (the slowest process of it), with the loop's own timings
where its run directory records them. Meant for an otherwise idle machine: anything else running
shares the cores (the output says the load average at the start and end).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

CELL = (
    "experiment=fig4b_biped",
    "variant=vae",
    "method=paper",
    "output.pictures=false",
    "output.animation=false",
    "output.progress=false",
)
ONE_THREAD = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"


def _launch(overrides: list[str], run_dir: str, cpu: int | None) -> subprocess.Popen[bytes]:
    env = dict(os.environ)
    command = [sys.executable, "-m", "litl", *overrides, f"hydra.run.dir={run_dir}"]
    if cpu is not None:
        env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") + " " + ONE_THREAD).strip()
        if shutil.which("taskset"):
            command = ["taskset", "-c", str(cpu), *command]
    return subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _wait(processes: list[subprocess.Popen[bytes]]) -> None:
    for process in processes:
        _, err = process.communicate()
        if process.returncode:
            raise SystemExit(f"a run failed (exit {process.returncode}):\n{err.decode()[-2000:]}")


def layout(name: str, base: list[str], seeds: tuple[int, int], root: str) -> float:
    start = time.perf_counter()
    if name == "apart":
        _wait(
            [
                _launch([*base, "seeds=1", f"seed={seed}"], os.path.join(root, f"{name}-{seed}"), cpu)
                for cpu, seed in enumerate(seeds)
            ]
        )
    else:
        extra = ["loop.learning_seeds_at_once=1"] if name == "together_1x1" else []
        _wait([_launch([*base, "seeds=2", f"seed={seeds[0]}", *extra], os.path.join(root, name), None)])
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--episodes", type=int, default=2, help="episodes per run (default 2)")
    parser.add_argument("--seeds", type=int, nargs=2, default=(100, 101))
    parser.add_argument("--layouts", nargs="+", default=["together", "apart", "together_1x1"])
    parser.add_argument("--overrides", nargs="*", default=[], help="more overrides for every run")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    base = [*CELL, f"loop.episodes={args.episodes}", *args.overrides]
    results: dict[str, object] = {"cell": base, "seeds": list(args.seeds), "load_before": os.getloadavg()[0]}
    with tempfile.TemporaryDirectory() as root:
        for name in args.layouts:
            seconds = layout(name, base, tuple(args.seeds), root)
            results[f"{name}_s"] = round(seconds, 1)
            if not args.json:
                print(f"{name:<14} {seconds:8.1f} s", flush=True)
    results["load_after"] = os.getloadavg()[0]
    results["cpus"] = os.cpu_count()
    print(
        json.dumps(results)
        if args.json
        else f"load average {results['load_before']:.2f} -> {results['load_after']:.2f}"
    )


if __name__ == "__main__":
    main()
