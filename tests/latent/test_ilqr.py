"""iLQR: on a linear-quadratic problem its first full step is LQR's answer; on a nonlinear one it
descends monotonically to the goal; bad settings are refused."""

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from litl.latent import LQRProblem, rollout, solve
from litl.latent.ilqr import ilqr, trajectory


def random_problem(seed: int, r: int = 4, m: int = 2) -> LQRProblem:
    rng = np.random.default_rng(seed)
    A = np.eye(r) + 0.1 * rng.normal(size=(r, r))
    B = rng.normal(size=(r, m))
    Q = np.diag(rng.uniform(0.5, 2.0, r))
    as_array = lambda x: jnp.asarray(x, jnp.float64)
    return LQRProblem(
        A=as_array(A),
        B=as_array(B),
        c=as_array(0.1 * rng.normal(size=r)),
        Q=as_array(Q),
        R=as_array(0.3 * np.eye(m)),
        Qf=as_array(3 * Q),
        target=as_array(rng.normal(size=r)),
    )


@pytest.mark.parametrize("seed", [0, 1])
def test_one_full_step_on_a_linear_quadratic_problem_is_lqr(x64, seed):
    problem, horizon = random_problem(seed), 12
    z0 = jnp.asarray(np.random.default_rng(10 + seed).normal(size=4), jnp.float64)
    dynamics = lambda z, a: problem.A @ z + problem.B @ a + problem.c
    error = lambda z: z - problem.target
    stage = lambda z, a, t: error(z) @ problem.Q @ error(z) + a @ problem.R @ a
    final = lambda z: error(z) @ problem.Qf @ error(z)
    controls, states, costs = ilqr(
        dynamics, stage, final, z0, jnp.zeros((horizon, 2), jnp.float64), 1, 1e-12, (1.0,)
    )
    latents, actions, cost = rollout(problem, solve(problem, horizon), z0, clip=False)
    chex.assert_trees_all_close(controls, actions, rtol=1e-8, atol=1e-10)
    chex.assert_trees_all_close(states, latents, rtol=1e-8, atol=1e-10)
    chex.assert_trees_all_close(costs[-1], cost, rtol=1e-10)
    # the optimum: a second iteration finds nothing cheaper
    _, _, again = ilqr(dynamics, stage, final, z0, controls, 1)
    assert float(again[-1]) == pytest.approx(float(cost), rel=1e-9)


def test_it_swings_a_pendulum_to_an_angle_and_holds_it_there_descending_every_iteration(x64):
    dt, target = 0.05, 1.2

    def pendulum(s, u):
        angle, speed = s
        speed = speed + dt * (-9.0 * jnp.sin(angle) - 0.2 * speed + 12.0 * jnp.tanh(u[0]))
        return jnp.stack([angle + dt * speed, speed])

    stage = lambda s, u, t: 0.1 * (s[0] - target) ** 2 + 1e-3 * jnp.tanh(u[0]) ** 2
    final = lambda s: 10 * (s[0] - target) ** 2 + s[1] ** 2
    s0 = jnp.zeros(2, jnp.float64)
    controls, states, costs = jax.jit(lambda u: ilqr(pendulum, stage, final, s0, u, 30))(
        jnp.zeros((40, 1), jnp.float64)
    )
    costs = np.asarray(costs)
    assert np.all(np.diff(costs) <= 1e-12), costs
    assert costs[-1] < 0.1 * costs[0]
    assert abs(float(states[-1, 0]) - target) < 0.02 and abs(float(states[-1, 1])) < 0.1
    chex.assert_trees_all_close(trajectory(pendulum, s0, controls), states, rtol=1e-12)


def test_bad_settings_are_refused():
    f = lambda s, u: s + u
    stage = lambda s, u, t: jnp.sum(s**2)
    final = lambda s: jnp.sum(s**2)
    with pytest.raises(ValueError, match="iterations must be a positive int"):
        ilqr(f, stage, final, jnp.zeros(1), jnp.zeros((3, 1)), 0)
    with pytest.raises(ValueError, match="regularization must be > 0"):
        ilqr(f, stage, final, jnp.zeros(1), jnp.zeros((3, 1)), 2, regularization=0.0)
