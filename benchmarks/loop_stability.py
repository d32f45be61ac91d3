"""Does optimization stay healthy? The biped at the demo resolution, several seeds, per observer.

    python benchmarks/loop_stability.py                          # vae and kmeans, 3 seeds, 100 its
    python benchmarks/loop_stability.py --observers kmeans --seeds 3 --episodes 5 --iterations 20
    python benchmarks/loop_stability.py --summarize outputs/stability   # re-read finished runs
    python benchmarks/loop_stability.py --episodes 1 --iterations 2 --seeds 2 \\
        --override +scale=smoke                                   # smoke

Each observer runs `python -m litl`'s own settings (the demo's defaults, plus `--override`s), with
`loop.episodes x loop.iterations` optimization iterations and all seeds vmapped, into
`<out>/<observer>/`. Then, per seed, from `metrics.jsonl`:

  skipped        iterations that changed nothing, by reason (simulation_nonfinite,
                 particles_escaped, loss_nonfinite, gradient_nonfinite)
  stepped_back   iterations that went back to the last accepted iterate at half the step
  best           largest distance travelled in any healthy iteration (tasks without a distance,
                 the arm's: largest minus task loss; the same for final and worse>0.01)
  final          mean distance of the last 10 iterations (healthy ones)
  worse>0.01     fraction of iterations whose distance fell more than 0.01 below the previous one
  grad_median    median controller gradient norm (before clipping)
  wall_s         the run's wall time (learning phases included)
"""

from __future__ import annotations

import argparse
import collections
import itertools
import json
import pathlib
import statistics
import time

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def run_observer(
    observer: str, out: pathlib.Path, seeds: int, episodes: int, iterations: int, overrides: list[str]
) -> float:
    from litl.app import compose, run_experiment

    settings = compose(
        [
            f"observer={observer}",
            f"seeds={seeds}",
            f"loop.episodes={episodes}",
            f"loop.iterations={iterations}",
            "output.progress=false",
            "output.animation=false",
            *overrides,
        ]
    )
    start = time.perf_counter()
    run_experiment(settings, out / observer)
    return time.perf_counter() - start


def summarize(run_dir: pathlib.Path) -> list[dict]:
    records = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    by_seed = collections.defaultdict(list)
    for record in records:
        by_seed[record["seed"]].append(record)
    rows = []
    for seed, seed_records in sorted(by_seed.items()):
        seed_records.sort(key=lambda r: r["step"])
        skipped = collections.Counter(r["skipped"] for r in seed_records if r.get("skipped"))
        healthy = [r for r in seed_records if not r.get("skipped")]
        # Tasks without a distance term (the arm's reach): minus the task loss, so more is better.
        distance = [r["task/distance"] if "task/distance" in r else -r["task_loss"] for r in healthy]
        drops = sum(b < a - 0.01 for a, b in itertools.pairwise(distance))
        grads = [r["controller_grad_norm"] for r in healthy if r["controller_grad_norm"] is not None]
        rows.append(
            {
                "seed": seed,
                "iterations": len(seed_records),
                "skipped": dict(skipped),
                "stepped_back": sum(bool(r.get("stepped_back")) for r in seed_records),
                "best": max(distance) if distance else None,
                "final": statistics.fmean(distance[-10:]) if distance else None,
                "worse_fraction": drops / max(len(distance) - 1, 1),
                "grad_median": statistics.median(grads) if grads else None,
                "wall_s": seed_records[-1]["wall_s"],
            }
        )
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--observers", nargs="+", default=["vae", "kmeans"])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--iterations", type=int, default=20)
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("outputs/stability"))
    parser.add_argument("--override", nargs="*", default=[], help="more `python -m litl` overrides")
    parser.add_argument(
        "--summarize",
        type=pathlib.Path,
        default=None,
        help="only summarize the runs already in this directory",
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    out = args.summarize or args.out
    results = {}
    for observer in args.observers:
        if args.summarize is None:
            run_observer(observer, out, args.seeds, args.episodes, args.iterations, args.override)
        if (out / observer / "metrics.jsonl").exists():
            results[observer] = summarize(out / observer)
    if args.json:
        print(json.dumps(results, indent=1))
        return
    print(
        f"{'observer':8s} {'seed':>4s} {'its':>4s} {'skipped':>20s} {'back':>4s} {'best':>7s} {'final':>7s} "
        f"{'worse>0.01':>10s} {'grad_med':>9s} {'wall_s':>7s}"
    )
    for observer, rows in results.items():
        for r in rows:
            skipped = ",".join(f"{k}:{v}" for k, v in r["skipped"].items()) or "0"
            fmt = lambda v: f"{v:7.3f}" if v is not None else "    n/a"
            grad = f"{r['grad_median']:9.3g}" if r["grad_median"] is not None else "      n/a"
            print(
                f"{observer:8s} {r['seed']:4d} {r['iterations']:4d} {skipped:>20s} {r['stepped_back']:4d} "
                f"{fmt(r['best'])} {fmt(r['final'])} {r['worse_fraction']:10.2f} {grad} "
                f"{r['wall_s']:7.0f}"
            )


if __name__ == "__main__":
    main()
