"""Design spaces as registered parts (`litl.designs`, ``design=<name>``): the robot's own
modulus, and actuator placement, whose weights start at the robot's own muscles and move."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import litl.designs
from litl.config import Config, SettingsError
from litl.loop.run import run
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


def test_co_designing_the_placement_moves_the_muscles_and_records_it(tmp_path):
    config = tiny_config(
        observer={"kind": "kmeans"}, design={"kind": "actuators"}, loop={"design_learning_rate": 0.5}
    )
    result = run(tiny_robot(), config, tmp_path, progress=False)
    saved = json.loads((tmp_path / "run.json").read_text())
    assert saved["config"]["design"]["kind"] == "actuators"
    records = result.metrics
    assert all("placement/actuated" in r and "placement/moved" in r for r in records)
    assert all(len(r["design"]) == tiny_robot().n_regions for r in records)  # the modulus per region
    start = litl.designs.apply(tiny_robot(), "actuators").design_space.initial()["placement"]
    final = result.state.design["placement"]
    moved = float(jnp.abs(final - start[None]).max())
    assert moved > 0.1, moved
    assert np.isfinite([r["task_loss"] for r in records]).all()


def test_an_evolution_strategy_refuses_a_design_space_it_cannot_search(tmp_path):
    from litl.app import compose, run_experiment

    config = compose(["optimizer=sep_cmaes", "design=actuators", "+scale=smoke", "output.progress=false"])
    with pytest.raises(SettingsError, match=r"searches the Young's modulus per region.*design=modulus"):
        run_experiment(config, tmp_path / "run")
    assert not (tmp_path / "run" / "run.json").exists()
