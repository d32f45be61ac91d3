"""Design spaces as registered parts (`litl.designs`, ``design=<name>``): the robot's own
modulus, and actuator placement, whose weights start at the robot's own muscles and move."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import litl.designs
import litl.robots
from litl.app import build_robot, compose, run_experiment
from litl.config import Config, SettingsError
from litl.loop import make_algorithm
from litl.loop.run import run
from litl.replay import replay
from litl.report import write_report
from litl.robots.catalog import from_image
from litl.robots.image import write_png, write_voxels
from tests.loop.tiny import tiny_config, tiny_robot


def test_the_built_in_design_spaces_are_registered_and_an_unknown_one_names_them():
    assert {"modulus", "actuators"} <= set(litl.designs.names())
    with pytest.raises(SettingsError, match=r"design.kind='bones'.*choose one of.*actuators"):
        Config().replace(design={"kind": "bones"}).check()


def test_bad_placement_settings_are_refused_naming_the_key():
    with pytest.raises(SettingsError, match=r"design.actuators.sharpness.*> 0"):
        Config().replace(design={"kind": "actuators", "actuators": {"sharpness": 0.0}})


def test_a_placement_starts_at_the_robots_own_muscles_and_the_modulus_stays_its_own():
    robot = tiny_robot()
    placed = litl.designs.apply(robot, "actuators")
    space = placed.design_space
    design = space.to_design()
    own = np.asarray(robot.layout.actuator)
    weights = np.asarray(design.actuator_weights)
    assert weights.shape == (robot.layout.n_particles, robot.n_actuators)
    assert np.all(weights.sum(-1) <= 1 + 1e-6)
    actuated = own >= 0
    np.testing.assert_array_equal(weights[actuated].argmax(-1), own[actuated])
    assert weights[actuated].max(-1).min() > 0.9 and weights[~actuated].max() < 0.05
    np.testing.assert_allclose(
        np.asarray(design.youngs_modulus), np.asarray(robot.scene().design.youngs_modulus)
    )
    assert set(space.initial()) == {"placement"}  # the modulus is not co-designed by default
    both = litl.designs.apply(
        robot, Config().replace(design={"kind": "actuators", "actuators": {"modulus": True}}).design
    )
    assert set(both.design_space.initial()) == {"placement", "youngs_modulus"}
    assert litl.designs.apply(robot, "modulus") is robot


def test_a_channel_a_particle_has_left_can_come_back():
    """The softmax has a derivative everywhere: a particle whose weight on an actuator is 3e-4
    still feels a gradient that asks for more, finite and nonzero, and the loop's optimizer (Adam,
    which follows the gradient's sign, not its size) raises the weight again."""
    import optax

    space = litl.designs.apply(tiny_robot(), "actuators").design_space
    phi = space.initial()
    n, m = phi["placement"].shape
    low = jnp.zeros((n, m)).at[:, m - 1].set(8.0)  # all passive: weight ~3e-4 on each actuator
    start = float(space.weights({"placement": low})[:, 0].mean())
    assert start < 1e-3
    wanted = jax.grad(lambda logits: -space.weights({"placement": logits})[:, 0].sum())
    grad = wanted(low)
    assert np.all(np.isfinite(np.asarray(grad))) and float(jnp.abs(grad[:, 0]).min()) > 0
    adam = optax.adam(0.5)
    logits, opt = low, adam.init(low)
    for _ in range(20):
        updates, opt = adam.update(wanted(logits), opt, logits)
        logits = optax.apply_updates(logits, updates)
    assert float(space.weights({"placement": logits})[:, 0].mean()) > 0.5


def same_body(a, b, spacing):
    """Whether two 2D layouts hold the same particles (on the same lattice, up to a shift) with
    the same actuators, regions, pins and groups."""
    if len(a.positions) != len(b.positions) or sorted(a.groups) != sorted(b.groups):
        return False
    cells = lambda layout: np.rint((layout.positions - layout.positions.min(0)) / spacing).astype(int)
    order_a, order_b = (np.lexsort((cells(x)[:, 1], cells(x)[:, 0])) for x in (a, b))
    if not np.array_equal(cells(a)[order_a], cells(b)[order_b]):
        return False
    rank_a, rank_b = np.argsort(order_a), np.argsort(order_b)
    return all(
        np.array_equal(np.asarray(getattr(a, key))[order_a], np.asarray(getattr(b, key))[order_b])
        for key in ("actuator", "region", "pinned")
    ) and all(np.array_equal(np.sort(rank_a[a.groups[g]]), np.sort(rank_b[b.groups[g]])) for g in a.groups)


@pytest.mark.parametrize("name", ["biped", "rhino", "arm"])
def test_a_2d_robot_drawn_as_a_png_loads_back_to_the_same_body(name, tmp_path):
    robot = litl.robots.get(name, dx=1 / 32)
    png, legend = write_png(robot.layout, tmp_path / f"{name}.png")
    back = from_image(png, dx=1 / 32)
    spacing = json.loads(legend.read_text())["_spacing"]
    assert same_body(robot.layout, back.layout, spacing)
    np.testing.assert_allclose(back.layout.fiber, robot.layout.fiber)


def test_co_designing_the_placement_moves_the_muscles_and_the_replay_draws_a_body_that_loads_back(tmp_path):
    config = tiny_config(
        observer={"kind": "kmeans"}, design={"kind": "actuators"}, loop={"design_learning_rate": 0.5}
    )
    result = run(tiny_robot(), config, tmp_path / "run", progress=False)
    saved = json.loads((tmp_path / "run" / "run.json").read_text())
    assert saved["config"]["design"]["kind"] == "actuators"
    records = result.metrics
    assert all("placement/actuated" in r and "placement/moved" in r for r in records)
    assert all(len(r["design"]) == tiny_robot().n_regions for r in records)  # the modulus per region
    space = litl.designs.apply(tiny_robot(), "actuators").design_space
    final = result.state.design["placement"]
    moved = float(jnp.abs(final - space.initial()["placement"][None]).max())
    assert moved > 0.1, moved
    assert np.isfinite([r["task_loss"] for r in records]).all()
    # The replay writes the co-designed body as a drawing; robot.image= loads it back.
    summary = replay(tmp_path / "run", seed=0, out=tmp_path / "replay" / "seed0.gif")
    drawing = tmp_path / "replay" / "seed0_robot.png"
    assert str(drawing) in summary["files"]
    placed = space.placed_layout(jax.tree.map(lambda x: x[0], result.state.design), tiny_robot().layout)
    config = compose([f"robot.image={drawing}", "robot.dx=0.03125", "design=actuators"])
    back = build_robot(config)
    spacing = json.loads(drawing.with_suffix(".json").read_text())["_spacing"]
    assert same_body(placed, back.layout, spacing)
    assert back.design is not None
    # The report draws the body's figures over the iterations.
    report = write_report(tmp_path / "run", tmp_path / "report")
    assert "design.png" in report.summary["files"] and (tmp_path / "report" / "design.png").stat().st_size > 0


def test_a_drawing_without_a_width_is_refused_naming_the_key(tmp_path):
    png, legend = write_png(litl.robots.get("biped", dx=1 / 32).layout, tmp_path / "b.png")
    legend.unlink()
    with pytest.raises(SettingsError, match=r"robot.image=.*robot.width=<length>"):
        build_robot(compose([f"robot.image={png}"]))
    with pytest.raises(SettingsError, match=r"robot.width.*> 0"):
        compose([f"robot.image={png}", "robot.width=-1"])


def test_ppo_refuses_a_design_space_it_would_never_move(tmp_path):
    from litl.app import compose, run_experiment

    config = compose(["optimizer=ppo", "design=actuators", "+scale=smoke", "output.progress=false"])
    with pytest.raises(SettingsError, match=r"controls only.*would never move.*design=modulus"):
        run_experiment(config, tmp_path / "run")
    assert not (tmp_path / "run" / "run.json").exists()


def test_an_evolution_strategy_searches_the_whole_body_and_reports_it_as_the_loop_does(tmp_path):
    """optimizer=sep_cmaes design=all: the strategy's mean moves the placement, the occupancy
    and the modulus, each kept in its bounds, and its records carry the loop's design figures."""
    from litl.app import compose, run_experiment
    from litl.optimizers.evolution import DesignUnits

    overrides = ["optimizer=sep_cmaes", "design=all", "+scale=smoke", "seeds=1", "output.progress=false"]
    overrides += ["optimizer.sep_cmaes.population=4", "optimizer.sep_cmaes.generations=3"]
    config = compose(overrides)
    run_experiment(config, tmp_path / "run")
    records = [json.loads(line) for line in (tmp_path / "run" / "metrics.jsonl").read_text().splitlines()]
    assert len(records) == 3 and all(np.isfinite(r["task_loss"]) for r in records)
    for name in ("placement/actuated", "placement/moved", "geometry/volume", "geometry/grayness"):
        assert all(name in r for r in records), name
    # Generation 0's figures are those of litl's start; the search moves the mean's body.
    assert records[0]["geometry/volume"] == pytest.approx(1.0, abs=1e-4)
    assert records[-1]["geometry/volume"] < 1.0 - 1e-4 and records[-1]["placement/actuated"] != pytest.approx(
        records[0]["placement/actuated"], abs=1e-6
    )
    # Units and back: the bounds are the loop's (modulus and occupancy clipped, logits free).
    space = litl.designs.apply(tiny_robot(), "all").design_space
    units = DesignUnits.of(space, "sep_cmaes")
    phi = space.initial()
    unit = units.to_unit(phi)
    assert float(unit["placement"].max()) == pytest.approx(1.0)  # the own channel, over its sharpness
    back = units.from_unit({k: v + 2.0 for k, v in unit.items()}, units.fixed(phi))
    low, high = space.bounds
    assert float(back["occupancy"].max()) == 1.0 and float(back["youngs_modulus"].max()) == high
    np.testing.assert_allclose(
        np.asarray(back["placement"]), np.asarray(phi["placement"] + 2 * units.sharpness)
    )


def test_geometry_starts_as_the_robots_own_body_and_its_figures_say_so():
    robot = tiny_robot()
    space = litl.designs.apply(robot, "geometry").design_space
    phi = space.initial()
    design = space.to_design(phi)
    own = robot.scene().design
    np.testing.assert_allclose(np.asarray(design.density), np.asarray(own.density), rtol=1e-6)
    np.testing.assert_allclose(np.asarray(design.youngs_modulus), np.asarray(own.youngs_modulus), rtol=1e-6)
    figures = {k: float(v) for k, v in space.summary(phi).items()}
    assert figures["geometry/volume"] == pytest.approx(1.0) and figures["geometry/grayness"] == pytest.approx(
        0.0, abs=1e-5
    )


def test_material_that_was_removed_comes_back_when_the_gradient_asks_for_it():
    """Occupancy 0.05 everywhere (the stiffness through SIMP's rho^3 almost nil): the gradient of
    a loss that wants stiffness is finite and nonzero, and Adam raises the occupancy again."""
    import optax

    space = litl.designs.apply(tiny_robot(), "geometry").design_space
    low = {"occupancy": jnp.full_like(space.initial()["occupancy"], 0.05)}
    stiffness = lambda phi: -jnp.mean(space.to_design(phi).youngs_modulus)
    grad = jax.grad(stiffness)(low)["occupancy"]
    assert np.all(np.isfinite(np.asarray(grad))) and float(jnp.abs(grad).min()) > 0
    adam = optax.adam(0.05)
    phi, opt = low, adam.init(low)
    for _ in range(20):
        updates, opt = adam.update(jax.grad(stiffness)(phi), opt, phi)
        phi = space.project(optax.apply_updates(phi, updates))
    assert float(jnp.mean(phi["occupancy"])) > 0.5
    assert float(space.summary(phi)["geometry/volume"]) > float(space.summary(low)["geometry/volume"])


def test_the_gradient_through_geometry_and_placement_matches_central_differences_in_float64():
    """d(task loss) / d(occupancy, placement logits, modulus) of a 30-step rollout of design=all,
    against central differences in float64 along random directions."""
    with jax.enable_x64(True):
        robot = litl.designs.apply(litl.robots.get("biped", dx=1 / 32), "all")
        algorithm = make_algorithm(
            robot,
            tiny_config(
                observer={"kind": "none"},
                controller={"kind": "sinusoid"},
                sim={"steps": 30, "dtype": "float64"},
            ).algorithm,
        )
        state = algorithm.init(0)
        rng = np.random.default_rng(1)
        phi = dict(state.design)
        phi["occupancy"] = jnp.asarray(rng.uniform(0.3, 1.0, phi["occupancy"].shape))
        phi["placement"] = phi["placement"] + jnp.asarray(rng.normal(size=phi["placement"].shape))
        loss = jax.jit(lambda design: algorithm.simulate(state.controller, design, state.observer)[0])
        grad = jax.jit(
            jax.grad(lambda design: algorithm.simulate(state.controller, design, state.observer)[0])
        )(phi)
        for part in ("occupancy", "placement", "youngs_modulus"):
            assert float(jnp.abs(grad[part]).max()) > 0, part
        eps = 1e-6
        for _ in range(2):
            direction = {k: jnp.asarray(rng.normal(size=v.shape)) for k, v in phi.items()}
            plus = {k: phi[k] + eps * direction[k] for k in phi}
            minus = {k: phi[k] - eps * direction[k] for k in phi}
            numeric = (loss(plus) - loss(minus)) / (2 * eps)
            analytic = sum(float(jnp.vdot(grad[k], direction[k])) for k in phi)
            np.testing.assert_allclose(analytic, float(numeric), rtol=1e-4, atol=1e-10)


def test_a_volume_above_its_fraction_costs_and_the_geometry_sheds_it(tmp_path):
    config = tiny_config(
        observer={"kind": "kmeans"},
        design={"kind": "geometry", "geometry": {"volume_fraction": 0.7, "volume_weight": 10.0}},
        loop={"design_learning_rate": 0.1},
    )
    result = run(tiny_robot(), config, tmp_path / "run", progress=False)
    first, last = result.metrics[0], result.metrics[-1]
    assert first["task/design/volume"] == pytest.approx(10.0 * 0.3**2, rel=1e-4)
    assert last["geometry/volume"] < first["geometry/volume"] - 0.05
    assert np.isfinite([r["task_loss"] for r in result.metrics]).all()


def test_a_learning_phase_reclusters_k_means_on_the_body_as_it_is_now():
    """observer.kmeans.recluster=true: the phase refits the clusters to the current design's
    material (here the front half of the body removed: every cluster moves behind it) and says
    how much material changed cluster; without it (the paper's baseline) the clusters stay."""
    from litl.models.kmeans import fit_kmeans

    robot = tiny_robot()
    rest = np.asarray(robot.own(robot.initial_state()).x)
    front = rest[:, 0] > np.median(rest[:, 0])
    for recluster in (True, False):
        config = tiny_config(
            observer={"kind": "kmeans", "kmeans": {"clusters": 3, "recluster": recluster}},
            design={"kind": "geometry"},
        )
        placed = litl.designs.apply(robot, config.design)
        algorithm = make_algorithm(placed, config.algorithm)
        state = algorithm.init(0)
        removed = jnp.where(jnp.asarray(front), 0.0, state.design["occupancy"])
        state = state.replace(design={**state.design, "occupancy": removed})
        learned, stats = jax.jit(algorithm.learn)(state)
        centers = np.asarray(learned.observer.centers)
        if recluster:
            behind = rest[~front, 0].max()
            assert (centers[:, 0] <= behind + 1e-6).all() and float(stats["kmeans/relabelled"]) > 0.1
            # Material once removed (its filtered density near the cut aside) counts in no cluster.
            assert float(np.asarray(learned.observer.averaging)[:, front].sum()) < 0.2
        else:
            assert "kmeans/relabelled" not in stats
            np.testing.assert_array_equal(centers, np.asarray(fit_kmeans(rest, 3, seed=0).centers))


def test_k_means_that_reclusters_records_it_in_every_learning_phase(tmp_path):
    config = tiny_config(
        observer={"kind": "kmeans", "kmeans": {"clusters": 3, "recluster": True}}, design={"kind": "geometry"}
    )
    run(tiny_robot(), config, tmp_path / "run", progress=False)
    phases = [json.loads(line) for line in (tmp_path / "run" / "learning.jsonl").read_text().splitlines()]
    # A phase after each of the 2 episodes, for each of the 2 seeds; the design moved, so did
    # some of the clusters' material.
    assert [(p["seed"], p["phase"]) for p in phases] == [(0, 1), (1, 1), (0, 2), (1, 2)]
    assert all(0.0 <= p["kmeans/relabelled"] <= 1.0 for p in phases)
    assert max(p["kmeans/relabelled"] for p in phases) > 0.0


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"filter_radius": 0.5}, r"design.geometry.filter_radius.*at least 1 grid cell"),
        ({"volume_fraction": 0.0}, r"design.geometry.volume_fraction.*\(0, 1\]"),
        ({"volume_fraction": 1.5}, r"design.geometry.volume_fraction.*\(0, 1\]"),
        ({"projection": 0.0}, r"design.geometry.projection.*> 0"),
    ],
)
def test_bad_geometry_settings_are_refused_naming_the_key_and_range(changes, message):
    with pytest.raises(SettingsError, match=message):
        Config().replace(design={"kind": "geometry", "geometry": changes})


def test_a_3d_robot_written_as_voxels_loads_back_to_the_same_body(tmp_path):
    robot = litl.robots.get("quadruped", dx=1 / 16)
    path = write_voxels(robot.layout, tmp_path / "quadruped.npz")
    back = build_robot(compose([f"robot.image={path}", "robot.dx=0.0625"]))
    spacing = float(np.load(path)["spacing"])
    assert back.dim == 3 and same_body(robot.layout, back.layout, spacing)
    np.testing.assert_allclose(back.layout.fiber, robot.layout.fiber)


def test_the_kept_body_drops_removed_material_and_a_body_without_an_actuator_is_refused():
    robot = tiny_robot()
    space = litl.designs.apply(robot, "all").design_space
    phi = space.initial()
    y = np.asarray(robot.layout.positions)[:, 1]
    top = y > np.quantile(y, 0.6)  # the torso's upper part (the filter smooths thinner cuts)
    phi["occupancy"] = jnp.where(jnp.asarray(top), 0.0, 1.0)
    kept = space.placed_layout(phi, robot.layout)
    assert (
        robot.layout.n_particles - 1.5 * top.sum()
        < kept.n_particles
        < robot.layout.n_particles - 0.5 * top.sum()
    )
    assert np.asarray(kept.positions)[:, 1].max() < y.max()
    passive = dict(phi, occupancy=jnp.ones_like(phi["occupancy"]))
    passive["placement"] = phi["placement"].at[:, -1].set(50.0)  # every particle passive
    with pytest.raises(litl.robots.LayoutError, match="have no particles"):
        space.placed_layout(passive, robot.layout)


def test_a_grayness_cost_pushes_the_geometry_towards_a_crisp_design():
    """Occupancy at 0.5 everywhere is all gray; with a grayness weight, Adam on the cost alone
    makes the design crisper (grayness falls), with no weight the cost is not there."""
    import optax

    robot = tiny_robot()
    gray = Config().replace(design={"kind": "geometry", "geometry": {"grayness_weight": 1.0}})
    space = litl.designs.apply(robot, gray.design).design_space
    assert "design/grayness" not in litl.designs.apply(robot, "geometry").design_space.penalty(
        space.initial()
    )
    rng = np.random.default_rng(0)
    phi = {"occupancy": jnp.asarray(0.5 + 0.05 * rng.normal(size=robot.layout.n_particles), jnp.float32)}
    cost = lambda phi: space.penalty(phi)["design/grayness"]
    start = float(cost(phi))
    adam = optax.adam(0.05)
    opt = adam.init(phi)
    for _ in range(30):
        updates, opt = adam.update(jax.grad(cost)(phi), opt, phi)
        phi = space.project(optax.apply_updates(phi, updates))
    assert float(cost(phi)) < 0.5 * start


def test_a_part_of_the_design_steps_at_its_own_step_size():
    """The occupancy at design.geometry.learning_rate 0.02 moves by at most 0.02 in the first
    iteration (Adam's first step is the step size times the gradient's sign), where the loop's
    0.5 would move it by up to 0.5; the modulus keeps the loop's step."""
    moves = {}
    for own in (None, 0.02):
        geometry = {"learning_rate": own, "modulus": True}
        config = tiny_config(
            observer={"kind": "none"},
            controller={"kind": "sinusoid"},
            design={"kind": "geometry", "geometry": geometry},
            loop={"design_learning_rate": 0.5, "safeguards": {"gradient_clip": None}},
        )
        robot = litl.designs.apply(tiny_robot(), config.design)
        algorithm = make_algorithm(robot, config.algorithm)
        start = algorithm.init(0)
        after, _ = jax.jit(algorithm.optimize)(start)
        moves[own] = {k: float(jnp.abs(after.design[k] - start.design[k]).max()) for k in start.design}
    assert moves[0.02]["occupancy"] <= 0.02 + 1e-6 < 0.1 < moves[None]["occupancy"]
    assert moves[0.02]["youngs_modulus"] == pytest.approx(moves[None]["youngs_modulus"], rel=1e-4)


def test_a_growing_projection_makes_the_design_crisper_step_by_step():
    """projection_growth 1.5: the sharpness, carried in φ and never moved by the gradient, grows
    by 1.5 per design step taken, up to projection_max; the same occupancies read crisper."""
    config = tiny_config(
        observer={"kind": "none"},
        controller={"kind": "sinusoid"},
        design={"kind": "geometry", "geometry": {"projection_growth": 1.5, "projection_max": 10.0}},
    )
    robot = litl.designs.apply(tiny_robot(), config.design)
    space = robot.design_space
    algorithm = make_algorithm(robot, config.algorithm)
    optimize = jax.jit(algorithm.optimize)
    state = algorithm.init(0)
    assert float(state.design["projection"]) == pytest.approx(2.0)
    sharpness = []
    for _ in range(5):
        state, metrics = optimize(state)
        sharpness.append(float(state.design["projection"]))
        assert float(metrics["geometry/projection"]) == pytest.approx(sharpness[-1])
    # Each kept design step multiplies it by 1.5 (an iteration the safeguards refuse keeps it).
    ladder = [2.0 * 1.5**k for k in range(1, 4)] + [10.0]
    assert all(any(abs(value - rung) < 1e-5 for rung in ladder) for value in sharpness), sharpness
    assert sharpness == sorted(sharpness) and sharpness[-1] >= 6.75 - 1e-5
    occupancy = jnp.linspace(0.2, 0.8, robot.layout.n_particles)
    gray = lambda beta: float(
        space.summary({"occupancy": occupancy, "projection": jnp.asarray(beta)})["geometry/grayness"]
    )
    assert gray(10.0) < gray(2.0)
    assert "projection" not in litl.designs.apply(tiny_robot(), "geometry").design_space.initial()


def test_placement_asked_of_a_robot_without_actuators_is_refused_before_anything_runs(tmp_path):
    from PIL import Image

    block = tmp_path / "block.png"
    Image.fromarray(np.zeros((8, 16, 3), np.uint8), "RGB").save(block)  # all black: passive body
    config = compose([f"robot.image={block}", "robot.width=0.25", "design=actuators"])
    with pytest.raises(SettingsError, match=r"design=actuators places the robot's actuators.*has none"):
        run_experiment(config, tmp_path / "run")
    assert not (tmp_path / "run").exists()
