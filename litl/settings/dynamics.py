"""Settings of the latent dynamics models (`litl.latent.dynamics`) and of their measurement in the
loop's learning phases (`loop.dynamics`, `litl.latent.in_loop`). No JAX here: `litl.config`
imports it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from litl.settings import Settings


@dataclass(frozen=True)
class LinearSettings(Settings):
    """The linear model's fit.

    Attributes:
      ridge: λ >= 0 of the ridge objective (1/n) Σ ||z' - A z - B a - c||² + λ (||A||² + ||B||²)
        (Frobenius norms; the offset c is not penalized). 0: plain least squares (the data must
        then determine A, B, c: at least r + m + 1 transitions that span them).
    """

    KEY = "loop.dynamics.linear"
    ridge: float = 1e-6

    def check(self) -> None:
        self._positive_numbers("ridge", zero=True)


@dataclass(frozen=True)
class MLPSettings(Settings):
    """The MLP residual model and its training.

    Attributes:
      widths: hidden layer widths of g (tanh between layers, a linear output).
      learning_rate: Adam's step size.
      max_epochs: full-batch Adam steps at most (one per epoch).
      patience: stop after this many epochs without a better validation loss (the best
        parameters are kept).
      validation_fraction: share of the transitions held out for validation (at least one, and
        at least one kept for training).
      weight_decay: AdamW's decoupled weight decay (0: plain Adam).
      rollout: K, the control steps each training start is rolled forward through the model
        under the recorded actions; the loss is the mean over k = 1 ... K of the k-step error
        (1: the one-step error). The split holds out blocks of K consecutive transitions.
    """

    KEY = "loop.dynamics.mlp"
    widths: tuple[int, ...] = (64, 64)
    learning_rate: float = 3e-3
    max_epochs: int = 2000
    patience: int = 100
    validation_fraction: float = 0.2
    weight_decay: float = 0.0
    rollout: int = 1

    def check(self) -> None:
        if not self.widths or any(
            isinstance(w, bool) or not isinstance(w, int) or w < 1 for w in self.widths
        ):
            self._invalid("widths", "must be one or more positive integers")
        self._positive_numbers("learning_rate")
        self._positive_numbers("weight_decay", zero=True)
        self._positive_ints("max_epochs", "patience", "rollout")
        if not (0 < self.validation_fraction < 1):
            self._invalid("validation_fraction", "must be in (0, 1)")


@dataclass(frozen=True)
class DynamicsConfig(Settings):
    """A latent dynamics model learned beside the observer at every learning phase (issue 78).

    After each phase (the bootstrap's included) the adopted observer encodes the replay buffer's
    snapshots in the order they were stored; whole rollouts are drawn at random for validation
    (`validation_fraction` of them, at least one), the linear and MLP models are fitted on the
    rest and their h-step predictions of the held-out rollouts are scored, in latent units and
    decoded back to the grid, beside the constant-latent baseline (learning.jsonl's
    ``dynamics/...`` values; `litl.latent.in_loop`).

    Attributes:
      enabled: measure it (off by default: it adds the fits to every phase, and a run's program).
        Needs an observer with a latent space (vae, ae, pca).
      horizons: the horizons h, control steps (snapshots) ahead.
      validation_fraction: the share of the buffer's rollouts held out.
      linear: the linear model's fit.
      mlp: the MLP model and its training.
    """

    KEY = "loop.dynamics"
    enabled: bool = False
    horizons: tuple[int, ...] = (1, 5, 20)
    validation_fraction: float = 0.2
    linear: LinearSettings = field(default_factory=LinearSettings)
    mlp: MLPSettings = field(default_factory=MLPSettings)

    def check(self) -> None:
        if not self.horizons or any(
            isinstance(h, bool) or not isinstance(h, int) or h < 1 for h in self.horizons
        ):
            self._invalid("horizons", "must be one or more positive integers (control steps ahead)")
        if not (0 < self.validation_fraction < 1):
            self._invalid("validation_fraction", "must be in (0, 1)")
