"""Materials with a return mapping: each maps a particle's trial deformation gradient to the one it
keeps (its plastic projection) and that state's Kirchhoff stress.

After a step moves the particles, `F_trial = (I + dt C) F`. An elastic material keeps it (or clamps
its stretch, the strain limit); a plastic one projects it back onto its yield surface, as MPM codes
for sand, snow and clay do (Stomakhin et al. 2013, Klar et al. 2016); a fluid forgets its shear.

* `Elastic`: a robot's own material (fixed-corotated, neo-Hookean or a stress law of one's own),
  optionally with the strain limit (`litl.sim.stretch`); the default `SimConfig.materials`.
* `Sand`: Drucker-Prager elastoplasticity in Hencky strain (Klar et al. 2016, without hardening):
  the friction angle is the parameter; pulled apart, a grain keeps no stress.
* `Clay`: von Mises perfect plasticity in Hencky strain: it yields when its von Mises (Kirchhoff)
  stress reaches `yield_stress`, at constant volume.
* `Fluid`: a weakly compressible fluid (water): pressure from the volume ratio J alone, the bulk
  modulus `lambda + 2 mu / d` of the particle's design, no shear stress.

All are pure JAX functions of per-component matrices (`litl.sim.linalg`) and differentiable
everywhere a simulation goes, the undeformed state (every singular value repeated) included: the
spectral maps use no SVD. A function of the singular values of F, applied as
`U diag(g(sigma)) V^T`, is written as `F h(C)` with `C = F^T F` and `h` the polynomial in `C` that
interpolates `g(sigma) / sigma` at `C`'s eigenvalues (Newton's form, as `litl.sim.stretch`); the
Kirchhoff stress `U diag(s(sigma)) U^T` is the polynomial in `B = F F^T` that interpolates `s`.
Where two eigenvalues merge, the divided difference is the derivative of the spectral function
across them (a forward-mode derivative), so values and gradients stay finite.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Protocol

import jax
import jax.numpy as jnp

from litl.sim import linalg
from litl.sim.constitutive import CONSTITUTIVE_MODELS, ConstitutiveModel
from litl.sim.errors import SimConfigError, is_stretch_bound
from litl.sim.stretch import limit_stretch

Values = Callable[[list], list]

# Eigenvalues closer than this fraction of their mean count as merged (the divided difference is
# then the derivative): float32 cancellation stays near 1e-4 relative.
_MERGE = 1e-3


class MaterialModel(Protocol):
    """What `SimConfig.materials` holds: a frozen (hashable) value with `update`."""

    def update(self, F: linalg.Mat, mu, lam, token=None) -> tuple[linalg.Mat, linalg.Mat]:
        """(kept F, Kirchhoff stress tau) from the trial deformation gradient `F` and the
        particles' (n,) Lamé parameters."""
        ...


# tau = stress(F, mu, lam): Kirchhoff stress from per-component F (F[i][j] of shape (n,)) and (n,)
# Lamé parameters, as the models in `litl.sim.constitutive`.
StressFn = Callable[[linalg.Mat, jax.Array, jax.Array], linalg.Mat]


@dataclasses.dataclass(frozen=True)
class Elastic:
    """A hyperelastic solid, the robot's own material (`SimConfig.materials[0]`).

    Attributes:
      model: its stress law: ``"fixed_corotated"`` or ``"neo_hookean"``
        (`litl.sim.constitutive.CONSTITUTIVE_MODELS`), or a function of one's own,
        ``stress(F, mu, lam) -> tau``, a Kirchhoff stress from per-component deformation
        gradients and (n,) Lamé parameters (`litl.sim.constitutive` shows the form; pass the
        same function object each time, since the config's hash, and so the compiled program,
        follows it).
      max_stretch: the strain limit (> 1, or None: none): after each step, every singular value
        of a particle's F above it is clamped to it, i.e. the material yields plastically instead
        of stretching further (`litl.sim.stretch`). It bounds the stress of a particle torn from
        the body, whose stiffening under stretch the time step does not cover. A rollout that
        never reaches it agrees with an unlimited one to rounding.
    """

    model: ConstitutiveModel | StressFn = "fixed_corotated"
    max_stretch: float | None = None

    def __post_init__(self) -> None:
        if not (callable(self.model) or self.model in CONSTITUTIVE_MODELS):
            raise SimConfigError(
                f"Elastic.model={self.model!r}: unknown; choose one of {sorted(CONSTITUTIVE_MODELS)} "
                "or pass a stress function stress(F, mu, lam) -> tau"
            )
        if self.max_stretch is not None and not is_stretch_bound(self.max_stretch):
            raise SimConfigError(
                f"Elastic.max_stretch={self.max_stretch!r}: must be a finite number > 1 (the largest "
                "principal stretch a particle keeps, e.g. 3.0) or None (no limit)"
            )

    def update(self, F, mu, lam, token=None):
        if self.max_stretch is not None:
            # Its shared scalars buffered in 3D only (the quadruped's forward on XLA:CPU: 7.3 s
            # -> 5.3 s); in 2D the buffers cost the walker's backward pass more than they save.
            F = limit_stretch(F, self.max_stretch, token if len(F) == 3 else None)
            if token is not None:
                # Read by every stress component: clamped once, not once per reader (XLA:CPU).
                F = linalg.materialize(F, token)
        stress = self.model if callable(self.model) else CONSTITUTIVE_MODELS[self.model]
        return F, stress(F, mu, lam)


@dataclasses.dataclass(frozen=True)
class Sand:
    """Dry sand: Drucker-Prager plasticity on Hencky strain (Klar et al. 2016, Sec. 7, without
    hardening). Let eps = log(sigma) be the principal Hencky strains of the trial F, eps_hat
    their deviatoric part. Pulled apart (tr eps > 0) the grain keeps no elastic strain (F becomes
    its rotation); otherwise, with alpha = sqrt(2/3) 2 sin(phi) / (3 - sin(phi)) and
    dgamma = |eps_hat| + (d lambda + 2 mu) / (2 mu) tr(eps) alpha, a positive dgamma moves eps
    back to the cone: eps - dgamma eps_hat / |eps_hat|. Stress: tau = U (2 mu eps + lambda tr(eps) I) U^T.

    Attributes:
      friction_angle: phi in degrees, in (0, 90); the angle of repose of a pile is near it.
    """

    friction_angle: float = 30.0

    def __post_init__(self) -> None:
        phi = self.friction_angle
        if not (isinstance(phi, (int, float)) and not isinstance(phi, bool) and 0 < phi < 90):
            raise SimConfigError(
                f"Sand.friction_angle={phi!r}: must be an angle in degrees in (0, 90), e.g. 30"
            )

    @property
    def alpha(self) -> float:
        s = math.sin(math.radians(self.friction_angle))
        return math.sqrt(2 / 3) * 2 * s / (3 - s)

    def update(self, F, mu, lam, token=None):
        d = len(F)

        def strains(eps):
            trace = sum(eps)
            deviator = [e - trace / d for e in eps]
            norm = _safe_norm(deviator)
            dgamma = norm + (d * lam + 2 * mu) / (2 * mu) * trace * self.alpha
            cut = (trace <= 0) & (dgamma > 0)
            scale = jnp.where(cut, dgamma * _safe_reciprocal(norm), 0.0)
            projected = [e - scale * h for e, h in zip(eps, deviator, strict=True)]
            return [jnp.where(trace > 0, 0.0, e) for e in projected]

        return _hencky_update(F, mu, lam, strains, token)


@dataclasses.dataclass(frozen=True)
class Clay:
    """Von Mises perfect plasticity on Hencky strain (a soft clay or plasticine): where the von
    Mises Kirchhoff stress sqrt(3/2) |2 mu eps_hat| exceeds `yield_stress`, the deviatoric strain
    is scaled back to the yield surface (plastic flow at constant volume).

    Attributes:
      yield_stress: tau_Y > 0, in the units of the design's Young's modulus.
    """

    yield_stress: float

    def __post_init__(self) -> None:
        y = self.yield_stress
        if not (isinstance(y, (int, float)) and not isinstance(y, bool) and math.isfinite(y) and y > 0):
            raise SimConfigError(f"Clay.yield_stress={y!r}: must be a finite number > 0")

    def update(self, F, mu, lam, token=None):
        d = len(F)
        radius = math.sqrt(2 / 3) * self.yield_stress  # |dev tau| on the yield surface

        def strains(eps):
            trace = sum(eps)
            deviator = [e - trace / d for e in eps]
            norm = _safe_norm(deviator)
            excess = jnp.maximum(norm - radius / (2 * mu), 0.0)
            scale = excess * _safe_reciprocal(norm)
            return [e - scale * h for e, h in zip(eps, deviator, strict=True)]

        return _hencky_update(F, mu, lam, strains, token)


@dataclasses.dataclass(frozen=True)
class Fluid:
    """A weakly compressible fluid (water): F is reset to J^(1/d) I every step (no memory of shear)
    and the Kirchhoff stress is tau = K (J - 1) J I, K = lambda + 2 mu / d the bulk modulus of the
    particle's design. Its sound speed sqrt(K / density) is below the elastic P-wave speed the
    time-step check uses."""

    def update(self, F, mu, lam, token=None):
        d = len(F)
        J = linalg.det(F)
        bulk = lam + 2 * mu / d
        # J^(1/d) of a compressed or stretched particle; an inverted one (J <= 0) is reported by the
        # rollout's health as non-finite.
        side = jnp.sqrt(J) if d == 2 else jnp.cbrt(J)
        zero = jnp.zeros_like(J)
        kept = [[side if i == j else zero for j in range(d)] for i in range(d)]
        pressure = bulk * (J - 1) * J
        return kept, [[pressure if i == j else zero for j in range(d)] for i in range(d)]


def update(materials: Sequence[MaterialModel], material, F, mu, lam, token=None):
    """Each particle's kept F and stress under its own material: `material` (n,) int32 indexes
    `materials` (None: all the first). Every material is evaluated for every particle and the
    particle's own is selected, so a scene of k materials costs k updates. `token` (a scan
    counter, or None) lets the materials buffer what many readers read (`linalg.materialize`)."""
    if len(materials) == 1 or material is None:
        return materials[0].update(F, mu, lam, token)
    kept, stress = materials[0].update(F, mu, lam, token)
    for index, model in enumerate(materials[1:], start=1):
        mine = material == index
        F_k, tau_k = model.update(F, mu, lam, token)
        kept = _select(mine, F_k, kept)
        stress = _select(mine, tau_k, stress)
    if token is not None:
        # The selected F is read by the next step's every component: buffered once.
        kept = linalg.materialize(kept, token)
    return kept, stress


def _select(mask, a: linalg.Mat, b: linalg.Mat) -> linalg.Mat:
    return [[jnp.where(mask, x, y) for x, y in zip(ra, rb, strict=True)] for ra, rb in zip(a, b, strict=True)]


def _safe_norm(values: list):
    """|values|, with a zero derivative (not NaN) at 0."""
    square = sum(v * v for v in values)
    positive = square > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, square, 1.0)), 0.0)


def _safe_reciprocal(x):
    nonzero = x > 0
    return jnp.where(nonzero, 1.0 / jnp.where(nonzero, x, 1.0), 0.0)


def _hencky_update(F, mu, lam, strains: Callable[[list], list], token=None):
    """The kept F and the Hencky (St. Venant-Kirchhoff in log strain) stress of a material whose
    return mapping `strains` maps principal Hencky strains to the kept ones."""
    C = linalg.matmul(linalg.transpose(F), F)
    eig = linalg.symmetric_eigenvalues(C)  # sigma^2, the same for C = F^T F and B = F F^T
    if token is not None:
        eig = linalg.materialize(eig, token)
    tiny = jnp.finfo(jnp.result_type(eig[0])).tiny

    def values(squares):
        log_sigma = [0.5 * jnp.log(jnp.maximum(s, tiny)) for s in squares]
        kept = strains(log_sigma)
        trace = sum(kept)
        ratio = [jnp.exp(k - e) for k, e in zip(kept, log_sigma, strict=True)]  # exp(eps_kept) / sigma
        stress = [2 * mu * k + lam * trace for k in kept]
        return ratio + stress

    ratio, stress = newton_coefficients(eig, values, token)
    h = interpolate(C, eig, ratio)
    tau = interpolate(linalg.matmul_transposed(F, F), eig, stress)
    return linalg.matmul(F, h), tau


def newton_coefficients(eig: list, values: Values, token=None) -> list:
    """Newton's coefficients [a0, a1(, a2)] of the polynomials that interpolate spectral functions
    at a symmetric matrix's eigenvalues `eig` (largest first, `linalg.symmetric_eigenvalues`).

    `values(eig)` returns k * len(eig) values: k symmetric functions g^(j) (permuting the
    eigenvalues permutes each one's results), function j's value at eigenvalue i at position
    j * len(eig) + i. Each coefficient a_m is a list of k arrays, one per function. Where two
    eigenvalues merge, the divided difference is the derivative of g_a across them (one
    forward-mode derivative for all functions); where all three merge (3D) the second one is
    dropped (its term is of the order of the eigenvalues' spread squared).
    """
    d = len(eig)
    g = values(eig)
    k = len(g) // d
    tiny = jnp.finfo(jnp.result_type(eig[0])).tiny

    def apart(a: int, b: int):
        gap = eig[a] - eig[b]
        return gap, gap > _MERGE * (0.5 * (jnp.abs(eig[a]) + jnp.abs(eig[b])) + tiny)

    def divided(a: int, b: int) -> list:
        gap, separate = apart(a, b)
        middle = 0.5 * (eig[a] + eig[b])
        at = [middle if i in (a, b) else e for i, e in enumerate(eig)]
        direction = [
            jnp.ones_like(e) if i == a else -jnp.ones_like(e) if i == b else jnp.zeros_like(e)
            for i, e in enumerate(eig)
        ]
        # d/dt g_a(l + t (e_a - e_b)) = dg_a/dl_a - dg_a/dl_b: the divided difference's limit
        # (g_b(l) is g_a with l_a and l_b swapped).
        _, slope = jax.jvp(values, (at,), (direction,))
        safe_gap = jnp.where(separate, gap, 1.0)
        return [
            jnp.where(separate, (g[j * d + a] - g[j * d + b]) / safe_gap, slope[j * d + a]) for j in range(k)
        ]

    first = divided(0, 1)
    coefficients = [[g[j * d] for j in range(k)], first]
    if d == 3:
        first_low = divided(1, 2)
        gap, separate = apart(0, 2)
        safe_gap = jnp.where(separate, gap, 1.0)
        coefficients.append(
            [jnp.where(separate, (hi - lo) / safe_gap, 0.0) for hi, lo in zip(first, first_low, strict=True)]
        )
    if token is not None:
        coefficients = linalg.materialize(coefficients, token)
    # One list per function: [[a0, a1(, a2)] for function 0, ...].
    return [[c[j] for c in coefficients] for j in range(k)]


def interpolate(M: linalg.Mat, eig: list, coefficients: list) -> linalg.Mat:
    """a0 I + a1 (M - l0 I) [+ a2 (M - l0 I)(M - l1 I) in 3D]: the spectral function of M whose
    Newton coefficients (`newton_coefficients`) are given."""
    shifted = linalg.add_to_diagonal(M, -eig[0])
    result = linalg.add_to_diagonal(linalg.scale(shifted, coefficients[1]), coefficients[0])
    if len(eig) == 3:
        product = linalg.matmul(shifted, linalg.add_to_diagonal(M, -eig[1]))
        result = linalg.add(result, linalg.scale(product, coefficients[2]))
    return result
