"""Finite-horizon LQR: the Riccati recursion against numpy and the DARE, its cost, its gradient."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg

from litl.latent import LQRProblem, rollout, solve, total_cost
from litl.latent.dynamics import LinearDynamics


def numpy_riccati(A, B, Q, R, Qf, horizon):
    """The textbook recursion for the regulator (no affine term, target 0), in float64 numpy."""
    P, gains = Qf, []
    for _ in range(horizon):
        K = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
        P = Q + A.T @ P @ (A - B @ K)
        gains.append(K)
    return P, gains[::-1]


def two_state_problem(dtype=jnp.float64, c=(0.0, 0.0), target=(0.0, 0.0)):
    as_array = lambda x: jnp.asarray(x, dtype)
    return LQRProblem(
        A=as_array([[1.0, 0.1], [0.0, 1.0]]),  # a double integrator
        B=as_array([[0.005], [0.1]]),
        c=as_array(c),
        Q=as_array(np.diag([1.0, 0.1])),
        R=as_array([[0.5]]),
        Qf=as_array(np.diag([5.0, 1.0])),
        target=as_array(target),
    )


def test_a_scalar_problem_matches_the_hand_computed_recursion():
    # a = 1.2, b = 0.5, q = 1, r = 2, qf = 3, horizon 2 by hand:
    # K_1 = b qf a / (r + b^2 qf) = 1.8 / 2.75; P_1 = q + a^2 qf - (b qf a)^2 / (r + b^2 qf).
    a, b, q, r, qf = 1.2, 0.5, 1.0, 2.0, 3.0
    K1 = b * qf * a / (r + b * b * qf)
    P1 = q + a * a * qf - (b * qf * a) ** 2 / (r + b * b * qf)
    K0 = b * P1 * a / (r + b * b * P1)
    P0 = q + a * a * P1 - (b * P1 * a) ** 2 / (r + b * b * P1)
    with jax.enable_x64(True):
        problem = LQRProblem(
            *(
                jnp.asarray(x, jnp.float64).reshape(s)
                for x, s in [
                    (a, (1, 1)),
                    (b, (1, 1)),
                    (0.0, (1,)),
                    (q, (1, 1)),
                    (r, (1, 1)),
                    (qf, (1, 1)),
                    (0.0, (1,)),
                ]
            )
        )
        solution = solve(problem, 2)
        np.testing.assert_allclose(np.asarray(solution.gains)[:, 0, 0], [K0, K1], rtol=1e-13)
        np.testing.assert_allclose(np.asarray(solution.value_matrices)[:, 0, 0], [P0, P1, qf], rtol=1e-13)


def test_the_two_state_gains_match_numpy_and_the_dare_at_long_horizons():
    with jax.enable_x64(True):
        problem = two_state_problem()
        args = [np.asarray(x) for x in (problem.A, problem.B, problem.Q, problem.R, problem.Qf)]
        solution = jax.jit(solve, static_argnums=1)(problem, 30)
        P0, gains = numpy_riccati(*args, 30)
        chex.assert_trees_all_close(solution.gains, jnp.asarray(np.stack(gains)), atol=1e-12, rtol=1e-12)
        chex.assert_trees_all_close(solution.value_matrices[0], jnp.asarray(P0), atol=1e-12, rtol=1e-12)
        # Long horizon: P_0 converges to the discrete algebraic Riccati equation's solution.
        long = solve(problem, 2000)
        dare = scipy.linalg.solve_discrete_are(args[0], args[1], args[2], args[3])
        np.testing.assert_allclose(long.value_matrices[0], dare, rtol=1e-9)
        K = np.linalg.solve(args[3] + args[1].T @ dare @ args[1], args[1].T @ dare @ args[0])
        np.testing.assert_allclose(long.gains[0], K, rtol=1e-9)


def test_the_unclipped_rollout_costs_the_value_function_and_reaches_an_affine_target():
    with jax.enable_x64(True):
        problem = two_state_problem(c=(0.01, -0.02), target=(0.5, 0.0))
        solution = solve(problem, 60)
        initial = jnp.asarray([0.0, 0.0])
        latents, actions, cost = rollout(problem, solution, initial, clip=False)
        assert latents.shape == (61, 2) and actions.shape == (60, 1)
        # The optimal cost from z_0 is V_0(z_0 - z*): the recursion's constants included.
        np.testing.assert_allclose(cost, solution.cost_to_go(initial, problem.target), rtol=1e-12)
        np.testing.assert_allclose(cost, total_cost(problem, latents, actions), rtol=1e-14)

        # Any other action sequence costs more (here: the optimal one perturbed).
        def cost_of(plan):
            def forward(z, a):
                following = problem.A @ z + problem.B @ a + problem.c
                return following, following

            _, following = jax.lax.scan(forward, initial, plan)
            return total_cost(problem, jnp.concatenate([initial[None], following]), plan)

        for seed in range(3):
            noise = 0.05 * jax.random.normal(jax.random.key(seed), actions.shape, jnp.float64)
            assert float(cost_of(actions + noise)) > float(cost)
        # Against the affine drift the first state ends near the target.
        assert abs(float(latents[-1, 0]) - 0.5) < 0.05


def test_clipping_happens_in_the_rollout_only():
    problem = two_state_problem(
        jnp.float32, target=(20.0, 0.0)
    )  # far: the unclipped gains ask for more than 1
    solution = solve(problem, 20)
    _, free, _ = rollout(problem, solution, jnp.zeros(2), clip=False)
    _, clipped, _ = rollout(problem, solution, jnp.zeros(2))
    assert float(jnp.max(jnp.abs(free))) > 1.0
    assert float(jnp.max(jnp.abs(clipped))) <= 1.0 and float(jnp.max(jnp.abs(clipped))) == 1.0


def test_the_total_cost_gradient_matches_central_differences_in_float64():
    with jax.enable_x64(True):
        base = two_state_problem(c=(0.01, -0.02), target=(0.3, 0.1))
        initial = jnp.asarray([0.1, -0.2])

        def cost(A, B, initial, target):
            problem = base.replace(A=A, B=B, target=target)
            return rollout(problem, solve(problem, 15), initial, clip=False)[2]

        arguments = (base.A, base.B, initial, base.target)
        gradients = jax.grad(cost, argnums=(0, 1, 2, 3))(*arguments)
        step = 1e-6
        for index, (argument, gradient) in enumerate(zip(arguments, gradients, strict=True)):
            flat = np.asarray(argument).ravel()
            numeric = np.zeros_like(flat)
            for i in range(flat.size):
                shift = np.zeros_like(flat)
                shift[i] = step
                plus = list(arguments)
                minus = list(arguments)
                plus[index] = jnp.asarray((flat + shift).reshape(argument.shape))
                minus[index] = jnp.asarray((flat - shift).reshape(argument.shape))
                numeric[i] = (cost(*plus) - cost(*minus)) / (2 * step)
            np.testing.assert_allclose(np.asarray(gradient).ravel(), numeric, rtol=1e-6, atol=1e-8)


def test_a_problem_from_a_fitted_linear_model():
    model = LinearDynamics(A=jnp.eye(3), B=jnp.ones((3, 2)), c=jnp.zeros(3))
    problem = LQRProblem.from_linear(model, jnp.eye(3), jnp.eye(2), jnp.eye(3), jnp.ones(3))
    assert (problem.latent_size, problem.action_size) == (3, 2)
    assert solve(problem, 4).gains.shape == (4, 2, 3)


def test_bad_problems_and_horizons_are_refused_by_name():
    problem = two_state_problem(jnp.float32)
    for horizon in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match=r"horizon must be a positive int \(control steps, >= 1\)"):
            solve(problem, horizon)
    for name, value, message in [
        ("A", jnp.zeros((2, 3)), r"A must have shape \(r, r\)"),
        ("B", jnp.zeros((3, 1)), r"B must have shape \(r=2, m\)"),
        ("R", jnp.eye(2), r"R must have shape \(1, 1\) \(r=2, m=1\), got \(2, 2\)"),
        ("Qf", jnp.eye(3), r"Qf must have shape \(2, 2\)"),
        ("target", jnp.zeros(3), r"target must have shape \(2,\)"),
        ("c", jnp.zeros((2, 1)), r"c must have shape \(2,\)"),
        ("Q", jnp.full((2, 2), jnp.nan), "Q holds non-finite values"),
    ]:
        with pytest.raises(ValueError, match=message):
            solve(problem.replace(**{name: value}), 5)
