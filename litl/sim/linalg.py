"""Small-matrix algebra on per-component arrays.

XLA on CPU runs millions of 2x2 / 3x3 products far faster as fused elementwise arithmetic on
(n,)-shaped arrays than as batched `dot`s or reductions over tiny trailing axes (measured: ~10x on
the walker scene). So inside a step, a vector is a list of d arrays and a matrix a list of d rows
of d arrays (``m[i][j]``), all of the same shape; `split_*`/`stack_*` convert at the boundary.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

Vec = list  # d arrays
Mat = list  # d rows of d arrays


def _concatenate_materialized(parts, axis):
    # XLA:CPU fuses the producers of a concatenate into it and then evaluates them element by
    # element with a branch per element (no SIMD), recomputing shared subexpressions per operand;
    # for the per-component backward of a step that cost 10x the whole forward pass. The barrier
    # makes each part a plain buffer first, so the concatenate is a cheap copy.
    parts = jax.lax.optimization_barrier(list(parts))
    return jnp.concatenate(parts, axis=axis)


@functools.partial(jax.custom_vjp, nondiff_argnums=(1,))
def unstack(a, axis=-1) -> list:
    """Split an array into its slices along `axis` (the inverse of `stack`)."""
    axis = axis % a.ndim
    return [jnp.squeeze(p, axis) for p in jnp.split(a, a.shape[axis], axis=axis)]


def _unstack_fwd(a, axis):
    return unstack(a, axis), a.ndim


def _unstack_bwd(axis, ndim, cotangents):
    return (stack(cotangents, axis % ndim),)


unstack.defvjp(_unstack_fwd, _unstack_bwd)


@functools.partial(jax.custom_vjp, nondiff_argnums=(1,))
def stack(parts, axis=-1):
    """Stack equally shaped arrays along a new `axis`, materializing them first (see above)."""
    axis = axis % (parts[0].ndim + 1)
    return _concatenate_materialized([jnp.expand_dims(p, axis) for p in parts], axis)


def _stack_fwd(parts, axis):
    return stack(parts, axis), parts[0].ndim + 1


def _stack_bwd(axis, ndim, cotangent):
    return (unstack(cotangent, axis % ndim),)


stack.defvjp(_stack_fwd, _stack_bwd)


def split_vec(x) -> Vec:
    """(..., d) array -> list of d arrays (...)."""
    return unstack(x, -1)


def split_mat(a) -> Mat:
    """(..., d, d) array -> nested list m[i][j] of arrays (...)."""
    return [unstack(row, -1) for row in unstack(a, -2)]


def stack_vec(v: Vec):
    return stack(v, -1)


def stack_mat(m: Mat):
    return stack([stack(row, -1) for row in m], -2)


def materialize(x, token):
    """Return x, computed into its own buffer before any consumer reads it.

    XLA:CPU fuses cheap elementwise producers into every consumer, so a grid field read through a
    gather (each node by up to 3^d * particles-per-cell particles) is recomputed per read: half the
    cost of a step. `optimization_barrier` is dropped on CPU, but a conditional on a runtime value
    is not: its branches are separate computations whose results are buffers.

    Args:
      x: pytree of arrays.
      token: () int32 that is >= 0 at run time and *not* batched under vmap (e.g. a scan counter),
        so that the conditional stays a conditional instead of becoming a select.
    """
    return jax.lax.cond(token >= 0, lambda t: t, lambda t: jax.tree.map(jnp.zeros_like, t), x)


def identity(d, like) -> Mat:
    one, zero = jnp.ones_like(like), jnp.zeros_like(like)
    return [[one if i == j else zero for j in range(d)] for i in range(d)]


def add(a: Mat, b: Mat) -> Mat:
    return [[x + y for x, y in zip(ra, rb, strict=True)] for ra, rb in zip(a, b, strict=True)]


def sub(a: Mat, b: Mat) -> Mat:
    return [[x - y for x, y in zip(ra, rb, strict=True)] for ra, rb in zip(a, b, strict=True)]


def scale(a: Mat, s) -> Mat:
    return [[x * s for x in row] for row in a]


def matmul(a: Mat, b: Mat) -> Mat:
    d = len(a)
    return [[sum(a[i][k] * b[k][j] for k in range(d)) for j in range(d)] for i in range(d)]


def matmul_transposed(a: Mat, b: Mat) -> Mat:
    """a @ b^T."""
    d = len(a)
    return [[sum(a[i][k] * b[j][k] for k in range(d)) for j in range(d)] for i in range(d)]


def matvec(a: Mat, v: Vec) -> Vec:
    return [sum(row[k] * v[k] for k in range(len(v))) for row in a]


def transpose(a: Mat) -> Mat:
    return [list(col) for col in zip(*a, strict=True)]


def outer(u: Vec, v: Vec) -> Mat:
    return [[x * y for y in v] for x in u]


def add_to_diagonal(a: Mat, value) -> Mat:
    """a + value I (value a scalar or an array per matrix)."""
    return [[x + value if i == j else x for j, x in enumerate(row)] for i, row in enumerate(a)]


def trace(a: Mat):
    return sum(a[i][i] for i in range(len(a)))


def det(a: Mat):
    if len(a) == 2:
        return a[0][0] * a[1][1] - a[0][1] * a[1][0]
    return (
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    )


def cofactor(a: Mat) -> Mat:
    """Cofactor matrix of a 3x3, so that inverse(a) = cofactor(a)^T / det(a)."""
    c = lambda i, j: (
        a[(i + 1) % 3][(j + 1) % 3] * a[(i + 2) % 3][(j + 2) % 3]
        - a[(i + 1) % 3][(j + 2) % 3] * a[(i + 2) % 3][(j + 1) % 3]
    )
    return [[c(i, j) for j in range(3)] for i in range(3)]


def polar_rotation(F: Mat) -> Mat:
    """Rotation R of the polar decomposition F = R S (det F > 0).

    2D uses the closed form (as Taichi's `polar_decompose`); 3D ten steps of Higham's scaled Newton
    iteration (agrees with U V^T from the SVD to ~1e-10 in float64 for det F > 0.1 and
    |F - I| ~ 0.3), whose derivative is given analytically and stays finite at repeated singular
    values (F = I included), where the SVD's derivative is NaN. For an inverted 3D particle
    (det F < 0) the result is the orthogonal polar factor, a reflection; such states are far
    outside what a stable simulation reaches.
    """
    if len(F) == 2:
        return _polar_rotation_2d(F)
    return _polar_rotation_3d(F)


def _polar_rotation_2d(F: Mat) -> Mat:
    x = F[0][0] + F[1][1]
    y = F[1][0] - F[0][1]
    norm_sq = x * x + y * y
    # Undefined only when x = y = 0 (a degenerate F); masking the rsqrt argument keeps values and
    # gradients finite there, and the identity is used instead.
    degenerate = norm_sq <= 0
    inv_norm = jnp.where(degenerate, 0.0, jax.lax.rsqrt(jnp.where(degenerate, 1.0, norm_sq)))
    c = jnp.where(degenerate, 1.0, x * inv_norm)
    s = y * inv_norm
    return [[c, -s], [s, c]]


_NEWTON_ITERATIONS = 10


@jax.custom_jvp
def _polar_rotation_3d(F: Mat) -> Mat:
    def newton(_, X):
        d = det(X)
        inv_t = scale(cofactor(X), 1.0 / d)  # X^{-T}
        norm_sq = lambda m: sum(e * e for row in m for e in row)
        # Higham's scaling makes the iteration converge in a few steps even far from a rotation.
        gamma = jnp.sqrt(jnp.sqrt(norm_sq(inv_t) / norm_sq(X)))
        return add(scale(X, 0.5 * gamma), scale(inv_t, 0.5 / gamma))

    return jax.lax.fori_loop(0, _NEWTON_ITERATIONS, newton, F)


@_polar_rotation_3d.defjvp
def _polar_rotation_3d_jvp(primals, tangents):
    (F,), (dF,) = primals, tangents
    R = _polar_rotation_3d(F)
    Rt = transpose(R)
    S = matmul(Rt, F)
    S = scale(add(S, transpose(S)), 0.5)
    # With F = R S and the skew Omega = R^T dR: R^T dF - dF^T R = Omega S + S Omega, which in
    # axial-vector form is (tr(S) I - S) omega = axial(R^T dF - dF^T R). That matrix has eigenvalues
    # s_i + s_j > 0, so it is invertible even where singular values repeat.
    M = matmul(Rt, dF)
    rhs = [M[2][1] - M[1][2], M[0][2] - M[2][0], M[1][0] - M[0][1]]
    tr = trace(S)
    A = [[(tr if i == j else 0.0) - S[i][j] for j in range(3)] for i in range(3)]
    inv_det = 1.0 / det(A)
    omega = [x * inv_det for x in matvec(transpose(cofactor(A)), rhs)]
    wx, wy, wz = omega
    zero = jnp.zeros_like(wx)
    Omega = [[zero, -wz, wy], [wz, zero, -wx], [-wy, wx, zero]]
    return R, matmul(R, Omega)


def symmetric_eigenvalues(a: Mat) -> list:
    """Eigenvalues of a symmetric 2x2 or 3x3 matrix, largest first, in closed form.

    3D uses the trigonometric solution of the characteristic cubic. Values and derivatives stay
    finite where eigenvalues repeat (a multiple of the identity included): the spread is kept
    from reaching zero by a term of 1e-12 of the mean eigenvalue's square (which moves an
    eigenvalue by at most 1e-6 of the mean), and in 3D the cubic's angle is kept off its ends,
    which splits two exactly repeated eigenvalues by up to ~5e-4 of their value.
    """
    d = len(a)
    mean = trace(a) / d
    floor = 1e-12 * mean * mean + jnp.finfo(jnp.result_type(mean)).tiny
    if d == 2:
        half_gap = 0.5 * (a[0][0] - a[1][1])
        radius = jnp.sqrt(half_gap * half_gap + a[0][1] * a[1][0] + floor)
        return [mean + radius, mean - radius]
    off = a[0][1] * a[1][0] + a[0][2] * a[2][0] + a[1][2] * a[2][1]
    spread = jnp.sqrt((sum((a[i][i] - mean) ** 2 for i in range(3)) + 2 * off) / 6 + floor)
    shifted = add_to_diagonal(a, -mean)
    half_det = det(scale(shifted, 1.0 / spread)) / 2
    # |half_det| <= 1 mathematically; at +-1 two eigenvalues repeat and acos' is infinite.
    angle = jnp.arccos(jnp.clip(half_det, -1 + 1e-6, 1 - 1e-6)) / 3
    largest = mean + 2 * spread * jnp.cos(angle)
    smallest = mean + 2 * spread * jnp.cos(angle + 2 * jnp.pi / 3)
    return [largest, 3 * mean - largest - smallest, smallest]
