"""Finite-horizon discrete-time LQR in the latent space, by the backward Riccati recursion.

The problem (time-invariant, `LQRProblem`): dynamics z_{t+1} = A z_t + B a_t + c and the cost

    J = Σ_{t=0}^{T-1} [(z_t - z*)ᵀ Q (z_t - z*) + a_tᵀ R a_t] + (z_T - z*)ᵀ Qf (z_T - z*)

over T = `horizon` steps to a target latent z*. In the error e = z - z* the dynamics are
e' = A e + B a + d with d = A z* + c - z* (the affine term), so the optimal policy is affine,
a_t = -K_t e_t - k_t, and the cost-to-go is V_t(e) = eᵀ P_t e + 2 p_tᵀ e + s_t:

    Quu = R + Bᵀ P' B,  K = Quu⁻¹ Bᵀ P' A,  k = Quu⁻¹ Bᵀ (P' d + p'),
    P = Q + Aᵀ P' A - Kᵀ Quu K,  p = Aᵀ (P' d + p') - Kᵀ Quu k,
    s = s' + dᵀ P' d + 2 p'ᵀ d - kᵀ Quu k,   from P_T = Qf, p_T = 0, s_T = 0.

`solve` runs it as a reversed `lax.scan`; `rollout` applies the gains (jit-compiled), and is the
only place actions are clipped to the actuators' range [-1, 1] (`clip=True`): the gains are the
unconstrained problem's, so with clipping the rollout is no longer optimal, only feasible.
Q, Qf must be symmetric positive semidefinite and R positive definite (not checked).
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any, Self

import jax
import jax.numpy as jnp
from flax import struct

from litl.latent.dynamics import LinearDynamics


@struct.dataclass
class LQRProblem:
    """A time-invariant LQR problem with an affine term and a target (see the module docstring).

    Attributes:
      A: (r, r) state matrix.
      B: (r, m) input matrix.
      c: (r,) affine term of the dynamics.
      Q: (r, r) state cost per step.
      R: (m, m) action cost per step.
      Qf: (r, r) terminal state cost.
      target: (r,) the target latent z*.
    """

    A: jnp.ndarray
    B: jnp.ndarray
    c: jnp.ndarray
    Q: jnp.ndarray
    R: jnp.ndarray
    Qf: jnp.ndarray
    target: jnp.ndarray

    if TYPE_CHECKING:  # flax.struct adds `replace` at run time; declared for the type checker

        def replace(self, **changes: Any) -> Self: ...

    @classmethod
    def from_linear(cls, model: LinearDynamics, Q, R, Qf, target) -> LQRProblem:
        """The problem of steering a fitted `LinearDynamics` to `target`."""
        return cls(A=model.A, B=model.B, c=model.c, Q=Q, R=R, Qf=Qf, target=target)

    @property
    def latent_size(self) -> int:
        return self.A.shape[-1]

    @property
    def action_size(self) -> int:
        return self.B.shape[-1]

    def check(self) -> None:
        """Raise ValueError naming the first array whose shape does not fit A's (r, r) and B's
        (r, m), or, where concrete, that holds non-finite values."""
        if self.A.ndim != 2 or self.A.shape[0] != self.A.shape[1]:
            raise ValueError(f"A must have shape (r, r), got {self.A.shape}")
        r = self.A.shape[0]
        if self.B.ndim != 2 or self.B.shape[0] != r:
            raise ValueError(f"B must have shape (r={r}, m), got {self.B.shape}")
        m = self.B.shape[1]
        expected = {"c": (r,), "Q": (r, r), "R": (m, m), "Qf": (r, r), "target": (r,)}
        for name, shape in expected.items():
            got = jnp.shape(getattr(self, name))
            if got != shape:
                raise ValueError(f"{name} must have shape {shape} (r={r}, m={m}), got {got}")
        for name in ("A", "B", *expected):
            value = getattr(self, name)
            if not isinstance(value, jax.core.Tracer) and not bool(jnp.all(jnp.isfinite(value))):
                raise ValueError(f"{name} holds non-finite values; all must be finite")


@struct.dataclass
class LQRSolution:
    """The time-varying affine policy a_t = -K_t (z_t - z*) - k_t and its cost-to-go.

    Attributes:
      gains: (T, m, r) K_t.
      offsets: (T, m) k_t.
      value_matrices: (T + 1, r, r) P_t (P_T = Qf).
      value_vectors: (T + 1, r) p_t.
      value_constants: (T + 1,) s_t; the optimal cost from z_0 is V_0(z_0 - z*).
    """

    gains: jnp.ndarray
    offsets: jnp.ndarray
    value_matrices: jnp.ndarray
    value_vectors: jnp.ndarray
    value_constants: jnp.ndarray

    @property
    def horizon(self) -> int:
        return self.gains.shape[0]

    def cost_to_go(self, latent, target, t: int = 0):
        """() V_t(z - z*), the optimal (unclipped) cost from `latent` (r,) at step t."""
        error = latent - target
        return (
            error @ self.value_matrices[t] @ error
            + 2 * self.value_vectors[t] @ error
            + self.value_constants[t]
        )


def check_horizon(horizon) -> int:
    if isinstance(horizon, bool) or not isinstance(horizon, int) or horizon < 1:
        raise ValueError(f"horizon must be a positive int (control steps, >= 1), got {horizon!r}")
    return horizon


def solve(problem: LQRProblem, horizon: int) -> LQRSolution:
    """The backward Riccati recursion over `horizon` steps (a reversed `lax.scan`; jittable
    with `horizon` static, differentiable in every array of `problem`)."""
    horizon = check_horizon(horizon)
    problem.check()
    A, B, Q, R = problem.A, problem.B, problem.Q, problem.R
    drift = A @ problem.target + problem.c - problem.target  # d: e' = A e + B a + d

    def backward(carry, _):
        P, p, s = carry
        Quu = R + B.T @ P @ B
        Quu = (Quu + Quu.T) / 2  # keep it symmetric against rounding
        lookahead = P @ drift + p
        K = jnp.linalg.solve(Quu, B.T @ P @ A)
        k = jnp.linalg.solve(Quu, B.T @ lookahead)
        P_new = Q + A.T @ P @ A - K.T @ Quu @ K
        P_new = (P_new + P_new.T) / 2
        p_new = A.T @ lookahead - K.T @ Quu @ k
        s_new = s + drift @ P @ drift + 2 * p @ drift - k @ Quu @ k
        return (P_new, p_new, s_new), (K, k, P_new, p_new, s_new)

    terminal = (problem.Qf, jnp.zeros_like(problem.target), jnp.zeros((), problem.Qf.dtype))
    _, (gains, offsets, Ps, ps, ss) = jax.lax.scan(backward, terminal, None, length=horizon, reverse=True)
    return LQRSolution(
        gains=gains,
        offsets=offsets,
        value_matrices=jnp.concatenate([Ps, problem.Qf[None]]),
        value_vectors=jnp.concatenate([ps, terminal[1][None]]),
        value_constants=jnp.concatenate([ss, terminal[2][None]]),
    )


def total_cost(problem: LQRProblem, latents, actions):
    """() J of a trajectory: latents (T + 1, r) z_0 ... z_T, actions (T, m)."""
    errors = latents - problem.target
    running = jnp.einsum("ti,ij,tj->", errors[:-1], problem.Q, errors[:-1])
    effort = jnp.einsum("ti,ij,tj->", actions, problem.R, actions)
    return running + effort + errors[-1] @ problem.Qf @ errors[-1]


@functools.partial(jax.jit, static_argnames=("clip",))
def rollout(problem: LQRProblem, solution: LQRSolution, initial, clip: bool = True):
    """Apply the gains from `initial` (r,) through the problem's linear dynamics.

    Args:
      problem: the dynamics, costs and target the solution was computed for.
      solution: `solve`'s gains.
      initial: (r,) z_0.
      clip: clip each action to the actuators' range [-1, 1] (the only place LQR clips).

    Returns:
      (latents (T + 1, r) z_0 ... z_T, actions (T, m), the total cost J of that trajectory).
    """

    def forward(latent, gain):
        K, k = gain
        action = -K @ (latent - problem.target) - k
        if clip:
            action = jnp.clip(action, -1.0, 1.0)
        following = problem.A @ latent + problem.B @ action + problem.c
        return following, (following, action)

    _, (following, actions) = jax.lax.scan(forward, initial, (solution.gains, solution.offsets))
    latents = jnp.concatenate([initial[None], following])
    return latents, actions, total_cost(problem, latents, actions)
