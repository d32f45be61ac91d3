"""Batched 2x2 / 3x3 algebra written as broadcast multiply-adds.

XLA on CPU runs millions of tiny matrix products far faster as fused elementwise arithmetic than as
batched `dot`s, so everything here avoids `@`/`einsum` on (n, d, d) arrays.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def matmul(a, b):
    """(..., d, k) @ (..., k, e) -> (..., d, e)."""
    return jnp.sum(a[..., :, :, None] * b[..., None, :, :], axis=-2)


def matvec(a, v):
    """(..., d, k) @ (..., k) -> (..., d)."""
    return jnp.sum(a * v[..., None, :], axis=-1)


def transpose(a):
    return jnp.swapaxes(a, -1, -2)


def outer(u, v):
    """(..., d), (..., e) -> (..., d, e)."""
    return u[..., :, None] * v[..., None, :]


def trace(a):
    return jnp.sum(jnp.diagonal(a, axis1=-2, axis2=-1), axis=-1)


def det(a):
    """Determinant of (..., d, d), d in {2, 3}."""
    if a.shape[-1] == 2:
        return a[..., 0, 0] * a[..., 1, 1] - a[..., 0, 1] * a[..., 1, 0]
    return (
        a[..., 0, 0] * (a[..., 1, 1] * a[..., 2, 2] - a[..., 1, 2] * a[..., 2, 1])
        - a[..., 0, 1] * (a[..., 1, 0] * a[..., 2, 2] - a[..., 1, 2] * a[..., 2, 0])
        + a[..., 0, 2] * (a[..., 1, 0] * a[..., 2, 1] - a[..., 1, 1] * a[..., 2, 0])
    )


def cofactor(a):
    """Cofactor matrix of (..., 3, 3), so that inverse(a) = cofactor(a).T / det(a)."""
    c = lambda i, j: (
        a[..., (i + 1) % 3, (j + 1) % 3] * a[..., (i + 2) % 3, (j + 2) % 3]
        - a[..., (i + 1) % 3, (j + 2) % 3] * a[..., (i + 2) % 3, (j + 1) % 3]
    )
    return jnp.stack([jnp.stack([c(i, j) for j in range(3)], -1) for i in range(3)], -2)


def identity_like(a):
    return jnp.broadcast_to(jnp.eye(a.shape[-1], dtype=a.dtype), a.shape)


def polar_rotation(F):
    """Rotation R of the polar decomposition F = R S, for (..., d, d) with det F > 0.

    2D uses the closed form (as Taichi's `polar_decompose`), 3D a scaled Newton iteration with an
    analytic derivative that stays finite at repeated singular values (F = I included).
    """
    if F.shape[-1] == 2:
        return _polar_rotation_2d(F)
    return _polar_rotation_3d(F)


def _polar_rotation_2d(F):
    x = F[..., 0, 0] + F[..., 1, 1]
    y = F[..., 1, 0] - F[..., 0, 1]
    norm_sq = x * x + y * y
    # The rotation is undefined only when x = y = 0 (a fully degenerate F); masking the sqrt's
    # argument keeps its gradient finite there, and the identity is used instead.
    degenerate = norm_sq <= 0
    inv_norm = jnp.where(degenerate, 0.0, jax.lax.rsqrt(jnp.where(degenerate, 1.0, norm_sq)))
    c = jnp.where(degenerate, 1.0, x * inv_norm)
    s = y * inv_norm
    return jnp.stack([jnp.stack([c, -s], -1), jnp.stack([s, c], -1)], -2)


_NEWTON_ITERATIONS = 12


@jax.custom_jvp
def _polar_rotation_3d(F):
    def newton(_, X):
        cof = cofactor(X)
        d = det(X)[..., None, None]
        inv_t = cof / d  # X^{-T}
        # Higham's scaling makes the iteration converge fast even far from a rotation.
        gamma = jnp.sqrt(
            jnp.sqrt(jnp.sum(inv_t * inv_t, axis=(-2, -1)) / jnp.sum(X * X, axis=(-2, -1)))
        )[..., None, None]
        return 0.5 * (gamma * X + inv_t / gamma)

    return jax.lax.fori_loop(0, _NEWTON_ITERATIONS, newton, F)


@_polar_rotation_3d.defjvp
def _polar_rotation_3d_jvp(primals, tangents):
    (F,), (dF,) = primals, tangents
    R = _polar_rotation_3d(F)
    S = matmul(transpose(R), F)
    S = 0.5 * (S + transpose(S))
    # With F = R S: R^T dF - dF^T R = Omega S + S Omega for the skew Omega = R^T dR. In axial-vector
    # form this is (tr(S) I - S) omega = axial(R^T dF - dF^T R), whose matrix has eigenvalues
    # s_i + s_j > 0, so it is invertible even when singular values repeat (unlike the SVD's).
    M = matmul(transpose(R), dF)
    K = M - transpose(M)
    rhs = jnp.stack([K[..., 2, 1], K[..., 0, 2], K[..., 1, 0]], -1)
    A = trace(S)[..., None, None] * identity_like(S) - S
    omega = matvec(transpose(cofactor(A)), rhs) / det(A)[..., None]
    wx, wy, wz = omega[..., 0], omega[..., 1], omega[..., 2]
    zero = jnp.zeros_like(wx)
    Omega = jnp.stack(
        [jnp.stack([zero, -wz, wy], -1), jnp.stack([wz, zero, -wx], -1),
         jnp.stack([-wy, wx, zero], -1)],
        -2,
    )
    return R, matmul(R, Omega)
