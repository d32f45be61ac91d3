"""A tiny learning-in-the-loop run (32 x 32 biped, 40 steps) shared by the loop tests.

`python -m tests.loop.tiny RUN_DIR` runs it in its own process (the resume test kills that).
"""

import sys

import litl.robots
from litl.loop.config import LoopConfig
from litl.loop.learning import LearningConfig
from litl.loop.run import run


def tiny_config(**changes) -> LoopConfig:
    settings = dict(episodes=2, iterations=2, seeds=2, steps=40, latent_dim=4,
                    channels=(4, 4, 8, 8, 8), clusters=3, controller_widths=(16,),
                    snapshot_stride=10, replay_capacity=12, learning_rate=0.05,
                    learning=LearningConfig(patience_steps=None, max_steps=None, max_epochs=3, batch_size=4, patience=2))
    settings.update(changes)
    return LoopConfig(**settings)


def tiny_robot():
    return litl.robots.get("biped", dx=1 / 32)


if __name__ == "__main__":
    episodes = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    run(tiny_robot(), tiny_config(episodes=episodes), sys.argv[1], progress=False)
