"""Why the paper reading's first learning phase collapses: the bootstrap phase under variants.

For each seed: the seed's initial state, the bootstrap rollout into the replay buffer (`fill`),
then the first learning phase (as `learn(first=True)` runs it: the same key) under each variant
of the learning settings and of the network. Prints and writes one JSON line per variant and seed:
recon_explained, active units, SGD steps, best epoch.

  python first_phase.py OUT.jsonl 100 10 [+override ...] name:override,override ...

An argument starting with + is added to every variant's settings (e.g. +robot.resolution=demo).
"""

import json
import sys
import time

import jax
import numpy as np

from litl.app import build_robot, compose
from litl.loop.algorithm import make_algorithm
from litl.loop.state import split_key, stack_seeds

BASE = [
    "experiment=fig4b_biped",
    "variant=vae",
    "method=paper_first_reading",
    "output.pictures=false",
    "output.animation=false",
    "output.progress=false",
]


def main(out, first_seed, seeds, variants):
    base = [*BASE, *(v[1:] for v in variants if v.startswith("+"))]
    variants = [v for v in variants if not v.startswith("+")]
    config = compose([*base, f"seeds={seeds}", f"seed={first_seed}"])
    robot = build_robot(config)
    algorithm = make_algorithm(robot, config.algorithm)
    seed_list = list(range(first_seed, first_seed + seeds))
    start = time.perf_counter()
    states = stack_seeds([algorithm.init(s) for s in seed_list])
    filled = jax.block_until_ready(jax.jit(jax.vmap(algorithm.fill))(states))
    print(f"bootstrap rollouts: {time.perf_counter() - start:.1f} s", flush=True)
    for spec in variants:
        name, _, overrides = spec.partition(":")
        variant_config = compose(
            [*BASE, f"seeds={seeds}", f"seed={first_seed}", *filter(None, overrides.split(","))]
        )
        variant_algorithm = make_algorithm(robot, variant_config.algorithm)
        phase = variant_algorithm.observer.learner.phase

        def one(state, phase=phase):
            state, key = split_key(state)
            return phase(state.observer, state.buffer, key)[1]

        start = time.perf_counter()
        stats = jax.tree.map(np.asarray, jax.jit(jax.vmap(one))(filled))
        seconds = time.perf_counter() - start
        learned = 0
        with open(out, "a") as log:
            for index, seed in enumerate(seed_list):
                row = {
                    "variant": name,
                    "base": base[len(BASE) :],
                    "overrides": overrides,
                    "seed": seed,
                    "recon_explained": float(stats["recon_explained"][index]),
                    "active_units": int(stats["active_units"][index]),
                    "epochs_used": int(stats["epochs_used"][index]),
                    "best_epoch": int(stats["best_epoch"][index]),
                    "sgd_steps": int(stats["epochs_used"][index] * stats["steps_per_epoch"][index]),
                    "kl": float(stats["kl"][index]),
                    "wall_s": seconds,
                }
                learned += row["recon_explained"] >= 0.2 and row["active_units"] >= 4
                log.write(json.dumps(row) + "\n")
        steps = stats["epochs_used"] * stats["steps_per_epoch"]
        summary = ", ".join(
            f"{s}:{stats['recon_explained'][i]:.2f}/{int(stats['active_units'][i])}/{int(steps[i])}"
            for i, s in enumerate(seed_list)
        )
        print(
            f"{name}: learned {learned}/{seeds} ({seconds:.0f} s)  seed:explained/units/steps {summary}",
            flush=True,
        )


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4:])
