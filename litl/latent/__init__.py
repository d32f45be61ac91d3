"""Control in the observer's latent space (issue 78, first part): latent dynamics models learned
from the replay buffer's transitions, their multi-step prediction error, and finite-horizon LQR.

* `litl.latent.dynamics`: `Transitions`; `fit_linear` (z' = A z + B a + c, ridge least squares
  in closed form) and `fit_mlp` (z' = z + g(z, a), optax with early stopping), each with its
  frozen settings (`LinearSettings`, `MLPSettings`).
* `litl.latent.prediction`: `prediction_error`, h-step errors beside the constant-latent baseline.
* `litl.latent.lqr`: `LQRProblem`, `solve` (backward Riccati recursion), `rollout`.
* `litl.latent.model`: `LatentModel` (a dynamics model and a velocity readout), `fit_model` from
  a seed's replay buffer.
* `litl.latent.exploration`: `explore`, random-action episodes a model can be fitted on
  (`fit_sequence`) beside or instead of the buffer; `Exploration`, its settings.
* `litl.latent.planning`: `Goal`, shooting MPC (`MPCSettings`, `mpc_step`) and LQR on the
  position-augmented linear model (`LQRSettings`, `augmented_problem`), `control` (an episode in
  `litl.envs`); registered as `controller=latent_mpc`, `latent_lqr` and run on a trained run by
  `python -m litl.latent.control` (docs/guide/latent-control.md).
"""

from litl.latent.dynamics import (
    LinearDynamics,
    LinearSettings,
    MLPDynamics,
    MLPFit,
    MLPSettings,
    Transitions,
    fit_linear,
    fit_mlp,
)
from litl.latent.lqr import LQRProblem, LQRSolution, rollout, solve, total_cost
from litl.latent.prediction import PredictionError, prediction_error

__all__ = [
    "LQRProblem",
    "LQRSolution",
    "LinearDynamics",
    "LinearSettings",
    "MLPDynamics",
    "MLPFit",
    "MLPSettings",
    "PredictionError",
    "Transitions",
    "fit_linear",
    "fit_mlp",
    "prediction_error",
    "rollout",
    "solve",
    "total_cost",
]
