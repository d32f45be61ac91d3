"""Constitutive models as Kirchhoff stresses tau(F), plus the active actuation stress.

All functions take per-particle arrays: F (n, d, d), Lamé parameters mu, lam (n,).
"""

from __future__ import annotations

import jax.numpy as jnp

from litl.sim import linalg


def fixed_corotated(F, mu, lam):
    """tau = 2 mu (F - R) F^T + lam (J - 1) J I (ChainQueen / DiffTaichi form)."""
    R = linalg.polar_rotation(F)
    J = linalg.det(F)
    shear = 2 * mu[:, None, None] * linalg.matmul(F - R, linalg.transpose(F))
    return shear + (lam * (J - 1) * J)[:, None, None] * linalg.identity_like(F)


def neo_hookean(F, mu, lam):
    """tau = mu (F F^T - I) + lam log(J) I."""
    J = linalg.det(F)
    eye = linalg.identity_like(F)
    # log(J) is undefined for inverted particles (J <= 0); such a state is reported as non-finite.
    return mu[:, None, None] * (linalg.matmul(F, linalg.transpose(F)) - eye) + (
        lam * jnp.log(J)
    )[:, None, None] * eye


MODELS = {"fixed_corotated": fixed_corotated, "neo_hookean": neo_hookean}


def actuation_stress(F, activation, fiber):
    """Active stress F A F^T with A = a (d ⊗ d), along each particle's fiber direction.

    Args:
      F: (n, d, d) deformation gradients.
      activation: (n,) signed active stress magnitude a of each particle (0 for passive ones).
      fiber: (n, d) unit fiber direction of each particle in the material frame.
    """
    Fd = linalg.matvec(F, fiber)  # F d, so that F (d ⊗ d) F^T = (F d) ⊗ (F d)
    return activation[:, None, None] * linalg.outer(Fd, Fd)
