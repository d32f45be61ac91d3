"""`python -m litl`: learning-in-the-loop co-design from the command line (Hydra).

    python -m litl                                   # the default demo (2D biped, a few minutes)
    python -m litl robot=arm observer=kmeans seeds=10
    python -m litl experiment=fig4b_biped            # a paper preset (see conf/experiment)
    python -m litl -m observer=vae,kmeans robot=biped,elephant   # a sweep
    python -m litl +scale=smoke                      # any run, shrunk to seconds

Outputs go to the Hydra run directory (printed at the start): metrics.jsonl, checkpoints/, final/,
task_loss.png, robot.gif and pictures of the learned representation.
"""

from __future__ import annotations

import sys

import hydra
from hydra.core.hydra_config import HydraConfig

from litl.app import normalize_overrides, run_experiment
from litl.conf.schema import register, to_settings

register()


@hydra.main(version_base="1.3", config_path="conf", config_name="config")
def _main(cfg) -> None:
    run_experiment(to_settings(cfg), HydraConfig.get().runtime.output_dir)


def main(argv: list[str] | None = None) -> None:
    arguments = sys.argv[1:] if argv is None else argv
    sys.argv = [sys.argv[0]] + normalize_overrides(arguments)
    _main()


if __name__ == "__main__":
    main()
