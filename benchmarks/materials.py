"""Materials against published measurements, and what each material costs a step.

    python benchmarks/materials.py                         # every table, at dx 1/64 and 1/128
    python benchmarks/materials.py --only dam --grids 64,128,256
    python benchmarks/materials.py --only collapse --aspects 0.5,1,2,3,4
    python benchmarks/materials.py --only repose
    python benchmarks/materials.py --only cost --repeats 5
    python benchmarks/materials.py --pictures docs/assets/2026-11-27/materials

Dam break (`litl.sim.validation.dam_break`): a water column a = 0.1 m wide and 2a high (Martin &
Moyce's n^2 = 2 column), slip walls; the surge front Z = z / a at Martin & Moyce's Table 2 times
T = t sqrt(2 g / a), and the Ritter bound 1 + 2 T.

Granular collapse (`litl.sim.validation.granular_collapse`): sand (Drucker-Prager, friction angle
30 degrees) columns L0 = 0.1 m wide of aspect a = H0 / L0 on a sticky floor; the run-out
(L_inf - L0) / L0 (front as the 99.5th and 98th percentile of the grains' x, and where the deposit
thins below 5 mm = 0.05 L0) against Lube et al. (2005)'s 1.2 a (a < 1.8) and 1.9 a^(2/3) (a > 2.8), the
final height, and the deposit's surface angle. Repose (`litl.sim.validation.sand_wedge`): half a
heap whose surface slopes 10 degrees below to 10 above the friction angle, after 1 s: its slope
and how far its toe moved.

Cost: a 2D block of 2,500 particles (dx 1/64, float32) and a 3D block of 5,832 (dx 1/32) thrown
sideways under gravity, 200 steps forward and forward+backward (to every particle's Young's
modulus), per material: compile time apart (the first forward and backward call), medians of
--repeats runs after compiling, on this process's default backend.
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import statistics
import time

import numpy as np

import litl  # noqa: F401  (before JAX starts: XLA's determinism flag, litl.backend)


def dam_table(grids: list[int], pictures: str | None) -> None:
    from litl.sim import validation

    table = np.asarray(validation.MARTIN_MOYCE_TABLE_2)
    columns = " | ".join(f"Z, dx 1/{n}" for n in grids)
    header = f"| T (Table 2) | Z measured | {columns} | Ritter 1 + 2T |"
    rows = []
    runs = {}
    for n in grids:
        start = time.perf_counter()
        run = validation.dam_break(n_grid=n, frames=120)
        runs[n] = run
        print(f"dam break dx 1/{n}: {time.perf_counter() - start:.1f} s", flush=True)
    print(header)
    print("|" + "---|" * (len(grids) + 3))
    errors = {n: [] for n in grids}
    for T, Z in table:
        cells = []
        for n in grids:
            run = runs[n]
            times = validation.martin_moyce_time(run.times, 0.1, 2.0)
            z = float(np.interp(T, times, run.fronts / 0.1))
            errors[n].append((z - Z) / Z)
            cells.append(f"{z:.2f}")
        rows.append(f"| {T:.2f} | {Z:.2f} | " + " | ".join(cells) + f" | {1 + 2 * T:.2f} |")
    print("\n".join(rows))
    for n in grids:
        late = [e for (T, _), e in zip(table, errors[n], strict=True) if T >= 1.0]
        print(
            f"dx 1/{n}: relative error in Z for T >= 1: mean {100 * np.mean(late):+.1f}%, "
            f"largest {100 * max(late, key=abs):+.1f}%"
        )
    if pictures:
        _dam_picture(runs, pictures)


def _dam_picture(runs, folder: str) -> None:
    import pathlib

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from litl.sim import validation

    path = pathlib.Path(folder)
    path.mkdir(parents=True, exist_ok=True)
    table = np.asarray(validation.MARTIN_MOYCE_TABLE_2)
    fig, (curve, shape) = plt.subplots(1, 2, figsize=(10, 3.6))
    for n, run in runs.items():
        times = validation.martin_moyce_time(run.times, 0.1, 2.0)
        curve.plot(times, run.fronts / 0.1, label=f"litl, dx 1/{n}")
    curve.plot(table[:, 0], table[:, 1], "ko", label="Martin & Moyce 1952, Table 2")
    T = np.linspace(0, 3.4, 10)
    curve.plot(T, 1 + 2 * T, "k:", label="Ritter, 1 + 2T")
    curve.set(xlabel="T = t sqrt(2g/a)", ylabel="Z = front / a", xlim=(0, 3.5), ylim=(0.8, 5))
    curve.legend(fontsize=8)
    finest = runs[max(runs)]
    shape.scatter(finest.positions[:, 0], finest.positions[:, 1], s=0.3)
    shape.set(aspect="equal", xlim=(0, 0.7), ylim=(0, 0.25), title=f"T = 3.4, dx 1/{max(runs)}")
    fig.tight_layout()
    fig.savefig(path / "dam_break.png", dpi=120)
    print(f"wrote {path / 'dam_break.png'}")


def collapse_table(grids: list[int], aspects: list[float], pictures: str | None) -> None:
    from litl.sim import validation

    columns = " | ".join(f"dx 1/{n}" for n in grids)
    print(f"| a | Lube 2005 (L∞-L0)/L0 | {columns} | H∞/L0 | deposit angle |")
    print("|" + "---|" * (len(grids) + 4))
    finals = {}
    for a in aspects:
        cells, last = [], None
        for n in grids:
            start = time.perf_counter()
            run = validation.granular_collapse(a, n_grid=n)
            seconds = time.perf_counter() - start
            thick = validation.deposit_front(run.positions, 1.0 / n, 0.05 * 0.1)
            p98 = np.percentile(run.positions[:, 0], 98) - validation.THICKNESS / n
            cells.append(
                f"{(run.runout - 0.1) / 0.1:.2f} / {(p98 - 0.1) / 0.1:.2f} / {(thick - 0.1) / 0.1:.2f} "
                f"({seconds:.0f} s)"
            )
            last = (n, run)
        n, run = last
        finals[a] = run
        angle = validation.deposit_slope(run.positions, 1.0 / n)
        low, high = validation.lube_runout(a)
        lube = f"{low:.2f}" if low == high else f"{low:.2f}-{high:.2f} (transition)"
        measured = " | ".join(cells)
        print(f"| {a:g} | {lube} | {measured} | {run.height / 0.1:.2f} | {angle:.1f}° |", flush=True)
    if pictures:
        _collapse_picture(finals, max(grids), pictures)


def _collapse_picture(finals, n: int, folder: str) -> None:
    import pathlib

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = pathlib.Path(folder)
    path.mkdir(parents=True, exist_ok=True)
    heights = [0.1 * a + 0.03 for a in finals]
    fig, axes = plt.subplots(
        len(finals), 1, figsize=(9, 1.2 + 9 * sum(heights) / 0.8), gridspec_kw={"height_ratios": heights}
    )
    for ax, (a, run) in zip(np.atleast_1d(axes), finals.items(), strict=True):
        ax.scatter(run.positions[:, 0], run.positions[:, 1], s=0.1, c="tab:brown", linewidths=0)
        ax.add_patch(plt.Rectangle((3 / n, 3 / n), 0.1, 0.1 * a, fill=False, ls="--", lw=0.8))
        ax.set(aspect="equal", xlim=(0, 0.8), ylim=(0, 0.1 * a + 0.03))
        ax.set_ylabel(f"a = {a:g}", rotation=0, labelpad=20)
    np.atleast_1d(axes)[-1].set_xlabel(f"x (m); dashed: the column at release; dx 1/{n}")
    fig.tight_layout()
    fig.savefig(path / "granular_collapse.png", dpi=120)
    print(f"wrote {path / 'granular_collapse.png'}")


def repose_table(grids: list[int]) -> None:
    from litl.sim import validation

    print(
        "| friction angle | heap slope | "
        + " | ".join(f"dx 1/{n}: slope after 1 s, toe moved" for n in grids)
        + " |"
    )
    print("|" + "---|" * (len(grids) + 2))
    for phi in (20.0, 30.0):
        for offset in (-10, -5, 0, 5, 10):
            angle = phi + offset
            cells = []
            for n in grids:
                run = validation.sand_wedge(angle, phi, n_grid=n, seconds=1.0)
                slope = validation.deposit_slope(run.positions, 1.0 / n)
                cells.append(f"{slope:.1f}°, {(run.runout - 0.4) * n:+.1f} cells")
            print(f"| {phi:g}° | {angle:g}° | " + " | ".join(cells) + " |", flush=True)


def cost_table(repeats: int) -> None:
    import jax
    import jax.numpy as jnp

    from litl.sim import Body, Boundary, Design, SimConfig, SimState, make_rollout
    from litl.sim.materials import Clay, Elastic, Fluid, Sand
    from litl.sim.sampling import sample_box

    print("| dim | particles | material | compile (s) | forward (ms/step) | forward+backward (ms/step) |")
    print("|---|---|---|---|---|---|")
    steps = 200
    for dim, n_grid, size in ((2, 64, 0.4), (3, 32, 0.3)):
        dx = 1.0 / n_grid
        x = sample_box([0.2] * dim, [size] * dim, dx, per_cell=2)
        n = len(x)
        design = Design.uniform(n, 300.0, 0.3, 1.0, [], jnp.float32)
        body = Body(
            volume=jnp.full((n,), (dx / 2) ** dim),
            actuator=jnp.full((n,), -1, jnp.int32),
            fiber=jnp.zeros((0, dim)),
            pinned=jnp.zeros((n,), bool),
        )
        gravity = [0.0] * dim
        gravity[1] = -9.8
        state = SimState.at_rest(jnp.asarray(x, jnp.float32), jnp.full((n, dim), 0.5, jnp.float32))
        for label, materials in (
            ("elastic (no materials: today's program)", ()),
            ("Elastic(max_stretch=3)", (Elastic(max_stretch=3.0),)),
            ("Sand(30°)", (Sand(30.0),)),
            ("Clay(yield 30)", (Clay(30.0),)),
            ("Fluid()", (Fluid(),)),
            ("Elastic + Sand, half each", (Elastic(), Sand(30.0))),
        ):
            config = SimConfig(
                (n_grid,) * dim, dx, 0.4 * dx / 20.0, tuple(gravity), Boundary.box(dim), materials=materials
            )
            mixed = dataclasses.replace(body, material=jnp.asarray(np.arange(n) % 2, jnp.int32))
            rollout = make_rollout(config, mixed if len(materials) == 2 else body, lambda p, s, g: p, steps)

            def loss(youngs, rollout=rollout, state=state, design=design):
                final, _ = rollout(jnp.zeros((0,)), dataclasses.replace(design, youngs_modulus=youngs), state)
                return jnp.mean(final.x[:, 0]) + jnp.mean(final.x[:, 1] ** 2)

            forward, backward = jax.jit(loss), jax.jit(jax.grad(loss))
            youngs = design.youngs_modulus
            start = time.perf_counter()
            jax.block_until_ready(forward(youngs))
            jax.block_until_ready(backward(youngs))
            compile_seconds = time.perf_counter() - start
            timings = []
            for fn in (forward, backward):
                runs = []
                for _ in range(repeats):
                    start = time.perf_counter()
                    jax.block_until_ready(fn(youngs))
                    runs.append(time.perf_counter() - start)
                timings.append(1e3 * statistics.median(runs) / steps)
            print(
                f"| {dim}D | {n} | {label} | {compile_seconds:.1f} | {timings[0]:.3f} | {timings[1]:.3f} |",
                flush=True,
            )
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak resident memory of this process: {peak:.0f} MiB; backend {jax.default_backend()}")


def main() -> None:
    formatter = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=formatter)
    parser.add_argument("--only", choices=("dam", "collapse", "repose", "cost"))
    parser.add_argument("--grids", default="64,128", help="cells per metre, comma-separated")
    parser.add_argument("--aspects", default="0.5,1,2,3,4", help="column aspect ratios H0 / L0")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--pictures", help="folder for the figures (none if not given)")
    args = parser.parse_args()
    grids = [int(g) for g in args.grids.split(",")]
    if args.only in (None, "dam"):
        dam_table(grids, args.pictures)
    if args.only in (None, "collapse"):
        collapse_table(grids, [float(a) for a in args.aspects.split(",")], args.pictures)
    if args.only in (None, "repose"):
        repose_table(grids)
    if args.only in (None, "cost"):
        cost_table(args.repeats)


if __name__ == "__main__":
    main()
