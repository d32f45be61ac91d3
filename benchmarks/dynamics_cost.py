"""What measuring the latent dynamics model (`loop.dynamics`) adds to a learning phase.

    python benchmarks/dynamics_cost.py                      # the demo biped, VAE, a full buffer
    python benchmarks/dynamics_cost.py --observer pca --repeats 5
    python benchmarks/dynamics_cost.py --smoke              # seconds

One seed's buffer is filled with the untrained controller's rollouts (`Algorithm.fill`, until it
holds `loop.buffer_capacity` snapshots); then one learning phase (`Algorithm.learn`, jitted) is
timed with `loop.dynamics.enabled` false and true, and the measurement alone
(`litl.latent.in_loop.measure`), each compiled apart, medians of --repeats calls after
compilation. Peak RSS is the process's at the end (all three compiled).
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import time

import jax

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def timed(fn, *args, repeats: int) -> dict:
    start = time.perf_counter()
    jax.block_until_ready(fn(*args))
    compile_s = time.perf_counter() - start
    calls = []
    for _ in range(repeats):
        start = time.perf_counter()
        jax.block_until_ready(fn(*args))
        calls.append(time.perf_counter() - start)
    return {"compile_s": round(compile_s, 2), "median_s": round(statistics.median(calls), 4)}


def main() -> None:
    from litl.app import build_robot, compose
    from litl.latent import in_loop
    from litl.loop.algorithm import make_algorithm

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robot", default="biped")
    parser.add_argument("--observer", default="vae")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--smoke", action="store_true")
    args = parser.parse_args()
    overrides = [f"robot={args.robot}", f"observer={args.observer}"]
    overrides += ["+scale=smoke", "loop.dynamics.horizons=[1,2]"] if args.smoke else []
    plain_config = compose(overrides)
    measured_config = compose([*overrides, "loop.dynamics.enabled=true"])
    robot = build_robot(plain_config)
    plain = make_algorithm(robot, plain_config.algorithm)
    measured = make_algorithm(robot, measured_config.algorithm)
    state = measured.init(0)
    fill = jax.jit(measured.fill)
    while int(state.buffer.count) < state.buffer.capacity:
        state = fill(state)
    plain_state = plain.init(0).replace(buffer=state.buffer)
    settings = measured_config.loop.dynamics
    codec = measured.observer.learner.latent
    results = {
        "robot": robot.name,
        "observer": args.observer,
        "snapshots": int(state.buffer.count),
        "horizons": list(settings.horizons),
        "phase_without": timed(jax.jit(plain.learn), plain_state, repeats=args.repeats),
        "phase_with": timed(jax.jit(measured.learn), state, repeats=args.repeats),
        "measure_alone": timed(
            lambda s: in_loop.measure(codec, s.observer, s.buffer, jax.random.key(0), settings),
            state,
            repeats=args.repeats,
        ),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
        "device": jax.devices()[0].device_kind,
    }
    results["ratio"] = round(results["phase_with"]["median_s"] / results["phase_without"]["median_s"], 3)
    print(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
