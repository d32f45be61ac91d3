"""Iterative LQR (iLQR) for any differentiable dynamics and stage costs, as pure JAX.

The problem: controls u_0 … u_{T-1} minimizing

    J = Σ_{t=0}^{T-1} ℓ(s_t, u_t, t) + ℓ_f(s_T),   s_{t+1} = f(s_t, u_t),  s_0 given.

Each iteration (Li & Todorov 2004; the line search of Tassa, Erez & Todorov 2012) rolls the
current controls out, takes f's Jacobians and ℓ's gradients and Hessians along that trajectory
(`jax.jacfwd`, `jax.hessian`), runs the backward pass of the resulting time-varying LQR problem

    Q_x = ℓ_x + f_xᵀ V_x',  Q_u = ℓ_u + f_uᵀ V_x',  Q_xx = ℓ_xx + f_xᵀ V_xx' f_x,
    Q_uu = ℓ_uu + f_uᵀ V_xx' f_u,  Q_ux = ℓ_ux + f_uᵀ V_xx' f_x,
    k = −Q_uu⁻¹ Q_u,  K = −Q_uu⁻¹ Q_ux,
    V_x = Q_x + Kᵀ Q_uu k + Kᵀ Q_u + Q_uxᵀ k,  V_xx = Q_xx + Kᵀ Q_uu K + Kᵀ Q_ux + Q_uxᵀ K,

with Q_uu's eigenvalues clipped from below at a floor (so that a nonconvex model gives a descent
direction; the floor starts at `regularization`, rises tenfold after an iteration that found
nothing cheaper and falls tenfold, not below `regularization`, after one that did), then tries
the new controls u_t + α k_t + K_t (ŝ_t − s_t) for every α of `steps` at once (vmapped) and
keeps the cheapest, or the current controls where none is cheaper: the cost never rises. On
linear dynamics with a quadratic cost the first iteration at α = 1 is the LQR solution
(`litl.latent.lqr`), which is what tests/latent/test_ilqr.py checks.

`ilqr` is jittable and vmappable with `iterations` and `steps` static; bounded controls are the
caller's to parametrize (the latent planner plans tanh logits, as its shooting MPC does).
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

STEPS = (1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125)


def trajectory(dynamics: Callable, initial, controls):
    """(T + 1, n) the states from `initial` under `controls` (T, m)."""

    def forward(state, control):
        following = dynamics(state, control)
        return following, following

    _, following = jax.lax.scan(forward, initial, controls)
    return jnp.concatenate([initial[None], following])


def total(stage_cost: Callable, final_cost: Callable, states, controls):
    """() J of a trajectory: states (T + 1, n), controls (T, m)."""
    times = jnp.arange(controls.shape[0])
    return jnp.sum(jax.vmap(stage_cost)(states[:-1], controls, times)) + final_cost(states[-1])


def _psd_floor(matrix, floor):
    """The symmetric part of `matrix` with its eigenvalues raised to at least `floor`."""
    values, vectors = jnp.linalg.eigh((matrix + matrix.T) / 2)
    return (vectors * jnp.maximum(values, floor)) @ vectors.T


def _backward(dynamics, stage_cost, final_cost, states, controls, regularization):
    """The gains (K (T, m, n), k (T, m)) of the LQR problem around the trajectory."""
    times = jnp.arange(controls.shape[0])
    fx, fu = jax.vmap(jax.jacfwd(dynamics, argnums=(0, 1)))(states[:-1], controls)
    lx, lu = jax.vmap(jax.grad(stage_cost, argnums=(0, 1)))(states[:-1], controls, times)
    hessians = jax.vmap(jax.hessian(stage_cost, argnums=(0, 1)))(states[:-1], controls, times)
    (lxx, lxu), (_, luu) = hessians
    final = states[-1]
    Vx, Vxx = jax.grad(final_cost)(final), jax.hessian(final_cost)(final)

    def step(carry, derivatives):
        Vx, Vxx = carry
        fx, fu, lx, lu, lxx, lxu, luu = derivatives
        Qx = lx + fx.T @ Vx
        Qu = lu + fu.T @ Vx
        Qxx = lxx + fx.T @ Vxx @ fx
        Quu = _psd_floor(luu + fu.T @ Vxx @ fu, regularization)
        Qux = lxu.T + fu.T @ Vxx @ fx
        k = -jnp.linalg.solve(Quu, Qu)
        K = -jnp.linalg.solve(Quu, Qux)
        Vx = Qx + K.T @ Quu @ k + K.T @ Qu + Qux.T @ k
        Vxx = Qxx + K.T @ Quu @ K + K.T @ Qux + Qux.T @ K
        return (Vx, (Vxx + Vxx.T) / 2), (K, k)

    derivatives = (fx, fu, lx, lu, lxx, lxu, luu)
    _, (K, k) = jax.lax.scan(step, (Vx, Vxx), derivatives, reverse=True)
    return K, k


def _forward(dynamics, states, controls, K, k, alpha):
    """(states, controls) of the new controls u_t + α k_t + K_t (ŝ_t − s_t)."""

    def forward(state, inputs):
        nominal_state, nominal_control, gain, offset = inputs
        control = nominal_control + alpha * offset + gain @ (state - nominal_state)
        return dynamics(state, control), (state, control)

    last, (visited, new_controls) = jax.lax.scan(forward, states[0], (states[:-1], controls, K, k))
    return jnp.concatenate([visited, last[None]]), new_controls


def ilqr(
    dynamics: Callable,
    stage_cost: Callable,
    final_cost: Callable,
    initial,
    controls,
    iterations: int,
    regularization: float = 1e-6,
    steps: tuple[float, ...] = STEPS,
):
    """Improve `controls` (T, m) from `initial` (n,) by `iterations` iLQR iterations (see the
    module docstring).

    Args:
      dynamics: ``f(s, u) -> s'``, differentiable.
      stage_cost: ``ℓ(s, u, t) -> ()``, twice differentiable (t: the step, an int array).
      final_cost: ``ℓ_f(s) -> ()``, twice differentiable.
      initial: (n,) s_0.
      controls: (T, m) the first guess (a warm start).
      iterations: backward and forward passes (static).
      regularization: the least floor of Q_uu's eigenvalues (> 0), where it starts.
      steps: the line search's step sizes α, tried at once (static).

    Returns:
      (controls (T, m), states (T + 1, n), costs (iterations + 1,) J before each iteration and
      after the last; non-increasing).
    """
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ValueError(f"iterations must be a positive int, got {iterations!r}")
    if not regularization > 0:
        raise ValueError(f"regularization must be > 0 (Q_uu's eigenvalue floor), got {regularization!r}")
    alphas = jnp.asarray(steps, controls.dtype)
    cost_of = lambda states, controls: total(stage_cost, final_cost, states, controls)

    def iteration(carry, _):
        states, controls, cost, floor = carry
        K, k = _backward(dynamics, stage_cost, final_cost, states, controls, floor)
        tried_states, tried_controls = jax.vmap(lambda a: _forward(dynamics, states, controls, K, k, a))(
            alphas
        )
        tried_costs = jax.vmap(cost_of)(tried_states, tried_controls)
        tried_costs = jnp.where(jnp.isfinite(tried_costs), tried_costs, jnp.inf)
        best = jnp.argmin(tried_costs)
        better = tried_costs[best] < cost
        states = jnp.where(better, tried_states[best], states)
        controls = jnp.where(better, tried_controls[best], controls)
        cost = jnp.where(better, tried_costs[best], cost)
        # Levenberg-Marquardt: a failed iteration raises the floor tenfold, a good one lowers it.
        floor = jnp.where(better, jnp.maximum(floor / 10, regularization), floor * 10)
        return (states, controls, cost, floor), cost

    states = trajectory(dynamics, initial, controls)
    start = cost_of(states, controls)
    floor = jnp.asarray(regularization, controls.dtype)
    carry = (states, controls, start, floor)
    (states, controls, _, _), costs = jax.lax.scan(iteration, carry, None, length=iterations)
    return controls, states, jnp.concatenate([start[None], costs])
