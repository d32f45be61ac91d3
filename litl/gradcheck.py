"""`python -m litl.gradcheck`: are the gradients of a robot's rollout right? Central differences
against `jax.grad`, in float64.

    python -m litl.gradcheck robot=biped                       # a short rollout of the biped
    python -m litl.gradcheck robot=quadruped robot.resolution=smoke --steps 30
    python -m litl.gradcheck robot=arm observer=kmeans --directions 4 --rtol 1e-5

The task loss of one rollout (the loop's `Algorithm.simulate`: controller, design, observer, the
robot's task) is differentiated with respect to the controller's parameters θ, the design
parameters, and the initial particle velocities and positions. For each, along a few random
unit directions u, the directional derivative <jax.grad, u> is compared with the central
difference (L(x + εu) - L(x - εu)) / 2ε at several steps ε (the best agreeing one is reported);
the relative error is |analytic - numeric| / max(|analytic|, |numeric|). The check passes when
every error is at most `rtol`. Any other setting is a Hydra override as for `python -m litl`,
except two: the check runs in float64, and with `controller.mlp.feature_gradient=full` (the true
gradient; `stop`, litl's default, leaves out the path through the observer's features on
purpose). The observer is used as initialised; the gradient does not flow into its parameters.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys

import numpy as np

from litl.errors import UserError, exit_on_user_error
from litl.report.roundoff import hardly_moved

GROUPS = ("controller", "design", "initial velocity", "initial position")


@dataclasses.dataclass(frozen=True)
class Check:
    """One directional derivative.

    Attributes:
      group: which parameters (one of GROUPS).
      direction: its index.
      analytic: <jax.grad L, u>.
      numeric: the central difference along u at the step `eps` that agrees best with it.
      eps: that step.
    """

    group: str
    direction: int
    analytic: float
    numeric: float
    eps: float

    @property
    def relative_error(self) -> float:
        return relative_error(self.analytic, self.numeric)


def relative_error(analytic: float, numeric: float) -> float:
    """|analytic - numeric| / max(|analytic|, |numeric|) (0 when both are 0)."""
    scale = max(abs(analytic), abs(numeric))
    return abs(analytic - numeric) / scale if scale > 0 else 0.0


EPS = (1e-3, 1e-4, 1e-5, 1e-6)


def check_gradients(
    config, steps: int = 40, eps=EPS, directions: int = 2, seed: int = 0, feature_gradient: str = "full"
) -> tuple[list[Check], float]:
    """Directional derivatives of one rollout's task loss, analytic and by central differences.

    Args:
      config: a `litl.config.Config` (its `sim.dtype` is replaced by float64).
      steps: rollout length (short: the check costs 2 x directions x 4 + 1 rollouts).
      eps: the central difference's steps along a unit direction: a truncation error that grows
        as eps^2 and a round-off error that grows as 1/eps (a task loss built from positions
        ~0.5 that change by ~1e-6 loses digits) meet at a step that depends on the robot, so
        every step is tried and the one that agrees best is kept. A right gradient agrees at
        some step; a wrong one at none.
      directions: random directions per parameter group.
      seed: seeds the parameters' initialisation and the directions.
      feature_gradient: ``"full"``, the true gradient; ``"stop"`` checks what litl's default
        `controller.mlp.feature_gradient` differentiates, which leaves out the path through the
        observer's features on purpose, so central differences disagree with it.

    Returns:
      (checks, the task loss at the unperturbed parameters).
    """
    import jax
    import jax.numpy as jnp

    from litl.app import build_robot, check_observer
    from litl.config import DType
    from litl.controllers.mlp import FeatureGradient
    from litl.loop.algorithm import make_algorithm

    eps = _checked_arguments(steps, eps, directions)
    # The true gradient: with feature_gradient=stop (litl's default) jax.grad leaves out, by
    # design, the path through the observer's features, which central differences include.
    config = config.replace(
        sim={"dtype": DType.float64, "steps": steps},
        controller={"mlp": {"feature_gradient": FeatureGradient(feature_gradient)}},
    )
    robot = build_robot(config)
    check_observer(config)
    with jax.enable_x64(True):
        algorithm = make_algorithm(robot, config.algorithm)
        state = algorithm.init(seed)
        initial = robot.scene(jnp.float64).state
        observer = state.observer

        def loss(x):
            start = initial.replace(v=x["initial velocity"], x=x["initial position"])
            total, _ = algorithm.simulate(x["controller"], x["design"], observer, start)
            return total

        x = {
            "controller": state.controller,
            "design": state.design,
            "initial velocity": initial.v,
            "initial position": initial.x,
        }
        value, gradient = jax.jit(jax.value_and_grad(loss))(x)
        if not np.isfinite(float(value)):
            raise GradcheckError(
                f"the rollout's task loss is {float(value)}: the simulation "
                f"is unhealthy at these settings, nothing to check"
            )
        # The report's rule too (litl.report.roundoff): a robot that has hardly moved is not checkable.
        if hardly_moved(float(value), np.float64):
            raise GradcheckError(
                f"the task loss is {float(value):.3g} after {steps} steps: the robot has hardly "
                f"moved, so its derivatives are at the level of round-off and no difference "
                f"can check them; give more --steps (e.g. {4 * steps})"
            )
        checks = _directional_checks(jax.jit(loss), x, gradient, eps, directions, seed)
    return checks, float(value)


def _checked_arguments(steps, eps, directions) -> tuple[float, ...]:
    """`eps` as a tuple, once `steps`, `eps` and `directions` are checked (`GradcheckError`)."""
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise GradcheckError(f"--steps must be a positive number of steps, got {steps!r}")
    eps = tuple(eps)
    if not eps or not all(isinstance(e, float) and 0 < e < 1 for e in eps):
        raise GradcheckError(f"--eps must be steps in (0, 1), e.g. 1e-4,1e-6; got {eps!r}")
    if isinstance(directions, bool) or not isinstance(directions, int) or directions < 1:
        raise GradcheckError(f"--directions must be a positive count, got {directions!r}")
    return eps


def _directional_checks(
    f, x: dict, gradient: dict, eps: tuple[float, ...], directions: int, seed: int
) -> list[Check]:
    """Per parameter group of `x` and random unit direction u: the analytic derivative
    gradient · u against central differences of `f` along u at every step of `eps` (the one that
    agrees best is kept)."""
    import jax
    import jax.numpy as jnp

    rng = np.random.default_rng(seed)
    checks = []
    for group in GROUPS:
        for d in range(directions):
            leaves = [rng.normal(size=np.shape(leaf)) for leaf in jax.tree.leaves(x[group])]
            norm = math.sqrt(sum(float(np.sum(u**2)) for u in leaves))
            u = jax.tree.unflatten(
                jax.tree.structure(x[group]), [jnp.asarray(leaf / norm) for leaf in leaves]
            )
            analytic = sum(
                float(jnp.vdot(g, v))
                for g, v in zip(jax.tree.leaves(gradient[group]), jax.tree.leaves(u), strict=True)
            )

            def shifted(step, group=group, u=u):
                """x moved by `step` along u in `group` (the iteration's own, bound here)."""
                return {**x, group: jax.tree.map(lambda a, w: a + step * w, x[group], u)}

            numeric = {e: (float(f(shifted(e))) - float(f(shifted(-e)))) / (2 * e) for e in eps}
            best = min(eps, key=lambda e: relative_error(analytic, numeric[e]))
            checks.append(Check(group, d, analytic, numeric[best], best))
    return checks


class GradcheckError(UserError, ValueError):
    """A gradient check that cannot be run as asked; the message says what to change."""


def _steps(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"not numbers: {text!r} (e.g. 1e-4,1e-6)") from None


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m litl.gradcheck",
        description="Check jax.grad of a robot's rollout against central differences in "
        "float64: controller, design, initial velocities and positions.",
    )
    parser.add_argument("overrides", nargs="*", help="Hydra overrides as for python -m litl, e.g. robot=arm")
    parser.add_argument("--steps", type=int, default=40, help="rollout length (default: 40)")
    parser.add_argument(
        "--eps",
        type=_steps,
        default=EPS,
        help="central-difference steps along a unit direction, comma-separated; "
        "the best agreeing one is reported (default: 1e-3,1e-4,1e-5,1e-6)",
    )
    parser.add_argument(
        "--directions", type=int, default=2, help="random directions per parameter group (default: 2)"
    )
    parser.add_argument(
        "--rtol", type=float, default=1e-4, help="largest relative error that passes (default: 1e-4)"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of parameters and directions")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the check; returns 0 when every relative error is at most --rtol, else 1 (bad input:
    exit status 2 and a one-line message)."""
    from litl.app import compose

    parser = _parser()
    args = parser.parse_args(argv)
    with exit_on_user_error(parser.prog):
        config = compose(args.overrides)
        checks, value = check_gradients(config, args.steps, args.eps, args.directions, args.seed)
    print(
        f"litl.gradcheck: {config.robot.name}, observer {config.observer.kind}, controller "
        f"{config.controller.kind}, {args.steps} steps, float64; task loss {value:.6g}"
    )
    print(
        f"{'parameters':<17} {'u':>2} {'jax.grad . u':>14} {'central diff.':>14} "
        f"{'at eps':>7} {'rel. error':>10}"
    )
    for c in checks:
        print(
            f"{c.group:<17} {c.direction:>2} {c.analytic:>14.6e} {c.numeric:>14.6e} "
            f"{c.eps:>7.0e} {c.relative_error:>10.2e}"
        )
    worst = max(c.relative_error for c in checks)
    passed = worst <= args.rtol
    print(
        f"largest relative error {worst:.2e} {'<=' if passed else '>'} rtol {args.rtol:g}: "
        f"{'pass' if passed else 'FAIL'}"
    )
    sys.stdout.flush()
    return 0 if passed else 1


if __name__ == "__main__":
    sys.exit(main())
