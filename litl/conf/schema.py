"""Structured-config schema of `python -m litl`: every key and its type, checked by Hydra.

A typo (`loop.episods=3`) or a wrong type (`loop.episodes=abc`) fails when the config is composed,
with Hydra's message naming the key. `to_settings` converts a composed config once into frozen
dataclasses (`Settings`), which the rest of the program reads.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import List, Optional

from hydra.core.config_store import ConfigStore
from omegaconf import OmegaConf


@dataclass
class RobotConf:
    name: str = "biped"            # litl.robots.names()
    dx: Optional[float] = None     # grid spacing; None: the robot's default (1/128 2D, 1/32 3D)
    resolution: str = "paper"      # with dx null: paper (1/128 2D, 1/32 3D), demo (1/64, 1/32),
                                   # smoke (1/32, 1/16)
    module: Optional[str] = None   # a module to import first, which registers robots of your own
                                   # (litl.robots.register); then robot.name=<its name>


@dataclass
class TaskConf:
    kind: str = "default"          # default (the robot's own) | locomotion | velocity


@dataclass
class ObserverConf:
    kind: str = "vae"              # vae | ae | kmeans | none (open loop) | one you registered
    latent_dim: int = 8            # r
    window: Optional[float] = 0.5  # side of the grid window around the robot (null: whole grid)
    channels: List[int] = field(default_factory=lambda: [8, 16, 32, 32, 64])
    activation: str = "elu"        # elu | relu (the paper's)
    clusters: int = 6              # k of the k-means baseline
    module: Optional[str] = None   # a module to import first, which registers observers of your
                                   # own (litl.loop.observers.register); then observer.kind=<name>


@dataclass
class ControllerConf:
    kind: str = "mlp"              # mlp | sinusoid (open-loop baseline; with observer none)
    omega: float = 30.0            # rad/s of the sinusoid controller
    widths: List[int] = field(default_factory=lambda: [64, 64])
    period: Optional[float] = None  # seconds; adds a (sin, cos) clock input when set
    learning_rate: float = 0.01
    feature_gradient: str = "stop"  # stop | full (the paper: backpropagate through the features)


@dataclass
class SimConf:
    steps: Optional[int] = None    # per rollout; None: the robot's episode length
    dtype: str = "float32"


@dataclass
class LearningConf:
    max_epochs: int = 100          # N
    batch_size: int = 8            # b
    patience: int = 5              # q (epochs; used when patience_steps is null)
    learning_rate: float = 3e-3
    beta: float = 1.0
    max_steps: Optional[int] = 400        # SGD-step budget of a phase (null: none)
    patience_steps: Optional[int] = 100   # early stopping in SGD steps instead of epochs


@dataclass
class LoopConf:
    episodes: int = 10             # K
    iterations: int = 10           # M
    design_learning_rate: float = 0.5
    gradient_clip: Optional[float] = 1.0   # global-norm clip of θ's and φ's gradients (null: off)
    snapshot_stride: int = 20
    replay_capacity: int = 500     # B
    alpha: float = 0.5
    replay: bool = True
    one_shot: bool = False
    simultaneous: bool = False
    codesign: bool = True
    learning: LearningConf = field(default_factory=LearningConf)


@dataclass
class ExperimentConf:
    name: str = "demo"
    description: str = ""
    paper_scale: str = ""          # what the paper ran (seeds, size) when this is a preset


@dataclass
class OutputConf:
    progress: bool = True          # progress bar on stderr
    animation: bool = True         # GIF of the final robot (seed 0)
    pictures: bool = True          # loss plot, robot drawing, latent/cluster pictures
    animation_stride: int = 10     # simulation steps per animation frame


@dataclass
class LitlConfig:
    robot: RobotConf = field(default_factory=RobotConf)
    task: TaskConf = field(default_factory=TaskConf)
    observer: ObserverConf = field(default_factory=ObserverConf)
    controller: ControllerConf = field(default_factory=ControllerConf)
    sim: SimConf = field(default_factory=SimConf)
    loop: LoopConf = field(default_factory=LoopConf)
    experiment: ExperimentConf = field(default_factory=ExperimentConf)
    output: OutputConf = field(default_factory=OutputConf)
    seeds: int = 1                 # S, vmapped
    seed: int = 0


def register() -> None:
    """Put the schema in Hydra's ConfigStore (group `schema`), where config.yaml extends it."""
    ConfigStore.instance().store(group="schema", name="litl", node=LitlConfig, package="_global_")


@dataclasses.dataclass(frozen=True)
class Settings:
    """A composed config as frozen dataclasses (lists become tuples)."""

    robot: RobotConf
    task: TaskConf
    observer: ObserverConf
    controller: ControllerConf
    sim: SimConf
    loop: LoopConf
    experiment: ExperimentConf
    output: OutputConf
    seeds: int
    seed: int


def to_settings(cfg) -> Settings:
    """Convert a composed Hydra config (DictConfig) into `Settings`."""
    resolved = OmegaConf.to_object(cfg)  # instances of the schema's dataclasses
    return Settings(**{f.name: getattr(resolved, f.name) for f in dataclasses.fields(Settings)})
