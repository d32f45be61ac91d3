"""A loop that never poisons itself: failed iterations keep nothing of their own (with step backs on,
they retake the last step shorter) and are recorded."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import litl.robots
from litl.loop.algorithm import SKIP_REASONS, make_algorithm
from litl.loop.run import run
from litl.robots.robot import Robot
from litl.sim import Boundary, SimConfig
from litl.viz.run_pictures import draw_run
from tests.loop.tiny import tiny_config, tiny_robot


def _same(a, b):
    return all(
        np.array_equal(np.asarray(x), np.asarray(y), equal_nan=True)
        for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True)
    )


def test_a_blown_up_iteration_updates_nothing_and_says_why():
    algorithm = make_algorithm(tiny_robot(), tiny_config(observer={"kind": "kmeans"}).algorithm)
    state = algorithm.init(0)
    # A design far outside the bounds (and the time step's range) blows the rollout up.
    blown = state.replace(design=jnp.full_like(state.design, 1e7))
    after, metrics = jax.jit(algorithm.optimize)(blown)
    # It blows up: positions run off the grid (without the strain limit they then turn
    # non-finite; with it the clamped stress stays finite, but the particles still leave).
    assert SKIP_REASONS[int(metrics["skipped"])] in ("particles_escaped", "simulation_nonfinite")
    assert int(metrics["first_escape_step"]) >= 0
    assert int(after.consecutive_skips) == 1 and int(after.iteration) == 1
    for field in (
        "controller",
        "design",
        "controller_optimizer",
        "design_optimizer",
        "buffer",
        "observer",
        "best",
    ):
        assert _same(getattr(after, field), getattr(blown, field)), field
    assert float(after.best.task_loss) == np.inf


def test_a_robot_the_untrained_controller_leaves_at_rest_keeps_a_usable_observer():
    # The arm under method=paper: no gravity, and a controller reading only the features of an
    # empty field outputs zero, so the bootstrap rollout records nothing but zero fields. The
    # observer's input scale must not be fitted to them (it would drop to its floor, 1e-6, and
    # the first gradient through the features would be ~1e8 or not finite).
    algorithm = make_algorithm(litl.robots.get("arm", dx=1 / 32), tiny_config("paper").algorithm)
    state, _ = jax.jit(algorithm.bootstrap)(algorithm.init(0))
    assert int(state.buffer.count) > 0 and float(jnp.abs(state.buffer.fields).max()) == 0.0
    assert float(state.observer.scale) == 1.0
    after, metrics = jax.jit(algorithm.optimize)(state)
    assert int(metrics["skipped"]) == 0, SKIP_REASONS[int(metrics["skipped"])]
    assert 0 < float(metrics["controller_grad_norm"]) < 1.0


def test_a_healthy_iteration_keeps_the_parameters_of_its_rollout_as_best():
    algorithm = make_algorithm(tiny_robot(), tiny_config(observer={"kind": "kmeans"}).algorithm)
    state = algorithm.init(0)
    after, metrics = jax.jit(algorithm.optimize)(state)
    assert int(metrics["skipped"]) == 0 and int(after.consecutive_skips) == 0
    # One value XLA may compute twice (fused into two consumers): equal to float32 rounding.
    assert float(after.best.task_loss) == pytest.approx(float(metrics["task_loss"]), rel=1e-6, abs=1e-9)
    assert int(after.best.step) == 0
    assert _same(after.best.controller, state.controller)  # the parameters that were simulated
    assert not _same(after.controller, state.controller)  # ... then updated
    assert int(after.buffer.count) == 4


def _falling_robot():
    """The tiny biped over an open floor under strong gravity: it falls out of the grid."""
    robot = tiny_robot()
    config = SimConfig(
        robot.config.grid_shape,
        robot.config.dx,
        robot.config.dt,
        (0.0, -60.0),
        boundary=Boundary.box(2, floor="open"),
    )
    return Robot("falling", robot.layout, config, task=robot.task, steps=robot.steps)


def test_a_run_whose_seeds_always_fail_records_skips_and_still_draws(tmp_path, capsys):
    config = tiny_config(observer={"kind": "kmeans"}, loop={"iterations": 3, "episodes": 2})
    result = run(_falling_robot(), config, tmp_path, progress=False)
    err = capsys.readouterr().err
    assert "particles left the grid" in err and "iteration skipped" in err
    assert "has failed 5 iterations in a row" in err
    for record in result.metrics:
        assert record["skipped"] == "particles_escaped"
        assert record["design"] == [20.0] * 4  # never updated
    assert [r["consecutive_skips"] for r in result.metrics if r["seed"] == 0] == [1, 2, 3, 4, 5, 6]
    best = json.loads((tmp_path / "best.json").read_text())
    assert best == [{"seed": 0, "task_loss": None, "step": -1}, {"seed": 1, "task_loss": None, "step": -1}]
    written = draw_run(_falling_robot(), config.context(), result, tmp_path)
    err = capsys.readouterr().err
    assert "pictures: skipping seed 0" in err and "pictures: skipping seed 1" in err
    assert "no seed has a finite final rollout" in err
    assert (tmp_path / "robot.png") in written and not (tmp_path / "robot.gif").exists()


def test_an_observer_update_that_breaks_the_controller_is_refused():
    """loop.update_tolerance: the stepped observer is simulated with the current controller; a
    worse (here: non-finite) result keeps the old observer, and the phase says so."""
    algorithm = make_algorithm(
        tiny_robot(), tiny_config(loop={"safeguards": {"update_tolerance": 0.0}}).algorithm
    )
    pieces = algorithm.learn.__self__
    state, _ = jax.jit(algorithm.bootstrap)(algorithm.init(0))
    assert bool(state.stats["update_accepted"])  # the bootstrap is not checked
    safe = jax.jit(pieces.update_is_safe, static_argnums=2)
    # The same observer, simulated twice in one program: no worse, to rounding. XLA need not round
    # two copies of a computation alike (the older CPU emitters the tests use put them 3e-8 apart),
    # and the tiny run's task loss, 4.5e-5, is small beside its terms: 1% of it.
    assert bool(safe(state, state.observer, 0.01))
    broken = state.observer.replace(scale=jnp.full_like(state.observer.scale, jnp.nan))
    assert not bool(safe(state, broken, 0.01))  # the same tolerance: the same program

    # The check's verdict as an argument of one program (patched while it is traced): a refused
    # step leaves Θ as it was; an accepted one moves it.
    def learn_with(state, verdict, first):
        object.__setattr__(pieces, "update_is_safe", lambda *args: verdict)
        return algorithm.learn(state, first=first)

    learn = jax.jit(learn_with)
    refused, stats = learn(state, False, False)
    assert not bool(stats["update_accepted"]) and _same(refused.observer, state.observer)
    taken, stats = learn(state, True, False)
    assert bool(stats["update_accepted"]) and not _same(taken.observer, state.observer)
    # `first` passed as a value (the run shell's one program for the bootstrap's phase and the
    # later ones): the first phase takes Θ′ whole even where the check refuses, as the bootstrap
    # does.
    first, stats = learn(jax.jit(algorithm.fill)(algorithm.init(0)), False, True)
    assert bool(stats["update_accepted"])
    for mine, bootstrapped in zip(
        jax.tree.leaves(first.observer), jax.tree.leaves(state.observer), strict=True
    ):
        np.testing.assert_allclose(mine, bootstrapped, rtol=1e-5, atol=1e-7)
    assert learn._cache_size() == 1
    # None: the paper's loop, never checked.
    unchecked = make_algorithm(
        tiny_robot(), tiny_config(loop={"safeguards": {"update_tolerance": None}}).algorithm
    )
    _, stats = jax.jit(unchecked.learn)(state)
    assert bool(stats["update_accepted"])


def test_a_much_worse_iteration_steps_back_and_halves_the_step():
    """loop.step_back_tolerance: the anchor's step is retaken at half the size (no simulation
    repeated), at most three times in a row; then the next result is accepted."""
    algorithm = make_algorithm(
        tiny_robot(),
        tiny_config(
            observer={"kind": "kmeans"},
            # constant step sizes: every retaken step is exactly half the last
            loop={"safeguards": {"step_back_tolerance": 0.2, "final_learning_rate_fraction": 1.0}},
        ).algorithm,
    )
    optimize = jax.jit(algorithm.optimize)
    start = algorithm.init(0)
    first, metrics = optimize(start)
    # The anchor keeps the iteration's loss: XLA may compute one value twice for two outputs, so
    # equal to float32 rounding (of centroids ~0.3 apart by ~4e-5 here), not bit for bit.
    assert not bool(metrics["stepped_back"])
    np.testing.assert_allclose(
        float(first.anchor.task_loss), float(metrics["task_loss"]), rtol=1e-5, atol=1e-7
    )
    full_step = jax.tree.map(lambda a, b: a - b, first.controller, start.controller)
    # Pretend the anchor had done far better: every result now counts as a fall.
    state = first.replace(anchor=first.anchor.replace(task_loss=jnp.asarray(-1e6, jnp.float32)))
    for halvings in (1, 2, 3):
        state, metrics = optimize(state)
        assert bool(metrics["stepped_back"]) and float(state.anchor.step_scale) == 0.5**halvings
        expected = jax.tree.map(lambda a, u, h=halvings: a + u * 0.5**h, start.controller, full_step)
        for got, want in zip(jax.tree.leaves(state.controller), jax.tree.leaves(expected), strict=True):
            np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-7)
    state, metrics = optimize(state)  # three halvings: accepted whatever it is
    assert not bool(metrics["stepped_back"]) and float(state.anchor.step_scale) == 1.0
    assert int(state.iteration) == 5
    # Off (None, the paper's loop): never.
    plain = make_algorithm(
        tiny_robot(),
        tiny_config(
            observer={"kind": "kmeans"}, loop={"safeguards": {"step_back_tolerance": None}}
        ).algorithm,
    )
    _, metrics = jax.jit(plain.optimize)(
        plain.init(0).replace(anchor=state.anchor.replace(task_loss=jnp.asarray(-1e6, jnp.float32)))
    )
    assert not bool(metrics["stepped_back"])


def test_a_failed_iteration_retakes_the_last_step_at_half_its_size():
    """With step backs on, a rollout that fails after an accepted step retakes that step at half
    its size (the failure came from the step's parameters) and keeps nothing else of its own; off
    (the paper's loop) it changes nothing, as before."""
    settings = {"step_back_tolerance": 0.2, "final_learning_rate_fraction": 1.0}
    algorithm = make_algorithm(
        tiny_robot(), tiny_config(observer={"kind": "kmeans"}, loop={"safeguards": settings}).algorithm
    )
    optimize = jax.jit(algorithm.optimize)
    start = algorithm.init(0)
    first, _ = optimize(start)
    full_step = jax.tree.map(lambda a, b: a - b, first.controller, start.controller)
    # The parameters the step reached blow the rollout up.
    blown = first.replace(design=jnp.full_like(first.design, 1e7))
    after, metrics = optimize(blown)
    assert SKIP_REASONS[int(metrics["skipped"])] in ("particles_escaped", "simulation_nonfinite")
    assert bool(metrics["stepped_back"]) and float(after.anchor.step_scale) == 0.5
    half = jax.tree.map(lambda a, u: a + u / 2, start.controller, full_step)
    for got, want in zip(jax.tree.leaves(after.controller), jax.tree.leaves(half), strict=True):
        np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-7)
    assert np.all(np.asarray(after.design) < 1e3)  # back near the anchor's design, in its bounds
    assert int(after.consecutive_skips) == 1
    for field in ("buffer", "observer", "best"):
        assert _same(getattr(after, field), getattr(blown, field)), field
    # The retaken step is healthy again.
    _, metrics = optimize(after)
    assert int(metrics["skipped"]) == 0
    # Off: nothing changes.
    plain = make_algorithm(
        tiny_robot(),
        tiny_config(
            observer={"kind": "kmeans"}, loop={"safeguards": {"step_back_tolerance": None}}
        ).algorithm,
    )
    first = jax.jit(plain.optimize)(plain.init(0))[0]
    blown = first.replace(design=jnp.full_like(first.design, 1e7))
    after, metrics = jax.jit(plain.optimize)(blown)
    assert int(metrics["skipped"]) != 0 and not bool(metrics["stepped_back"])
    assert _same(after.controller, blown.controller) and _same(after.design, blown.design)


def test_step_sizes_decay_on_a_cosine_to_the_final_fraction():
    """loop.final_learning_rate_fraction: the same gradients move θ the full step at the first
    iteration, the configured fraction of it at the run's last (K x M = 4 here), and the cosine's
    value in between; optimizer states are those of the constant-step run."""

    def step(fraction, iteration):
        algorithm = make_algorithm(
            tiny_robot(),
            tiny_config(
                observer={"kind": "kmeans"}, loop={"safeguards": {"final_learning_rate_fraction": fraction}}
            ).algorithm,
        )
        start = algorithm.init(0).replace(iteration=jnp.asarray(iteration, jnp.int32))
        after, _ = jax.jit(algorithm.optimize)(start)
        return jax.tree.map(lambda a, b: a - b, after.controller, start.controller), after

    for iteration, factor in ((0, 1.0), (1, 0.25 + 0.75 * 0.75), (3, 0.25)):
        constant, constant_state = step(1.0, iteration)
        decayed, decayed_state = step(0.25, iteration)
        assert _same(constant_state.controller_optimizer, decayed_state.controller_optimizer)
        for got, full in zip(jax.tree.leaves(decayed), jax.tree.leaves(constant), strict=True):
            assert np.abs(full).max() > 0
            np.testing.assert_allclose(got, full * factor, rtol=1e-4, atol=1e-8)
