"""`LoopConfig`: hyperparameters and ablation switches of Algorithm 1, checked once up front."""

from __future__ import annotations

import dataclasses
import math

from litl.loop.learning import LearningConfig

CONTROLLERS = ("mlp", "sinusoid")
DTYPES = ("float32", "float64")
FEATURE_GRADIENTS = ("full", "stop")


class LoopConfigError(ValueError):
    """A loop setting is invalid; the message says which and how to fix it.

    Attributes:
      field: the `LoopConfig` field at fault (None when several are), so that a front end can
        name it as its user typed it (`litl.app` names the command-line key).
    """

    def __init__(self, message: str, field: str | None = None):
        super().__init__(message)
        self.field = field


@dataclasses.dataclass(frozen=True)
class LoopConfig:
    """Everything that shapes one learning-in-the-loop run (for every seed of it).

    Attributes:
      episodes: K, alternations of optimization and learning.
      iterations: M, optimization iterations (simulations with backpropagation) per episode.
      seeds: S, independent runs batched with `jax.vmap` (the paper uses 10).
      seed: base seed; the runs use seed, seed + 1, ..., seed + S - 1.
      steps: simulation steps per rollout (None: the robot's own episode length).
      observer: a registered observer (`litl.loop.observers`): ``"vae"`` (the method), ``"ae"``
        (plain autoencoder), ``"kmeans"`` (baseline), ``"none"`` (no features: open-loop control,
        e.g. by an MLP of the clock or sinusoids), or one of your own.
      latent_dim: r, latent variables of the (V)AE.
      window: side (domain units) of the window of the grid that a (V)AE sees, centred on the
        robot's particle centroid and rounded up to a multiple of 32 nodes (`litl.models.window`);
        None: the whole grid, as in the paper. The replay buffer stores these windows.
      channels: channel widths of the five encoder convolutions.
      activation: the (V)AE's activation, ``"elu"`` or ``"relu"`` (the paper's).
      clusters: k, clusters of the k-means observer.
      controller: ``"mlp"`` (closed loop: an MLP of the observer's features) or ``"sinusoid"``
        (the open-loop baseline `litl.models.open_loop.SinusoidController`; needs observer none).
      controller_widths: hidden layers of the MLP controller.
      controller_omega: angular frequency (rad/s) of the sinusoid controller.
      controller_period: if set, the controller also sees (sin, cos) of a clock of this period (s).
      feature_gradient: ``"stop"`` treats the observer's features as constants in the task-loss
        gradient (the gradient reaches θ through the actuation's effect on the motion only);
        ``"full"`` also differentiates the features w.r.t. the simulated grid (the paper's
        end-to-end backpropagation), which chains the controller's sensitivity through every
        step and explodes with the horizon (see `benchmarks/gradient_horizon.py`).
      learning_rate: Adam step size of the controller parameters θ.
      design_learning_rate: Adam step size of the design variables φ (Young's modulus per region).
      gradient_clip: clip the controller's and the design's gradients to this global norm before
        Adam (None: no clipping). Gradients through long closed-loop rollouts can spike by orders
        of magnitude; a spike would otherwise swamp Adam's second-moment estimate for many steps.
      snapshot_stride: record the grid velocity every this many steps.
      replay_capacity: B, snapshots kept in the replay buffer (a ring buffer).
      learning: the learning phase (N epochs, minibatch b, patience q, Adam step, β).
      alpha: target step Θ ← α·Θ′ + (1 − α)·Θ after each learning phase.
      replay: keep a replay buffer; False keeps only the latest rollout's snapshots.
      one_shot: learn the observer once, from the initial rollout, and never again.
      simultaneous: instead of alternating, take one observer step on the latest rollout's
        snapshots at every optimization iteration (no learning phases).
      codesign: optimize the design φ with the controller; False: control only.
      dtype: ``"float32"`` or ``"float64"`` (float64 needs `jax.enable_x64`).
    """

    episodes: int = 10
    iterations: int = 10
    seeds: int = 1
    seed: int = 0
    steps: int | None = None
    observer: str = "vae"
    latent_dim: int = 8
    window: float | None = 0.5
    channels: tuple[int, ...] = (8, 16, 32, 32, 64)
    activation: str = "elu"
    clusters: int = 6
    controller: str = "mlp"
    controller_widths: tuple[int, ...] = (64, 64)
    controller_omega: float = 30.0
    controller_period: float | None = None
    feature_gradient: str = "stop"
    learning_rate: float = 0.01
    design_learning_rate: float = 0.5
    gradient_clip: float | None = 1.0
    snapshot_stride: int = 10
    replay_capacity: int = 1000
    learning: LearningConfig = LearningConfig()
    alpha: float = 0.5
    replay: bool = True
    one_shot: bool = False
    simultaneous: bool = False
    codesign: bool = True
    dtype: str = "float32"

    def __post_init__(self):
        object.__setattr__(self, "channels", tuple(self.channels))
        object.__setattr__(self, "controller_widths", tuple(self.controller_widths))

        def invalid(field: str, text: str):
            raise LoopConfigError(f"{field}={getattr(self, field)!r}: {text}", field)

        def number(value):
            return isinstance(value, (int, float)) and not isinstance(value, bool) and \
                math.isfinite(value)

        for name in ("episodes", "iterations", "seeds", "latent_dim", "clusters",
                     "snapshot_stride", "replay_capacity"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                invalid(name, "must be a positive integer")
        if self.steps is not None and (not isinstance(self.steps, int) or self.steps < 1):
            invalid("steps", "must be a positive integer, or None for the robot's episode length")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            invalid("seed", "must be an integer >= 0")
        from litl.loop import observers   # (imported here: it builds on the loop's modules)

        if self.observer not in observers.names():
            invalid("observer", f"unknown observer; choose one of {observers.names()}")
        if self.window is not None and not (number(self.window) and self.window > 0):
            invalid("window", "must be a positive length (domain units), or None for the whole "
                              "grid")
        if self.controller not in CONTROLLERS:
            invalid("controller", f"unknown controller; choose one of {CONTROLLERS}")
        if self.controller == "sinusoid" and self.observer != "none":
            invalid("observer", "the sinusoid controller is open loop and reads no observer: set "
                                "observer none (controller=sinusoid on the command line does so)")
        if not (number(self.controller_omega) and self.controller_omega > 0):
            invalid("controller_omega", "must be a positive angular frequency (rad/s)")
        if self.activation not in ("elu", "relu"):
            invalid("activation", "must be 'elu' or 'relu'")
        if len(self.channels) != 5 or any(c < 1 for c in self.channels):
            invalid("channels", "needs 5 positive widths")
        if any(w < 1 for w in self.controller_widths):
            invalid("controller_widths", "every width must be positive")
        for name in ("learning_rate", "design_learning_rate"):
            value = getattr(self, name)
            if not (number(value) and value > 0):
                invalid(name, "must be a positive number")
        if self.gradient_clip is not None and not (number(self.gradient_clip)
                                                   and self.gradient_clip > 0):
            invalid("gradient_clip", "must be positive, or None for no clipping")
        if self.controller_period is not None and not (number(self.controller_period)
                                                       and self.controller_period > 0):
            invalid("controller_period", "must be positive (seconds), or None for no clock")
        if not (number(self.alpha) and 0 < self.alpha <= 1):
            invalid("alpha", "must lie in (0, 1] (1 = no target smoothing)")
        if self.one_shot and self.simultaneous:
            invalid("one_shot", "one_shot and simultaneous exclude each other; pick one ablation")
        if self.feature_gradient not in FEATURE_GRADIENTS:
            invalid("feature_gradient", f"must be one of {FEATURE_GRADIENTS}")
        if self.dtype not in DTYPES:
            invalid("dtype", f"must be one of {DTYPES}")
