"""Strain limiting: past a largest principal stretch, a particle yields instead of stretching.

A particle torn from its neighbours (a leg's edge pulled hard at dx 1/128) keeps its elastic
stress, and the fixed-corotated stress's stiffness grows with stretch: the time step chosen for
the material at rest (`litl.robots.design.TARGET_CFL`) is then too long for it, it rings on its own
stencil and the rollout blows up (docs/results/2026-11-26-paper-scale-stability.md). Clamping the
singular values of the deformation gradient F at ``max_stretch`` after each update (plastic yield,
as MPM's snow and sand models clamp theirs) bounds that stress.

A particle that never reaches the bound keeps its F exactly (the clamp's branch is not taken);
a rollout that never reaches it agrees with one without the limit to rounding (the program
differs, so the backward pass may round differently). The clamp needs no SVD: with
C = F^T F = V diag(sigma^2) V^T, the clamped deformation gradient is F h(C),
h(lambda) = min(1, max_stretch / sqrt(lambda)), and h(C) is the polynomial in C that interpolates h
at C's eigenvalues (Newton's form, whose divided differences stay finite where eigenvalues repeat).
"""

from __future__ import annotations

import jax.numpy as jnp

from litl.sim import linalg

# Eigenvalues of C closer than this fraction of max_stretch^2 count as equal in the divided
# differences (which then use derivatives): float32 cancellation stays below ~1e-4 relative.
_MERGE = 1e-3


def largest_stretch(F: linalg.Mat):
    """(n,) largest singular value of each particle's deformation gradient."""
    return jnp.sqrt(linalg.symmetric_eigenvalues(linalg.matmul(linalg.transpose(F), F))[0])


def limit_stretch(F: linalg.Mat, max_stretch: float, token=None) -> linalg.Mat:
    """F with every singular value above `max_stretch` set to `max_stretch` (per-component F).

    `token` (as `linalg.materialize` takes it): compute the per-particle scalars the clamp's
    entries share into buffers first; XLA:CPU otherwise recomputes the eigenvalues for every entry
    that reads them. Measured on XLA:CPU with the limit on: the 3D quadruped's forward pass
    7.3 s unbuffered, 5.3 s buffered (4.3 s without the limit); the 2D walker's forward+backward
    is slower buffered, 1.34 s against 0.93 s, so the step buffers them in 3D only.
    """
    C = linalg.matmul(linalg.transpose(F), F)
    eig = linalg.symmetric_eigenvalues(C)
    # The clamp is evaluated for every particle and kept where the largest stretch is over the
    # bound; its derivatives are finite everywhere (repeated eigenvalues included), so the
    # discarded ones cannot turn the kept gradient into NaN.
    over = eig[0] > max_stretch * max_stretch
    coefficients = _newton_coefficients(eig, max_stretch)
    if token is not None:
        over, eig, coefficients = linalg.materialize((over, eig, coefficients), token)
    # h(C) = a0 I + a1 (C - l0 I) [+ a2 (C - l0 I)(C - l1 I) in 3D]
    shifted = linalg.add_to_diagonal(C, -eig[0])
    h = linalg.add_to_diagonal(linalg.scale(shifted, coefficients[1]), coefficients[0])
    if len(F) == 3:
        product = linalg.matmul(shifted, linalg.add_to_diagonal(C, -eig[1]))
        h = linalg.add(h, linalg.scale(product, coefficients[2]))
    clamped = linalg.matmul(F, h)
    return [
        [jnp.where(over, x, y) for x, y in zip(rc, rf, strict=True)]
        for rc, rf in zip(clamped, F, strict=True)
    ]


def _newton_coefficients(eig: list, cap: float) -> list:
    """Newton's divided differences of h(lambda) = min(1, cap / sqrt(lambda)) at the eigenvalues
    `eig` of C (largest first): h(C) = sum_k a_k prod_{j<k} (C - eig_j I)."""
    cap_sq = cap * cap

    def h(x):
        return cap * jnp.reciprocal(jnp.sqrt(jnp.maximum(x, cap_sq)))

    def dh(x):  # h'
        return jnp.where(x > cap_sq, -0.5 * h(x) / x, 0.0)

    def ddh(x):  # h''
        return jnp.where(x > cap_sq, 0.75 * h(x) / (x * x), 0.0)

    def divided(a, b, fa, fb, derivative):
        # (fa - fb) / (a - b), or the derivative at their midpoint where a and b merge (a >= b).
        apart = a - b > _MERGE * cap_sq
        return jnp.where(apart, (fa - fb) / jnp.where(apart, a - b, 1.0), derivative(0.5 * (a + b)))

    first = divided(eig[0], eig[1], h(eig[0]), h(eig[1]), dh)
    if len(eig) == 2:
        return [h(eig[0]), first]
    second_low = divided(eig[1], eig[2], h(eig[1]), h(eig[2]), dh)
    return [h(eig[0]), first, divided(eig[0], eig[2], first, second_low, lambda x: 0.5 * ddh(x))]
