"""A tiny learning-in-the-loop run (32 x 32 biped, 40 steps) shared by the loop tests.

`python -m tests.loop.tiny RUN_DIR` runs it in its own process (the resume test kills that).
"""

import sys

import litl.robots
from litl.config import Config
from litl.loop.run import run


def tiny_config(method: str = "litl", **changes) -> Config:
    """The tiny run's config under `method` with `changes` (`Config.replace`:
    ``loop={"episodes": 3}``)."""
    return (
        Config.for_method(method)
        .replace(
            seeds=2,
            sim={"steps": 40},
            observer={"vae": {"latent_dim": 4, "channels": (4, 4, 8, 8, 8)}, "kmeans": {"clusters": 3}},
            controller={"mlp": {"widths": (16,)}, "learning_rate": 0.05},
            loop={
                "episodes": 2,
                "iterations": 2,
                "snapshot_stride": 10,
                "buffer_capacity": 12,
                "learning": {
                    "patience_steps": None,
                    "max_steps": None,
                    "max_epochs": 3,
                    "batch_size": 4,
                    "patience": 2,
                },
            },
        )
        .replace(**changes)
    )


def tiny_robot():
    return litl.robots.get("biped", dx=1 / 32)


if __name__ == "__main__":
    episodes = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    run(tiny_robot(), tiny_config(loop={"episodes": episodes}), sys.argv[1], progress=False)
