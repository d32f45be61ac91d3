"""Constitutive models as Kirchhoff stresses tau(F), plus the active actuation stress.

A robot's material (`litl.sim.materials.Elastic`, in `SimConfig.materials`) names one of
`CONSTITUTIVE_MODELS` or takes any other stress function of the same form. (A robot's `Material`
is something else: the parameter values, E, nu, density, actuator strength.)

Matrices are per-component lists (see `litl.sim.linalg`): `F[i][j]` is an (n,) array; mu, lam (n,).
"""

from __future__ import annotations

from typing import Literal

import jax.numpy as jnp

from litl.sim import linalg


def fixed_corotated(F, mu, lam):
    """tau = 2 mu (F - R) F^T + lam (J - 1) J I (ChainQueen / DiffTaichi form)."""
    R = linalg.polar_rotation(F)
    J = linalg.det(F)
    shear = linalg.scale(linalg.matmul_transposed(linalg.sub(F, R), F), 2 * mu)
    return linalg.add_to_diagonal(shear, lam * (J - 1) * J)


def neo_hookean(F, mu, lam):
    """tau = mu (F F^T - I) + lam log(J) I."""
    J = linalg.det(F)
    # log(J) is undefined for inverted particles (J <= 0); such a state is reported as non-finite.
    shear = linalg.scale(linalg.matmul_transposed(F, F), mu)
    return linalg.add_to_diagonal(shear, lam * jnp.log(J) - mu)


ConstitutiveModel = Literal["fixed_corotated", "neo_hookean"]
CONSTITUTIVE_MODELS = {"fixed_corotated": fixed_corotated, "neo_hookean": neo_hookean}


def actuation_stress(F, activation, fiber):
    """Active stress F A F^T with A = a (d ⊗ d), along each particle's fiber direction.

    Args:
      F: deformation gradients, `F[i][j]` of shape (n,).
      activation: (n,) signed active stress magnitude a of each particle (0 for passive ones).
      fiber: d arrays (n,), unit fiber direction of each particle in the material frame.
    """
    Fd = linalg.matvec(F, fiber)  # F (d ⊗ d) F^T = (F d) ⊗ (F d)
    return linalg.scale(linalg.outer(Fd, Fd), activation)
