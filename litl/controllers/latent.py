"""The latent planners (`latent_mpc`, `latent_ilqr`, `latent_lqr`; `litl.latent.planning`): listed under
`controller=` with their settings, and run on a trained run by `python -m litl.latent.control`.

They plan with a latent model fitted on a trained run's replay buffer, so Algorithm 1 does not
train them: a run asked to (``python -m litl controller=latent_mpc``) is refused before anything
runs, with the command that does use them (`Config.check`, the ``plans`` trait).
"""

from __future__ import annotations

from litl.controllers.interface import Controller, ControllerContext
from litl.latent.planning import ILQRSettings, LQRSettings, MPCSettings
from litl.settings import SettingsError

USAGE = (
    "python -m litl.latent.control RUN_DIR --planner {name} --goal reach:<x> (or walk:<+1|-1>) on a "
    "run trained with a latent observer (e.g. python -m litl, observer vae)"
)


def refusal(name: str) -> SettingsError:
    """What a training run with planner `name` as its controller is told."""
    return SettingsError(
        f"controller={name} plans in a trained run's latent space and is not trained by the loop: "
        f"train a run with controller=mlp, then steer it with {USAGE.format(name=name)}",
        "controller.kind",
    )


def latent_mpc(robot, settings: MPCSettings, context: ControllerContext) -> Controller:
    raise refusal("latent_mpc")


def latent_ilqr(robot, settings: ILQRSettings, context: ControllerContext) -> Controller:
    raise refusal("latent_ilqr")


def latent_lqr(robot, settings: LQRSettings, context: ControllerContext) -> Controller:
    raise refusal("latent_lqr")
