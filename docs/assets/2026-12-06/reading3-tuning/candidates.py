"""The paper reading's two open gradient values, measured on seeds no verdict reports.

    python docs/assets/2026-12-06/reading3-tuning/candidates.py RUNS_DIR OUT.json [--episodes 4]
        [--seeds 100 101 102] [--jobs 2] [--only NAME ...] [--summarize-only]

Under `method=paper` (the reading of 2026-12-02) the first learning phase learns, but the
controller's gradient through the VAE's features explodes (Fig. 4b at dx 1/128: median norm 801,
spikes to 1e16, 57 of 1,000 iterations non-finite). The paper's text is silent on two values that
bear on it: whether the task gradient passes through the observer's features
(`controller.mlp.feature_gradient`), and whether the controller's gradient is clipped
(`loop.safeguards.gradient_clip`). This script runs Fig. 4b's paper-method VAE cell (dx 1/128) for
each candidate below on each seed, one seed per process with one XLA thread, `--jobs` at a time,
and writes per candidate and seed what the criterion reads.

The criterion, fixed before any of these runs (docs/guide/method.md): a candidate passes when, in
every seed, the first learning phase learns (`recon_explained` >= 0.2 and >= 4 active latent
units), no controller gradient is non-finite, and the 90th percentile of the controller's gradient
norm (before any clipping) over the run's iterations is at most 1e3 (the k-means cell's largest
over its 2,000 iterations of seeds 10-29 was 768). The reading takes the first candidate in
CANDIDATES' order that passes: the order of closeness to the paper's text ("backpropagating
through an entire simulation"; no clipping mentioned). The task loss is recorded, never used.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import subprocess
import sys
import time

import numpy as np

CELL = (
    "experiment=fig4b_biped",
    "variant=vae",
    "method=paper",
    "seeds=1",
    "output.pictures=false",
    "output.animation=false",
    "output.progress=false",
)
# name -> overrides on top of method=paper, in the order the reading would take them.
CANDIDATES = {
    "reading2": (),  # today's method=paper: full feature gradient, no clipping (the baseline)
    "full_clip1": ("loop.safeguards.gradient_clip=1.0",),
    "stop": ("controller.mlp.feature_gradient=stop",),
    "stop_clip1": ("controller.mlp.feature_gradient=stop", "loop.safeguards.gradient_clip=1.0"),
}
ORDER = ("full_clip1", "stop", "stop_clip1")  # reading2 is the baseline, not a candidate
ONE_THREAD = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
LEARNED_EXPLAINED, LEARNED_UNITS, P90_BOUND = 0.2, 4, 1e3


def _command(name: str, seed: int, episodes: int, run_dir: pathlib.Path, extra: list[str]) -> list[str]:
    return [
        sys.executable,
        "-m",
        "litl",
        *CELL,
        *CANDIDATES[name],
        f"seed={seed}",
        f"loop.episodes={episodes}",
        *extra,
        f"hydra.run.dir={run_dir}",
    ]


def run_all(
    runs: pathlib.Path, names: list[str], seeds: list[int], episodes: int, jobs: int, extra: list[str]
) -> None:
    """Each (candidate, seed) not yet finished (no final.json), `jobs` processes at a time."""
    # Seed-major, so that a stopped run leaves every candidate with its first seeds.
    todo = [(n, s) for s in seeds for n in names if not (runs / n / f"seed{s}" / "final.json").exists()]
    env = dict(os.environ, XLA_FLAGS=(os.environ.get("XLA_FLAGS", "") + " " + ONE_THREAD).strip())
    running: list[tuple[str, int, subprocess.Popen[bytes], float]] = []
    while todo or running:
        while todo and len(running) < jobs:
            name, seed = todo.pop(0)
            run_dir = runs / name / f"seed{seed}"
            run_dir.mkdir(parents=True, exist_ok=True)
            with open(run_dir / "stderr.log", "wb") as log:  # the child keeps its own descriptor
                process = subprocess.Popen(
                    _command(name, seed, episodes, run_dir, extra), env=env, stdout=log, stderr=log
                )
            running.append((name, seed, process, time.time()))
            print(f"started {name} seed {seed}", flush=True)
        time.sleep(10)
        for item in list(running):
            name, seed, process, start = item
            if process.poll() is not None:
                running.remove(item)
                print(
                    f"ended {name} seed {seed}: exit {process.returncode}, {time.time() - start:.0f} s",
                    flush=True,
                )
                if process.returncode:
                    raise SystemExit(
                        f"{name} seed {seed} failed: see {runs / name / f'seed{seed}' / 'stderr.log'}"
                    )


def _records(path: pathlib.Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def summarize(runs: pathlib.Path, names: list[str], seeds: list[int]) -> dict:
    """Per candidate and seed: the first phase, the controller's gradient norms, the task loss."""
    out: dict = {
        "criterion": {
            "recon_explained": LEARNED_EXPLAINED,
            "active_units": LEARNED_UNITS,
            "p90_bound": P90_BOUND,
            "order": list(ORDER),
        },
        "candidates": {},
    }
    for name in names:
        per_seed = {}
        for seed in seeds:
            run_dir = runs / name / f"seed{seed}"
            if not (run_dir / "final.json").exists():
                continue
            first = _records(run_dir / "learning.jsonl")[0]
            norms = np.array(
                [
                    math.nan if m["controller_grad_norm"] is None else m["controller_grad_norm"]
                    for m in _records(run_dir / "metrics.jsonl")
                ],
                dtype=float,
            )
            finite = norms[np.isfinite(norms)]
            losses = [m["task_loss"] for m in _records(run_dir / "metrics.jsonl")]
            learned = first["recon_explained"] >= LEARNED_EXPLAINED and first["active_units"] >= LEARNED_UNITS
            p90 = float(np.percentile(finite, 90)) if finite.size else math.inf
            per_seed[seed] = {
                "first_recon_explained": first["recon_explained"],
                "first_active_units": first["active_units"],
                "first_learned": bool(learned),
                "iterations": int(norms.size),
                "non_finite": int(norms.size - finite.size),
                "grad_median": float(np.median(finite)) if finite.size else None,
                "grad_p90": p90,
                "grad_max": float(finite.max()) if finite.size else None,
                "passes": bool(learned and norms.size == finite.size and p90 <= P90_BOUND),
                "task_loss_last10": float(np.nanmean(losses[-10:])),
            }
        complete = len(per_seed) == len(seeds)
        out["candidates"][name] = {
            "overrides": list(CANDIDATES[name]),
            "seeds": per_seed,
            "complete": complete,
            "passes": complete and all(s["passes"] for s in per_seed.values()),
        }
    chosen = [n for n in ORDER if out["candidates"].get(n, {}).get("passes")]
    out["chosen"] = chosen[0] if chosen else None
    return out


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("runs", type=pathlib.Path)
    parser.add_argument("out", type=pathlib.Path)
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--seeds", type=int, nargs="+", default=[100, 101, 102])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--only", nargs="+", default=list(CANDIDATES), choices=list(CANDIDATES))
    parser.add_argument("--summarize-only", action="store_true")
    parser.add_argument("--extra", nargs="*", default=[], help="more overrides (e.g. +scale=smoke to try it)")
    args = parser.parse_args()
    if args.episodes < 1 or args.jobs < 1:
        raise SystemExit("--episodes and --jobs must be at least 1")
    if not args.summarize_only:
        run_all(args.runs, args.only, args.seeds, args.episodes, args.jobs, args.extra)
    summary = summarize(args.runs, args.only, args.seeds)
    args.out.write_text(json.dumps(summary, indent=1) + "\n")
    print(
        json.dumps({n: c["passes"] for n, c in summary["candidates"].items()}), "chosen:", summary["chosen"]
    )


if __name__ == "__main__":
    main()
