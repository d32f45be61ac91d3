"""Algorithm 1 building blocks: replay buffer, learning phase, target update."""

from litl.loop.learning import (
    LearningConfig,
    LearningStats,
    Split,
    fit_scale_masked,
    make_learning_phase,
    random_split,
    soft_update,
)
from litl.loop.replay import ReplayBuffer, add, clear, replace_with, valid_fields, valid_mask

__all__ = [
    "LearningConfig",
    "LearningStats",
    "ReplayBuffer",
    "Split",
    "add",
    "clear",
    "fit_scale_masked",
    "make_learning_phase",
    "random_split",
    "replace_with",
    "soft_update",
    "valid_fields",
    "valid_mask",
]
